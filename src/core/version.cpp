// Versions come from compile definitions and library headers, so they are the build's, not
// whatever shared library happens to be loaded.
#include "cutsim/core/version.hpp"

#include <cholmod.h>

#include <Eigen/Core>
#include <string>

#ifndef CUTSIM_VERSION
#error "CUTSIM_VERSION must be defined by the build (see src/CMakeLists.txt)"
#endif

namespace cutsim::core {

std::string version() {
  return CUTSIM_VERSION;
}

std::string versionString() {
  const auto v = [](int major, int minor, int patch) {
    return std::to_string(major) + "." + std::to_string(minor) + "." + std::to_string(patch);
  };
  return "cutsim " + version() + " (Eigen " +
         v(EIGEN_WORLD_VERSION, EIGEN_MAJOR_VERSION, EIGEN_MINOR_VERSION) + ", CHOLMOD " +
         v(CHOLMOD_MAIN_VERSION, CHOLMOD_SUB_VERSION, CHOLMOD_SUBSUB_VERSION) + ")";
}

}  // namespace cutsim::core
