#pragma once
// A point or vector of 3D space, as every layer passes it.
#include <array>

namespace cutsim {

using Vec3 = std::array<double, 3>;

}  // namespace cutsim
