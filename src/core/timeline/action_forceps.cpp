// The "forceps" action: two jaws (capsules) moving in the world along a path of keyframes, opening
// and closing. When they close (their axes 2 radii apart: touching), they take the surface between
// them where it is then: each point where their middle line crosses the surface becomes a point of
// the mesh (a material point inside a triangle is inserted there, exactly: its weights of the
// triangle's corners give its rest position and where it is now), with the points within a radius
// of that line connected to it; a grasp named after the forceps carries them with the jaws (the
// reaction force in the CSV as for every grasp) until the jaws open again. Given one `axis`, the
// jaws keep their orientation (they translate); given an axis per keyframe, they turn (the
// smallest rotation from one keyframe's axis to the next's, at a constant rate: they do not roll
// about their own axis), and what they hold turns with them about their tip. docs/instruments.md.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/core/timeline.hpp"
#include "cutsim/forcefields/surface_query.hpp"
#include "cutsim/topology/geometry.hpp"
#include "tool_path.hpp"

namespace cutsim::core {
namespace {

using topology::geometry::dist2;
using topology::geometry::distanceToSegment;
using topology::geometry::dot;
using topology::geometry::unit;

struct ForcepsParameters {
  std::string name;
  /// The jaws' tip (the middle of their two tips), world; with an axis per keyframe when they
  /// turn.
  ToolPath path;
  std::vector<double> openings;  ///< per keyframe: the distance between the jaws' axes (m)
  Vec3 axis{0, 0, 1};            ///< unit: from the tips along the jaws (at the first keyframe)
  Vec3 across{1, 0, 0};  ///< unit, normal to the axis: from one jaw to the other (first keyframe)
  /// Turning jaws: per keyframe, their rotation from the first keyframe's orientation (the
  /// smallest rotation between consecutive axes, composed). Empty: they translate.
  std::vector<Eigen::Quaterniond> turns;
  double radius = 0.0;  ///< of each jaw
  double length = 0.0;  ///< of each jaw, from its tip
  double minAngle = kDefaultMinAngle;
};

class ForcepsAction final : public TimelineAction {
 public:
  ForcepsAction(ForcepsParameters p, const ActionTiming& timing)
      : p_(std::move(p)), timing_(timing) {}

  void dryRun(DryRunContext& c) const override {
    if (c.activeGrasps().count(p_.name))
      c.fail("name", "a grasp named \"" + p_.name + "\" is already active");
    // (its grasp holds from when the jaws close until they open: its name is taken from here on)
    c.activeGrasps().insert(p_.name);
  }
  bool rehearsed() const override { return false; }
  std::string graspName() const override { return p_.name; }

  void start(ActionContext& c) override {
    started_ = true;
    afterStep(c);
  }

  void afterStep(ActionContext& c) override {
    if (!started_ || finished_) return;
    const double now = std::min(c.time(), timing_.to) - timing_.from;
    const bool closed = opening(now) <= 2 * p_.radius * (1 + 1e-12);
    Simulation& sim = c.simulation();
    if (holding_ && !closed) {
      if (sim.findGrasp(p_.name)) sim.releaseGrasp(p_.name);
      holding_ = false;
    } else if (!holding_ && closed) {
      take(c, now);
      holding_ = true;  // (closed on nothing: holds nothing until it opens and closes again)
    }
    // After `to` the jaws stay where they are: closed, they hold on.
    if (c.time() >= timing_.to - 1e-9 * c.timeStep()) finished_ = true;
  }

  void instruments(double time, std::vector<std::array<Vec3, 2>>& out) const override {
    const double eps = 1e-9 * std::max(1.0, std::abs(timing_.to));
    if (time < timing_.from - eps || (time > timing_.to + eps && !holding_)) return;
    const double t = std::clamp(time, timing_.from, timing_.to) - timing_.from;
    for (const double side : {-0.5, 0.5}) {
      const auto [a, b] = jaw(t, side);
      wireCapsule(a, b, p_.radius, out);
    }
  }

  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override { fields(out, started_, finished_, holding_); }
  void loadState(ArchiveReader& in, const Simulation&) override {
    fields(in, started_, finished_, holding_);
  }

 private:
  double opening(double t) const { return p_.path.valueAt(p_.openings, t); }
  /// The jaws' rotation at time t from their orientation at the first keyframe.
  Eigen::Quaterniond turn(double t) const {
    if (p_.turns.empty()) return Eigen::Quaterniond::Identity();
    const auto& T = p_.path.times();
    if (!(t > T.front())) return p_.turns.front();
    if (t >= T.back()) return p_.turns.back();
    const std::size_t i = std::size_t(std::upper_bound(T.begin(), T.end(), t) - T.begin());
    return p_.turns[i - 1].slerp((t - T[i - 1]) / (T[i] - T[i - 1]), p_.turns[i]);
  }
  /// The unit vector v of the first keyframe's orientation, turned as the jaws are at time t.
  Vec3 turned(const Vec3& v, double t) const {
    if (p_.turns.empty()) return v;
    const Eigen::Vector3d w = turn(t) * Eigen::Vector3d(v[0], v[1], v[2]);
    return {w[0], w[1], w[2]};
  }
  /// The middle line between the jaws at time t: from the tip along the axis, `length` long.
  std::array<Vec3, 2> middle(double t) const {
    const Vec3 tip = p_.path.at(t).first, axis = turned(p_.axis, t);
    return {
        tip,
        {tip[0] + p_.length * axis[0], tip[1] + p_.length * axis[1], tip[2] + p_.length * axis[2]}};
  }
  /// A jaw's axis at time t (side -1/2 or +1/2 of the opening along `across`).
  std::array<Vec3, 2> jaw(double t, double side) const {
    auto m = middle(t);
    const double d = side * opening(t);
    const Vec3 across = turned(p_.across, t);
    for (Vec3& q : m)
      for (int k = 0; k < 3; ++k) q[k] += d * across[k];
    return m;
  }

  /// Takes the surface between the closed jaws: the points where the middle line crosses it
  /// (inserted where they fall inside a triangle or on an edge), and the points within a radius of
  /// the line connected to one of those by edges within it; grasps them, carried by the tip's
  /// displacement from now on.
  void take(ActionContext& c, double now) {
    Simulation& sim = c.simulation();
    topology::Topology& topo = sim.topology();
    const auto line = middle(now);
    const auto current = [&sim](PointId p) {
      const auto x = sim.state().x();
      return Vec3{x[3 * p.idx()], x[3 * p.idx() + 1], x[3 * p.idx() + 2]};
    };
    // Where the middle line crosses the surface (a hit on an edge shared by two triangles may
    // come twice: one point each place).
    std::vector<Vec3> seen;
    {
      const forcefields::SurfaceQuery query(topo, sim.state().x());
      const double same = 1e-18 * c.meanRestEdge() * c.meanRestEdge();
      for (const forcefields::SurfaceHit& h : query.segmentHits(line[0], line[1]))
        if (std::none_of(seen.begin(), seen.end(),
                         [&](const Vec3& q) { return dist2(q, h.point) <= same; }))
          seen.push_back(h.point);
    }
    // Each as a point of the mesh, one at a time: an insertion changes the triangles around it,
    // so the next is found again where it is (which no insertion moves).
    std::vector<PointId> seeds;
    try {
      for (const Vec3& q : seen) {
        const forcefields::SurfaceQuery query(topo, sim.state().x());
        const auto at = query.closestPoint(q);
        if (at) seeds.push_back(pointAt(topo, at->triangle, at->weights));
      }
    } catch (const TopologyError& e) {
      c.failTopology("the forceps \"" + p_.name + "\" cannot take the surface: " + e.what());
    }
    std::sort(seeds.begin(), seeds.end());
    seeds.erase(std::unique(seeds.begin(), seeds.end()), seeds.end());
    if (seeds.empty()) return;  // closed beside the surface: nothing between the jaws
    // The quality repair around the inserted points, which stay where they are.
    topology::RepairOptions repair = repairOptions(sim, p_.minAngle);
    repair.locked.insert(repair.locked.end(), seeds.begin(), seeds.end());
    if (p_.minAngle > 0) {
      try {
        topo.repair(seeds, repair);
      } catch (const TopologyError& e) {
        c.failTopology("the forceps \"" + p_.name + "\": the repair failed: " + e.what());
      }
    }
    std::vector<PointId> inside;
    for (PointId p : topo.points())
      if (distanceToSegment(current(p), line[0], line[1]) <= p_.radius) inside.push_back(p);
    std::vector<PointId> held(seeds);
    for (PointId s : seeds) {
      if (!std::binary_search(inside.begin(), inside.end(), s)) continue;
      const auto piece = connectedWithin(topo, inside, s);
      held.insert(held.end(), piece.begin(), piece.end());
    }
    std::sort(held.begin(), held.end());
    held.erase(std::unique(held.begin(), held.end()), held.end());
    requireFree(c, held, "the forceps \"" + p_.name + "\"");
    // The tip's displacement from now on, and for turning jaws their rotation about the tip since
    // now (linear and along the shortest arc between keyframes, as the jaws move: exact).
    DisplacementPath path;
    const Vec3 tip0 = p_.path.at(now).first;
    const Eigen::Quaterniond since = turn(now).inverse();
    path.pivot = tip0;
    const auto key = [&](double t) {
      const Vec3 tip = p_.path.at(t).first;
      path.times.push_back(t - now);
      path.displacements.push_back({tip[0] - tip0[0], tip[1] - tip0[1], tip[2] - tip0[2]});
      if (!p_.turns.empty()) {
        const Eigen::Quaterniond q = (turn(t) * since).normalized();
        path.rotations.push_back({q.w(), q.x(), q.y(), q.z()});
      }
    };
    key(now);
    const double horizon = timing_.to - timing_.from;
    for (std::size_t k = 0; k < p_.path.times().size(); ++k) {
      const double t = std::min(p_.path.times()[k], horizon);
      if (!(t > now + 1e-12 * std::max(1.0, horizon))) continue;
      if (t - now <= path.times.back()) continue;
      key(t);
    }
    if (horizon > now && !(horizon - now <= path.times.back())) key(horizon);
    sim.addGrasp(p_.name, held, path);
  }

  ForcepsParameters p_;
  ActionTiming timing_;
  bool started_ = false, finished_ = false, holding_ = false;
};

ForcepsParameters readForceps(const ParameterSource& s) {
  ForcepsParameters p;
  if (!s.has("from") || !s.has("to"))
    s.fail(s.has("from") ? "to" : "from",
           "forceps move over an interval: give \"from\" and \"to\" (not \"at\")");
  p.name = readGraspName(s);
  for (const char* key : {"radius", "length"}) {
    s.require(key);
    const double v = s.number(key);
    if (!(v > 0)) s.fail(key, "must be a positive number (m)");
    (std::string(key) == "radius" ? p.radius : p.length) = v;
  }
  // One axis: the jaws translate; none: the path gives an axis per keyframe, and they turn.
  const bool turning = !s.has("axis");
  std::vector<std::vector<double>> extras(1);
  p.path = ToolPath::read(s, turning, "the forceps", extras);
  p.openings = extras[0];
  for (std::size_t i = 0; i < p.openings.size(); ++i)
    if (!(p.openings[i] >= 2 * p.radius))
      s.fail("path/" + std::to_string(i) + (turning ? "/7" : "/4"),
             "the jaws' opening (the distance between their axes) must be at least 2 radii = " +
                 describeNumber(2 * p.radius) + " (closed: touching); got " +
                 describeNumber(p.openings[i]));
  s.require("across");
  const Vec3 axis = turning ? p.path.at(p.path.times().front()).second : s.vec3("axis"),
             across = s.vec3("across");
  if (!(dot(axis, axis) > 0)) s.fail("axis", "must not be zero");
  p.axis = unit(axis);
  // `across` made normal to the axis.
  const double along = dot(across, p.axis);
  const Vec3 normal{across[0] - along * p.axis[0], across[1] - along * p.axis[1],
                    across[2] - along * p.axis[2]};
  if (!(dot(normal, normal) > 1e-12 * std::max(dot(across, across), 1e-300)))
    s.fail("across", "must not be parallel to the axis (it is the direction the jaws close along)");
  p.across = unit(normal);
  if (turning) {
    // Each keyframe's rotation: the smallest one from the axis before (at most
    // ToolPath::kMaxTurn degrees: never near a half turn, where it is ill-defined), composed.
    p.turns.push_back(Eigen::Quaterniond::Identity());
    const auto& T = p.path.times();
    for (std::size_t i = 1; i < T.size(); ++i) {
      const Vec3 a = p.path.at(T[i - 1]).second, b = p.path.at(T[i]).second;
      const Eigen::Quaterniond step = Eigen::Quaterniond::FromTwoVectors(
          Eigen::Vector3d(a[0], a[1], a[2]), Eigen::Vector3d(b[0], b[1], b[2]));
      p.turns.push_back((step * p.turns.back()).normalized());
    }
  }
  p.minAngle = readMinAngle(s);
  return p;
}

const bool registered = ActionRegistry::instance().add(
    {"forceps",
     "two jaws moving in world coordinates along a path of keyframes over an interval (\"from\", "
     "\"to\"), opening and closing: closed, they take the surface between them where it is then "
     "(material points inside triangles included) and carry it until they open",
     {{"from", KeyType::Number, "when they start moving", {}, true},
      {"to", KeyType::Number, "when they stop (closed then, they hold on)", {}, true},
      {"name",
       KeyType::String,
       "their grasp's name (unique among the active grasps): the CSV's reaction-force columns",
       {"forceps"},
       true},
      {"path",
       KeyType::Rows,
       "[[t, x, y, z, opening], ...] with \"axis\", [[t, x, y, z, ax, ay, az, opening], ...] "
       "without: times from \"from\", strictly increasing; the middle of the jaws' tips (x, y, z) "
       "in world coordinates, the jaws' axis (turning jaws: from the tips along the jaws, not "
       "zero, at most 170 degrees from the keyframe before) and the distance between their axes "
       "(m, at least 2 radii: closed, the jaws touch); linear between keyframes (the axis along "
       "the great circle), held outside",
       {},
       true},
      {"axis", KeyType::Point,
       "[x, y, z]: from the tips along the jaws (world); the jaws keep it (they translate). "
       "Without it the path gives an axis per keyframe and the jaws turn, the smallest rotation "
       "from one keyframe's axis to the next's (they do not roll about their axis), and what they "
       "hold turns with them about their tip"},
      {"across",
       KeyType::Point,
       "[x, y, z]: from one jaw to the other, the direction they close along (made normal to the "
       "axis; turning jaws: at the first keyframe, turned with them)",
       {},
       true},
      {"radius", KeyType::Number, "of each jaw (m), > 0", {}, true},
      {"length", KeyType::Number, "of each jaw from its tip (m), > 0", {}, true},
      {"minAngle", KeyType::Number,
       "smallest-angle target (degrees) of the quality repair around the points the jaws insert "
       "where they take the surface, in [0, 60) (default 20; 0 turns it off)"}},
     {},
     [](const ParameterSource& s) -> std::any { return readForceps(s); },
     [](const std::any& p, const ActionTiming& timing) -> std::unique_ptr<TimelineAction> {
       return std::make_unique<ForcepsAction>(std::any_cast<const ForcepsParameters&>(p), timing);
     }});

}  // namespace
}  // namespace cutsim::core
