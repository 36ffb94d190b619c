#pragma once
// Checks of numeric parameters shared by the force fields and the simulation core: each throws
// cutsim::InvalidInput whose where() is the parameter's name and whose message shows the value.
#include <string>

namespace cutsim::forcefields {

/// The shortest text that reads back to v ("nan", "inf" included), computed without arithmetic
/// on v, so that describing a NaN raises no floating-point exception.
std::string describeNumber(double v);

/// v must be finite and >= 0.
void requireFiniteNonNegative(const char* name, double v);

/// v must be finite and > 0.
void requireFinitePositive(const char* name, double v);

}  // namespace cutsim::forcefields
