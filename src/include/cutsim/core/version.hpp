#pragma once
// The version of cutsim and of the libraries it was built with.
#include <string>

namespace cutsim::core {

/// cutsim's version (the CMake project version), e.g. "0.1.0".
std::string version();

/// One line for `cutsim --version`: "cutsim 0.1.0 (Eigen 3.4.0, CHOLMOD 3.0.14)", the library
/// versions being those of the headers cutsim was compiled against.
std::string versionString();

}  // namespace cutsim::core
