#pragma once
// Private to cutsim::core: numbers as SOFA's files write them (a scene's attributes, a reference's
// values), read locale-independently and exactly (std::from_chars: the double nearest the text).
#include <charconv>
#include <optional>
#include <string_view>
#include <system_error>

namespace cutsim::core::detail {

/// The number the whole token spells (an optional leading '+'), or nothing.
inline std::optional<double> parseSofaNumber(std::string_view t) {
  if (!t.empty() && t.front() == '+') t.remove_prefix(1);
  double v = 0;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  if (r.ec != std::errc() || r.ptr != t.data() + t.size()) return std::nullopt;
  return v;
}

}  // namespace cutsim::core::detail
