// ParameterSource's conveniences (cutsim/base/registry.hpp).
#include <cmath>

#include "cutsim/base/numbers.hpp"
#include "cutsim/base/registry.hpp"

namespace cutsim {

ParameterSource::~ParameterSource() = default;

const char* toString(KeyType type) {
  switch (type) {
    case KeyType::Number:
      return "number";
    case KeyType::Integer:
      return "integer";
    case KeyType::Boolean:
      return "boolean";
    case KeyType::Choice:
      return "choice";
    case KeyType::String:
      return "string";
    case KeyType::Integers:
      return "integers";
    case KeyType::Points:
      return "points";
    case KeyType::Rows:
      return "rows";
    case KeyType::Box:
      return "box";
    case KeyType::Object:
      return "object";
    case KeyType::Point:
      return "point";
  }
  return "?";
}

double ParameterSource::nonNegative(std::string_view key, double fallback) const {
  if (!has(key)) return fallback;
  const double v = number(key);
  if (v < 0) fail(key, "must be >= 0 (got " + describeNumber(v) + ")");
  return v;
}

double ParameterSource::positive(std::string_view key, double fallback) const {
  if (!has(key)) return fallback;
  const double v = number(key);
  if (!(v > 0)) fail(key, "must be > 0 (got " + describeNumber(v) + ")");
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
    list +=
        (list.empty() ? "\"" : (k == *(keys.end() - 1) ? "\" or \"" : "\", \"")) + std::string(k);
    if (has(k)) {
      found = k;
      ++count;
    }
  }
  if (count != 1) fail("", "give exactly one of " + list + "\"");
  return found;
}

const ScalarParameters::Value& ScalarParameters::value(std::string_view key) const {
  auto it = values_.find(key);
  if (it == values_.end()) fail(key, "missing key");
  return it->second;
}

double ScalarParameters::number(std::string_view key) const {
  const Value& v = value(key);
  double d = 0;
  if (const double* p = std::get_if<double>(&v))
    d = *p;
  else if (const long* q = std::get_if<long>(&v))
    d = double(*q);
  else
    fail(key, "expected a number");
  if (!std::isfinite(d)) fail(key, "expected a finite number, got " + describeNumber(d));
  return d;
}

long ScalarParameters::integer(std::string_view key, long min, long max) const {
  const long* p = std::get_if<long>(&value(key));
  if (!p) fail(key, "expected an integer");
  if (*p < min || *p > max)
    fail(key, "must be between " + std::to_string(min) + " and " + std::to_string(max) + " (got " +
                  std::to_string(*p) + ")");
  return *p;
}

bool ScalarParameters::boolean(std::string_view key) const {
  const bool* p = std::get_if<bool>(&value(key));
  if (!p) fail(key, "expected true or false");
  return *p;
}

std::string ScalarParameters::string(std::string_view key) const {
  const std::string* p = std::get_if<std::string>(&value(key));
  if (!p) fail(key, "expected a string");
  return *p;
}

void ScalarParameters::fail(std::string_view key, const std::string& message) const {
  throw InvalidInput(where_, key.empty() ? message : std::string(key) + ": " + message);
}

void ScalarParameters::structured(std::string_view key) const {
  fail(key, "expects an array or an object, which plain values cannot give");
}

void requireDeclared(const ScalarParameters& values, const std::vector<KeyInfo>& keys) {
  for (const std::string& key : values.keys()) {
    bool known = false;
    std::string list;
    for (const KeyInfo& k : keys) {
      known = known || k.name == key;
      list += (list.empty() ? "" : ", ") + k.name;
    }
    if (!known)
      values.fail(key, "unknown key; expected one of: " + (list.empty() ? "(none)" : list));
  }
}

}  // namespace cutsim
