#pragma once
// Moved to the base layer: cutsim/base/numbers.hpp, in namespace cutsim. This header and its
// names in cutsim::forcefields stay for code written against earlier releases.
#include "cutsim/base/numbers.hpp"

namespace cutsim::forcefields {
using cutsim::describeNumber;
using cutsim::requireFiniteNonNegative;
using cutsim::requireFinitePositive;
}  // namespace cutsim::forcefields
