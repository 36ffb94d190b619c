#pragma once
// Checks of numeric parameters shared by every layer: each throws
// cutsim::InvalidInput whose where() is the parameter's name and whose message shows the value.
#include <string>

namespace cutsim {

/// The shortest text that reads back to v ("nan", "inf" included), computed without arithmetic
/// on v, so that describing a NaN raises no floating-point exception.
std::string describeNumber(double v);

/// v must be finite and >= 0.
void requireFiniteNonNegative(const char* name, double v);

/// v must be finite and > 0.
void requireFinitePositive(const char* name, double v);

/// A relative tolerance: in (0, 1). One of 1 or more is met before the first iteration (the
/// residual starts at the right-hand side's, or the first residual), so nothing would be solved.
void requireRelativeTolerance(const char* name, double v);

}  // namespace cutsim
