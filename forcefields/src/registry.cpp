// ParameterSource's conveniences (registry.hpp).
#include "cutsim/forcefields/registry.hpp"

#include "cutsim/forcefields/parameters.hpp"

namespace cutsim {

ParameterSource::~ParameterSource() = default;

double ParameterSource::nonNegative(std::string_view key, double fallback) const {
  if (!has(key)) return fallback;
  const double v = number(key);
  if (v < 0) fail(key, "must be >= 0 (got " + forcefields::describeNumber(v) + ")");
  return v;
}

double ParameterSource::positive(std::string_view key, double fallback) const {
  if (!has(key)) return fallback;
  const double v = number(key);
  if (!(v > 0)) fail(key, "must be > 0 (got " + forcefields::describeNumber(v) + ")");
  return v;
}

std::string ParameterSource::choice(std::string_view key, std::string fallback,
                                    std::initializer_list<std::string_view> choices) const {
  if (!has(key)) return fallback;
  const std::string v = string(key);
  std::string list;
  for (std::string_view c : choices) {
    if (c == v) return v;
    list += (list.empty() ? "" : ", ") + std::string(c);
  }
  fail(key, "unknown value \"" + v + "\" (" + list + ")");
  return fallback;  // not reached: fail() throws
}

void ParameterSource::require(std::string_view key) const {
  if (!has(key)) fail("", "missing key \"" + std::string(key) + "\"");
}

std::string_view ParameterSource::oneOf(std::initializer_list<std::string_view> keys) const {
  std::string_view found;
  int count = 0;
  std::string list;
  for (std::string_view k : keys) {
    list += (list.empty() ? "\"" : (k == *(keys.end() - 1) ? "\" or \"" : "\", \"")) + std::string(k);
    if (has(k)) {
      found = k;
      ++count;
    }
  }
  if (count != 1) fail("", "give exactly one of " + list + "\"");
  return found;
}

}  // namespace cutsim
