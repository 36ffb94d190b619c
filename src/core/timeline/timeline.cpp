// What the timeline's actions and the scene's constraints share: point selections, regions, the
// contexts' and interfaces' destructors (timeline.hpp).
#include "cutsim/core/timeline.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <set>

#include "cutsim/base/numbers.hpp"
#include "cutsim/forcefields/sutures.hpp"
#include "cutsim/topology/geometry.hpp"

namespace cutsim::core {

using topology::geometry::dist2;

ActionContext::~ActionContext() = default;
DryRunContext::~DryRunContext() = default;
TimelineAction::~TimelineAction() = default;

bool incisionOpened(const topology::IncisionResult& r) {
  const topology::RepairReport& q = r.repair;
  return !r.copies.empty() || !r.insertedPoints.empty() ||
         q.flips + q.collapses + q.relocations + q.splits + q.insertions > 0;
}
SceneConstraint::~SceneConstraint() = default;

PointSelection PointSelection::read(const ParameterSource& s) {
  PointSelection sel;
  const std::string_view key = s.oneOf({"points", "box", "near"});
  if (key == "points") {
    sel.kind = Kind::Points;
    const std::vector<long> ids =
        s.integers("points", 0, long(std::numeric_limits<topology::Index>::max()) - 1);
    if (ids.empty()) s.fail("points", "lists no point");
    for (long id : ids) sel.points.push_back(PointId(id));
  } else if (key == "box") {
    sel.kind = Kind::Box;
    std::tie(sel.boxMin, sel.boxMax) = s.box("box");
  } else {
    sel.kind = Kind::Near;
    sel.near = s.points("near", 1);
  }
  return sel;
}

Region Region::read(const ParameterSource& s, std::string_view key) {
  Region r;
  if (key == "sphere") {
    const auto sphere = s.object("sphere", {"center", "radius"});
    sphere->require("center");
    sphere->require("radius");
    r.kind = Kind::Sphere;
    r.center = sphere->vec3("center");
    r.radius = sphere->positive("radius", 0.0);
  } else {
    r.kind = Kind::Box;
    std::tie(r.boxMin, r.boxMax) = s.box("box");
  }
  return r;
}

std::string_view PointSelection::key() const {
  switch (kind) {
    case Kind::Points:
      return "points";
    case Kind::Box:
      return "box";
    case Kind::Near:
      return "near";
  }
  return "";
}

PointId nearestPoint(std::span<const PointId> points, const Vec3& position,
                     const std::function<Vec3(PointId)>& positionOf) {
  PointId best = PointId::invalid();
  double bestD = 0.0;
  for (PointId p : points) {
    const double d = dist2(positionOf(p), position);
    if (best == PointId::invalid() || d < bestD) {
      bestD = d;
      best = p;
    }
  }
  return best;
}

std::vector<PointId> connectedWithin(const topology::Topology& topo,
                                     const std::vector<PointId>& inside, PointId start) {
  const std::set<PointId> in(inside.begin(), inside.end());
  std::set<PointId> reached = {start};
  std::vector<PointId> stack = {start};
  while (!stack.empty()) {
    const PointId p = stack.back();
    stack.pop_back();
    for (topology::EdgeId e : topo.edgesAroundPoint(p)) {
      const topology::EdgeVertices v = topo.edgeVertices(e);
      const PointId q = v[0] == p ? v[1] : v[0];
      if (in.count(q) && reached.insert(q).second) stack.push_back(q);
    }
  }
  return {reached.begin(), reached.end()};
}

std::vector<PointId> PointSelection::resolve(const topology::Topology& topo) const {
  const auto rest = [&topo](PointId p) { return topo.restPosition(p); };
  std::vector<PointId> out;
  switch (kind) {
    case Kind::Points:
      for (PointId p : points) {
        if (p.idx() < topo.pointCapacity() && topo.isPointAlive(p)) out.push_back(p);
      }
      break;
    case Kind::Box:
      for (PointId p : topo.points()) {
        const Vec3 x = topo.restPosition(p);
        bool inside = true;
        for (int k = 0; k < 3; ++k) inside = inside && x[k] >= boxMin[k] && x[k] <= boxMax[k];
        if (inside) out.push_back(p);
      }
      if (onePiece && !out.empty()) {
        const Vec3 centre{0.5 * (boxMin[0] + boxMax[0]), 0.5 * (boxMin[1] + boxMax[1]),
                          0.5 * (boxMin[2] + boxMax[2])};
        out = connectedWithin(topo, out, nearestPoint(out, seed.value_or(centre), rest));
      }
      break;
    case Kind::Near: {
      const std::vector<PointId> live = topo.points();
      if (live.empty()) break;
      for (const Vec3& q : near) out.push_back(nearestPoint(live, q, rest));
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

double Region::levelSet(const Vec3& p) const {
  if (kind == Kind::Sphere) return std::sqrt(dist2(p, center)) - radius;
  double d = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    const double mid = 0.5 * (boxMin[k] + boxMax[k]), half = 0.5 * (boxMax[k] - boxMin[k]);
    d = std::max(d, std::abs(p[k] - mid) - half);
  }
  return d;
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

PointId pointAt(topology::Topology& topo, topology::TriangleId t, std::array<double, 3> w) {
  for (double& x : w) x = std::clamp(x, 0.0, 1.0);
  for (double& x : w)
    if (x < 1e-9) x = 0.0;
  const double sum = w[0] + w[1] + w[2];
  for (double& x : w) x /= sum;
  const auto v = topo.triangleVertices(t);
  for (int k = 0; k < 3; ++k)
    if (w[k] >= 1.0 - 1e-9) return v[k];
  for (int k = 0; k < 3; ++k)
    if (w[k] == 0.0) {
      // On the edge opposite corner k: from v[k+1] to v[k+2].
      const PointId a = v[(k + 1) % 3], b = v[(k + 2) % 3];
      const topology::EdgeId e = topo.findEdge(a, b);
      const auto ends = topo.edgeVertices(e);
      const double along = ends[0] == a ? w[(k + 2) % 3] : w[(k + 1) % 3];
      return topo.splitEdge(e, along);
    }
  return topo.splitTriangle(t, w);
}

std::string readGraspName(const ParameterSource& s) {
  s.require("name");
  std::string name = s.string("name");
  if (name.empty()) s.fail("name", "must not be empty");
  if (name.find_first_of(",\"\n\r") != std::string::npos || name.find('\0') != std::string::npos)
    s.fail("name", "must not contain a comma, a quote or a line break (it names CSV columns)");
  return name;
}

void requireFree(ActionContext& c, std::span<const PointId> points, const std::string& who) {
  const Simulation& sim = c.simulation();
  for (PointId p : points) {
    if (sim.fixed().contains(p))
      c.fail(who + ": point " + std::to_string(p.idx()) +
             " is fixed: a point is held by one constraint (hold points that are not fixed)");
    for (std::size_t g = 0; g < sim.numGrasps(); ++g)
      if (sim.grasp(g).points().contains(p))
        c.fail(who + ": point " + std::to_string(p.idx()) + " is held by the grasp \"" +
               sim.grasp(g).name() + "\": a point is held by one constraint");
  }
}

topology::RepairOptions repairOptions(const Simulation& simulation, double minAngle) {
  topology::RepairOptions o;
  o.minAngle = minAngle;
  // Locked even without the repair: carving moves points onto the region's boundary.
  o.locked = simulation.fixed().points();
  for (std::size_t i = 0; i < simulation.numGrasps(); ++i) {
    auto g = simulation.grasp(i).points().points();
    o.locked.insert(o.locked.end(), g.begin(), g.end());
  }
  // The points a suture's thread ties: moved or replaced, the stitch would be lost.
  const Model& model = simulation.model();
  for (std::size_t i = 0; i < model.numForceFields(); ++i)
    if (const auto* s = dynamic_cast<const forcefields::Sutures*>(&model.forceField(i)))
      for (const auto& st : s->stitches())
        if (st.alive) {
          o.locked.push_back(st.a);
          o.locked.push_back(st.b);
        }
  return o;
}

double readMinAngle(const ParameterSource& s) {
  if (!s.has("minAngle")) return kDefaultMinAngle;
  const double a = s.number("minAngle");
  if (!(a >= 0.0 && a < 60.0))
    s.fail("minAngle",
           "must be in [0, 60) degrees (0 turns the quality repair off); got " + describeNumber(a));
  return a;
}

}  // namespace cutsim::core
