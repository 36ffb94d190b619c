// Contact's sections of scene files (SceneSections, scene_internal.hpp): "contact", the step
// hook "contact" of StepHookRegistry read as any component (its keys checked by the registry), and
// "obstacles", the list of obstacles added to its setup, each a shape of ObstacleShapeRegistry
// with a name, a friction and a path; once the scene is read, the check that it starts free of
// intersections. The format is in docs/scenes.md and docs/contact.md.
#include <cmath>
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include "cutsim/core/output.hpp"
#include "cutsim/core/registries.hpp"
#include "cutsim/core/scene.hpp"
#include "cutsim/forcefields/contact.hpp"
#include "cutsim/forcefields/obstacle.hpp"
#include "scene/scene_internal.hpp"
#include "scene/scene_json.hpp"

namespace cutsim::core::detail {
namespace {

/// The "contact" section: the step hook "contact" of StepHookRegistry (its keys checked as any
/// component's); the "obstacles" list is added to its setup after.
void parseContact(const Reader& r, const json& j, const std::string& ptr, Scene& s) {
  r.expectObject(j, ptr);
  const auto& registry = StepHookRegistry::instance();
  const auto* entry = registry.find("contact");
  if (!entry) r.fail(ptr, "this build has no contact");
  checkComponentKeys(r, j, ptr, registry, *entry, {}, nullptr, "");
  ComponentSpec spec;
  spec.type = "contact";
  spec.location = r.location(ptr);
  spec.parameters = entry->read(JsonParameterSource(r, j, ptr));
  s.stepHooks.push_back(std::move(spec));
}

forcefields::Obstacle parseObstacle(const Reader& r, const json& j, const std::string& ptr,
                                    const std::filesystem::path& baseDir) {
  r.expectObject(j, ptr);
  forcefields::Obstacle o;
  const std::string type = r.string(r.require(j, ptr, "type"), ptr + "/type");
  const auto& registry = forcefields::ObstacleShapeRegistry::instance();
  const auto* entry = registry.find(type);
  if (!entry)
    r.fail(ptr + "/type",
           "unknown obstacle type \"" + type + "\" (" + registeredNames(registry) + ")");
  checkComponentKeys(r, j, ptr, registry, *entry, {"name", "friction", "path"});
  if (const json* v = r.find(j, "name")) o.name = r.string(*v, ptr + "/name");
  if (const json* v = r.find(j, "friction")) o.friction = r.nonNegative(*v, ptr + "/friction");
  o.shape = entry->build(entry->read(JsonParameterSource(r, j, ptr, baseDir)));
  if (const json* v = r.find(j, "path")) {
    r.expectArray(*v, ptr + "/path");
    if (v->empty()) r.fail(ptr + "/path", "expected at least one [time, dx, dy, dz]");
    for (std::size_t k = 0; k < v->size(); ++k) {
      const std::string kp = ptr + "/path/" + Reader::idx(k);
      const json& row = (*v)[k];
      if (!row.is_array() || row.size() != 4) r.fail(kp, "expected [time, dx, dy, dz]");
      forcefields::ObstacleKey key;
      key.time = r.number(row[0], kp + "/0");
      for (int c = 0; c < 3; ++c)
        key.offset[std::size_t(c)] =
            r.number(row[std::size_t(c + 1)], kp + "/" + Reader::idx(std::size_t(c + 1)));
      if (k > 0 && !(key.time > o.path.back().time)) r.fail(kp + "/0", "times must increase");
      o.path.push_back(key);
    }
  }
  try {
    o.validate();
  } catch (const InvalidInput& e) {
    r.fail(ptr + "/" + e.where(), e.message());
  }
  return o;
}

/// The thinnest contact layer a scene may ask for, as a fraction of its mesh's mean rest edge.
constexpr double kThinnestContact = 100.0;

/// A scene with contact must start free of intersections (within the thickness is allowed: the
/// penalty pushes the primitives apart).
void checkContactAtStart(const Reader& r, const Scene& s, const topology::MeshData& mesh) {
  topology::Topology topo(mesh);
  const forcefields::ContactSetup& setup = *s.contactSetup();
  // The guarantee is shown down to a hundredth of the mean rest edge (docs/contact.md, "A floor
  // under every gap"): a thinner layer is refused rather than run without it.
  const double smallest = meanRestEdge(topo) / kThinnestContact;
  if (setup.parameters.thickness < smallest) {
    // Three significant digits, the smallest rounded up (a value that passes).
    auto digits = [](double v, bool up) {
      const double unit = std::pow(10.0, std::floor(std::log10(v)) - 2);
      char text[32];
      std::snprintf(text, sizeof text, "%.3g",
                    (up ? std::ceil(v / unit) : std::round(v / unit)) * unit);
      return std::string(text);
    };
    r.fail("/contact/thickness",
           formatNumber(setup.parameters.thickness) +
               " is below a hundredth of the mesh's mean rest edge (" +
               digits(smallest * kThinnestContact, false) +
               " m), where the intersection-free guarantee is not shown: give at least " +
               digits(smallest, true) + " or refine the mesh");
  }
  forcefields::Contact contact(topo, setup.parameters, setup.obstacles);
  std::vector<double> x(3 * topo.pointCapacity(), 0.0);
  for (topology::PointId p : topo.points())
    for (int c = 0; c < 3; ++c)
      x[3 * std::size_t(p.idx()) + std::size_t(c)] = topo.restPosition(p)[std::size_t(c)];
  const auto found = contact.intersections(x, 1);
  if (found.empty()) return;
  const auto& c = found.front();
  std::string where = "/contact";
  for (std::size_t k = 0; k < setup.obstacles.size(); ++k)
    if (c.what.find("obstacle \"" + setup.obstacles[k].name + "\"") != std::string::npos)
      where = "/obstacles/" + Reader::idx(k);
  r.fail(where,
         "the scene starts in intersection: " + c.what +
             " (contact can only keep apart what starts apart: move the mesh or the obstacle)");
}

/// The "obstacles" list, added to the contact's setup (an empty list needs no contact).
void parseObstacles(const Reader& r, const json& v, const std::string& ptr,
                    const std::filesystem::path& baseDir, Scene& s) {
  r.expectArray(v, ptr);
  if (!s.contactSetup() && !v.empty())
    r.fail(ptr, "obstacles need a \"contact\" section (its thickness and stiffness)");
  std::vector<forcefields::Obstacle> obstacles;
  std::set<std::string> names;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const std::string at = ptr + "/" + Reader::idx(i);
    obstacles.push_back(parseObstacle(r, v[i], at, baseDir));
    if (obstacles.back().name.empty())
      obstacles.back().name = obstacles.back().shapeName() + std::to_string(i);
    const std::string& name = obstacles.back().name;
    if (name.find_first_of(",\"\n\r") != std::string::npos)
      r.fail(at + "/name",
             "must not contain a comma, a quote or a line break (it names CSV columns)");
    if (!names.insert(name).second)
      r.fail(at + "/name", "another obstacle has the name \"" + name + "\"");
  }
  for (ComponentSpec& h : s.stepHooks)
    if (h.type == "contact")
      std::any_cast<forcefields::ContactSetup&>(h.parameters).obstacles = std::move(obstacles);
}

const bool registered =
    SceneSections::instance().add(
        {"contact", "",
         [](const Reader& r, const json& v, const std::string& ptr, const std::filesystem::path&,
            Scene& s) { parseContact(r, v, ptr, s); },
         checkContactAtStart}) &&
    SceneSections::instance().add({"obstacles", "contact", parseObstacles, {}});

}  // namespace
}  // namespace cutsim::core::detail
