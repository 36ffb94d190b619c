// SOFA's XML scenes: read with pugixml, translated into a JSON scene (sofa_scene.hpp; the table of
// components is in docs/sofa.md).
#include "cutsim/core/sofa_scene.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <pugixml.hpp>
#include <set>
#include <sstream>

#include "cutsim/base/errors.hpp"
#include "scene/scene_json.hpp"
#include "sofa/sofa_text.hpp"

namespace cutsim::core {
namespace {

using ojson = nlohmann::ordered_json;

// ---- the scene as a tree of nodes and components ----

struct SofaNode;

struct SofaComponent {
  std::string type;  ///< SOFA's class name
  std::string name;  ///< its name attribute, or the class name
  pugi::xml_node xml;
  SofaNode* node = nullptr;
  std::size_t line = 0;
  std::set<std::string> read;  ///< attributes the translation looked at
  std::string path() const;
};

struct SofaNode {
  std::string name;
  pugi::xml_node xml;
  SofaNode* parent = nullptr;
  std::size_t line = 0;
  std::vector<std::unique_ptr<SofaNode>> children;
  std::vector<std::unique_ptr<SofaComponent>> components;
  std::string path() const { return parent ? parent->path() + "/" + name : "/" + name; }
};

std::string SofaComponent::path() const {
  return node->path() + "/" + name;
}

/// Text helpers: numbers read with from_chars (locale-independent, exact round trip).
using detail::parseSofaNumber;

std::vector<std::string_view> words(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  auto blank = [](char c) {
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == ',' || c == '[' || c == ']';
  };
  while (i < s.size()) {
    while (i < s.size() && blank(s[i])) ++i;
    std::size_t j = i;
    while (j < s.size() && !blank(s[j])) ++j;
    if (j > i) out.push_back(s.substr(i, j - i));
    i = j;
  }
  return out;
}

std::string inQuotes(std::string_view s) {
  return "\"" + std::string(s) + "\"";
}

bool startsWith(std::string_view s, std::string_view p) {
  return s.substr(0, p.size()) == p;
}
bool endsWith(std::string_view s, std::string_view p) {
  return s.size() >= p.size() && s.substr(s.size() - p.size()) == p;
}

/// Components that only draw, or that cutsim's design makes unnecessary: accepted, listed as
/// ignored.
bool isVisualOrGui(std::string_view type) {
  static const std::set<std::string_view> names = {"VisualStyle",
                                                   "RequiredPlugin",
                                                   "VisualModel",
                                                   "VisualGrid",
                                                   "LineAxis",
                                                   "InteractiveCamera",
                                                   "LightManager",
                                                   "DirectionalLight",
                                                   "PositionalLight",
                                                   "SpotLight",
                                                   "BackgroundSetting",
                                                   "DefaultVisualManagerLoop",
                                                   "VisualManagerPass",
                                                   "VisualManagerSecondaryPass",
                                                   "ClipPlane",
                                                   "InfoComponent",
                                                   "MeshExporter",
                                                   "VTKExporter",
                                                   "AttachBodyButtonSetting",
                                                   "FixPickedParticleButtonSetting",
                                                   "SofaDefaultPathSetting",
                                                   "StatsSetting",
                                                   "ViewerSetting",
                                                   "MouseButtonSetting",
                                                   "CompositingVisualLoop",
                                                   "OrderIndependentTransparencyManager",
                                                   "PointSetGeometryAlgorithms",
                                                   "EdgeSetGeometryAlgorithms",
                                                   "TriangleSetGeometryAlgorithms",
                                                   "QuadSetGeometryAlgorithms",
                                                   "TetrahedronSetGeometryAlgorithms",
                                                   "HexahedronSetGeometryAlgorithms",
                                                   "TriangleSetTopologyModifier",
                                                   "EdgeSetTopologyModifier",
                                                   "PointSetTopologyModifier",
                                                   "TriangleSetTopologyAlgorithms",
                                                   "EdgeSetTopologyAlgorithms",
                                                   "PointSetTopologyAlgorithms",
                                                   "PlaybackParameters"};
  return names.count(type) > 0 || startsWith(type, "Ogl") || startsWith(type, "Visual");
}

bool isMapping(std::string_view type) {
  return endsWith(type, "Mapping");
}

/// Attributes that change only what SOFA draws or prints: read silently.
bool isDisplayAttribute(std::string_view a) {
  static const std::set<std::string_view> names = {"name",
                                                   "printLog",
                                                   "tags",
                                                   "bbox",
                                                   "listening",
                                                   "showObject",
                                                   "showObjectScale",
                                                   "showIndices",
                                                   "showIndicesScale",
                                                   "showVectors",
                                                   "showVectorsScale",
                                                   "drawMode",
                                                   "showColor",
                                                   "drawBoxes",
                                                   "drawPoints",
                                                   "drawEdges",
                                                   "drawTriangles",
                                                   "drawQuads",
                                                   "drawTetrahedra",
                                                   "drawHexahedra",
                                                   "drawSize",
                                                   "drawInitialMesh",
                                                   "showStressVector",
                                                   "showStressThreshold",
                                                   "showStressValue",
                                                   "showFiber",
                                                   "showMaxStress",
                                                   "verbose",
                                                   "showBoundingTree",
                                                   "showAxisSizeFactor",
                                                   "showGravity",
                                                   "showInitialCenterOfGravity",
                                                   "showCenterOfGravity",
                                                   "showX0",
                                                   "componentState",
                                                   "drawArrows",
                                                   "drawArrowSize",
                                                   "showArrowSize",
                                                   "color",
                                                   "computeResidual",
                                                   "threadSafeVisitor",
                                                   "doUpdate"};
  return names.count(a) > 0;
}

class Importer {
 public:
  Importer(std::filesystem::path file, const SofaImportOptions& options)
      : file_(std::move(file)), options_(options) {}

  SofaSceneImport run();

 private:
  // ---- errors and notes ----
  std::string where(std::size_t line) const {
    return line ? file_.string() + ":" + std::to_string(line) : file_.string();
  }
  [[noreturn]] void fail(std::size_t line, const std::string& path,
                         const std::string& message) const {
    throw InvalidInput(where(line), path + ": " + message);
  }
  [[noreturn]] void fail(const SofaComponent& c, const std::string& attribute,
                         const std::string& message) const {
    fail(c.line, c.path() + (attribute.empty() ? "" : "/" + attribute), message);
  }
  void note(std::size_t line, const std::string& message) {
    out_.notes.push_back(where(line) + ": " + message);
  }
  std::size_t lineOf(std::ptrdiff_t offset) const {
    return std::size_t(1 + std::count(text_.begin(),
                                      text_.begin() + std::min<std::ptrdiff_t>(
                                                          offset, std::ptrdiff_t(text_.size())),
                                      '\n'));
  }

  // ---- attributes ----
  std::optional<std::string> attr(SofaComponent& c, const char* name) {
    c.read.insert(name);
    const pugi::xml_attribute a = c.xml.attribute(name);
    if (!a) return std::nullopt;
    return std::string(a.value());
  }
  /// The value of an attribute, following a link "@path.field" to another component's value.
  std::optional<std::string> value(SofaComponent& c, const char* name) {
    auto v = attr(c, name);
    if (!v || v->empty() || v->front() != '@') return v;
    return linkedValue(c, name, *v);
  }
  double number(SofaComponent& c, const char* name, double fallback) {
    const auto v = value(c, name);
    if (!v) return fallback;
    const auto w = words(*v);
    if (w.size() != 1) fail(c, name, "expected one number, got " + inQuotes(*v));
    const auto d = parseSofaNumber(w[0]);
    if (!d || !std::isfinite(*d)) fail(c, name, "expected a finite number, got " + inQuotes(*v));
    return *d;
  }
  std::vector<double> numbers(SofaComponent& c, const char* name, const std::string& text) {
    std::vector<double> out;
    for (auto w : words(text)) {
      const auto d = parseSofaNumber(w);
      if (!d || !std::isfinite(*d)) fail(c, name, "expected numbers, got " + inQuotes(w));
      out.push_back(*d);
    }
    return out;
  }
  std::optional<Vec3> vec3(SofaComponent& c, const char* name) {
    const auto v = value(c, name);
    if (!v) return std::nullopt;
    const auto n = numbers(c, name, *v);
    if (n.size() != 3) fail(c, name, "expected 3 numbers, got " + inQuotes(*v));
    return Vec3{n[0], n[1], n[2]};
  }
  bool boolean(SofaComponent& c, const char* name, bool fallback) {
    const auto v = value(c, name);
    if (!v) return fallback;
    const auto w = words(*v);
    if (w.size() == 1 && (w[0] == "1" || w[0] == "true" || w[0] == "True")) return true;
    if (w.size() == 1 && (w[0] == "0" || w[0] == "false" || w[0] == "False")) return false;
    fail(c, name, "expected 0 or 1 (or true, false), got " + inQuotes(*v));
  }
  /// A physics attribute cutsim does not honour: SOFA's default value only.
  void requireDefault(SofaComponent& c, const char* name, std::string_view meaning,
                      const std::function<bool(const std::string&)>& isDefault) {
    const auto v = value(c, name);
    if (v && !isDefault(*v))
      fail(c, name,
           std::string(name) + "=" + inQuotes(*v) + " is not supported: cutsim " +
               std::string(meaning));
  }
  void requireFalse(SofaComponent& c, const char* name, std::string_view meaning) {
    const auto v = value(c, name);
    if (v && boolean(c, name, false))
      fail(c, name,
           std::string(name) + "=" + inQuotes(*v) + " is not supported: cutsim " +
               std::string(meaning));
  }
  void requireNumber(SofaComponent& c, const char* name, double expected,
                     std::string_view meaning) {
    const auto v = value(c, name);
    if (v && number(c, name, expected) != expected)
      fail(c, name,
           std::string(name) + "=" + inQuotes(*v) + " is not supported: cutsim " +
               std::string(meaning));
  }
  void checkTemplate(SofaComponent& c) {
    const auto t = attr(c, "template");
    if (!t) return;
    static const std::set<std::string> ok = {"Vec3", "Vec3d", "Vec3Types", "Vec3dTypes"};
    if (*t == "Vec3f" || *t == "Vec3fTypes")
      fail(c, "template",
           "template " + inQuotes(*t) +
               " (single precision) is not supported: cutsim computes in double (Vec3d)");
    if (!ok.count(*t))
      fail(c, "template",
           "template " + inQuotes(*t) +
               " is not supported: cutsim simulates surfaces of 3D points (Vec3)");
  }

  // ---- links ----
  SofaComponent* findComponent(SofaNode* from, const std::string& path, std::string& why);
  std::string linkedValue(SofaComponent& c, const char* name, const std::string& link);
  std::vector<SofaComponent*> boxes_;  ///< BoxROIs whose indices a link read ("@box:N")
  int linkDepth_ = 0;
  std::map<std::string, int> unnamed_;      ///< unnamed components so far, by type
  std::vector<SofaComponent*> actOnState_;  ///< force fields, constraints: in the state's node
  SofaComponent& linkTarget(SofaComponent& c, const char* name, const std::string& link,
                            std::string& field);

  // ---- the tree ----
  /// SOFA's scenes are a few nodes deep; a tree deeper than this is refused (a name, a line), not
  /// walked into a stack overflow.
  static constexpr int kMaxNodeDepth = 256;
  void readTree(pugi::xml_node xml, SofaNode* parent, int depth = 0);
  void translate(SofaNode& n);
  void translateLoaders(SofaNode& n);
  /// One kind of SOFA component cutsim reads: its type names, whether it acts on the mechanical
  /// state (and must sit in the state's node), and its translation into the scene's JSON. A new
  /// kind is a row of translators() and its member function.
  struct Translator {
    std::vector<const char*> types;
    bool onState = false;
    void (Importer::*translate)(SofaComponent&);
  };
  static const std::vector<Translator>& translators();
  static const Translator* translatorOf(std::string_view type);
  static bool isLoader(std::string_view type) {
    const Translator* tr = translatorOf(type);
    return tr && tr->translate == &Importer::loader;
  }
  void component(SofaComponent& c);
  void loader(SofaComponent& c);
  void animationLoop(SofaComponent& c);
  void eulerImplicitSolver(SofaComponent& c);
  void cgLinearSolver(SofaComponent& c);
  void topologyContainer(SofaComponent& c);
  void mechanicalObject(SofaComponent& c);
  void mass(SofaComponent& c);
  void triangleFem(SofaComponent& c);
  void boxConstraint(SofaComponent& c);
  void meshSprings(SofaComponent& c);
  void bendingSprings(SofaComponent& c);
  void fastBendingSprings(SofaComponent& c);
  void boxRoi(SofaComponent& c);
  void fixedConstraint(SofaComponent& c);
  void meshFrom(SofaComponent& c, bool topologyContainer);
  void finish();
  /// A fixed constraint per box (6 numbers each; each axis' bounds ordered, as SOFA orders them).
  void addBoxes(SofaComponent& c, const std::vector<double>& n) {
    if (n.empty() || n.size() % 6 != 0)
      fail(c, "box",
           "expected 6 numbers per box (xmin ymin zmin xmax ymax zmax), got " +
               std::to_string(n.size()));
    for (std::size_t k = 0; k + 5 < n.size(); k += 6) {
      ojson lo = ojson::array(), hi = ojson::array();
      for (int a = 0; a < 3; ++a) {
        lo.push_back(std::min(n[k + std::size_t(a)], n[k + 3 + std::size_t(a)]));
        hi.push_back(std::max(n[k + std::size_t(a)], n[k + 3 + std::size_t(a)]));
      }
      constraints_.push_back({{"type", "fixed"}, {"box", {lo, hi}}});
      constraintFrom_.push_back(&c);
    }
  }
  std::string resolveMeshFile(SofaComponent& c, const std::string& name);
  void setLine(const std::string& pointer, std::size_t line) { out_.lines[pointer] = line; }
  /// The line and the scene's own path of a JSON value (messages of the JSON checks show them).
  void setFrom(const std::string& pointer, const SofaComponent& c) {
    out_.lines[pointer] = c.line;
    out_.labels[pointer] = c.path();
  }

  std::filesystem::path file_;
  SofaImportOptions options_;
  std::string text_;
  pugi::xml_document doc_;
  std::unique_ptr<SofaNode> root_;
  SofaSceneImport out_;

  struct Loader {
    std::optional<GridSpec> grid;  ///< GridMeshCreator's grid, or:
    std::filesystem::path file;
    MeshTransform transform;
    std::size_t line = 0;
  };
  std::map<const SofaComponent*, Loader> loaders_;
  const SofaComponent* meshLoader_ = nullptr;  // the loader the state and the topology read
  SofaComponent* mechanicalObject_ = nullptr;
  SofaComponent* topology_ = nullptr;
  SofaComponent* mass_ = nullptr;
  SofaComponent* odeSolver_ = nullptr;
  SofaComponent* linearSolver_ = nullptr;
  MeshTransform stateTransform_;
  ojson massJson_, integratorJson_, linearSolverJson_;
  ojson forceFields_ = ojson::array(), constraints_ = ojson::array(), ignored_ = ojson::array();
  std::vector<const SofaComponent*> forceFieldFrom_,
      constraintFrom_;  // the components they come from
  std::size_t massAt_ = 0;
  std::size_t rootLine_ = 0;
  double dt_ = 0.01;
  Vec3 gravity_{0, -9.81, 0};
};

SofaComponent* Importer::findComponent(SofaNode* from, const std::string& path, std::string& why) {
  // "name", "../name", "node/name", "/root/node/name": SOFA's paths. A bare name is looked for in
  // the component's node, then in its ancestors'.
  std::vector<std::string> parts;
  std::size_t i = 0;
  const bool absolute = !path.empty() && path.front() == '/';
  while (i <= path.size()) {
    const std::size_t j = std::min(path.find('/', i), path.size());
    if (j > i) parts.push_back(path.substr(i, j - i));
    i = j + 1;
  }
  if (parts.empty()) {
    why = "an empty link";
    return nullptr;
  }
  const auto inNode = [](SofaNode* n, const std::string& name) -> SofaComponent* {
    for (auto& c : n->components)
      if (c->name == name) return c.get();
    return nullptr;
  };
  if (parts.size() == 1 && !absolute) {
    for (SofaNode* n = from; n; n = n->parent)
      if (SofaComponent* c = inNode(n, parts[0])) return c;
    why = "no component named " + inQuotes(parts[0]) + " in node " + inQuotes(from->path()) +
          " or above";
    return nullptr;
  }
  // The path walked from a node; a relative path that starts with a node's name is looked for
  // from the component's node, then from each of its ancestors (as SOFA does).
  auto walk = [&](SofaNode* n, std::string& whyHere) -> SofaComponent* {
    std::size_t k = 0;
    if (absolute && parts[0] == root_->name) k = 1;
    for (; k + 1 < parts.size(); ++k) {
      if (parts[k] == ".") continue;
      if (parts[k] == "..") {
        if (!n->parent) {
          whyHere = "\"..\" above the root node";
          return nullptr;
        }
        n = n->parent;
        continue;
      }
      SofaNode* next = nullptr;
      for (auto& child : n->children)
        if (child->name == parts[k]) next = child.get();
      if (!next) {
        whyHere = "no node named " + inQuotes(parts[k]) + " in " + inQuotes(n->path());
        return nullptr;
      }
      n = next;
    }
    if (SofaComponent* c = inNode(n, parts.back())) return c;
    whyHere = "no component named " + inQuotes(parts.back()) + " in node " + inQuotes(n->path());
    return nullptr;
  };
  if (absolute) return walk(root_.get(), why);
  const bool fromHere = parts[0] == "." || parts[0] == "..";
  for (SofaNode* start = from; start; start = fromHere ? nullptr : start->parent) {
    std::string whyHere;
    if (SofaComponent* c = walk(start, whyHere)) return c;
    if (start == from) why = whyHere;
  }
  return nullptr;
}

SofaComponent& Importer::linkTarget(SofaComponent& c, const char* name, const std::string& link,
                                    std::string& field) {
  // "@path" or "@path.field" (a component's name may itself hold dots: the field is after the
  // last).
  std::string path = link.substr(1);
  field.clear();
  std::string why;
  SofaComponent* target = findComponent(c.node, path, why);
  if (!target) {
    const std::size_t dot = path.rfind('.');
    const std::size_t slash = path.rfind('/');
    if (dot != std::string::npos && (slash == std::string::npos || dot > slash) && dot > 0 &&
        path[dot - 1] != '.') {
      field = path.substr(dot + 1);
      std::string why2;
      target = findComponent(c.node, path.substr(0, dot), why2);
      if (!target) why = why2;
    }
  }
  if (!target) fail(c, name, "link " + inQuotes(link) + ": " + why);
  return *target;
}

std::string Importer::linkedValue(SofaComponent& c, const char* name, const std::string& link) {
  std::string field;
  SofaComponent& t = linkTarget(c, name, link, field);
  if (field.empty())
    fail(c, name,
         "link " + inQuotes(link) +
             " names a component where a value is expected (give @name.field)");
  // The values cutsim knows: a BoxROI's selection (the component itself, kept), a component's own
  // attributes (followed through further links, at most 32 deep: a cycle is an error).
  if (t.type == "BoxROI" && field == "indices") {
    boxes_.push_back(&t);
    return "@box:" + std::to_string(boxes_.size() - 1);
  }
  if (const auto v = attr(t, field.c_str())) {
    if (!v->empty() && v->front() == '@') {
      if (++linkDepth_ > 32) {
        linkDepth_ = 0;
        fail(c, name, "link " + inQuotes(link) + " leads round a cycle of links");
      }
      std::string out = linkedValue(t, field.c_str(), *v);
      linkDepth_ = 0;
      return out;
    }
    return *v;
  }
  fail(c, name,
       "link " + inQuotes(link) + ": " + t.type + " " + inQuotes(t.name) + " has no field " +
           inQuotes(field) + " that cutsim can read");
}

void Importer::readTree(pugi::xml_node xml, SofaNode* parent, int depth) {
  if (depth > kMaxNodeDepth)
    fail(lineOf(xml.offset_debug()), parent->path(),
         "nodes nested deeper than " + std::to_string(kMaxNodeDepth) + " levels");
  auto node = std::make_unique<SofaNode>();
  node->xml = xml;
  node->parent = parent;
  node->line = lineOf(xml.offset_debug());
  node->name = xml.attribute("name") ? xml.attribute("name").value() : (parent ? "Node" : "root");
  SofaNode* self = node.get();
  if (parent)
    parent->children.push_back(std::move(node));
  else
    root_ = std::move(node);
  for (pugi::xml_node child : xml.children()) {
    if (child.type() != pugi::node_element) continue;
    const std::string tag = child.name();
    if (tag == "Node") {
      readTree(child, self, depth + 1);
      continue;
    }
    auto c = std::make_unique<SofaComponent>();
    c->xml = child;
    c->node = self;
    c->line = lineOf(child.offset_debug());
    c->type = tag == "Object" && child.attribute("type") ? child.attribute("type").value() : tag;
    if (tag == "Object") c->read.insert("type");
    // An unnamed component: SOFA names it after its class, numbered (MechanicalObject1, ...).
    c->name = child.attribute("name") ? std::string(child.attribute("name").value())
                                      : c->type + std::to_string(++unnamed_[c->type]);
    self->components.push_back(std::move(c));
  }
}

std::string Importer::resolveMeshFile(SofaComponent& c, const std::string& name) {
  // As SOFA's data repository: the scene's folder, then each enclosing folder's share/ (SOFA's
  // examples/ resolve mesh/... in share/).
  const std::filesystem::path base =
      file_.parent_path().empty() ? std::filesystem::path(".") : file_.parent_path();
  std::vector<std::filesystem::path> tried;
  std::error_code ec;
  const std::filesystem::path direct = base / name;
  tried.push_back(direct);
  if (std::filesystem::is_regular_file(direct, ec)) return direct.string();
  std::filesystem::path dir = std::filesystem::absolute(base, ec);
  while (!dir.empty()) {
    const std::filesystem::path candidate = dir / "share" / name;
    tried.push_back(candidate);
    if (std::filesystem::is_regular_file(candidate, ec)) return candidate.string();
    if (dir == dir.parent_path()) break;
    dir = dir.parent_path();
  }
  fail(c, "filename",
       "mesh file " + inQuotes(name) + " not found (looked for " + tried.front().string() +
           " and in the share/ folder of every enclosing folder)");
}

void Importer::loader(SofaComponent& c) {
  checkTemplate(c);
  Loader l;
  l.line = c.line;
  if (c.type == "GridMeshCreator") {
    // SOFA's procedural grid: resolution nx ny over the unit square, z = 0; trianglePattern 1
    // alternate, 2 upward (SOFA's default), 3 downward; 0 (quads) is not a triangle mesh.
    GridSpec g;
    g.nx = g.ny = 2;
    if (const auto r = value(c, "resolution")) {
      const auto n = numbers(c, "resolution", *r);
      if (n.size() != 2 || n[0] < 2 || n[1] < 2 || n[0] != std::floor(n[0]) ||
          n[1] != std::floor(n[1]) || n[0] > 1e5 || n[1] > 1e5)
        fail(c, "resolution",
             "expected two whole numbers >= 2 (vertices along x and y), got " + inQuotes(*r));
      g.nx = int(n[0]);
      g.ny = int(n[1]);
    }
    const double pattern = number(c, "trianglePattern", 2);
    if (pattern == 1)
      g.alternating = true;
    else if (pattern == 2)
      g.alternating = false;
    else if (pattern == 3) {
      g.alternating = false;
      g.downward = true;
    } else
      fail(c, "trianglePattern",
           "trianglePattern " + inQuotes(std::to_string(int(pattern))) +
               " is not supported (1 alternate, 2 upward, 3 downward; 0 makes quads)");
    l.grid = g;
  } else {
    const auto f = attr(c, "filename");
    if (!f) {
      if (c.xml.attribute("position") || c.xml.attribute("triangles"))
        fail(c, "position",
             "a loader given its points and triangles inline is not supported: give a mesh file");
      fail(c, "filename", "missing attribute \"filename\"");
    }
    l.file = resolveMeshFile(c, *f);
    {
      // Each loader reads its own format (cutsim reads by the file's extension).
      std::string ext = l.file.extension().string();
      for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
      const std::string want = c.type == "MeshOBJLoader"    ? ".obj"
                               : c.type == "MeshGmshLoader" ? ".msh"
                                                            : ".off";
      if (ext != want)
        fail(c, "filename",
             c.type + " reads " + want + " files, not " + inQuotes(l.file.filename().string()));
    }
  }
  // SOFA reads "scale" as a float and multiplies scale3d by it.
  if (const auto s = vec3(c, "scale3d")) l.transform.scale = *s;
  if (value(c, "scale")) {
    const double k = double(float(number(c, "scale", 1)));
    l.transform.scale = {l.transform.scale[0] * k, l.transform.scale[1] * k,
                         l.transform.scale[2] * k};
  }
  for (int k = 0; k < 3; ++k)
    if (!(l.transform.scale[std::size_t(k)] > 0)) fail(c, "scale", "must be > 0");
  if (const auto r = vec3(c, "rotation")) l.transform.rotation = *r;
  if (const auto t = vec3(c, "translation")) l.transform.translation = *t;
  if (value(c, "transformation"))
    fail(c, "transformation",
         "a loader's 4x4 transformation is not supported: give scale, rotation and translation");
  requireFalse(c, "flipNormals", "keeps the triangles' orientation as read");
  requireFalse(c, "onlyAttachedPoints", "keeps every point of the file");
  requireFalse(c, "handleSeams", "reads one point per vertex (no duplicated seams)");
  attr(c, "triangulate");  // cutsim reads triangles only: a quad is an error of the mesh reader
  attr(c, "createSubelements");  // edges follow from the triangles
  loaders_[&c] = l;
}

void Importer::meshFrom(SofaComponent& c, bool topologyContainer) {
  // src="@loader", or position="@loader.position" (and triangles="@loader.triangles").
  const SofaComponent* from = nullptr;
  auto take = [&](const char* attribute) {
    const auto v = attr(c, attribute);
    if (!v) return;
    if (v->empty() || v->front() != '@') {
      if (std::string(attribute) == "src")
        fail(c, attribute, "expected a link to a loader, \"@name\"");
      fail(c, attribute,
           "inline " + std::string(attribute) +
               " is not supported: link a loader (src=\"@loader\")");
    }
    std::string field;
    SofaComponent& t = linkTarget(c, attribute, *v, field);
    if (!loaders_.count(&t))
      fail(c, attribute,
           "link " + inQuotes(*v) + " names " + t.type + " " + inQuotes(t.name) +
               ", not a mesh loader");
    if (from && from != &t) fail(c, attribute, "reads two different loaders");
    from = &t;
  };
  take("src");
  take("position");
  if (topologyContainer) {
    take("triangles");
    take("edges");
    take("points");
  }
  if (!from) {
    if (topologyContainer && attr(c, "filename"))
      fail(c, "filename",
           "a topology container with its own file is not supported: use a loader and "
           "src=\"@loader\"");
    return;
  }
  if (meshLoader_ && meshLoader_ != from)
    fail(c, "src",
         "reads the loader " + inQuotes(from->name) + " where the scene's mesh comes from " +
             inQuotes(meshLoader_->name) + ": cutsim simulates one surface");
  meshLoader_ = from;
}

void Importer::component(SofaComponent& c) {
  const std::string& t = c.type;
  const Translator* translator = translatorOf(t);
  if (translator && translator->onState) actOnState_.push_back(&c);
  if (isLoader(t)) return loader(c);
  if (isVisualOrGui(t)) {
    for (const auto& a : c.xml.attributes()) c.read.insert(a.name());
    ignored_.push_back(t + " " + inQuotes(c.name) + " (line " + std::to_string(c.line) +
                       "): drawing or GUI only");
    return;
  }
  if (isMapping(t)) {
    // A mapping whose output is a visual model only moves what is drawn.
    for (const auto& a : c.xml.attributes()) c.read.insert(a.name());
    const auto out = c.xml.attribute("output");
    std::string field;
    if (out && out.value()[0] == '@') {
      SofaComponent& target = linkTarget(c, "output", out.value(), field);
      if (isVisualOrGui(target.type)) {
        ignored_.push_back(t + " " + inQuotes(c.name) + " (line " + std::to_string(c.line) +
                           "): maps the state onto a visual model only");
        return;
      }
    }
    fail(c, "",
         t + " whose output is not a visual model is not supported: cutsim simulates one surface, "
             "without mapped states");
  }
  if (t == "QuadularBendingSprings")
    fail(c, "", t + " is not supported: cutsim simulates triangle meshes");
  if (translator) return (this->*translator->translate)(c);
  std::string known;
  for (const Translator& tr : translators())
    for (const char* type : tr.types) known += (known.empty() ? "" : ", ") + std::string(type);
  fail(c, "",
       "component " + inQuotes(t) + " is not supported (cutsim reads: " + known +
           "; drawing and GUI components are ignored)");
}

const std::vector<Importer::Translator>& Importer::translators() {
  static const std::vector<Translator> table = {
      {{"DefaultAnimationLoop"}, false, &Importer::animationLoop},
      {{"EulerImplicitSolver"}, false, &Importer::eulerImplicitSolver},
      {{"CGLinearSolver"}, false, &Importer::cgLinearSolver},
      {{"MeshOBJLoader", "MeshGmshLoader", "MeshOffLoader", "GridMeshCreator"},
       false,
       &Importer::loader},
      {{"MeshTopology", "TriangleSetTopologyContainer"}, false, &Importer::topologyContainer},
      {{"MechanicalObject"}, false, &Importer::mechanicalObject},
      {{"BoxROI"}, false, &Importer::boxRoi},
      {{"FixedProjectiveConstraint", "FixedConstraint"}, true, &Importer::fixedConstraint},
      {{"BoxConstraint"}, true, &Importer::boxConstraint},
      {{"UniformMass", "DiagonalMass"}, true, &Importer::mass},
      {{"TriangularFEMForceFieldOptim", "TriangularFEMForceField", "TriangleFEMForceField"},
       true,
       &Importer::triangleFem},
      {{"FastTriangularBendingSprings"}, true, &Importer::fastBendingSprings},
      {{"TriangularBendingSprings"}, true, &Importer::bendingSprings},
      {{"MeshSpringForceField"}, true, &Importer::meshSprings},
  };
  return table;
}

const Importer::Translator* Importer::translatorOf(std::string_view type) {
  for (const Translator& tr : translators())
    for (const char* t : tr.types)
      if (type == t) return &tr;
  return nullptr;
}

void Importer::animationLoop(SofaComponent& c) {
  requireFalse(c, "parallelODESolving", "steps one solver");
}

void Importer::eulerImplicitSolver(SofaComponent& c) {
  if (odeSolver_)
    fail(c, "",
         "a second ODE solver (the first at line " + std::to_string(odeSolver_->line) +
             "): cutsim steps one");
  odeSolver_ = &c;
  integratorJson_ = ojson::object();
  integratorJson_["type"] = "sofa-euler";
  integratorJson_["rayleighMass"] = number(c, "rayleighMass", 0.0);
  integratorJson_["rayleighStiffness"] = number(c, "rayleighStiffness", 0.0);
  if (integratorJson_["rayleighMass"].get<double>() < 0 ||
      integratorJson_["rayleighStiffness"].get<double>() < 0)
    fail(c, "", "negative Rayleigh damping is not supported");
  requireFalse(c, "firstOrder", "integrates the second-order system (firstOrder=0)");
  requireFalse(c, "trapezoidalScheme", "has backward Euler's scheme (trapezoidalScheme=0)");
  requireFalse(c, "solveConstraint", "has no Lagrangian constraints");
  requireNumber(c, "vdamping", 0.0, "has no velocity damping (use rayleighMass)");
}

void Importer::cgLinearSolver(SofaComponent& c) {
  if (linearSolver_)
    fail(c, "",
         "a second linear solver (the first at line " + std::to_string(linearSolver_->line) + ")");
  linearSolver_ = &c;
  const auto tmpl = attr(c, "template");
  if (tmpl && *tmpl != "GraphScattered" && !startsWith(*tmpl, "CompressedRowSparseMatrix") &&
      *tmpl != "SparseMatrix" && *tmpl != "FullMatrix")
    fail(c, "template", "template " + inQuotes(*tmpl) + " is not supported");
  linearSolverJson_ = ojson::object();
  linearSolverJson_["type"] = "sofa-cg";
  const double it = number(c, "iterations", 25);
  if (it < 1 || it != std::floor(it) || it > 1e6)
    fail(c, "iterations", "expected a whole number >= 1");
  linearSolverJson_["iterations"] = long(it);
  linearSolverJson_["tolerance"] = number(c, "tolerance", 1e-5);
  linearSolverJson_["threshold"] = number(c, "threshold", 1e-5);
  linearSolverJson_["warmStart"] = boolean(c, "warmStart", false);
  if (!(linearSolverJson_["tolerance"].get<double>() > 0)) fail(c, "tolerance", "must be > 0");
  if (linearSolverJson_["threshold"].get<double>() < 0) fail(c, "threshold", "must be >= 0");
}

void Importer::topologyContainer(SofaComponent& c) {
  if (topology_)
    fail(c, "",
         "a second topology (the first at line " + std::to_string(topology_->line) +
             "): cutsim simulates one surface");
  topology_ = &c;
  meshFrom(c, true);
}

void Importer::mechanicalObject(SofaComponent& c) {
  if (mechanicalObject_)
    fail(c, "",
         "a second MechanicalObject (the first at line " + std::to_string(mechanicalObject_->line) +
             "): cutsim simulates one surface");
  mechanicalObject_ = &c;
  checkTemplate(c);
  meshFrom(c, false);
  // SOFA reads "scale" as a float, and it sets scale3d (after scale3d itself is read).
  if (const auto s = vec3(c, "scale3d")) stateTransform_.scale = *s;
  if (value(c, "scale")) {
    const double k = double(float(number(c, "scale", 1)));
    stateTransform_.scale = {k, k, k};
  }
  for (int k = 0; k < 3; ++k)
    if (!(stateTransform_.scale[std::size_t(k)] > 0)) fail(c, "scale", "must be > 0");
  if (const auto r = vec3(c, "rotation")) stateTransform_.rotation = *r;
  if (const auto tr = vec3(c, "translation")) stateTransform_.translation = *tr;
  requireDefault(c, "rotation2",
                 "places the rest shape and the state together (rotation2 moves the state only)",
                 [&](const std::string& v) {
                   return numbers(c, "rotation2", v) == std::vector<double>{0, 0, 0};
                 });
  requireDefault(c, "translation2",
                 "places the rest shape and the state together (translation2 moves the state only)",
                 [&](const std::string& v) {
                   return numbers(c, "translation2", v) == std::vector<double>{0, 0, 0};
                 });
  requireNumber(c, "restScale", 1.0,
                "takes the rest shape from the mesh (use a force field's restScale)");
  for (const char* a : {"velocity", "rest_position", "force", "externalForce", "derivX",
                        "free_position", "free_velocity"})
    if (c.xml.attribute(a))
      fail(c, a, "an initial " + std::string(a) + " is not supported: the state starts at rest");
  for (const char* a : {"dx", "dy", "dz", "rx", "ry", "rz", "sx", "sy", "sz", "dx2", "dy2", "dz2",
                        "rx2", "ry2", "rz2"})
    if (c.xml.attribute(a))
      fail(c, a,
           "the per-axis placement attributes are not supported: give scale3d, rotation, "
           "translation");
  attr(c, "size");
  out_.mechanicalObject = c.name;
}

void Importer::mass(SofaComponent& c) {
  const std::string& t = c.type;
  if (mass_) fail(c, "", "a second mass (the first at line " + std::to_string(mass_->line) + ")");
  mass_ = &c;
  massAt_ = forceFields_.size();  // SOFA sums the components in the node's order
  checkTemplate(c);
  massJson_ = ojson::object();
  requireNumber(c, "rayleighMass", 0.0, "has Rayleigh damping on the ODE solver only");
  requireFalse(c, "separateGravity", "adds gravity as a force");
  if (t == "UniformMass") {
    const auto total = value(c, "totalMass");
    const auto vertex = value(c, "vertexMass");
    if (value(c, "filename")) fail(c, "filename", "a mass from a file is not supported");
    if (c.xml.attribute("indices"))
      fail(c, "indices", "a mass on some points only is not supported");
    requireFalse(c, "preserveTotalMass",
                 "keeps the mass per point when a cut adds points (preserveTotalMass=0)");
    if (c.xml.attribute("localRange")) fail(c, "localRange", "localRange is not supported");
    if (total) {  // SOFA: totalMass wins over vertexMass
      if (vertex)
        note(
            c.line,
            c.path() + "/vertexMass: ignored: totalMass is given too (as in SOFA, totalMass wins)");
      massJson_["total"] = number(c, "totalMass", 1);
      massJson_["lumping"] = "uniform";
    } else if (vertex) {
      massJson_["perPoint"] = number(c, "vertexMass", 1);
    } else {
      fail(c, "", "give totalMass or vertexMass (SOFA refuses a UniformMass without either)");
    }
  } else {
    const auto total = value(c, "totalMass");
    const auto density = value(c, "massDensity");
    if (c.xml.attribute("vertexMass"))
      fail(c, "vertexMass", "per-point masses are not supported: give massDensity or totalMass");
    attr(c, "computeMassOnRest");  // the state starts at rest: the same areas either way
    if (total) {
      if (density)
        note(c.line,
             c.path() +
                 "/massDensity: ignored: totalMass is given too (as in SOFA, totalMass wins)");
      massJson_["total"] = number(c, "totalMass", 1);
    } else if (density) {
      massJson_["density"] = number(c, "massDensity", 1);
    } else {
      massJson_["total"] = 1.0;  // SOFA: neither given, a total mass of 1
    }
  }
  for (auto it = massJson_.begin(); it != massJson_.end(); ++it)
    if (it.value().is_number() && !(it.value().get<double>() > 0))
      fail(c, "", "the mass must be > 0");
}

void Importer::triangleFem(SofaComponent& c) {
  const std::string& t = c.type;
  checkTemplate(c);
  ojson f = ojson::object();
  f["type"] = "TriangularFEMForceFieldOptim";
  f["label"] = c.name;
  const auto method = value(c, "method");
  if (method && *method != "large") {
    // SOFA's Optim has the large method only: it warns and runs it; the other field's small
    // method is another element.
    if (t == "TriangularFEMForceFieldOptim")
      note(c.line, c.path() + "/method: \"" + *method +
                       "\" ignored: TriangularFEMForceFieldOptim has the large method only (as "
                       "SOFA warns)");
    else
      fail(
          c, "method",
          "method " + inQuotes(*method) + " is not supported (cutsim has SOFA's \"large\" method)");
  }
  f["youngModulus"] =
      number(c, "youngModulus", 5000);  // SOFA's defaults (BaseLinearElasticityFEMForceField)
  f["poissonRatio"] = number(c, "poissonRatio", 0.45);
  if (value(c, "restScale")) f["restScale"] = number(c, "restScale", 1);
  requireNumber(c, "rayleighStiffness", 0.0, "has Rayleigh damping on the ODE solver only");
  attr(c, "damping");  // SOFA reads it and never uses it
  attr(c, "computePrincipalStress");
  attr(c, "stressMaxValue");
  if (t == "TriangleFEMForceField") {  // SOFA's older triangle: the same element, with a thickness
    if (value(c, "thickness")) f["thickness"] = number(c, "thickness", 1);
    requireFalse(c, "planeStrain", "has plane stress (planeStrain=0)");
  }
  if (t == "TriangularFEMForceField") {
    requireFalse(c, "computeGlobalMatrix", "has no global matrix option");
    for (const char* a :
         {"fiberAngle", "fiberCenter", "hosfordExponant", "criteriaValue", "computeVonMisesStress"})
      attr(c, a);
    if (c.xml.attribute("rotatedInitialElements") || c.xml.attribute("initialTransformation"))
      fail(c, "", "given initial rotations are not supported");
  }
  forceFields_.push_back(f);
  forceFieldFrom_.push_back(&c);
}

void Importer::boxConstraint(SofaComponent& c) {
  checkTemplate(c);
  const auto b = value(c, "box");
  if (!b) fail(c, "box", "missing attribute \"box\"");
  addBoxes(c, numbers(c, "box", *b));
}

void Importer::meshSprings(SofaComponent& c) {
  checkTemplate(c);
  // Every edge of a triangle mesh is a line and a triangle's edge: one stiffness, one damping.
  auto agreed = [&](std::initializer_list<const char*> names, const char* what) {
    std::optional<double> v;
    for (const char* a : names) {
      const auto s = value(c, a);
      if (!s) continue;
      const double d = number(c, a, 0);
      if (d == 0 && std::string(a) != "stiffness" && std::string(a) != "damping") continue;
      if (v && *v != d)
        fail(c, a,
             std::string("the mesh's edges get one ") + what + ": " + a +
                 " differs from the other " + what + " given");
      v = d;
    }
    return v.value_or(0.0);
  };
  const double ks = agreed({"stiffness", "linesStiffness", "trianglesStiffness"}, "stiffness");
  const double kd = agreed({"damping", "linesDamping", "trianglesDamping"}, "damping");
  for (const char* a :
       {"quadsStiffness", "quadsDamping", "tetrahedraStiffness", "tetrahedraDamping",
        "tetrasStiffness", "tetrasDamping", "cubesStiffness", "cubesDamping"})
    requireNumber(c, a, 0.0, "simulates triangle meshes (no quads, tetrahedra or cubes)");
  requireFalse(c, "noCompression", "has springs that push as they pull");
  if (c.xml.attribute("localRange")) fail(c, "localRange", "localRange is not supported");
  if (ks < 0 || kd < 0) fail(c, "", "stiffness and damping must be >= 0");
  ojson f = ojson::object();
  f["type"] = "StretchSprings";
  f["label"] = c.name;
  f["stiffness"] = ks;
  f["damping"] = kd;
  f["perRestLength"] = true;    // SOFA: stiffness / L0 per spring
  f["stableJacobian"] = false;  // SOFA's K is the spring's whole Jacobian
  forceFields_.push_back(f);
  forceFieldFrom_.push_back(&c);
}

void Importer::bendingSprings(SofaComponent& c) {
  checkTemplate(c);
  ojson f = ojson::object();
  f["type"] = "TriangularBendingSprings";
  f["label"] = c.name;
  f["stiffness"] = number(c, "stiffness", 100000.0);  // SOFA's defaults
  f["damping"] = number(c, "damping", 1.0);
  requireNumber(c, "rayleighStiffness", 0.0, "has Rayleigh damping on the ODE solver only");
  attr(c, "showSprings");
  forceFields_.push_back(f);
  forceFieldFrom_.push_back(&c);
}

void Importer::fastBendingSprings(SofaComponent& c) {
  checkTemplate(c);
  ojson f = ojson::object();
  f["type"] = "FastTriangularBendingSprings";
  f["label"] = c.name;
  f["bendingStiffness"] = number(c, "bendingStiffness", 1.0);
  f["minDistValidity"] = number(c, "minDistValidity", 1e-6);
  requireNumber(c, "rayleighStiffness", 0.0, "has Rayleigh damping on the ODE solver only");
  forceFields_.push_back(f);
  forceFieldFrom_.push_back(&c);
}

void Importer::boxRoi(SofaComponent& c) {
  checkTemplate(c);
  // Read when a constraint links its indices ("@box.indices"); its boxes are checked here.
  const auto b = value(c, "box");
  if (!b)
    fail(c, "box", "missing attribute \"box\" (SOFA's default box 0 0 0 1 1 1 is not assumed)");
  const auto n = numbers(c, "box", *b);
  if (n.empty() || n.size() % 6 != 0)
    fail(c, "box",
         "expected 6 numbers per box (xmin ymin zmin xmax ymax zmax), got " +
             std::to_string(n.size()));
  for (const char* a : {"orientedBox", "sphere", "plane"})
    if (c.xml.attribute(a))
      fail(c, a, "a BoxROI with " + std::string(a) + " is not supported: axis-aligned boxes only");
  if (const auto p = attr(c, "position")) {
    std::string field;
    if (p->empty() || p->front() != '@')
      fail(c, "position",
           "inline positions are not supported: a BoxROI selects the state's rest positions");
    linkTarget(c, "position", *p, field);
  }
  for (const char* a : {"computeEdges", "computeTriangles", "computeTetrahedra", "computeHexahedra",
                        "computeQuad", "strict"})
    attr(c, a);
}

void Importer::fixedConstraint(SofaComponent& c) {
  checkTemplate(c);
  if (boolean(c, "fixAll", false)) {
    constraints_.push_back(
        {{"type", "fixed"}, {"box", {{-1e300, -1e300, -1e300}, {1e300, 1e300, 1e300}}}});
    constraintFrom_.push_back(&c);
    return;
  }
  attr(c, "activate_projectVelocity");  // the fixed points' velocity is zero either way
  const auto v = value(c, "indices");
  if (v && startsWith(*v, "@box:")) {
    SofaComponent& box = *boxes_.at(std::size_t(std::stoul(v->substr(5))));
    const auto b = value(box, "box");
    if (!b)
      fail(box, "box", "missing attribute \"box\" (SOFA's default box 0 0 0 1 1 1 is not assumed)");
    addBoxes(box, numbers(box, "box", *b));
    return;
  }
  ojson points = ojson::array();
  for (double d : numbers(c, "indices", v ? *v : std::string("0"))) {  // SOFA's default: point 0
    if (d < 0 || d != std::floor(d) || d > 4e9)
      fail(c, "indices", "expected point indices (whole numbers >= 0)");
    points.push_back(long(d));
  }
  if (points.empty()) {
    note(c.line, c.path() + "/indices: fixes no point");
    return;
  }
  constraints_.push_back({{"type", "fixed"}, {"points", points}});
  constraintFrom_.push_back(&c);
}

void Importer::translateLoaders(SofaNode& n) {
  for (auto& c : n.components)
    if (isLoader(c->type)) component(*c);
  for (auto& child : n.children) translateLoaders(*child);
}

void Importer::translate(SofaNode& n) {
  // The loaders were read first (others link to them, anywhere): the rest in file order, then
  // the nodes.
  for (auto& c : n.components)
    if (!isLoader(c->type)) component(*c);
  for (auto& c : n.components)
    for (const auto& a : c->xml.attributes()) {
      const std::string name = a.name();
      if (!c->read.count(name) && !isDisplayAttribute(name))
        note(c->line, c->path() + "/" + name + ": attribute " + inQuotes(name) + " of " + c->type +
                          " is not used by cutsim");
    }
  static const std::set<std::string> nodeAttributes = {"name",
                                                       "dt",
                                                       "gravity",
                                                       "time",
                                                       "animate",
                                                       "multiThreadSimulation",
                                                       "showBoundingTree",
                                                       "activated",
                                                       "bbox",
                                                       "printLog",
                                                       "tags"};
  for (const auto& a : n.xml.attributes()) {
    const std::string name = a.name();
    if (!n.parent && (name == "dt" || name == "gravity")) continue;
    if (n.parent && (name == "dt" || name == "gravity"))
      fail(n.line, n.path() + "/" + name,
           "a child node's own " + name + " is not supported: give it on the root node");
    if (name == "activated" && (std::string(a.value()) == "0" || std::string(a.value()) == "false"))
      fail(n.line, n.path() + "/activated", "a deactivated node is not supported: remove it");
    if (!nodeAttributes.count(name))
      note(n.line, n.path() + "/" + name + ": attribute " + inQuotes(name) +
                       " of the node is not used by cutsim");
  }
  for (auto& child : n.children) translate(*child);
}

void Importer::finish() {
  if (!mechanicalObject_) fail(rootLine_, "/" + root_->name, "the scene has no MechanicalObject");
  if (!meshLoader_)
    fail(mechanicalObject_->line, mechanicalObject_->path(),
         "the MechanicalObject reads no mesh (give src=\"@loader\")");
  if (!topology_)
    fail(mechanicalObject_->line, mechanicalObject_->path(),
         "the scene has no topology (MeshTopology or TriangleSetTopologyContainer)");
  if (!mass_)
    fail(mechanicalObject_->line, mechanicalObject_->path(),
         "the scene has no mass (UniformMass or DiagonalMass)");
  if (!odeSolver_)
    fail(rootLine_, "/" + root_->name, "the scene has no ODE solver (EulerImplicitSolver)");
  if (!linearSolver_)
    fail(odeSolver_->line, odeSolver_->path(),
         "the ODE solver has no linear solver (CGLinearSolver)");
  // SOFA's context: a mass, a force field or a constraint acts on the state of its own node; a
  // solver on the states of its node and below; a state takes the topology of its node or above.
  const SofaNode* stateNode = mechanicalObject_->node;
  auto above = [&](const SofaNode* n, const SofaNode* below) {
    for (const SofaNode* m = below; m; m = m->parent)
      if (m == n) return true;
    return false;
  };
  for (const SofaComponent* c : actOnState_)
    if (c->node != stateNode)
      fail(c->line, c->path(),
           c->type + " acts on the MechanicalObject of its own node: put it in " +
               inQuotes(stateNode->path()) + ", beside the MechanicalObject (line " +
               std::to_string(mechanicalObject_->line) + ")");
  if (!above(odeSolver_->node, stateNode))
    fail(odeSolver_->line, odeSolver_->path(),
         "the ODE solver steps the states of its node and below: the MechanicalObject (line " +
             std::to_string(mechanicalObject_->line) + ") is not among them");
  if (!above(linearSolver_->node, odeSolver_->node))
    fail(linearSolver_->line, linearSolver_->path(),
         "the ODE solver (line " + std::to_string(odeSolver_->line) +
             ") finds its linear solver in its node or above, not here");
  if (!above(topology_->node, stateNode))
    fail(topology_->line, topology_->path(),
         "the MechanicalObject (line " + std::to_string(mechanicalObject_->line) +
             ") takes the topology of its node or above, not this one");
  const Loader& l = loaders_.at(meshLoader_);
  // The loader places the points (scale, rotation, translation), then the MechanicalObject does.
  // SOFA places the points twice (the loader's 4 x 4 matrix, then the MechanicalObject's scale,
  // rotation and translation): cutsim places them once, so only one of the two may move them.
  if (!l.transform.identity() && !stateTransform_.identity())
    fail(mechanicalObject_->line, mechanicalObject_->path(),
         "both the loader (line " + std::to_string(l.line) +
             ") and the MechanicalObject place the mesh (scale, rotation, translation): place it "
             "in one of them");
  const MeshTransform tr = l.transform.identity() ? stateTransform_ : l.transform;
  const std::size_t placedAt = l.transform.identity() ? mechanicalObject_->line : l.line;

  ojson& s = out_.scene;
  s = ojson::object();
  s["name"] = file_.stem().string();
  s["description"] = "SOFA scene " + file_.filename().string() + ", translated by cutsim's reader";
  ojson mesh = ojson::object();
  const std::filesystem::path jsonDir =
      options_.jsonDir.empty() ? file_.parent_path() : options_.jsonDir;
  out_.jsonDir = jsonDir;
  std::error_code ec;
  if (l.grid) {
    ojson grid = {{"nx", l.grid->nx}, {"ny", l.grid->ny}, {"size", {1.0, 1.0}}};
    grid["diagonals"] = l.grid->alternating ? "alternating"
                        : l.grid->downward  ? "downward"
                                            : "oneway";
    mesh["grid"] = grid;
  } else {
    // Relative to the JSON's folder, both resolved (symbolic links, "..") first.
    const std::filesystem::path meshAbs =
        std::filesystem::weakly_canonical(std::filesystem::absolute(l.file, ec), ec);
    const std::filesystem::path dirAbs = std::filesystem::weakly_canonical(
        std::filesystem::absolute(jsonDir.empty() ? "." : jsonDir, ec), ec);
    const std::filesystem::path rel = meshAbs.lexically_relative(dirAbs);
    mesh["file"] = (rel.empty() ? meshAbs : rel).generic_string();
  }
  if (tr.scale != Vec3{1, 1, 1}) {
    if (tr.scale[0] == tr.scale[1] && tr.scale[1] == tr.scale[2])
      mesh["scale"] = tr.scale[0];
    else
      mesh["scale"] = {tr.scale[0], tr.scale[1], tr.scale[2]};
  }
  if (tr.rotation != Vec3{0, 0, 0})
    mesh["rotation"] = {tr.rotation[0], tr.rotation[1], tr.rotation[2]};
  if (tr.translation != Vec3{0, 0, 0})
    mesh["translation"] = {tr.translation[0], tr.translation[1], tr.translation[2]};
  s["mesh"] = mesh;
  setFrom("/mesh", *meshLoader_);
  for (const char* k : {"scale", "rotation", "translation"}) {
    setLine(std::string("/mesh/") + k, placedAt);
    out_.labels[std::string("/mesh/") + k] =
        (l.transform.identity() ? mechanicalObject_->path() : meshLoader_->path()) + "/" + k;
  }
  s["mass"] = massJson_;
  setFrom("/mass", *mass_);
  s["gravity"] = {gravity_[0], gravity_[1], gravity_[2]};
  setLine("/gravity", rootLine_);
  out_.labels["/gravity"] = root_->path() + "/gravity";
  s["forceFields"] = forceFields_;
  for (std::size_t i = 0; i < forceFieldFrom_.size(); ++i)
    setFrom("/forceFields/" + std::to_string(i), *forceFieldFrom_[i]);
  s["constraints"] = constraints_;
  for (std::size_t i = 0; i < constraintFrom_.size(); ++i)
    setFrom("/constraints/" + std::to_string(i), *constraintFrom_[i]);
  if (massAt_ > 0) integratorJson_["massAt"] = massAt_;
  s["integrator"] = integratorJson_;
  setFrom("/integrator", *odeSolver_);
  s["linearSolver"] = linearSolverJson_;
  setFrom("/linearSolver", *linearSolver_);
  s["timeStep"] = dt_;
  setLine("/timeStep", rootLine_);
  out_.labels["/timeStep"] = root_->path() + "/dt";
  setLine("/duration", rootLine_);
  out_.labels["/duration"] = root_->path() + "/dt (times the steps)";
  s["duration"] = double(options_.steps) * dt_;
  s["output"] = {{"every", 1}, {"vtk", true}, {"springs", false}, {"obj", false}, {"csv", true}};
  s["ignored"] = ignored_;
  setLine("", rootLine_);
  out_.labels[""] = root_->path();
}

SofaSceneImport Importer::run() {
  out_.file = file_;
  {
    std::error_code ec;
    if (std::filesystem::is_directory(file_, ec))
      throw InvalidInput(file_.string(), "cannot open: it is a folder");
    std::ifstream in(file_, std::ios::binary);
    if (!in) throw InvalidInput(file_.string(), "cannot open the scene file");
    std::ostringstream o;
    o << in.rdbuf();
    text_ = o.str();
  }
  const pugi::xml_parse_result r =
      doc_.load_buffer(text_.data(), text_.size(), pugi::parse_default | pugi::parse_declaration);
  if (!r) {
    const std::size_t line = lineOf(r.offset);
    const std::size_t lineStart =
        text_.rfind('\n', std::size_t(std::max<std::ptrdiff_t>(0, r.offset - 1)));
    const std::size_t column =
        std::size_t(r.offset) - (lineStart == std::string::npos ? 0 : lineStart + 1) + 1;
    throw InvalidInput(file_.string() + ":" + std::to_string(line) + ":" + std::to_string(column),
                       std::string("malformed XML: ") + r.description());
  }
  pugi::xml_node rootXml;
  for (pugi::xml_node n : doc_.children())
    if (n.type() == pugi::node_element) {
      if (rootXml)
        fail(lineOf(n.offset_debug()), "/",
             "a second root element <" + std::string(n.name()) + ">");
      rootXml = n;
    }
  if (!rootXml) fail(0, "/", "no root <Node> element");
  if (std::string(rootXml.name()) != "Node")
    fail(lineOf(rootXml.offset_debug()), "/",
         "the root element is <" + std::string(rootXml.name()) + ">, expected <Node>");
  readTree(rootXml, nullptr);
  rootLine_ = root_->line;
  if (const auto a = rootXml.attribute("dt")) {
    const auto w = words(a.value());
    const auto d = w.size() == 1 ? parseSofaNumber(w[0]) : std::nullopt;
    if (!d || !(*d > 0) || !std::isfinite(*d))
      fail(rootLine_, root_->path() + "/dt",
           "expected a time step > 0, got " + inQuotes(a.value()));
    dt_ = *d;
    if (!std::isfinite(dt_ * double(options_.steps)))
      fail(rootLine_, root_->path() + "/dt",
           "dt times the " + std::to_string(options_.steps) +
               " steps is beyond the range of doubles");
  }
  if (const auto a = rootXml.attribute("gravity")) {
    std::vector<double> g;
    for (auto w : words(a.value())) {
      const auto d = parseSofaNumber(w);
      if (!d || !std::isfinite(*d))
        fail(rootLine_, root_->path() + "/gravity",
             "expected 3 numbers, got " + inQuotes(a.value()));
      g.push_back(*d);
    }
    if (g.size() != 3)
      fail(rootLine_, root_->path() + "/gravity", "expected 3 numbers, got " + inQuotes(a.value()));
    gravity_ = {g[0], g[1], g[2]};
  }
  translateLoaders(*root_);
  translate(*root_);
  finish();
  return std::move(out_);
}

}  // namespace

SofaSceneImport importSofaScene(const std::filesystem::path& file,
                                const SofaImportOptions& options) {
  if (options.steps < 1) throw InvalidInput("steps", "must be >= 1");
  return Importer(file, options).run();
}

Scene sceneFromSofa(const SofaSceneImport& imported) {
  detail::JsonDocument doc;
  doc.root = detail::json::parse(imported.scene.dump());
  doc.lines = imported.lines;
  doc.labels = imported.labels;
  return detail::parseSceneDocument(doc, imported.file.string(), imported.jsonDir);
}

}  // namespace cutsim::core
