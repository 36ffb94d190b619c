// The "grasp" and "release" actions: points that follow a displacement path from where they are
// when grasped, and the end of that.
#include <sstream>

#include "cutsim/base/numbers.hpp"
#include "cutsim/core/timeline.hpp"

namespace cutsim::core {
namespace {

/// Fails at the first selected id beyond the mesh (ids are checked against the mesh in the dry
/// run).
void checkIds(DryRunContext& c, const PointSelection& sel) {
  if (sel.kind != PointSelection::Kind::Points) return;
  const std::size_t n = c.restMesh().points.size();
  for (std::size_t i = 0; i < sel.points.size(); ++i)
    if (sel.points[i].idx() >= n)
      c.fail("points/" + std::to_string(i), "must be between 0 and " + std::to_string(long(n) - 1) +
                                                " (got " + std::to_string(sel.points[i].idx()) +
                                                ")");
}

class GraspAction final : public TimelineAction {
 public:
  explicit GraspAction(GraspParameters p) : p_(std::move(p)) {}
  bool checkpointable() const override { return true; }  // done once started
  void dryRun(DryRunContext& c) const override {
    if (c.activeGrasps().count(p_.name))
      c.fail("name", "a grasp named \"" + p_.name + "\" is already active");
    if (!p_.worldSphere) {  // a world sphere meets the surface where it is then: start() checks
      checkIds(c, p_.selection);
      if (p_.selection.resolve(c.topology()).empty())
        c.fail(std::string(p_.selection.key()), "selects no live point at that time");
    }
    c.activeGrasps().insert(p_.name);
  }
  void start(ActionContext& c) override {
    Simulation& sim = c.simulation();
    if (p_.selection.kind == PointSelection::Kind::Points)
      for (PointId p : p_.selection.points)
        if (p.idx() >= sim.topology().pointCapacity() || !sim.topology().isPointAlive(p))
          c.fail("grasp \"" + p_.name + "\": point " + std::to_string(p.idx()) +
                 " is not a point of the surface");
    const std::vector<PointId> points =
        p_.worldSphere ? inWorldSphere(sim) : p_.selection.resolve(sim.topology());
    if (points.empty()) {
      if (p_.worldSphere) {
        std::ostringstream os;
        os << "grasp \"" << p_.name << "\" selects no point of the surface: none lies within "
           << p_.worldSphere->radius << " of (" << p_.worldSphere->center[0] << ", "
           << p_.worldSphere->center[1] << ", " << p_.worldSphere->center[2]
           << ") (world coordinates, the surface as it is now)";
        c.fail(os.str());
      }
      c.fail("grasp \"" + p_.name + "\" selects no point of the surface");
    }
    requireFree(c, points, "grasp \"" + p_.name + "\"");
    sim.addGrasp(p_.name, points, p_.path);
  }
  std::string graspName() const override { return p_.name; }

 private:
  /// The live points whose current position lies in the sphere; one piece: those connected to the
  /// one nearest the centre by edges inside the sphere (the side of a cut the jaws are on).
  std::vector<PointId> inWorldSphere(const Simulation& sim) const {
    const topology::Topology& t = sim.topology();
    const std::span<const double> x = sim.state().x();
    const auto current = [&x](PointId p) {
      return Vec3{x[3 * p.idx()], x[3 * p.idx() + 1], x[3 * p.idx() + 2]};
    };
    std::vector<PointId> inside;
    for (PointId p : t.points())
      if (p_.worldSphere->contains(current(p))) inside.push_back(p);
    if (inside.empty() || !p_.selection.onePiece) return inside;
    return connectedWithin(t, inside, nearestPoint(inside, p_.worldSphere->center, current));
  }

  GraspParameters p_;
};

class ReleaseAction final : public TimelineAction {
 public:
  explicit ReleaseAction(ReleaseParameters p) : p_(std::move(p)) {}
  bool checkpointable() const override { return true; }  // done once started
  void dryRun(DryRunContext& c) const override {
    if (!c.activeGrasps().erase(p_.name))
      c.fail("name", "no grasp named \"" + p_.name + "\" is active at that time");
  }
  void start(ActionContext& c) override {
    if (!c.simulation().findGrasp(p_.name)) c.fail("no grasp named \"" + p_.name + "\" is active");
    c.simulation().releaseGrasp(p_.name);
  }

 private:
  ReleaseParameters p_;
};

DisplacementPath readPath(const ParameterSource& s) {
  DisplacementPath out;
  s.require("path");
  const auto rows = s.rows("path", 4, 1);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const double t = rows[i][0];
    const std::string key = "path/" + std::to_string(i) + "/0";
    if (t < 0) s.fail(key, "path times are relative to the grasp's start: must be >= 0");
    if (!out.times.empty() && !(t > out.times.back()))
      s.fail(key, "path times must increase strictly");
    out.times.push_back(t);
    out.displacements.push_back({rows[i][1], rows[i][2], rows[i][3]});
  }
  return out;
}

const bool graspRegistered = ActionRegistry::instance().add(
    {"grasp",
     "points (resolved when it starts) that follow their position then plus a displacement path",
     {{"at", KeyType::Number, "time the grasp starts"},
      {"name",
       KeyType::String,
       "unique among the active grasps; names the CSV's reaction-force columns",
       {"forceps"},
       true},
      {"points", KeyType::Integers, "[ids] of the mesh as loaded"},
      {"box", KeyType::Box,
       "[[xmin, ymin, zmin], [xmax, ymax, zmax]]: the points inside, in rest coordinates, that "
       "are connected to the seed inside the box (one side of a cut that crosses it)"},
      {"sphere",
       KeyType::Object,
       "{\"center\": [x, y, z], \"radius\": r} in WORLD coordinates: the points of the surface "
       "as it is when the grasp starts that lie in it (one piece: the side of a cut the centre "
       "is on), what forceps of that radius close on",
       {R"({"center": [0.5, 0.5, 0], "radius": 0.1})"}},
      {"piece",
       KeyType::Choice,
       "with a box or a sphere: \"seed\" (default), the piece connected to the seed (a "
       "sphere's: the point nearest its centre) inside it; \"all\", every point inside",
       {"seed", "all"}},
      {"seed", KeyType::Point,
       "[x, y, z] in rest coordinates: the box's point nearest it starts the piece (default: the "
       "box's centre)"},
      {"near", KeyType::Points,
       "[[x, y, z], ...]: the nearest live point to each position, in rest coordinates"},
      {"path",
       KeyType::Rows,
       "[[t, dx, dy, dz], ...]: times from the grasp's start, strictly increasing",
       {},
       true}},
     {},
     [](const ParameterSource& s) -> std::any {
       GraspParameters p;
       p.name = readGraspName(s);
       if (s.has("sphere")) {
         for (const char* key : {"points", "box", "near", "seed"})
           if (s.has(key)) s.fail(key, "give a sphere or a selection, not both");
         p.worldSphere = Region::read(s, "sphere");
       } else {
         p.selection = PointSelection::read(s);
         if (p.selection.kind != PointSelection::Kind::Box) {
           for (const char* key : {"piece", "seed"})
             if (s.has(key)) s.fail(key, "is for a box or a sphere");
         }
       }
       p.selection.onePiece = s.choice("piece", "seed", {"seed", "all"}) == "seed";
       if (s.has("seed")) p.selection.seed = s.vec3("seed");
       p.path = readPath(s);
       return p;
     },
     [](const std::any& p, const ActionTiming&) -> std::unique_ptr<TimelineAction> {
       return std::make_unique<GraspAction>(std::any_cast<const GraspParameters&>(p));
     }});

const bool releaseRegistered = ActionRegistry::instance().add(
    {"release",
     "ends an active grasp",
     {{"at", KeyType::Number, "time of the release"},
      {"name", KeyType::String, "the grasp to release", {"forceps"}, true}},
     {},
     [](const ParameterSource& s) -> std::any {
       s.require("name");
       return ReleaseParameters{s.string("name")};
     },
     [](const std::any& p, const ActionTiming&) -> std::unique_ptr<TimelineAction> {
       return std::make_unique<ReleaseAction>(std::any_cast<const ReleaseParameters&>(p));
     }});

}  // namespace
}  // namespace cutsim::core
