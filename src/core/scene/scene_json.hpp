#pragma once
// Private to cutsim::core: the scene reader's JSON layer. The text is parsed with the line of
// every value (nlohmann's SAX interface over an iterator that counts lines), and Reader checks
// values and keys, failing with "SOURCE:LINE: /json/pointer: message". JsonParameterSource lets
// the component registries read a JSON object through the same checks.
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/scene.hpp"
#include "cutsim/forcefields/registry.hpp"

namespace cutsim::core::detail {

using json = nlohmann::json;
using topology::Vec3;

/// A key as a JSON pointer token ('~' and '/' escaped).
std::string escapePointerToken(const std::string& key);

/// A parsed document and the line of each value, by JSON pointer.
struct JsonDocument {
  json root;
  std::map<std::string, std::size_t> lines;
  /// What messages call a value instead of its JSON pointer (by the pointer of it or of an
  /// ancestor; the rest of the pointer appended): a translated scene's own paths. Usually empty.
  std::map<std::string, std::string> labels;
};
/// Parses the text (nested at most 64 deep, no duplicate keys); InvalidInput "SOURCE:LINE: ..."
/// for malformed text.
JsonDocument parseJsonWithLines(std::string_view text, const std::string& source);
/// The scene a parsed document describes (parseScene's checks); messages name `sourceName` and
/// the document's lines.
Scene parseSceneDocument(const JsonDocument& doc, const std::string& sourceName,
                         const std::filesystem::path& baseDir);

class Reader {
 public:
  Reader(std::string source, std::map<std::string, std::size_t> lines,
         std::map<std::string, std::string> labels = {})
      : source_(std::move(source)), lines_(std::move(lines)), labels_(std::move(labels)) {}

  /// The pointer as messages show it: itself, or its nearest labelled ancestor's label and the
  /// rest.
  std::string shown(const std::string& pointer) const {
    if (labels_.empty()) return pointer.empty() ? "/" : pointer;
    std::string p = pointer;
    while (true) {
      auto it = labels_.find(p);
      if (it != labels_.end()) return it->second + pointer.substr(p.size());
      if (p.empty()) return pointer.empty() ? "/" : pointer;
      p = p.substr(0, p.rfind('/'));
    }
  }

  SceneLocation location(const std::string& pointer) const {
    // The value's own line, else its nearest ancestor's.
    std::string p = pointer;
    while (true) {
      auto it = lines_.find(p);
      if (it != lines_.end()) return {pointer, it->second, ""};
      if (p.empty()) return {pointer, 0, ""};
      p = p.substr(0, p.rfind('/'));
    }
  }

  /// "SOURCE:LINE: /pointer: message", as fail() would throw it (a warning's text).
  std::string located(const std::string& pointer, const std::string& message) const {
    return location(pointer).where(source_) + ": " + shown(pointer) + ": " + message;
  }

  [[noreturn]] void fail(const std::string& pointer, const std::string& message) const {
    const SceneLocation loc = location(pointer);
    throw InvalidInput(loc.where(source_), shown(pointer) + ": " + message);
  }

  const std::string& source() const { return source_; }

  static std::string typeName(const json& j) {
    switch (j.type()) {
      case json::value_t::null:
        return "null";
      case json::value_t::object:
        return "an object";
      case json::value_t::array:
        return "an array";
      case json::value_t::string:
        return "a string";
      case json::value_t::boolean:
        return "a boolean";
      case json::value_t::number_integer:
      case json::value_t::number_unsigned:
      case json::value_t::number_float:
        return "a number";
      default:
        return "an unsupported value";
    }
  }

  void expectObject(const json& j, const std::string& ptr) const {
    if (!j.is_object()) fail(ptr, "expected an object, got " + typeName(j));
  }
  void expectArray(const json& j, const std::string& ptr) const {
    if (!j.is_array()) fail(ptr, "expected an array, got " + typeName(j));
  }

  /// Every key of the object must be one of `allowed`.
  void checkKeys(const json& obj, const std::string& ptr,
                 std::initializer_list<std::string_view> allowed) const {
    for (auto it = obj.begin(); it != obj.end(); ++it) {
      if (std::find(allowed.begin(), allowed.end(), it.key()) == allowed.end()) {
        std::string list;
        for (std::string_view a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
        fail(ptr + "/" + escapePointerToken(it.key()),
             "unknown key \"" + it.key() + "\" (expected one of: " + list + ")");
      }
    }
  }

  void checkKeys(const json& obj, const std::string& ptr,
                 const std::vector<std::string>& allowed) const {
    for (auto it = obj.begin(); it != obj.end(); ++it) {
      if (std::find(allowed.begin(), allowed.end(), it.key()) == allowed.end()) {
        std::string list;
        for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(ptr + "/" + escapePointerToken(it.key()),
             "unknown key \"" + it.key() + "\" (expected one of: " + list + ")");
      }
    }
  }

  const json* find(const json& obj, const std::string& key) const {
    auto it = obj.find(key);
    return it == obj.end() ? nullptr : &*it;
  }
  const json& require(const json& obj, const std::string& ptr, const std::string& key) const {
    const json* j = find(obj, key);
    if (!j) fail(ptr, "missing key \"" + key + "\"");
    return *j;
  }

  double number(const json& j, const std::string& ptr) const {
    if (!j.is_number()) fail(ptr, "expected a number, got " + typeName(j));
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(ptr, "must be finite");
    return v;
  }
  double nonNegative(const json& j, const std::string& ptr) const {
    const double v = number(j, ptr);
    if (v < 0) fail(ptr, "must be >= 0 (got " + text(v) + ")");
    return v;
  }
  double positive(const json& j, const std::string& ptr) const {
    const double v = number(j, ptr);
    if (!(v > 0)) fail(ptr, "must be > 0 (got " + text(v) + ")");
    return v;
  }
  long integer(const json& j, const std::string& ptr, long min, long max) const {
    if (!j.is_number_integer()) {
      fail(ptr,
           "expected an integer, got " + (j.is_number() ? "the number " + j.dump() : typeName(j)));
    }
    if (j.is_number_unsigned() && j.get<std::uint64_t>() > std::uint64_t(max)) {
      fail(ptr, "must be between " + std::to_string(min) + " and " + std::to_string(max) +
                    " (got " + j.dump() + ")");
    }
    const long v = j.get<long>();
    if (v < min || v > max) {
      fail(ptr, "must be between " + std::to_string(min) + " and " + std::to_string(max) +
                    " (got " + std::to_string(v) + ")");
    }
    return v;
  }
  bool boolean(const json& j, const std::string& ptr) const {
    if (!j.is_boolean()) fail(ptr, "expected true or false, got " + typeName(j));
    return j.get<bool>();
  }
  std::string string(const json& j, const std::string& ptr) const {
    if (!j.is_string()) fail(ptr, "expected a string, got " + typeName(j));
    return j.get<std::string>();
  }
  Vec3 vec3(const json& j, const std::string& ptr) const {
    if (!j.is_array() || j.size() != 3) {
      fail(ptr, "expected [x, y, z] (an array of 3 numbers), got " +
                    (j.is_array() ? "an array of " + std::to_string(j.size()) : typeName(j)));
    }
    return {number(j[0], ptr + "/0"), number(j[1], ptr + "/1"), number(j[2], ptr + "/2")};
  }
  std::vector<Vec3> points(const json& j, const std::string& ptr, std::size_t minCount) const {
    expectArray(j, ptr);
    if (j.size() < minCount) {
      fail(ptr, "expected at least " + std::to_string(minCount) + " points, got " +
                    std::to_string(j.size()));
    }
    std::vector<Vec3> out;
    for (std::size_t i = 0; i < j.size(); ++i) out.push_back(vec3(j[i], ptr + "/" + idx(i)));
    return out;
  }
  std::pair<Vec3, Vec3> box(const json& j, const std::string& ptr) const {
    if (!j.is_array() || j.size() != 2)
      fail(ptr, "expected [[xmin, ymin, zmin], [xmax, ymax, zmax]]");
    const Vec3 lo = vec3(j[0], ptr + "/0"), hi = vec3(j[1], ptr + "/1");
    for (int k = 0; k < 3; ++k) {
      if (lo[k] > hi[k]) fail(ptr, "the box's minimum exceeds its maximum along axis " + idx(k));
    }
    return {lo, hi};
  }

  static std::string idx(std::size_t i) { return std::to_string(i); }
  /// The shortest text that reads back to v.
  static std::string text(double v) {
    std::array<char, 64> buf{};
    const auto res = std::to_chars(buf.data(), buf.data() + buf.size(), v);
    return std::string(buf.data(), res.ptr);
  }

 private:
  std::string source_;
  std::map<std::string, std::size_t> lines_;
  std::map<std::string, std::string> labels_;
};

/// The keys of one JSON object as a component's parameters: every key that is not one of the
/// component's keys (or of `extraKeys`) is an error naming the keys, and the component that owns
/// it when it belongs to another one.
class JsonParameterSource : public ParameterSource {
 public:
  JsonParameterSource(const Reader& reader, const json& object, std::string pointer,
                      std::filesystem::path baseDir = {})
      : r_(reader), j_(object), ptr_(std::move(pointer)), baseDir_(std::move(baseDir)) {}
  bool has(std::string_view key) const override { return r_.find(j_, std::string(key)) != nullptr; }
  double number(std::string_view key) const override { return r_.number(at(key), path(key)); }
  long integer(std::string_view key, long min, long max) const override {
    return r_.integer(at(key), path(key), min, max);
  }
  bool boolean(std::string_view key) const override { return r_.boolean(at(key), path(key)); }
  std::string string(std::string_view key) const override { return r_.string(at(key), path(key)); }
  /// A relative name is taken from the scene's folder.
  std::string file(std::string_view key) const override {
    std::filesystem::path p(string(key));
    return (p.is_relative() && !baseDir_.empty() ? baseDir_ / p : p).string();
  }
  [[noreturn]] void fail(std::string_view key, const std::string& message) const override {
    if (key.empty()) r_.fail(ptr_, message);
    if (key.find('/') != std::string_view::npos) r_.fail(ptr_ + "/" + std::string(key), message);
    r_.fail(has(key) ? path(key) : ptr_, message);
  }
  std::vector<long> integers(std::string_view key, long min, long max) const override {
    const json& a = at(key);
    r_.expectArray(a, path(key));
    std::vector<long> out;
    for (std::size_t i = 0; i < a.size(); ++i)
      out.push_back(r_.integer(a[i], path(key) + "/" + Reader::idx(i), min, max));
    return out;
  }
  std::vector<std::vector<double>> rows(std::string_view key, std::size_t width,
                                        std::size_t minCount) const override {
    const json& a = at(key);
    r_.expectArray(a, path(key));
    if (a.size() < minCount)
      r_.fail(path(key), "expected at least " + std::to_string(minCount) + " entries, got " +
                             std::to_string(a.size()));
    std::vector<std::vector<double>> out;
    for (std::size_t i = 0; i < a.size(); ++i) {
      const std::string rp = path(key) + "/" + Reader::idx(i);
      if (!a[i].is_array() || a[i].size() != width)
        r_.fail(rp, "expected an array of " + std::to_string(width) + " numbers");
      std::vector<double> row;
      for (std::size_t k = 0; k < width; ++k)
        row.push_back(r_.number(a[i][k], rp + "/" + Reader::idx(k)));
      out.push_back(std::move(row));
    }
    return out;
  }
  std::unique_ptr<ParameterSource> object(
      std::string_view key, std::initializer_list<std::string_view> keys) const override {
    const json& o = at(key);
    r_.expectObject(o, path(key));
    r_.checkKeys(o, path(key), keys);
    return std::make_unique<JsonParameterSource>(r_, o, path(key));
  }
  Vec3 vec3(std::string_view key) const override { return r_.vec3(at(key), path(key)); }
  std::vector<Vec3> points(std::string_view key, std::size_t minCount) const override {
    return r_.points(at(key), path(key), minCount);
  }
  std::pair<Vec3, Vec3> box(std::string_view key) const override {
    return r_.box(at(key), path(key));
  }
  using ParameterSource::boolean;
  using ParameterSource::integer;
  using ParameterSource::number;
  const std::string& pointer() const { return ptr_; }

 private:
  const json& at(std::string_view key) const { return r_.require(j_, ptr_, std::string(key)); }
  std::string path(std::string_view key) const {
    return ptr_ + "/" + escapePointerToken(std::string(key));
  }
  const Reader& r_;
  const json& j_;
  std::string ptr_;
  std::filesystem::path baseDir_;
};

/// Checks the keys of a component's object against its registry entry: its type key ("type", or
/// "action" for timeline actions), the entry's keys and `extraKeys`; an unknown key names the
/// expected ones and, if another component of the registry has it, that component.
template <class Registry>
void checkComponentKeys(const Reader& r, const json& obj, const std::string& ptr,
                        const Registry& registry, const typename Registry::Entry& entry,
                        std::initializer_list<std::string_view> extraKeys,
                        std::vector<std::string> (*elsewhere)(const std::string&) = nullptr,
                        std::string_view typeKey = "type") {
  for (auto it = obj.begin(); it != obj.end(); ++it) {
    const std::string& key = it.key();
    if (!typeKey.empty() && key == typeKey) continue;
    if (std::find(extraKeys.begin(), extraKeys.end(), key) != extraKeys.end()) continue;
    bool known = false;
    for (const KeyInfo& k : entry.keys) known = known || k.name == key;
    if (known) continue;
    std::string list(typeKey);
    for (std::string_view k : extraKeys) list += (list.empty() ? "" : ", ") + std::string(k);
    for (const KeyInfo& k : entry.keys) list += (list.empty() ? "" : ", ") + k.name;
    std::string owners;
    std::vector<std::string> found = registry.ownersOf(key);
    if (elsewhere)
      for (std::string& o : elsewhere(key)) found.push_back(std::move(o));
    for (const std::string& o : found) owners += (owners.empty() ? "" : ", ") + o;
    r.fail(ptr + "/" + escapePointerToken(key),
           "unknown key \"" + key + "\" for " + entry.name +
               (owners.empty() ? "" : " (it belongs to " + owners + ")") +
               "; expected one of: " + list);
  }
}

/// The registered names of a registry, for "unknown type" messages.
template <class Registry>
std::string registeredNames(const Registry& registry) {
  std::string list;
  for (const std::string& n : registry.names()) list += (list.empty() ? "" : ", ") + n;
  return list;
}

}  // namespace cutsim::core::detail
