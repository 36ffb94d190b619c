// The "sew" action: the lips of a wound joined back into one surface where they meet in the world
// (Topology::sew, the reverse of a cut), with the quality repair around the seam. Every facing
// pair of lip edges whose ends lie within `tolerance` of each other where the surface is now
// becomes one interior edge; with `near`, only the lips within `radius` of that path (world
// coordinates) take part. docs/instruments.md.
#include <algorithm>
#include <cmath>

#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/core/timeline.hpp"
#include "cutsim/forcefields/sutures.hpp"
#include "cutsim/topology/geometry.hpp"

namespace cutsim::core {
namespace {

struct SewParameters {
  double tolerance = 0.0;  ///< how far apart the lips' points may be (m)
  std::vector<Vec3> near;  ///< a path in the world (empty: everywhere)
  double radius = 0.0;     ///< how far from `near` a lip point may be (m)
  double minAngle = kDefaultMinAngle;
};

/// The distance from p to the segment [a, b].
double segmentDistance(const Vec3& p, const Vec3& a, const Vec3& b) {
  Vec3 d{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w{p[0] - a[0], p[1] - a[1], p[2] - a[2]};
  const double dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  const double s =
      dd > 0 ? std::clamp((w[0] * d[0] + w[1] * d[1] + w[2] * d[2]) / dd, 0.0, 1.0) : 0.0;
  for (int k = 0; k < 3; ++k) w[k] -= s * d[k];
  return std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
}

class SewAction final : public TimelineAction {
 public:
  explicit SewAction(SewParameters p) : p_(std::move(p)) {}

  void dryRun(DryRunContext&) const override {}
  /// Not rehearsed on the surface at rest: the lips meet (or not) where the surface is then.
  bool rehearsed() const override { return false; }

  void start(ActionContext& c) override {
    Simulation& sim = c.simulation();
    topology::Topology& topo = sim.topology();
    const auto x = sim.state().x();
    topology::SewOptions o;
    o.tolerance = p_.tolerance;
    if (!p_.near.empty())
      o.within = [this, x](PointId p) {
        const Vec3 q{x[3 * p.idx()], x[3 * p.idx() + 1], x[3 * p.idx() + 2]};
        if (p_.near.size() == 1) return segmentDistance(q, p_.near[0], p_.near[0]) <= p_.radius;
        for (std::size_t k = 0; k + 1 < p_.near.size(); ++k)
          if (segmentDistance(q, p_.near[k], p_.near[k + 1]) <= p_.radius) return true;
        return false;
      };
    // Fixed and grasped points must stay; a suture's threads keep their points where they can.
    topology::RepairOptions held = repairOptions(sim, p_.minAngle);
    const Model& model = sim.model();
    for (std::size_t i = 0; i < model.numForceFields(); ++i)
      if (const auto* s = dynamic_cast<const forcefields::Sutures*>(&model.forceField(i)))
        for (const auto& st : s->stitches())
          if (st.alive) {
            o.preferred.push_back(st.a);
            o.preferred.push_back(st.b);
          }
    o.locked = sim.fixed().points();
    for (std::size_t i = 0; i < sim.numGrasps(); ++i) {
      const auto g = sim.grasp(i).points().points();
      o.locked.insert(o.locked.end(), g.begin(), g.end());
    }
    o.repair = held;  // (the repair keeps the threads' points too)
    // Where the lips' points are and how they move, before the sew.
    const std::vector<double> x0(x.begin(), x.end());
    const auto v = sim.state().v();
    const std::vector<double> v0(v.begin(), v.end());
    topology::SewResult result;
    try {
      result = topo.sew(x, o);
    } catch (const TopologyError& e) {
      c.failTopology(std::string("the lips cannot be sewn: ") + e.what());
    }
    // A group kept as one of its points (their rest positions agree) takes the mean of their
    // positions and velocities, as a new point at their mean does through its ancestors: the
    // lips meet halfway and the momentum stays.
    auto xs = sim.state().x();
    auto vs = sim.state().v();
    for (const topology::SewResult::Group& g : result.groups) {
      const std::size_t into = g.into.idx();
      // (Not a held point, which stays where its constraint holds it; not a group with a point
      // the sew inserted, which had no position before it.)
      const bool before = std::all_of(g.points.begin(), g.points.end(), [&](PointId p) {
        return 3 * std::size_t(p.idx()) + 2 < x0.size();
      });
      if (!before || !topo.isPointAlive(g.into) ||
          std::find(g.points.begin(), g.points.end(), g.into) == g.points.end() ||
          std::find(o.locked.begin(), o.locked.end(), g.into) != o.locked.end())
        continue;
      for (int k = 0; k < 3; ++k) {
        double mx = 0, mv = 0;
        for (PointId p : g.points) {
          mx += x0[3 * p.idx() + k];
          mv += v0[3 * p.idx() + k];
        }
        xs[3 * into + k] = mx / double(g.points.size());
        vs[3 * into + k] = mv / double(g.points.size());
      }
    }
  }

 private:
  SewParameters p_;
};

SewParameters readSew(const ParameterSource& s) {
  SewParameters p;
  s.require("tolerance");
  p.tolerance = s.number("tolerance");
  if (!(p.tolerance > 0) || !std::isfinite(p.tolerance))
    s.fail("tolerance", "must be a positive distance (m): how far apart the lips may be");
  if (s.has("near")) {
    p.near = s.points("near", 1);
    for (std::size_t k = 0; k < p.near.size(); ++k)
      for (double v : p.near[k])
        if (!std::isfinite(v)) s.fail("near/" + std::to_string(k), "must be finite numbers");
    s.require("radius");
    p.radius = s.number("radius");
    if (!(p.radius > 0) || !std::isfinite(p.radius))
      s.fail("radius", "must be a positive distance (m) from the \"near\" path");
  } else if (s.has("radius")) {
    s.fail("radius", "goes with \"near\" (the path the lips to sew lie along)");
  }
  p.minAngle = readMinAngle(s);
  return p;
}

const bool registered = ActionRegistry::instance().add(
    {"sew",
     "joins the lips of a wound back into one surface where they meet in the world, the reverse "
     "of a cut: every pair of facing lip edges whose ends lie within the tolerance of each other "
     "becomes one interior edge, and every table follows",
     {{"at", KeyType::Number, "time of the sew"},
      {"tolerance", KeyType::Number,
       "how far apart (m, > 0) the lips' points may be where the surface is then, required"},
      {"near", KeyType::Points,
       "[[x, y, z], ...]: only the lips within \"radius\" of this path (world coordinates) are "
       "sewn (default: every lip)"},
      {"radius", KeyType::Number, "with \"near\": how far from the path (m, > 0)"},
      {"minAngle", KeyType::Number,
       "smallest-angle target (degrees) of the quality repair around the seam, in [0, 60) "
       "(default 20; 0 turns it off)"}},
     {},
     [](const ParameterSource& s) -> std::any { return readSew(s); },
     [](const std::any& p, const ActionTiming&) -> std::unique_ptr<TimelineAction> {
       return std::make_unique<SewAction>(std::any_cast<const SewParameters&>(p));
     }});

}  // namespace
}  // namespace cutsim::core
