// Scene files: the schema (every section and key checked before anything runs, force fields,
// integrators and linear solvers read through their registries) and loadScene. The format is
// described in docs/scenes.md.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "cutsim/base/numbers.hpp"
#include "cutsim/core/registries.hpp"
#include "cutsim/core/scene.hpp"
#include "cutsim/core/sofa_scene.hpp"
#include "cutsim/core/timeline.hpp"
#include "cutsim/topology/geometry.hpp"
#include "scene/scene_internal.hpp"
#include "scene/scene_json.hpp"

namespace cutsim::core {

using namespace detail;
using topology::geometry::dist2;

SceneSections& SceneSections::instance() {
  static SceneSections sections;
  return sections;
}

bool SceneSections::add(SceneSection section) {
  for (const SceneSection& s : sections_)
    if (s.name == section.name)
      throw std::logic_error("the scene section \"" + section.name + "\" is added twice");
  sections_.push_back(std::move(section));
  return true;
}

std::vector<const SceneSection*> SceneSections::inOrder() const {
  std::vector<const SceneSection*> out;
  for (const SceneSection& s : sections_)
    if (s.after.empty()) out.push_back(&s);
  for (const SceneSection& s : sections_)
    if (!s.after.empty()) out.push_back(&s);
  return out;
}

std::string SceneLocation::where(const std::string& file) const {
  const std::string& f = source.empty() ? file : source;
  return line ? f + ":" + std::to_string(line) : f;
}

namespace detail {

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
    } else if (v ==
               "downward") {  // SOFA's GridMeshCreator pattern 3: every cell along (i+1,j)-(i,j+1)
      g.alternating = false;
      g.downward = true;
    } else {
      r.fail(ptr + "/diagonals", "unknown value \"" + v + "\" (alternating, oneway, downward)");
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
  // The grid's points must be representable with room for the forces on them.
  if (g.width > 1e100) r.fail(ptr + "/size/0", "must be at most 1e100");
  if (g.height > 1e100) r.fail(ptr + "/size/1", "must be at most 1e100");
  for (std::size_t k = 0; k < 3; ++k)
    if (std::abs(g.origin[k]) > 1e100)
      r.fail(ptr + "/origin/" + std::to_string(k), "must be at most 1e100 in size");
}

ForceFieldSpec parseForceField(const Reader& r, const json& j, const std::string& ptr) {
  r.expectObject(j, ptr);
  ForceFieldSpec f;
  f.location = r.location(ptr);
  f.type = r.string(r.require(j, ptr, "type"), ptr + "/type");
  const auto& registry = forcefields::ForceFieldRegistry::instance();
  const auto* entry = registry.find(f.type);
  if (!entry) {
    r.fail(ptr + "/type", "unknown force field type \"" + f.type +
                              "\" (registered: " + registeredNames(registry) + ")");
  }
  checkComponentKeys(r, j, ptr, registry, *entry, {"label"});
  if (const json* l = r.find(j, "label")) {
    f.label = r.string(*l, ptr + "/label");
    if (f.label.empty()) r.fail(ptr + "/label", "must not be empty");
    if (f.label.find_first_of(",\"\n\r") != std::string::npos ||
        f.label.find('\0') != std::string::npos)
      r.fail(ptr + "/label",
             "must not contain a comma, a quote or a line break (it names CSV columns and files)");
  }
  f.parameters = entry->read(JsonParameterSource(r, j, ptr));
  return f;
}

/// A component of the integrator's or the linear solver's registry, read from its object.
/// The components of the other stepping registry that have a key (a linear solver's key given to
/// an integrator, or the other way round).
std::vector<std::string> linearSolversWithKey(const std::string& key) {
  std::vector<std::string> out;
  for (std::string& o : LinearSolverRegistry::instance().ownersOf(key))
    out.push_back("the linear solver " + o);
  return out;
}
std::vector<std::string> integratorsWithKey(const std::string& key) {
  std::vector<std::string> out;
  for (std::string& o : IntegratorRegistry::instance().ownersOf(key))
    out.push_back("the integrator " + o);
  return out;
}

template <class Registry>
ComponentSpec parseComponent(const Reader& r, const json& j, const std::string& ptr,
                             const Registry& registry, const char* kind, std::string defaultType,
                             std::vector<std::string> (*elsewhere)(const std::string&)) {
  r.expectObject(j, ptr);
  ComponentSpec c;
  c.location = r.location(ptr);
  c.type = defaultType;
  if (const json* t = r.find(j, "type"))
    c.type = r.string(*t, ptr + "/type");
  else if (defaultType.empty())
    r.fail(ptr, "missing key \"type\"");
  const auto* entry = registry.find(c.type);
  if (!entry) {
    r.fail(ptr + "/type", "unknown " + std::string(kind) + " type \"" + c.type +
                              "\" (registered: " + registeredNames(registry) + ")");
  }
  checkComponentKeys(r, j, ptr, registry, *entry, {}, elsewhere);
  c.parameters = entry->read(JsonParameterSource(r, j, ptr));
  return c;
}

/// The "solver" shorthand of the first scenes: "explicit", "implicit-cg", "implicit-cholmod"
/// with CG's and the damping's settings, read as the integrator and linear solver it stands for.
void parseSolverShorthand(const Reader& r, const json& j, const std::string& ptr, Scene& s) {
  r.expectObject(j, ptr);
  for (auto it = j.begin(); it != j.end(); ++it) {
    static const std::vector<std::string> keys{"type",      "iterations",   "tolerance",
                                               "warmStart", "rayleighMass", "rayleighStiffness"};
    if (std::find(keys.begin(), keys.end(), it.key()) == keys.end())
      r.fail(ptr + "/" + escapePointerToken(it.key()),
             "unknown key \"" + it.key() +
                 "\" (expected one of: type, iterations, tolerance, warmStart, rayleighMass, "
                 "rayleighStiffness; \"solver\" is the shorthand of the first scenes: give "
                 "\"integrator\" and \"linearSolver\" for every other setting)");
  }
  SolverSettings legacy;
  if (const json* v = r.find(j, "type")) {
    const std::string type = r.string(*v, ptr + "/type");
    try {
      legacy.kind = parseSolverKind(type);
    } catch (const InvalidInput&) {
      r.fail(ptr + "/type",
             "unknown solver type \"" + type +
                 "\" (explicit, implicit-cg, implicit-cholmod; or give \"integrator\" "
                 "and \"linearSolver\")");
    }
  }
  const bool isExplicit = legacy.kind == SolverSettings::Kind::Explicit;
  const bool cg = legacy.kind == SolverSettings::Kind::ImplicitCG;
  for (const char* key :
       {"iterations", "tolerance", "warmStart", "rayleighMass", "rayleighStiffness"}) {
    const bool cgKey = std::string_view(key) == "iterations" ||
                       std::string_view(key) == "tolerance" || std::string_view(key) == "warmStart";
    if (r.find(j, key) && (isExplicit || (cgKey && !cg)))
      r.fail(ptr + "/" + key, "the solver \"" + std::string(toString(legacy.kind)) +
                                  "\" does not use \"" + key + "\" (it is a setting of " +
                                  (cgKey ? "the linear solver cg" : "the implicit integrators") +
                                  "; give \"integrator\" and \"linearSolver\" to choose each)");
  }
  CGSettings cgs;
  if (const json* v = r.find(j, "iterations"))
    cgs.maxIterations = int(r.integer(*v, ptr + "/iterations", 1, 1000000));
  if (const json* v = r.find(j, "tolerance")) cgs.tolerance = r.positive(*v, ptr + "/tolerance");
  if (const json* v = r.find(j, "warmStart")) cgs.warmStart = r.boolean(*v, ptr + "/warmStart");
  try {
    cgs.validate();
  } catch (const InvalidInput& e) {
    r.fail(ptr + "/" + e.where(), e.message());
  }
  ImplicitSettings is;
  if (const json* v = r.find(j, "rayleighMass"))
    is.rayleighMass = r.nonNegative(*v, ptr + "/rayleighMass");
  if (const json* v = r.find(j, "rayleighStiffness"))
    is.rayleighStiffness = r.nonNegative(*v, ptr + "/rayleighStiffness");
  const SceneLocation loc = r.location(ptr);
  if (isExplicit) {
    s.integrator = {"explicit-euler", std::any{}, loc};
    s.linearSolver.reset();
    return;
  }
  s.integrator = {"implicit-euler", is, loc};
  if (cg)
    s.linearSolver = ComponentSpec{"cg", cgs, loc};
  else
    s.linearSolver = ComponentSpec{"cholmod", CholmodSettings{}, loc};
}

/// "integrator" and "linearSolver" (or the "solver" shorthand); by default implicit Euler with CG.
void parseStepping(const Reader& r, const json& root, Scene& s) {
  const json* solver = r.find(root, "solver");
  const json* integrator = r.find(root, "integrator");
  const json* linear = r.find(root, "linearSolver");
  if (solver && (integrator || linear)) {
    r.fail(integrator ? "/integrator" : "/linearSolver",
           "give either \"solver\" (the shorthand of the first scenes) or \"integrator\" and "
           "\"linearSolver\", not both");
  }
  if (solver) {
    parseSolverShorthand(r, *solver, "/solver", s);
    return;
  }
  const auto& integrators = IntegratorRegistry::instance();
  if (integrator) {
    s.integrator = parseComponent(r, *integrator, "/integrator", integrators, "integrator", "",
                                  linearSolversWithKey);
  } else {
    s.integrator = {"implicit-euler", ImplicitSettings{}, r.location("")};
  }
  const auto& uses = integrators.find(s.integrator.type)->uses;
  const bool usesSolver = std::find(uses.begin(), uses.end(), "linearSolver") != uses.end();
  if (linear && !usesSolver) {
    std::string with;
    for (auto& [name, e] : integrators.entries())
      if (std::find(e.uses.begin(), e.uses.end(), "linearSolver") != e.uses.end())
        with += (with.empty() ? "" : ", ") + name;
    r.fail("/linearSolver", "the integrator \"" + s.integrator.type +
                                "\" uses no linear solver (the integrators that do: " + with + ")");
  }
  if (linear) {
    s.linearSolver = parseComponent(r, *linear, "/linearSolver", LinearSolverRegistry::instance(),
                                    "linear solver", "", integratorsWithKey);
    if (s.integrator.type == "sofa-euler" && s.linearSolver->type != "sofa-cg")
      r.fail(
          "/linearSolver/type",
          "the integrator \"sofa-euler\" solves with \"sofa-cg\" (SOFA's CGLinearSolver), not \"" +
              s.linearSolver->type + "\"");
  } else if (s.integrator.type == "sofa-euler") {
    s.linearSolver = ComponentSpec{"sofa-cg", SofaCGSettings{}, s.integrator.location};
  } else if (usesSolver) {
    s.linearSolver = ComponentSpec{"cg", CGSettings{}, s.integrator.location};
  } else {
    s.linearSolver.reset();
  }
}

void parseOutput(const Reader& r, const json& j, const std::string& ptr, OutputSettings& o) {
  r.expectObject(j, ptr);
  r.checkKeys(j, ptr, {"every", "vtk", "springs", "obj", "csv", "energy"});
  if (const json* v = r.find(j, "every")) o.every = int(r.integer(*v, ptr + "/every", 1, 1 << 30));
  if (const json* v = r.find(j, "vtk")) o.vtk = r.boolean(*v, ptr + "/vtk");
  if (const json* v = r.find(j, "springs")) o.springs = r.boolean(*v, ptr + "/springs");
  if (const json* v = r.find(j, "obj")) o.obj = r.boolean(*v, ptr + "/obj");
  if (const json* v = r.find(j, "csv")) o.csv = r.boolean(*v, ptr + "/csv");
  if (const json* v = r.find(j, "energy")) o.energy = r.boolean(*v, ptr + "/energy");
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

/// "at", or "from" and "to" for an action whose entry has "from".
ActionTiming parseTiming(const Reader& r, const json& j, const std::string& ptr, double duration,
                         const ActionRegistry::Entry& entry) {
  ActionTiming timing;
  bool hasInterval = false;
  for (const KeyInfo& k : entry.keys) hasInterval = hasInterval || k.name == "from";
  if (hasInterval && (r.find(j, "from") || r.find(j, "to"))) {
    if (r.find(j, "at"))
      r.fail(ptr + "/at", "a " + entry.name + " has either \"at\" or \"from\" and \"to\"");
    timing.interval = true;
    timing.from = actionTime(r, r.require(j, ptr, "from"), ptr + "/from", duration);
    timing.to = actionTime(r, r.require(j, ptr, "to"), ptr + "/to", duration);
    if (!(timing.to > timing.from)) r.fail(ptr + "/to", "must be after \"from\"");
  } else {
    timing.at = actionTime(r, r.require(j, ptr, "at"), ptr + "/at", duration);
  }
  return timing;
}

ActionSpec parseAction(const Reader& r, const json& j, const std::string& ptr, double duration) {
  r.expectObject(j, ptr);
  ActionSpec a;
  a.location = r.location(ptr);
  a.type = r.string(r.require(j, ptr, "action"), ptr + "/action");
  const auto& registry = ActionRegistry::instance();
  const auto* entry = registry.find(a.type);
  if (!entry)
    r.fail(ptr + "/action",
           "unknown action \"" + a.type + "\" (" + registeredNames(registry) + ")");
  a.timing = parseTiming(r, j, ptr, duration, *entry);
  checkComponentKeys(r, j, ptr, registry, *entry, {}, nullptr, "action");
  a.parameters = entry->read(JsonParameterSource(r, j, ptr));
  return a;
}

ConstraintSpec parseConstraint(const Reader& r, const json& j, const std::string& ptr) {
  r.expectObject(j, ptr);
  ConstraintSpec c;
  c.location = r.location(ptr);
  c.type = r.string(r.require(j, ptr, "type"), ptr + "/type");
  const auto& registry = ConstraintRegistry::instance();
  const auto* entry = registry.find(c.type);
  if (!entry)
    r.fail(ptr + "/type",
           "unknown constraint type \"" + c.type + "\" (" + registeredNames(registry) + ")");
  checkComponentKeys(r, j, ptr, registry, *entry, {});
  c.parameters = entry->read(JsonParameterSource(r, j, ptr));
  return c;
}

/// Checks what can only be checked against the mesh: cut polylines on the rest surface, regions
/// and selections that hold something, grasps released by name. Cuts and removals are carried
}  // namespace detail

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
      if (g.downward) {
        m.triangles.push_back({a, b, d});
        m.triangles.push_back({b, c, d});
      } else if (!g.alternating || (i + j) % 2 == 0) {
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

long Scene::numSteps() const {
  const double n = duration / timeStep;
  const double r = std::round(n);
  if (std::abs(n - r) <= 1e-9 * std::max(1.0, r)) return long(r);
  return long(std::ceil(n));
}

bool MeshTransform::identity() const {
  return scale == Vec3{1, 1, 1} && rotation == Vec3{0, 0, 0} && translation == Vec3{0, 0, 0};
}

Vec3 MeshTransform::apply(const Vec3& p) const {
  Vec3 q{p[0] * scale[0], p[1] * scale[1], p[2] * scale[2]};
  constexpr double kDegree = 3.14159265358979323846 / 180.0;
  for (int axis = 0; axis < 3; ++axis) {  // x, then y, then z
    const double a = rotation[std::size_t(axis)] * kDegree;
    if (a == 0) continue;
    const double c = std::cos(a), s = std::sin(a);
    const std::size_t i = std::size_t((axis + 1) % 3), j = std::size_t((axis + 2) % 3);
    const double u = c * q[i] - s * q[j], w = s * q[i] + c * q[j];
    q[i] = u;
    q[j] = w;
  }
  return {q[0] + translation[0], q[1] + translation[1], q[2] + translation[2]};
}

topology::MeshData Scene::mesh() const {
  topology::MeshData m = grid ? makeGrid(*grid) : topology::readMesh(*meshFile);
  if (!meshTransform.identity())
    for (Vec3& p : m.points) p = meshTransform.apply(p);
  return m;
}

MassLaw Scene::massLaw(const topology::Topology& t) const {
  if (massUniform) {
    if (perPointMass > 0) return MassLaw::perPoint(perPointMass);
    const std::size_t n = t.numPoints();
    if (n == 0) throw InvalidInput("mass.total", "the mesh has no point to carry a mass");
    return MassLaw::perPoint(totalMass / double(n));
  }
  return MassLaw::areaDensity(massByTotal ? LumpedMass::densityForTotal(t, totalMass) : density);
}

std::vector<std::string> Scene::forceFieldLabels() const {
  std::vector<std::string> labels;
  std::map<std::string, int> seen;
  for (const ForceFieldSpec& f : forceFields) {
    const std::string base = !f.label.empty() ? f.label : f.type;
    const int n = ++seen[base];
    labels.push_back(n == 1 ? base : base + "_" + std::to_string(n));
  }
  for (const ComponentSpec& h : stepHooks) {  // (the fields the hooks add come last)
    const int n = ++seen[h.type];
    labels.push_back(n == 1 ? h.type : h.type + "_" + std::to_string(n));
  }
  return labels;
}

const forcefields::ContactSetup* Scene::contactSetup() const {
  for (const ComponentSpec& h : stepHooks)
    if (h.type == "contact") return std::any_cast<forcefields::ContactSetup>(&h.parameters);
  return nullptr;
}

std::vector<std::string> Scene::graspNames() const {
  std::vector<std::string> names;
  for (const ActionSpec& a : timeline) {
    const std::string name = a.build()->graspName();
    if (!name.empty() && std::find(names.begin(), names.end(), name) == names.end())
      names.push_back(name);
  }
  return names;
}

std::unique_ptr<TimelineAction> ActionSpec::build() const {
  const auto* entry = ActionRegistry::instance().find(type);
  if (!entry) throw InvalidInput(location.pointer, "unknown action \"" + type + "\"");
  return entry->build(parameters, timing);
}

namespace detail {
namespace {

/// "mesh": a file name, {"file"} or {"grid"}. Returns the pointer that names the mesh.
std::string parseMesh(const Reader& r, const json& root, const std::filesystem::path& baseDir,
                      Scene& s) {
  const json& mesh = r.require(root, "", "mesh");
  std::string meshPtr = "/mesh";
  const json* meshFile = nullptr;
  if (mesh.is_string()) {
    meshFile = &mesh;
  } else if (mesh.is_object()) {
    r.checkKeys(mesh, meshPtr, {"file", "grid", "scale", "rotation", "translation"});
    const json* file = r.find(mesh, "file");
    const json* grid = r.find(mesh, "grid");
    if ((file != nullptr) == (grid != nullptr))
      r.fail(meshPtr, "give exactly one of \"file\" or \"grid\"");
    if (const json* v = r.find(mesh, "scale")) {
      if (v->is_number()) {
        const double k = r.positive(*v, meshPtr + "/scale");
        s.meshTransform.scale = {k, k, k};
      } else {
        s.meshTransform.scale = r.vec3(*v, meshPtr + "/scale");
        for (int k = 0; k < 3; ++k)
          if (!(s.meshTransform.scale[std::size_t(k)] > 0))
            r.fail(meshPtr + "/scale/" + Reader::idx(std::size_t(k)), "must be > 0");
      }
    }
    if (const json* v = r.find(mesh, "rotation"))
      s.meshTransform.rotation = r.vec3(*v, meshPtr + "/rotation");
    if (const json* v = r.find(mesh, "translation"))
      s.meshTransform.translation = r.vec3(*v, meshPtr + "/translation");
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
    if (!std::filesystem::is_regular_file(p, ec))
      r.fail(meshPtr, "mesh file \"" + name + "\" not found (looked for " + p.string() + ")");
    s.meshFile = p;
  }
  return meshPtr;
}

/// "mass": {"density"}, {"total"}, {"total", "lumping": "uniform"} or {"perPoint"}.
void parseMass(const Reader& r, const json& root, Scene& s) {
  const std::string ptr = "/mass";
  const json& m = r.require(root, "", "mass");
  r.expectObject(m, ptr);
  r.checkKeys(m, ptr, {"density", "total", "perPoint", "lumping"});
  const json* d = r.find(m, "density");
  const json* t = r.find(m, "total");
  const json* p = r.find(m, "perPoint");
  if ((d != nullptr) + (t != nullptr) + (p != nullptr) != 1)
    r.fail(ptr, "give exactly one of \"density\", \"total\" or \"perPoint\"");
  if (const json* l = r.find(m, "lumping")) {
    const std::string lumping = r.string(*l, ptr + "/lumping");
    if (lumping != "area" && lumping != "uniform")
      r.fail(ptr + "/lumping",
             "unknown value \"" + lumping +
                 "\" (area: by triangle areas; uniform: the same mass on every point)");
    s.massUniform = lumping == "uniform";
  }
  if (p) s.massUniform = true;
  if (d) {
    if (s.massUniform)
      r.fail(ptr + "/density",
             "a density is spread by area: it does not go with \"lumping\": \"uniform\"");
    s.density = r.positive(*d, ptr + "/density");
  } else if (t) {
    s.massByTotal = true;
    s.totalMass = r.positive(*t, ptr + "/total");
  } else {
    if (const json* l = r.find(m, "lumping"); l && !s.massUniform)
      r.fail(ptr + "/lumping",
             "a mass per point is uniform: it does not go with \"lumping\": \"area\"");
    s.perPointMass = r.positive(*p, ptr + "/perPoint");
  }
}

/// "name" and "description".
void parseHeader(const Reader& r, const json& root, const std::string& sourceName, Scene& s) {
  s.file = sourceName;
  s.name = std::filesystem::path(sourceName).stem().string();
  if (const json* v = r.find(root, "name")) {
    s.name = r.string(*v, "/name");
    if (s.name.empty() || s.name.find_first_of("/\\") != std::string::npos || s.name == "." ||
        s.name == "..")
      r.fail("/name", "must be a plain file name (no slash)");
    // It names the output folder: a name every file system takes.
    if (s.name.size() > 200)
      r.fail("/name", "must be at most 200 bytes long (it names the output folder)");
    for (unsigned char c : s.name)
      if (c < 0x20 || c == 0x7f)
        r.fail("/name",
               "must not contain control characters such as a line break (it names the output "
               "folder)");
  }
  if (const json* v = r.find(root, "description")) s.description = r.string(*v, "/description");
}

/// "constraints" and "timeline" (sorted by start time).
void parseConstraintsAndTimeline(const Reader& r, const json& root, Scene& s) {
  if (const json* v = r.find(root, "constraints")) {
    r.expectArray(*v, "/constraints");
    for (std::size_t i = 0; i < v->size(); ++i)
      s.constraints.push_back(parseConstraint(r, (*v)[i], "/constraints/" + Reader::idx(i)));
  }
  if (const json* v = r.find(root, "timeline")) {
    r.expectArray(*v, "/timeline");
    for (std::size_t i = 0; i < v->size(); ++i)
      s.timeline.push_back(parseAction(r, (*v)[i], "/timeline/" + Reader::idx(i), s.duration));
    std::stable_sort(
        s.timeline.begin(), s.timeline.end(),
        [](const ActionSpec& a, const ActionSpec& b) { return a.startTime() < b.startTime(); });
  }
}

}  // namespace
}  // namespace detail

Scene parseScene(std::string_view text, const std::string& sourceName,
                 const std::filesystem::path& baseDir) {
  return detail::parseSceneDocument(parseJsonWithLines(text, sourceName), sourceName, baseDir);
}

Scene detail::parseSceneDocument(const JsonDocument& doc, const std::string& sourceName,
                                 const std::filesystem::path& baseDir) {
  const Reader r(sourceName, doc.lines, doc.labels);
  const json& root = doc.root;
  r.expectObject(root, "");
  std::vector<std::string> keys{"name",       "description",  "mesh",        "mass",
                                "gravity",    "forceFields",  "constraints", "solver",
                                "integrator", "linearSolver", "timeStep",    "duration",
                                "output",     "timeline",     "ignored",     "threads"};
  for (const SceneSection* section : SceneSections::instance().inOrder())
    keys.push_back(section->name);
  r.checkKeys(root, "", keys);
  Scene s;
  parseHeader(r, root, sourceName, s);
  if (const json* v = r.find(root, "ignored")) {  // what an import left out: text, for the reader
    r.expectArray(*v, "/ignored");
    for (std::size_t i = 0; i < v->size(); ++i) r.string((*v)[i], "/ignored/" + Reader::idx(i));
  }
  const std::string meshPtr = parseMesh(r, root, baseDir, s);
  parseMass(r, root, s);
  if (const json* v = r.find(root, "gravity")) s.gravity = r.vec3(*v, "/gravity");
  if (const json* v = r.find(root, "forceFields")) {
    r.expectArray(*v, "/forceFields");
    std::set<std::string> labels;
    for (std::size_t i = 0; i < v->size(); ++i) {
      s.forceFields.push_back(parseForceField(r, (*v)[i], "/forceFields/" + Reader::idx(i)));
      const std::string& label = s.forceFields.back().label;
      if (!label.empty() && !labels.insert(label).second)
        r.fail("/forceFields/" + Reader::idx(i) + "/label",
               "another force field has the label \"" + label + "\"");
    }
  }
  // The sections components read in their own files (contact's "contact" and "obstacles").
  std::set<std::string> given;
  for (const SceneSection* section : SceneSections::instance().inOrder())
    if (const json* v = r.find(root, section->name)) {
      section->read(r, *v, "/" + section->name, baseDir, s);
      given.insert(section->name);
    }
  parseStepping(r, root, s);
  s.timeStep = r.positive(r.require(root, "", "timeStep"), "/timeStep");
  s.duration = r.nonNegative(r.require(root, "", "duration"), "/duration");
  if (s.duration / s.timeStep > 1e8) r.fail("/duration", "more than 1e8 steps of timeStep");
  if (s.duration > 0 && s.numSteps() == 0)
    r.fail("/duration", "is " + describeNumber(s.duration) +
                            " s, a vanishing part of the time step (" + describeNumber(s.timeStep) +
                            " s): the run would take no step (a duration of 0 writes the first "
                            "state only, on purpose)");
  if (const json* v = r.find(root, "output")) parseOutput(r, *v, "/output", s.output);
  if (const json* v = r.find(root, "threads")) s.threads = int(r.integer(*v, "/threads", 1, 256));

  // The mesh is needed for point ids and for the dry run.
  const topology::MeshData meshData = s.mesh();
  if (meshData.triangles.empty()) r.fail(meshPtr, "the mesh has no triangle");
  topology::checkManifold(meshData);
  checkMemory(r, s.grid ? meshPtr + "/grid/nx" : meshPtr, s, meshData.points.size());
  {
    // The mass needs an area: representable (a total spread over an area beyond the range of
    // doubles is no mass) and not zero. Computed scaled, so that nothing overflows on the way.
    double area = 0;
    bool tooLarge = false;
    for (const auto& t : meshData.triangles) {
      const auto u =
          topology::geometry::sub(meshData.points[t[1].idx()], meshData.points[t[0].idx()]);
      const auto w =
          topology::geometry::sub(meshData.points[t[2].idx()], meshData.points[t[0].idx()]);
      double scale = 0;
      for (int k = 0; k < 3; ++k)
        scale = std::max({scale, std::abs(u[std::size_t(k)]), std::abs(w[std::size_t(k)])});
      if (!(scale <= 1e150)) {
        tooLarge = true;
        break;
      }
      const double cx = u[1] * w[2] - u[2] * w[1], cy = u[2] * w[0] - u[0] * w[2],
                   cz = u[0] * w[1] - u[1] * w[0];
      area += 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
      if (area > 1e300) tooLarge = true;
    }
    const std::string massPtr = s.massByTotal        ? "/mass/total"
                                : s.perPointMass > 0 ? "/mass/perPoint"
                                                     : "/mass/density";
    if (tooLarge)
      r.fail(meshPtr,
             "the mesh's area is beyond the range of doubles: no mass can be spread over it");
    if (!(area > 0)) r.fail(massPtr, "the mesh has no area: it can carry no mass");
    if (!s.massUniform && (s.massByTotal ? !(s.totalMass / area > 0) || s.totalMass / area > 1e300
                                         : s.density > 1e300 / area))
      r.fail(massPtr, "the mass per area of this mesh is beyond the range of doubles");
  }
  parseConstraintsAndTimeline(r, root, s);
  dryRun(r, s, meshData);
  // A progressive cut is checked above as one cut at its start; the run makes it piece by piece
  // among the other actions, which may fail where the whole cut does not (a removal across its
  // path, a path that doubles back): the timeline is rehearsed, the surface at rest.
  const bool progressive =
      std::any_of(s.timeline.begin(), s.timeline.end(),
                  [](const ActionSpec& a) { return a.type == "cut" && a.timing.interval; });
  if (progressive) {
    try {
      SceneRunner::rehearseTimeline(s);
    } catch (const TopologyError& e) {
      throw InvalidInput(
          s.file.string(),
          std::string(e.what()) + " (the timeline played before the run, the surface at rest)");
    } catch (const InvalidInput& e) {
      throw InvalidInput(
          e.where(), e.message() + " (the timeline played before the run, the surface at rest)");
    }
  }
  for (const SceneSection* section : SceneSections::instance().inOrder())
    if (section->check && given.count(section->name)) section->check(r, s, meshData);
  return s;
}

namespace {
/// One entry of a scene given on its own (an action, a force field, a constraint): its own JSON
/// text named `sourceName`, read by `parse` with the scene's checks; failures name the source.
template <class Spec, class Parse>
Spec parseEntry(std::string_view text, const std::string& sourceName, Parse parse) {
  const JsonDocument doc = parseJsonWithLines(text, sourceName);
  const Reader r(sourceName, doc.lines);
  Spec spec = parse(r, doc.root);
  spec.location.source = sourceName;
  return spec;
}
}  // namespace

ActionSpec parseActionEntry(std::string_view text, const std::string& sourceName, double now) {
  return parseEntry<ActionSpec>(text, sourceName, [&](const Reader& r, const json& root) {
    ActionSpec a = parseAction(r, root, "", std::numeric_limits<double>::infinity());
    const double eps = 1e-9 * std::max(1.0, std::abs(now));
    if (a.startTime() < now - eps)
      r.fail(a.timing.interval ? "/from" : "/at", "time " + Reader::text(a.startTime()) +
                                                      " is before the current time " +
                                                      Reader::text(now));
    return a;
  });
}

ForceFieldSpec parseForceFieldEntry(std::string_view text, const std::string& sourceName) {
  return parseEntry<ForceFieldSpec>(text, sourceName, [](const Reader& r, const json& root) {
    return parseForceField(r, root, "");
  });
}

ConstraintSpec parseConstraintEntry(std::string_view text, const std::string& sourceName) {
  return parseEntry<ConstraintSpec>(text, sourceName, [](const Reader& r, const json& root) {
    return parseConstraint(r, root, "");
  });
}

Scene loadScene(const std::filesystem::path& file) {
  {
    std::string ext = file.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    if (ext == ".scn") return sceneFromSofa(importSofaScene(file));
  }
  return parseScene(readSceneText(file), file.string(), file.parent_path());
}

std::string readSceneText(const std::filesystem::path& file) {
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec))
    throw InvalidInput(file.string(), "is a folder, not a scene file");
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InvalidInput(file.string(), "cannot open the scene file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InvalidInput(file.string(), "cannot read the scene file");
  return text.str();
}

}  // namespace cutsim::core
