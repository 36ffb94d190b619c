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

}  // namespace cutsim
