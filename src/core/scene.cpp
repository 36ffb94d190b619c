// Scene files: parsing with line numbers (nlohmann's SAX interface over an iterator that counts
// lines), validation of every key before anything runs, a dry run of the timeline's cuts and
// removals on a copy of the mesh, and SceneRunner, which builds the simulation and plays the
// timeline. The format is described in docs/scenes.md.
#include "cutsim/core/scene.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "cutsim/forcefields/stretch_springs.hpp"
#include "cutsim/topology/errors.hpp"
#include "tearing.hpp"

namespace cutsim::core {

using json = nlohmann::json;
using topology::Vec3;

std::string SceneLocation::where(const std::string& file) const {
  return line ? file + ":" + std::to_string(line) : file;
}

namespace {

// ---------------------------------------------------------------------------------------------
// JSON with the line of every value

/// Input iterator over the text that counts the lines of the characters it has delivered.
struct LineCounter {
  std::size_t line = 1;
  char last = '\0';
};

class CountingIterator {
 public:
  using iterator_category = std::input_iterator_tag;
  using value_type = char;
  using difference_type = std::ptrdiff_t;
  using pointer = const char*;
  using reference = const char&;

  CountingIterator(const char* p, LineCounter* counter) : p_(p), counter_(counter) {}
  reference operator*() const { return *p_; }
  CountingIterator& operator++() {
    counter_->last = *p_;
    if (*p_ == '\n') ++counter_->line;
    ++p_;
    return *this;
  }
  CountingIterator operator++(int) {
    CountingIterator old = *this;
    ++*this;
    return old;
  }
  bool operator==(const CountingIterator& o) const { return p_ == o.p_; }
  bool operator!=(const CountingIterator& o) const { return p_ != o.p_; }

 private:
  const char* p_;
  LineCounter* counter_;
};

std::string escapePointerToken(const std::string& key) {
  std::string out;
  for (char c : key) {
    if (c == '~') {
      out += "~0";
    } else if (c == '/') {
      out += "~1";
    } else {
      out += c;
    }
  }
  return out;
}

/// Builds the DOM and records, for every value, the line where it ends (scalars) or starts
/// (objects, arrays), keyed by its JSON pointer.
class LineRecordingBuilder : public nlohmann::json_sax<json> {
 public:
  static constexpr std::size_t kMaxDepth = 64;

  LineRecordingBuilder(LineCounter& counter, std::string source)
      : counter_(counter), source_(std::move(source)) {}

  json root;
  std::map<std::string, std::size_t> lines;

  bool null() override { return put(json(nullptr), false); }
  bool boolean(bool b) override { return put(json(b), false); }
  bool number_integer(number_integer_t v) override { return put(json(v), true); }
  bool number_unsigned(number_unsigned_t v) override { return put(json(v), true); }
  bool number_float(number_float_t v, const string_t&) override { return put(json(v), true); }
  bool string(string_t& s) override { return put(json(s), false); }
  bool binary(binary_t&) override { return put(json(nullptr), false); }
  bool start_object(std::size_t) override { return open(json::object()); }
  bool end_object() override { return close(); }
  bool start_array(std::size_t) override { return open(json::array()); }
  bool end_array() override { return close(); }
  bool key(string_t& k) override {
    Frame& f = stack_.back();
    if (f.value->contains(k)) {
      duplicateKey_ = f.pointer + "/" + escapePointerToken(k);
      duplicateLine_ = counter_.line;
      return false;
    }
    f.key = k;
    return true;
  }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception& e) override {
    std::string message = e.what();
    // "[json.exception.parse_error.101] parse error at line 3, column 5: syntax error while
    // parsing value - invalid literal; last read: 'x'": keep what follows the position.
    const std::size_t colon = message.find(": ");
    if (message.rfind("[json.exception.", 0) == 0 && colon != std::string::npos) {
      message = message.substr(colon + 2);
    }
    throw InvalidInput(source_ + ":" + std::to_string(counter_.line), "invalid JSON: " + message);
  }

  void throwIfDuplicate() const {
    if (!duplicateKey_.empty()) {
      throw InvalidInput(source_ + ":" + std::to_string(duplicateLine_),
                         duplicateKey_ + ": duplicate key");
    }
  }

 private:
  struct Frame {
    json* value;
    std::string pointer;
    std::string key;  // the pending key of an object
  };

  /// Pointer of the value about to be put into the innermost container (or the root).
  std::string childPointer() const {
    if (stack_.empty()) return "";
    const Frame& f = stack_.back();
    if (f.value->is_object()) return f.pointer + "/" + escapePointerToken(f.key);
    return f.pointer + "/" + std::to_string(f.value->size());
  }

  json* insert(json value) {
    if (stack_.empty()) {
      root = std::move(value);
      return &root;
    }
    Frame& f = stack_.back();
    if (f.value->is_object()) return &((*f.value)[f.key] = std::move(value));
    f.value->push_back(std::move(value));
    return &f.value->back();
  }

  std::size_t currentLine(bool lookahead) const {
    // A number is known only once the character after it was read; if that was a newline, the
    // number ended on the line before.
    if (lookahead && counter_.last == '\n' && counter_.line > 1) return counter_.line - 1;
    return counter_.line;
  }

  bool put(json value, bool lookahead) {
    lines[childPointer()] = currentLine(lookahead);
    insert(std::move(value));
    return true;
  }
  bool open(json container) {
    // A scene is a few levels deep; refusing deep nesting early keeps the pointer bookkeeping
    // (a string per level) from growing quadratically on a malicious or broken file.
    if (stack_.size() >= kMaxDepth) {
      throw InvalidInput(source_ + ":" + std::to_string(counter_.line),
                         "invalid JSON: nested deeper than " + std::to_string(kMaxDepth) + " levels");
    }
    const std::string pointer = childPointer();
    lines[pointer] = counter_.line;
    json* inserted = insert(std::move(container));
    stack_.push_back({inserted, pointer, {}});
    return true;
  }
  bool close() {
    stack_.pop_back();
    return true;
  }

  LineCounter& counter_;
  std::string source_;
  std::vector<Frame> stack_;
  std::string duplicateKey_;
  std::size_t duplicateLine_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Validation helpers

class Reader {
 public:
  Reader(std::string source, std::map<std::string, std::size_t> lines)
      : source_(std::move(source)), lines_(std::move(lines)) {}

  SceneLocation location(const std::string& pointer) const {
    // The value's own line, else its nearest ancestor's.
    std::string p = pointer;
    while (true) {
      auto it = lines_.find(p);
      if (it != lines_.end()) return {pointer, it->second};
      if (p.empty()) return {pointer, 0};
      p = p.substr(0, p.rfind('/'));
    }
  }

  [[noreturn]] void fail(const std::string& pointer, const std::string& message) const {
    const SceneLocation loc = location(pointer);
    throw InvalidInput(loc.where(source_), (pointer.empty() ? "/" : pointer) + ": " + message);
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
};

std::string vecText(const Vec3& p) {
  return "(" + Reader::text(p[0]) + ", " + Reader::text(p[1]) + ", " + Reader::text(p[2]) + ")";
}

// ---------------------------------------------------------------------------------------------
// Geometry for the checks

Vec3 sub(const Vec3& a, const Vec3& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
double dot(const Vec3& a, const Vec3& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
double dist2(const Vec3& a, const Vec3& b) {
  return dot(sub(a, b), sub(a, b));
}

/// Closest point to p on triangle (a, b, c) (Ericson, Real-Time Collision Detection, 5.1.5).
Vec3 closestOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
  auto lerp = [](const Vec3& o, const Vec3& d, double t) {
    return Vec3{o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
  };
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = sub(p, b);
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return lerp(a, ab, d1 / (d1 - d3));
  const Vec3 cp = sub(p, c);
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return lerp(a, ac, d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    return lerp(b, sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6)));
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return {a[0] + ab[0] * v + ac[0] * w, a[1] + ab[1] * v + ac[1] * w, a[2] + ab[2] * v + ac[2] * w};
}

/// Distance from p to the mesh and the longest edge of the nearest triangle.
std::pair<double, double> distanceToSurface(const topology::MeshData& mesh, const Vec3& p) {
  double best = std::numeric_limits<double>::infinity(), edge = 0;
  for (const auto& t : mesh.triangles) {
    const Vec3 &a = mesh.points[t[0]], &b = mesh.points[t[1]], &c = mesh.points[t[2]];
    const double d = dist2(p, closestOnTriangle(p, a, b, c));
    if (d < best) {
      best = d;
      edge = std::sqrt(std::max({dist2(a, b), dist2(b, c), dist2(c, a)}));
    }
  }
  return {std::sqrt(best), edge};
}

std::vector<topology::TriangleId> trianglesInRegion(const topology::Topology& topo,
                                                    const Region& region) {
  std::vector<topology::TriangleId> out;
  for (topology::TriangleId t : topo.triangles()) {
    const auto v = topo.triangleVertices(t);
    Vec3 c{0, 0, 0};
    for (int i = 0; i < 3; ++i) {
      const Vec3 p = topo.restPosition(v[i]);
      for (int k = 0; k < 3; ++k) c[k] += p[k] / 3.0;
    }
    if (region.contains(c)) out.push_back(t);
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// The sections of a scene

void parseGrid(const Reader& r, const json& j, const std::string& ptr, GridSpec& g) {
  r.expectObject(j, ptr);
  r.checkKeys(j, ptr, {"nx", "ny", "size", "diagonals", "plane", "origin"});
  g.nx = int(r.integer(r.require(j, ptr, "nx"), ptr + "/nx", 2, 2000));
  g.ny = int(r.integer(r.require(j, ptr, "ny"), ptr + "/ny", 2, 2000));
  if (const json* s = r.find(j, "size")) {
    if (!s->is_array() || s->size() != 2) r.fail(ptr + "/size", "expected [width, height]");
    g.width = r.positive((*s)[0], ptr + "/size/0");
    g.height = r.positive((*s)[1], ptr + "/size/1");
  }
  if (const json* d = r.find(j, "diagonals")) {
    const std::string v = r.string(*d, ptr + "/diagonals");
    if (v == "alternating") {
      g.alternating = true;
    } else if (v == "oneway") {
      g.alternating = false;
    } else {
      r.fail(ptr + "/diagonals", "unknown value \"" + v + "\" (alternating, oneway)");
    }
  }
  if (const json* p = r.find(j, "plane")) {
    const std::string v = r.string(*p, ptr + "/plane");
    if (v == "xy") {
      g.planeXZ = false;
    } else if (v == "xz") {
      g.planeXZ = true;
    } else {
      r.fail(ptr + "/plane", "unknown value \"" + v + "\" (xy, xz)");
    }
  }
  if (const json* o = r.find(j, "origin")) g.origin = r.vec3(*o, ptr + "/origin");
}

PointSelection parseSelection(const Reader& r, const json& j, const std::string& ptr,
                              std::size_t numMeshPoints) {
  PointSelection s;
  const json* pts = r.find(j, "points");
  const json* box = r.find(j, "box");
  const json* near = r.find(j, "near");
  const int given = (pts != nullptr) + (box != nullptr) + (near != nullptr);
  if (given != 1) r.fail(ptr, "give exactly one of \"points\", \"box\" or \"near\"");
  if (pts) {
    s.kind = PointSelection::Kind::Points;
    r.expectArray(*pts, ptr + "/points");
    if (pts->empty()) r.fail(ptr + "/points", "lists no point");
    for (std::size_t i = 0; i < pts->size(); ++i) {
      s.points.push_back(PointId(
          r.integer((*pts)[i], ptr + "/points/" + Reader::idx(i), 0, long(numMeshPoints) - 1)));
    }
  } else if (box) {
    s.kind = PointSelection::Kind::Box;
    std::tie(s.boxMin, s.boxMax) = r.box(*box, ptr + "/box");
  } else {
    s.kind = PointSelection::Kind::Near;
    s.near = r.points(*near, ptr + "/near", 1);
  }
  return s;
}

std::string selectionPointer(const PointSelection& s, const std::string& ptr) {
  switch (s.kind) {
    case PointSelection::Kind::Points:
      return ptr + "/points";
    case PointSelection::Kind::Box:
      return ptr + "/box";
    case PointSelection::Kind::Near:
      return ptr + "/near";
  }
  return ptr;
}

ForceFieldSpec parseForceField(const Reader& r, const json& j, const std::string& ptr) {
  r.expectObject(j, ptr);
  ForceFieldSpec f;
  f.location = r.location(ptr);
  const std::string type = r.string(r.require(j, ptr, "type"), ptr + "/type");
  if (const json* l = r.find(j, "label")) f.label = r.string(*l, ptr + "/label");
  if (type == "FastTriangularBendingSprings") {
    f.kind = ForceFieldSpec::Kind::Bending;
    r.checkKeys(j, ptr,
                {"type", "label", "bendingStiffness", "minDistValidity", "rayleighStiffness",
                 "areaWeights"});
    forcefields::BendingParameters& b = f.bending;
    if (const json* v = r.find(j, "bendingStiffness")) {
      b.bendingStiffness = r.nonNegative(*v, ptr + "/bendingStiffness");
    }
    if (const json* v = r.find(j, "minDistValidity")) {
      b.minDistValidity = r.nonNegative(*v, ptr + "/minDistValidity");
    }
    if (const json* v = r.find(j, "rayleighStiffness")) {
      b.rayleighStiffness = r.nonNegative(*v, ptr + "/rayleighStiffness");
    }
    if (const json* v = r.find(j, "areaWeights")) {
      const std::string w = r.string(*v, ptr + "/areaWeights");
      try {
        b.areaWeights = forcefields::parseAreaWeights(w);
      } catch (const InvalidInput&) {
        r.fail(ptr + "/areaWeights", "unknown value \"" + w + "\" (unsigned, signed)");
      }
    }
    try {
      b.validate();
    } catch (const InvalidInput& e) {
      r.fail(ptr + "/" + e.where(), e.message());
    }
  } else if (type == "StretchSprings") {
    f.kind = ForceFieldSpec::Kind::Stretch;
    r.checkKeys(j, ptr, {"type", "label", "stiffness", "damping", "stableJacobian"});
    f.stiffness = r.nonNegative(r.require(j, ptr, "stiffness"), ptr + "/stiffness");
    if (const json* v = r.find(j, "damping")) f.damping = r.nonNegative(*v, ptr + "/damping");
    if (const json* v = r.find(j, "stableJacobian")) {
      f.stableJacobian = r.boolean(*v, ptr + "/stableJacobian");
    }
    forcefields::StretchParameters p{f.stiffness, f.damping, f.stableJacobian};
    try {
      p.validate();
    } catch (const InvalidInput& e) {
      r.fail(ptr + "/" + e.where(), e.message());
    }
  } else {
    r.fail(ptr + "/type", "unknown force field type \"" + type +
                              "\" (FastTriangularBendingSprings, StretchSprings)");
  }
  return f;
}

void parseSolver(const Reader& r, const json& j, const std::string& ptr, SolverSettings& s) {
  r.expectObject(j, ptr);
  r.checkKeys(
      j, ptr,
      {"type", "iterations", "tolerance", "warmStart", "rayleighMass", "rayleighStiffness"});
  if (const json* v = r.find(j, "type")) {
    const std::string type = r.string(*v, ptr + "/type");
    try {
      s.kind = parseSolverKind(type);
    } catch (const InvalidInput&) {
      r.fail(ptr + "/type",
             "unknown solver type \"" + type + "\" (explicit, implicit-cg, implicit-cholmod)");
    }
  }
  if (const json* v = r.find(j, "iterations")) {
    s.cgMaxIterations = int(r.integer(*v, ptr + "/iterations", 1, 1000000));
  }
  if (const json* v = r.find(j, "tolerance")) s.cgTolerance = r.positive(*v, ptr + "/tolerance");
  if (const json* v = r.find(j, "warmStart")) s.cgWarmStart = r.boolean(*v, ptr + "/warmStart");
  if (const json* v = r.find(j, "rayleighMass")) {
    s.rayleighMass = r.nonNegative(*v, ptr + "/rayleighMass");
  }
  if (const json* v = r.find(j, "rayleighStiffness")) {
    s.rayleighStiffness = r.nonNegative(*v, ptr + "/rayleighStiffness");
  }
}

void parseOutput(const Reader& r, const json& j, const std::string& ptr, OutputSettings& o) {
  r.expectObject(j, ptr);
  r.checkKeys(j, ptr, {"every", "vtk", "springs", "obj", "csv"});
  if (const json* v = r.find(j, "every")) o.every = int(r.integer(*v, ptr + "/every", 1, 1 << 30));
  if (const json* v = r.find(j, "vtk")) o.vtk = r.boolean(*v, ptr + "/vtk");
  if (const json* v = r.find(j, "springs")) o.springs = r.boolean(*v, ptr + "/springs");
  if (const json* v = r.find(j, "obj")) o.obj = r.boolean(*v, ptr + "/obj");
  if (const json* v = r.find(j, "csv")) o.csv = r.boolean(*v, ptr + "/csv");
}

/// A time of the timeline: finite, in [0, duration].
double actionTime(const Reader& r, const json& j, const std::string& ptr, double duration) {
  const double t = r.number(j, ptr);
  if (t < 0)
    r.fail(ptr, "an action cannot happen at a negative time (got " + Reader::text(t) + ")");
  if (t > duration) {
    r.fail(ptr, "time " + Reader::text(t) + " is after the end of the scene (duration " +
                    Reader::text(duration) + ")");
  }
  return t;
}

SceneAction parseAction(const Reader& r, const json& j, const std::string& ptr, double duration,
                        std::size_t numMeshPoints) {
  r.expectObject(j, ptr);
  SceneAction a;
  a.location = r.location(ptr);
  const std::string kind = r.string(r.require(j, ptr, "action"), ptr + "/action");
  const bool progressive = kind == "cut" && (r.find(j, "from") || r.find(j, "to"));
  if (progressive) {
    a.kind = SceneAction::Kind::ProgressiveCut;
    if (r.find(j, "at")) r.fail(ptr + "/at", "a cut has either \"at\" or \"from\" and \"to\"");
    a.from = actionTime(r, r.require(j, ptr, "from"), ptr + "/from", duration);
    a.to = actionTime(r, r.require(j, ptr, "to"), ptr + "/to", duration);
    if (!(a.to > a.from)) r.fail(ptr + "/to", "must be after \"from\"");
  } else if (kind == "cut" || kind == "remove" || kind == "tearing" || kind == "grasp" ||
             kind == "release") {
    a.at = actionTime(r, r.require(j, ptr, "at"), ptr + "/at", duration);
  }
  if (kind == "cut") {
    if (!progressive) a.kind = SceneAction::Kind::Cut;
    r.checkKeys(j, ptr,
                progressive ? std::initializer_list<std::string_view>{"action", "from", "to",
                                                                      "polyline", "snapTolerance"}
                            : std::initializer_list<std::string_view>{"action", "at", "polyline",
                                                                      "snapTolerance"});
    a.polyline = r.points(r.require(j, ptr, "polyline"), ptr + "/polyline", 2);
    if (const json* v = r.find(j, "snapTolerance")) {
      a.snapTolerance = r.nonNegative(*v, ptr + "/snapTolerance");
      if (!(a.snapTolerance < 0.5)) r.fail(ptr + "/snapTolerance", "must be < 0.5");
    }
  } else if (kind == "remove") {
    a.kind = SceneAction::Kind::Remove;
    r.checkKeys(j, ptr, {"action", "at", "sphere", "box"});
    const json* sphere = r.find(j, "sphere");
    const json* box = r.find(j, "box");
    if ((sphere != nullptr) == (box != nullptr)) {
      r.fail(ptr, "give exactly one of \"sphere\" or \"box\"");
    }
    if (sphere) {
      const std::string sp = ptr + "/sphere";
      r.expectObject(*sphere, sp);
      r.checkKeys(*sphere, sp, {"center", "radius"});
      a.region.kind = Region::Kind::Sphere;
      a.region.center = r.vec3(r.require(*sphere, sp, "center"), sp + "/center");
      a.region.radius = r.positive(r.require(*sphere, sp, "radius"), sp + "/radius");
    } else {
      a.region.kind = Region::Kind::Box;
      std::tie(a.region.boxMin, a.region.boxMax) = r.box(*box, ptr + "/box");
    }
  } else if (kind == "tearing") {
    a.kind = SceneAction::Kind::Tearing;
    r.checkKeys(j, ptr, {"action", "at", "threshold", "maxPerStep"});
    a.threshold = r.positive(r.require(j, ptr, "threshold"), ptr + "/threshold");
    if (const json* v = r.find(j, "maxPerStep")) {
      a.maxPerStep = int(r.integer(*v, ptr + "/maxPerStep", 1, 1000000));
    }
  } else if (kind == "grasp") {
    a.kind = SceneAction::Kind::Grasp;
    r.checkKeys(j, ptr, {"action", "at", "name", "points", "box", "near", "path"});
    a.name = r.string(r.require(j, ptr, "name"), ptr + "/name");
    if (a.name.empty()) r.fail(ptr + "/name", "must not be empty");
    a.selection = parseSelection(r, j, ptr, numMeshPoints);
    const std::string pp = ptr + "/path";
    const json& path = r.require(j, ptr, "path");
    r.expectArray(path, pp);
    if (path.empty()) r.fail(pp, "expected at least one key [t, dx, dy, dz]");
    for (std::size_t i = 0; i < path.size(); ++i) {
      const std::string kp = pp + "/" + Reader::idx(i);
      const json& key = path[i];
      if (!key.is_array() || key.size() != 4) r.fail(kp, "expected [t, dx, dy, dz]");
      const double t = r.number(key[0], kp + "/0");
      if (t < 0) r.fail(kp + "/0", "path times are relative to the grasp's start: must be >= 0");
      if (!a.path.times.empty() && !(t > a.path.times.back())) {
        r.fail(kp + "/0", "path times must increase strictly");
      }
      a.path.times.push_back(t);
      a.path.displacements.push_back(
          {r.number(key[1], kp + "/1"), r.number(key[2], kp + "/2"), r.number(key[3], kp + "/3")});
    }
  } else if (kind == "release") {
    a.kind = SceneAction::Kind::Release;
    r.checkKeys(j, ptr, {"action", "at", "name"});
    a.name = r.string(r.require(j, ptr, "name"), ptr + "/name");
  } else {
    r.fail(ptr + "/action",
           "unknown action \"" + kind + "\" (cut, remove, tearing, grasp, release)");
  }
  return a;
}

/// Checks what can only be checked against the mesh: cut polylines on the rest surface, regions
/// and selections that hold something, grasps released by name. Cuts and removals are carried
/// out in order on a copy of the topology.
void dryRun(const Reader& r, const Scene& scene, const topology::MeshData& mesh) {
  topology::Topology topo(mesh);
  for (const FixedSpec& f : scene.fixed) {
    if (f.selection.resolve(topo).empty()) {
      r.fail(selectionPointer(f.selection, f.location.pointer), "selects no point of the mesh");
    }
  }
  std::set<std::string> active;
  for (const SceneAction& a : scene.timeline) {
    const std::string& ptr = a.location.pointer;
    switch (a.kind) {
      case SceneAction::Kind::Cut:
      case SceneAction::Kind::ProgressiveCut: {
        for (std::size_t i = 0; i < a.polyline.size(); ++i) {
          const auto [d, edge] = distanceToSurface(mesh, a.polyline[i]);
          if (d > 0.25 * edge) {
            r.fail(ptr + "/polyline/" + Reader::idx(i),
                   "the cut misses the surface: point " + vecText(a.polyline[i]) + " is " +
                       Reader::text(d) + " away from the rest surface");
          }
        }
        try {
          topology::CutOptions options;
          options.snapTolerance = a.snapTolerance;
          topo.cutPolyline(a.polyline, options);
        } catch (const TopologyError& e) {
          r.fail(ptr + "/polyline",
                 std::string("the cut cannot be made on the rest surface: ") + e.what());
        }
        break;
      }
      case SceneAction::Kind::Remove: {
        const auto tris = trianglesInRegion(topo, a.region);
        const std::string rp = ptr + (a.region.kind == Region::Kind::Sphere ? "/sphere" : "/box");
        if (tris.empty()) r.fail(rp, "removes no triangle: no rest centroid lies inside");
        try {
          topo.removeTriangles(tris);
        } catch (const TopologyError& e) {
          r.fail(rp, std::string("the removal cannot be made: ") + e.what());
        }
        break;
      }
      case SceneAction::Kind::Grasp:
        if (active.count(a.name)) {
          r.fail(ptr + "/name", "a grasp named \"" + a.name + "\" is already active");
        }
        if (a.selection.resolve(topo).empty()) {
          r.fail(selectionPointer(a.selection, ptr), "selects no live point at that time");
        }
        active.insert(a.name);
        break;
      case SceneAction::Kind::Release:
        if (!active.erase(a.name)) {
          r.fail(ptr + "/name", "no grasp named \"" + a.name + "\" is active at that time");
        }
        break;
      case SceneAction::Kind::Tearing:
        break;
    }
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------

topology::MeshData makeGrid(const GridSpec& g) {
  topology::MeshData m;
  for (int j = 0; j < g.ny; ++j) {
    for (int i = 0; i < g.nx; ++i) {
      const double u = g.width * i / (g.nx - 1), v = g.height * j / (g.ny - 1);
      if (g.planeXZ) {
        m.points.push_back({g.origin[0] + u, g.origin[1], g.origin[2] + v});
      } else {
        m.points.push_back({g.origin[0] + u, g.origin[1] + v, g.origin[2]});
      }
    }
  }
  auto id = [&](int i, int j) { return PointId(j * g.nx + i); };
  for (int j = 0; j + 1 < g.ny; ++j) {
    for (int i = 0; i + 1 < g.nx; ++i) {
      const PointId a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      if (!g.alternating || (i + j) % 2 == 0) {
        m.triangles.push_back({a, b, c});
        m.triangles.push_back({a, c, d});
      } else {
        m.triangles.push_back({a, b, d});
        m.triangles.push_back({b, c, d});
      }
    }
  }
  m.source = "grid";
  return m;
}

std::vector<PointId> PointSelection::resolve(const topology::Topology& topo) const {
  std::vector<PointId> out;
  switch (kind) {
    case Kind::Points:
      for (PointId p : points) {
        if (p < topo.pointCapacity() && topo.isPointAlive(p)) out.push_back(p);
      }
      break;
    case Kind::Box:
      for (PointId p : topo.points()) {
        const Vec3 x = topo.restPosition(p);
        bool inside = true;
        for (int k = 0; k < 3; ++k) inside = inside && x[k] >= boxMin[k] && x[k] <= boxMax[k];
        if (inside) out.push_back(p);
      }
      break;
    case Kind::Near: {
      const std::vector<PointId> live = topo.points();
      if (live.empty()) break;
      for (const Vec3& q : near) {
        PointId best = live.front();
        double bestD = dist2(topo.restPosition(best), q);
        for (PointId p : live) {
          const double d = dist2(topo.restPosition(p), q);
          if (d < bestD) {
            bestD = d;
            best = p;
          }
        }
        out.push_back(best);
      }
      break;
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

bool Region::contains(const Vec3& p) const {
  if (kind == Kind::Sphere) return dist2(p, center) <= radius * radius;
  for (int k = 0; k < 3; ++k) {
    if (p[k] < boxMin[k] || p[k] > boxMax[k]) return false;
  }
  return true;
}

long Scene::numSteps() const {
  const double n = duration / timeStep;
  const double r = std::round(n);
  if (std::abs(n - r) <= 1e-9 * std::max(1.0, r)) return long(r);
  return long(std::ceil(n));
}

topology::MeshData Scene::mesh() const {
  if (grid) return makeGrid(*grid);
  return topology::readMesh(*meshFile);
}

std::vector<std::string> Scene::forceFieldLabels() const {
  std::vector<std::string> labels;
  std::map<std::string, int> seen;
  for (const ForceFieldSpec& f : forceFields) {
    std::string base = !f.label.empty()                          ? f.label
                       : f.kind == ForceFieldSpec::Kind::Bending ? "FastTriangularBendingSprings"
                                                                 : "StretchSprings";
    const int n = ++seen[base];
    labels.push_back(n == 1 ? base : base + "_" + std::to_string(n));
  }
  return labels;
}

std::vector<std::string> Scene::graspNames() const {
  std::vector<std::string> names;
  for (const SceneAction& a : timeline) {
    if (a.kind == SceneAction::Kind::Grasp &&
        std::find(names.begin(), names.end(), a.name) == names.end()) {
      names.push_back(a.name);
    }
  }
  return names;
}

Scene parseScene(std::string_view text, const std::string& sourceName,
                 const std::filesystem::path& baseDir) {
  LineCounter counter;
  LineRecordingBuilder builder(counter, sourceName);
  const bool ok = json::sax_parse(CountingIterator(text.data(), &counter),
                                  CountingIterator(text.data() + text.size(), &counter), &builder);
  builder.throwIfDuplicate();
  if (!ok) throw InvalidInput(sourceName, "invalid JSON");
  const Reader r(sourceName, builder.lines);
  const json& root = builder.root;
  r.expectObject(root, "");
  r.checkKeys(root, "",
              {"name", "description", "mesh", "mass", "gravity", "forceFields", "constraints",
               "solver", "timeStep", "duration", "output", "timeline"});

  Scene s;
  s.file = sourceName;
  s.name = std::filesystem::path(sourceName).stem().string();
  if (const json* v = r.find(root, "name")) {
    s.name = r.string(*v, "/name");
    if (s.name.empty() || s.name.find_first_of("/\\") != std::string::npos || s.name == "." ||
        s.name == "..") {
      r.fail("/name", "must be a plain file name (no slash)");
    }
  }
  if (const json* v = r.find(root, "description")) s.description = r.string(*v, "/description");

  // mesh
  const json& mesh = r.require(root, "", "mesh");
  std::string meshPtr = "/mesh";
  const json* meshFile = nullptr;
  if (mesh.is_string()) {
    meshFile = &mesh;
  } else if (mesh.is_object()) {
    r.checkKeys(mesh, meshPtr, {"file", "grid"});
    const json* file = r.find(mesh, "file");
    const json* grid = r.find(mesh, "grid");
    if ((file != nullptr) == (grid != nullptr)) {
      r.fail(meshPtr, "give exactly one of \"file\" or \"grid\"");
    }
    if (file) {
      meshFile = file;
      meshPtr += "/file";
    } else {
      GridSpec g;
      parseGrid(r, *grid, meshPtr + "/grid", g);
      s.grid = g;
    }
  } else {
    r.fail(meshPtr, "expected a file name or an object {\"file\"} or {\"grid\"}, got " +
                        Reader::typeName(mesh));
  }
  if (meshFile) {
    const std::string name = r.string(*meshFile, meshPtr);
    const std::filesystem::path p = baseDir / name;
    std::error_code ec;
    if (!std::filesystem::is_regular_file(p, ec)) {
      r.fail(meshPtr, "mesh file \"" + name + "\" not found (looked for " + p.string() + ")");
    }
    s.meshFile = p;
  }

  // mass
  {
    const std::string ptr = "/mass";
    const json& m = r.require(root, "", "mass");
    r.expectObject(m, ptr);
    r.checkKeys(m, ptr, {"density", "total"});
    const json* d = r.find(m, "density");
    const json* t = r.find(m, "total");
    if ((d != nullptr) == (t != nullptr))
      r.fail(ptr, "give exactly one of \"density\" or \"total\"");
    if (d) {
      s.density = r.positive(*d, ptr + "/density");
    } else {
      s.massByTotal = true;
      s.totalMass = r.positive(*t, ptr + "/total");
    }
  }
  if (const json* v = r.find(root, "gravity")) s.gravity = r.vec3(*v, "/gravity");

  if (const json* v = r.find(root, "forceFields")) {
    r.expectArray(*v, "/forceFields");
    for (std::size_t i = 0; i < v->size(); ++i) {
      s.forceFields.push_back(parseForceField(r, (*v)[i], "/forceFields/" + Reader::idx(i)));
    }
  }
  if (const json* v = r.find(root, "solver")) parseSolver(r, *v, "/solver", s.solver);
  s.timeStep = r.positive(r.require(root, "", "timeStep"), "/timeStep");
  s.duration = r.nonNegative(r.require(root, "", "duration"), "/duration");
  if (s.duration / s.timeStep > 1e8) r.fail("/duration", "more than 1e8 steps of timeStep");
  if (const json* v = r.find(root, "output")) parseOutput(r, *v, "/output", s.output);

  // The mesh is needed for point ids and for the dry run.
  const topology::MeshData meshData = s.mesh();
  if (meshData.triangles.empty()) r.fail(meshPtr, "the mesh has no triangle");
  topology::checkManifold(meshData);

  if (const json* v = r.find(root, "constraints")) {
    r.expectArray(*v, "/constraints");
    for (std::size_t i = 0; i < v->size(); ++i) {
      const std::string ptr = "/constraints/" + Reader::idx(i);
      const json& c = (*v)[i];
      r.expectObject(c, ptr);
      const std::string type = r.string(r.require(c, ptr, "type"), ptr + "/type");
      if (type != "fixed")
        r.fail(ptr + "/type", "unknown constraint type \"" + type + "\" (fixed)");
      r.checkKeys(c, ptr, {"type", "points", "box", "near"});
      s.fixed.push_back({parseSelection(r, c, ptr, meshData.points.size()), r.location(ptr)});
    }
  }
  if (const json* v = r.find(root, "timeline")) {
    r.expectArray(*v, "/timeline");
    for (std::size_t i = 0; i < v->size(); ++i) {
      s.timeline.push_back(parseAction(r, (*v)[i], "/timeline/" + Reader::idx(i), s.duration,
                                       meshData.points.size()));
    }
    std::stable_sort(
        s.timeline.begin(), s.timeline.end(),
        [](const SceneAction& a, const SceneAction& b) { return a.startTime() < b.startTime(); });
  }
  dryRun(r, s, meshData);
  return s;
}

Scene loadScene(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InvalidInput(file.string(), "cannot open the scene file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InvalidInput(file.string(), "cannot read the scene file");
  return parseScene(text.str(), file.string(), file.parent_path());
}

// ---------------------------------------------------------------------------------------------
// SceneRunner

struct SceneRunner::Progressive {
  const SceneAction* action;
  std::vector<double> arc;  // cumulative length at each polyline vertex
  double done = 0.0;        // arc length cut so far
  bool started = false, finished = false;
  double minPiece = 0.0;
  // Where the previous piece really ended (its last path vertex, which snapping may have put a
  // little off the polyline): the next piece starts there, so that it continues from the cut's
  // tip instead of starting beside it.
  std::optional<Vec3> tip;

  Vec3 pointAt(double s) const {
    const auto& p = action->polyline;
    std::size_t i = 1;
    while (i + 1 < arc.size() && arc[i] < s) ++i;
    const double len = arc[i] - arc[i - 1];
    const double t = len > 0 ? std::clamp((s - arc[i - 1]) / len, 0.0, 1.0) : 1.0;
    return {p[i - 1][0] + t * (p[i][0] - p[i - 1][0]), p[i - 1][1] + t * (p[i][1] - p[i - 1][1]),
            p[i - 1][2] + t * (p[i][2] - p[i - 1][2])};
  }
  /// The polyline between arc lengths s0 < s1.
  std::vector<Vec3> piece(double s0, double s1) const {
    std::vector<Vec3> out{pointAt(s0)};
    for (std::size_t i = 1; i + 1 < arc.size(); ++i) {
      if (arc[i] > s0 && arc[i] < s1) out.push_back(action->polyline[i]);
    }
    out.push_back(s1 >= arc.back() ? action->polyline.back() : pointAt(s1));
    return out;
  }
};

SceneRunner::SceneRunner(const Scene& scene) : scene_(scene) {
  const topology::MeshData mesh = scene_.mesh();
  auto topo = std::make_unique<topology::Topology>(mesh);
  const double density =
      scene_.massByTotal ? LumpedMass::densityForTotal(*topo, scene_.totalMass) : scene_.density;
  // Mean rest edge length: the smallest piece a progressive cut makes is half of it.
  double edgeSum = 0;
  std::size_t edgeCount = 0;
  for (topology::EdgeId e : topo->edges()) {
    const auto v = topo->edgeVertices(e);
    edgeSum += std::sqrt(dist2(topo->restPosition(v[0]), topo->restPosition(v[1])));
    ++edgeCount;
  }
  const double meanEdge = edgeCount ? edgeSum / double(edgeCount) : 0.0;

  sim_ = std::make_unique<Simulation>(std::move(topo), density);
  sim_->setGravity(scene_.gravity);
  const std::vector<std::string> labels = scene_.forceFieldLabels();
  for (std::size_t i = 0; i < scene_.forceFields.size(); ++i) {
    const ForceFieldSpec& f = scene_.forceFields[i];
    std::unique_ptr<forcefields::ForceField> field;
    if (f.kind == ForceFieldSpec::Kind::Bending) {
      field =
          std::make_unique<forcefields::FastTriangularBendingSprings>(sim_->topology(), f.bending);
    } else {
      forcefields::StretchParameters p;
      p.stiffness = f.stiffness;
      p.damping = f.damping;
      p.stableJacobian = f.stableJacobian;
      field = std::make_unique<forcefields::StretchSprings>(sim_->topology(), p);
    }
    sim_->addForceField(std::move(field), labels[i]);
  }
  for (const FixedSpec& f : scene_.fixed) {
    for (PointId p : f.selection.resolve(sim_->topology())) sim_->fixed().add(p);
  }
  sim_->setSolver(scene_.solver);
  numSteps_ = scene_.numSteps();
  for (const SceneAction& a : scene_.timeline) {
    if (a.kind != SceneAction::Kind::ProgressiveCut) continue;
    Progressive pc;
    pc.action = &a;
    pc.arc.push_back(0.0);
    for (std::size_t i = 1; i < a.polyline.size(); ++i) {
      pc.arc.push_back(pc.arc.back() + std::sqrt(dist2(a.polyline[i - 1], a.polyline[i])));
    }
    pc.minPiece = 0.5 * meanEdge;
    progressive_.push_back(std::move(pc));
  }
}

SceneRunner::~SceneRunner() = default;

double SceneRunner::time() const {
  return double(step_) * scene_.timeStep;
}

const forcefields::FastTriangularBendingSprings* SceneRunner::bendingField() const {
  for (std::size_t i = 0; i < sim_->numForceFields(); ++i) {
    if (auto* f =
            dynamic_cast<const forcefields::FastTriangularBendingSprings*>(&sim_->forceField(i))) {
      return f;
    }
  }
  return nullptr;
}

void SceneRunner::start() {
  if (started_) return;
  started_ = true;
  runDueActions(0.0);
}

StepStats SceneRunner::advance() {
  if (!started_) start();
  if (finished()) return lastStats_;
  lastStats_ = sim_->step(scene_.timeStep);
  ++step_;
  const double t = time();
  advanceProgressive(t);
  if (tearing_) {
    tornEdges_ +=
        tearOverstrained(sim_->topology(), sim_->state().x(), tearThreshold_, tearMaxPerStep_);
  }
  runDueActions(t);
  return lastStats_;
}

void SceneRunner::runDueActions(double t) {
  const double eps = 1e-9 * scene_.timeStep;
  while (nextAction_ < scene_.timeline.size() &&
         scene_.timeline[nextAction_].startTime() <= t + eps) {
    runAction(scene_.timeline[nextAction_]);
    ++nextAction_;
  }
}

topology::IncisionResult SceneRunner::cut(std::span<const Vec3> polyline, double snap,
                                          const SceneLocation& where) {
  topology::CutOptions options;
  options.snapTolerance = snap;
  try {
    topology::IncisionResult result = sim_->topology().cutPolyline(polyline, options);
    ++cutsDone_;
    return result;
  } catch (const TopologyError& e) {
    throw Error(where.where(scene_.file.string()) + ": " + where.pointer +
                ": at t = " + Reader::text(time()) + " the cut failed: " + e.what());
  }
}

void SceneRunner::runAction(const SceneAction& a) {
  const std::string file = scene_.file.string();
  switch (a.kind) {
    case SceneAction::Kind::Cut:
      cut(a.polyline, a.snapTolerance, a.location);
      break;
    case SceneAction::Kind::ProgressiveCut:
      for (Progressive& p : progressive_) {
        if (p.action == &a) p.started = true;
      }
      advanceProgressive(time());
      break;
    case SceneAction::Kind::Remove: {
      const auto tris = trianglesInRegion(sim_->topology(), a.region);
      if (!tris.empty()) sim_->topology().removeTriangles(tris);
      break;
    }
    case SceneAction::Kind::Tearing:
      tearing_ = true;
      tearThreshold_ = a.threshold;
      tearMaxPerStep_ = a.maxPerStep;
      break;
    case SceneAction::Kind::Grasp: {
      const std::vector<PointId> points = a.selection.resolve(sim_->topology());
      if (points.empty()) {
        throw Error(a.location.where(file) + ": " + a.location.pointer +
                    ": at t = " + Reader::text(time()) + " the grasp selects no live point");
      }
      sim_->addGrasp(a.name, points, a.path);
      break;
    }
    case SceneAction::Kind::Release:
      sim_->releaseGrasp(a.name);
      break;
  }
}

void SceneRunner::advanceProgressive(double t) {
  for (Progressive& p : progressive_) {
    if (!p.started || p.finished) continue;
    const SceneAction& a = *p.action;
    const double total = p.arc.back();
    double s = total * std::clamp((t - a.from) / (a.to - a.from), 0.0, 1.0);
    if (t >= a.to - 1e-9 * scene_.timeStep) s = total;
    // Never leave a remainder shorter than the smallest piece; never cut a piece shorter than it
    // (except a whole polyline that is shorter).
    if (s < total && total - s < p.minPiece) s = total;
    if (s < total && s - p.done < p.minPiece) continue;
    if (!(s > p.done)) continue;
    std::vector<Vec3> piece = p.piece(p.done, s);
    if (p.tip) piece.front() = *p.tip;
    topology::IncisionResult result;
    if (s < total) {
      // A piece that the topology refuses without changing anything (for example one that ends
      // exactly on an edge in a way its walk does not handle) is tried again, longer, at the next
      // step; only the last piece must succeed where the scalpel is.
      topology::Topology& topo = sim_->topology();
      const topology::Index points = topo.pointCapacity(), triangles = topo.triangleCapacity();
      try {
        topology::CutOptions options;
        options.snapTolerance = a.snapTolerance;
        result = topo.cutPolyline(piece, options);
        ++cutsDone_;
      } catch (const TopologyError& e) {
        if (topo.pointCapacity() == points && topo.triangleCapacity() == triangles) continue;
        throw Error(a.location.where(scene_.file.string()) + ": " + a.location.pointer +
                    ": at t = " + Reader::text(time()) + " the cut failed: " + e.what());
      }
    } else {
      result = cut(piece, a.snapTolerance, a.location);
    }
    if (!result.path.empty()) p.tip = sim_->topology().restPosition(result.path.back());
    p.done = s;
    if (s >= total) p.finished = true;
  }
}

}  // namespace cutsim::core
