// Checks of numeric parameters (numbers.hpp).
#include "cutsim/base/numbers.hpp"

#include <charconv>
#include <cmath>

#include "cutsim/base/errors.hpp"

namespace cutsim {

std::string describeNumber(double v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, res.ptr);
}

void requireFiniteNonNegative(const char* name, double v) {
  if (!std::isfinite(v)) {
    throw InvalidInput(name, "must be a finite number >= 0, got " + describeNumber(v));
  }
  if (v < 0.0) throw InvalidInput(name, "must be >= 0, got " + describeNumber(v));
}

void requireFinitePositive(const char* name, double v) {
  if (!std::isfinite(v) || !(v > 0.0)) {
    throw InvalidInput(name, "must be a finite number > 0, got " + describeNumber(v));
  }
}

void requireRelativeTolerance(const char* name, double v) {
  requireFinitePositive(name, v);
  if (!(v < 1.0))
    throw InvalidInput(name, "must be < 1, got " + describeNumber(v) +
                                 ": a relative tolerance of 1 or more is met before the first "
                                 "iteration, and nothing would be solved");
}

}  // namespace cutsim
