// The "cautery" action: a sphere, or a capsule along an axis from its tip, moving in the world
// along a path of keyframes, that burns away the surface it touches where the surface now is; or,
// as a dissector, only releases the surface from the tissue beneath (its Attachment force fields)
// where it passes. The region it swept since it last acted (the points within its radius of the
// surface its axis swept between sampled positions, or of the segment its centre ran along) is met
// with the surface as it is: the topology carves it out (Topology::carve, with the region's
// function of the points' current positions), cutting the triangles its boundary crosses, in one
// transaction whose events the mass and every table follow, then the quality repair, once the
// instrument has moved half a mean rest edge; or, after each step, its points inside are released.
// docs/instruments.md.
#include <algorithm>
#include <cmath>
#include <limits>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/core/timeline.hpp"
#include "cutsim/forcefields/attachment.hpp"
#include "cutsim/forcefields/surface_query.hpp"
#include "cutsim/topology/geometry.hpp"
#include "tool_path.hpp"

namespace cutsim::core {
namespace {

using topology::geometry::dist2;
using topology::geometry::distanceToSegment;
using topology::geometry::dot;
using topology::geometry::lerp;
using topology::geometry::sub;

/// A turning capsule sweeps a bilinear surface between two samples: sampled every few degrees.
constexpr double kSampleTurn = 5.0;

struct CauteryParameters {
  ToolPath path;        ///< the tip in world coordinates (and the axis of a capsule)
  double radius = 0.0;  ///< of the sphere or the capsule (m)
  double length = 0.0;  ///< of the capsule's axis from the tip (m); 0: a sphere
  bool dissect = false;
  std::string field;  ///< dissecting: an Attachment's label ("": every Attachment)
  /// Carving: cut the triangles the region's boundary crosses (a clean hole following the
  /// instrument), or remove every triangle it touches whole.
  bool cutBoundary = true;
  double minAngle = kDefaultMinAngle;
};

Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

/// The distance from p to triangle (a, b, c), which may be degenerate (a segment, a point): the
/// nearest of its edges, or of its plane where p projects inside it.
double distanceToTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  double d = std::min(
      {distanceToSegment(p, a, b), distanceToSegment(p, b, c), distanceToSegment(p, c, a)});
  const Vec3 n = cross(sub(b, a), sub(c, a));
  const double n2 = dot(n, n);
  const double scale = std::max({dist2(a, b), dist2(b, c), dist2(c, a)});
  if (!(n2 > 1e-20 * scale * scale)) return d;
  const Vec3 ap = sub(p, a);
  // p's projection inside: on the inner side of each edge.
  const Vec3 pts[3] = {a, b, c};
  for (int i = 0; i < 3; ++i) {
    const Vec3& u = pts[i];
    const Vec3& v = pts[(i + 1) % 3];
    if (dot(cross(sub(v, u), sub(p, u)), n) < 0) return d;
  }
  return std::min(d, std::abs(dot(ap, n)) / std::sqrt(n2));
}

/// The region an instrument swept between sampled positions: the points within `radius` of the
/// triangles between consecutive positions of its axis (a sphere's: segments).
class SweptRegion {
 public:
  SweptRegion(std::vector<std::array<Vec3, 2>> poses, double radius)
      : poses_(std::move(poses)), radius_(radius) {
    lo_ = hi_ = poses_.front()[0];
    for (const auto& p : poses_)
      for (const Vec3& q : p)
        for (int k = 0; k < 3; ++k) {
          lo_[k] = std::min(lo_[k], q[k] - radius_);
          hi_[k] = std::max(hi_[k], q[k] + radius_);
        }
  }
  /// Negative inside, positive outside: the distance to the swept axis less the radius (outside
  /// the region's bounding box, the distance to the box).
  double levelSet(const Vec3& q) const {
    double box = 0.0;
    for (int k = 0; k < 3; ++k) box = std::max({box, lo_[k] - q[k], q[k] - hi_[k]});
    if (box > 0) return box;
    double d = std::numeric_limits<double>::infinity();
    if (poses_.size() == 1) return distanceToSegment(q, poses_[0][0], poses_[0][1]) - radius_;
    for (std::size_t i = 1; i < poses_.size(); ++i) {
      const auto& a = poses_[i - 1];
      const auto& b = poses_[i];
      d = std::min(
          {d, distanceToTriangle(q, a[0], a[1], b[1]), distanceToTriangle(q, a[0], b[1], b[0])});
    }
    return d - radius_;
  }
  const std::vector<std::array<Vec3, 2>>& poses() const { return poses_; }

 private:
  std::vector<std::array<Vec3, 2>> poses_;
  double radius_;
  Vec3 lo_, hi_;
};

class CauteryAction final : public TimelineAction {
 public:
  CauteryAction(CauteryParameters p, const ActionTiming& timing)
      : p_(std::move(p)), timing_(timing) {}

  void dryRun(DryRunContext& c) const override {
    // The surface it meets is where the run has put it: only a dissector's field is known now.
    if (!p_.dissect) return;
    if (const auto* fields = c.forceFields()) {
      bool found = false;
      for (const auto& [type, label] : *fields)
        found = found || (type == "Attachment" && (p_.field.empty() || label == p_.field));
      if (!found)
        c.fail(p_.field.empty() ? "mode" : "field",
               p_.field.empty()
                   ? "a dissecting cautery needs an Attachment force field: the scene has none"
                   : "no Attachment force field is labelled \"" + p_.field + "\"");
    }
  }
  bool rehearsed() const override { return false; }

  void start(ActionContext& c) override {
    started_ = true;
    last_ = 0.0;
    first_ = true;
    afterStep(c);
  }

  void afterStep(ActionContext& c) override {
    if (!started_ || finished_) return;
    const bool final = c.time() >= timing_.to - 1e-9 * c.timeStep();
    const double now = std::min(c.time(), timing_.to) - timing_.from;
    if (!(now > last_) && !first_) return;
    std::vector<std::array<Vec3, 2>> poses = posesBetween(last_, now);
    // It acts once it has moved half a mean rest edge since it last did (and when it starts and
    // stops): a carve every step would cut crescents a small fraction of an edge wide, whose
    // slivers the repair would refine without end.
    double travelled = 0.0;
    for (std::size_t i = 1; i < poses.size(); ++i)
      travelled += std::sqrt(
          std::max(dist2(poses[i - 1][0], poses[i][0]), dist2(poses[i - 1][1], poses[i][1])));
    if (!p_.dissect && !first_ && !final && travelled < 0.5 * c.meanRestEdge()) return;
    if (!p_.dissect && !first_ && travelled == 0.0) {  // held still: it swept nothing new
      last_ = now;
      if (final) finished_ = true;
      return;
    }
    first_ = false;
    const SweptRegion region(std::move(poses), p_.radius);
    if (p_.dissect)
      dissect(c, region);
    else
      carve(c, region);
    last_ = now;
    if (final) finished_ = true;
  }

  void instruments(double time, std::vector<std::array<Vec3, 2>>& out) const override {
    const double eps = 1e-9 * std::max(1.0, std::abs(timing_.to));
    if (time < timing_.from - eps || time > timing_.to + eps) return;
    const auto [a, b] = pose(std::clamp(time, timing_.from, timing_.to) - timing_.from);
    wireCapsule(a, b, p_.radius, out);
  }

  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override {
    fields(out, started_, finished_, first_, last_);
  }
  void loadState(ArchiveReader& in, const Simulation&) override {
    fields(in, started_, finished_, first_, last_);
    if (!(last_ >= 0 && last_ <= timing_.to - timing_.from))
      in.fail("a cautery's progress of " + std::to_string(last_));
  }

 private:
  /// The axis at time t from the action's start: the tip and the end of the capsule's axis (the
  /// tip again for a sphere).
  std::array<Vec3, 2> pose(double t) const {
    const auto [tip, axis] = p_.path.at(t);
    return {
        tip,
        {tip[0] + p_.length * axis[0], tip[1] + p_.length * axis[1], tip[2] + p_.length * axis[2]}};
  }

  /// Its positions from t0 to t1: both, every keyframe between, and enough between those that the
  /// axis turns by at most a few degrees from one to the next (the swept region between two is
  /// exact for a translation, the bilinear surface split along a diagonal for a turn).
  std::vector<std::array<Vec3, 2>> posesBetween(double t0, double t1) const {
    std::vector<std::array<Vec3, 2>> out;
    for (double t : p_.path.samples(t0, t1, kSampleTurn, std::numeric_limits<double>::infinity()))
      out.push_back(pose(t));
    return out;
  }

  void carve(ActionContext& c, const SweptRegion& region) {
    Simulation& sim = c.simulation();
    const std::span<const double> x = sim.state().x();
    const auto world = [&x](topology::Topology::PointWeights w) {
      Vec3 q{0, 0, 0};
      for (const auto& [p, f] : w)
        for (int k = 0; k < 3; ++k) q[k] += f * x[3 * p.idx() + std::size_t(k)];
      return q;
    };
    topology::Topology& topo = sim.topology();
    // A point the last carve left on the region's boundary (within the bisection's rounding of
    // it) is not inside: the points are inside deeper than eps, while the boundary's crossings
    // along edges are where the region's function changes sign.
    const double eps = 1e-9 * c.meanRestEdge();
    const topology::RepairOptions repair = repairOptions(sim, p_.minAngle);
    try {
      if (p_.cutBoundary) {
        // (nothing inside: no transaction; the carve would find the same)
        const auto points = topo.points();
        if (std::none_of(points.begin(), points.end(), [&](PointId p) {
              return region.levelSet({x[3 * p.idx()], x[3 * p.idx() + 1], x[3 * p.idx() + 2]}) +
                         eps <=
                     0;
            }))
          return;
        topo.carve(
            [&](const Vec3&, topology::Topology::PointWeights w) {
              return region.levelSet(world(w)) + (w.size() == 1 ? eps : 0.0);
            },
            repair, nullptr, true);
        return;
      }
      const std::vector<topology::TriangleId> touched = touchedTriangles(sim, region);
      if (!touched.empty()) topo.removeTriangles(touched, repair);
    } catch (const TopologyError& e) {
      c.failTopology(std::string("the cautery's removal failed: ") + e.what());
    }
  }

  /// The live triangles within the radius of the swept axis, at the current positions.
  std::vector<topology::TriangleId> touchedTriangles(const Simulation& sim,
                                                     const SweptRegion& region) {
    if (!query_)
      query_ = std::make_unique<forcefields::SurfaceQuery>(sim.topology(), sim.state().x());
    else
      query_->update(sim.state().x());
    std::vector<topology::TriangleId> out;
    const auto& poses = region.poses();
    const auto add = [&out](const std::vector<topology::TriangleId>& t) {
      out.insert(out.end(), t.begin(), t.end());
    };
    if (poses.size() == 1) add(query_->capsuleOverlap(poses[0][0], poses[0][1], p_.radius));
    for (std::size_t i = 1; i < poses.size(); ++i) {
      if (p_.length > 0)
        add(query_->sweptSegmentHits(poses[i - 1][0], poses[i - 1][1], poses[i][0], poses[i][1],
                                     p_.radius));
      else
        add(query_->capsuleOverlap(poses[i - 1][0], poses[i][0], p_.radius));
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }

  void dissect(ActionContext& c, const SweptRegion& region) {
    Model& model = c.simulation().model();
    const std::span<const double> x = c.simulation().state().x();
    bool found = false;
    for (std::size_t i = 0; i < model.numForceFields(); ++i) {
      auto* a = dynamic_cast<forcefields::Attachment*>(&model.forceField(i));
      if (!a || (!p_.field.empty() && model.forceFieldLabel(i) != p_.field)) continue;
      found = true;
      a->releasePoints([&](PointId p) {
        return region.levelSet({x[3 * p.idx()], x[3 * p.idx() + 1], x[3 * p.idx() + 2]}) <= 0;
      });
    }
    if (!found)
      c.fail(p_.field.empty()
                 ? "the dissecting cautery finds no Attachment force field to release"
                 : "the dissecting cautery finds no Attachment labelled \"" + p_.field + "\"");
  }

  CauteryParameters p_;
  ActionTiming timing_;
  bool started_ = false, finished_ = false, first_ = true;
  double last_ = 0.0;  // time (from the action's start) of its position at the last pass
  std::unique_ptr<forcefields::SurfaceQuery> query_;
};

CauteryParameters readCautery(const ParameterSource& s) {
  CauteryParameters p;
  if (!s.has("from") || !s.has("to"))
    s.fail(s.has("from") ? "to" : "from",
           "a cautery moves over an interval: give \"from\" and \"to\" (not \"at\")");
  s.require("radius");
  p.radius = s.number("radius");
  if (!(p.radius > 0)) s.fail("radius", "must be a positive number (m)");
  if (s.has("length")) {
    p.length = s.number("length");
    if (!(p.length >= 0)) s.fail("length", "must be >= 0 (m; 0: a sphere)");
  }
  p.path = ToolPath::read(s, s.has("length"), "the cautery");
  const std::string mode = s.choice("mode", "carve", {"carve", "dissect"});
  p.dissect = mode == "dissect";
  if (s.has("field")) {
    if (!p.dissect) s.fail("field", "is for a dissecting cautery (\"mode\": \"dissect\")");
    p.field = s.string("field");
  }
  if (p.dissect) {
    for (const char* key : {"boundary", "minAngle"})
      if (s.has(key)) s.fail(key, "is for a carving cautery: a dissection changes no triangle");
  }
  p.cutBoundary = s.choice("boundary", "cut", {"cut", "touched"}) == "cut";
  p.minAngle = readMinAngle(s);
  return p;
}

const bool registered = ActionRegistry::instance().add(
    {"cautery",
     "a sphere, or a capsule along an axis from its tip, moving in world coordinates along a "
     "path of keyframes over an interval (\"from\", \"to\"): after each step it burns away the "
     "surface it has touched, where the surface now is, or only releases it from the tissue "
     "beneath (\"mode\": \"dissect\")",
     {{"from", KeyType::Number, "when it starts moving (and burning)", {}, true},
      {"to", KeyType::Number, "when it stops", {}, true},
      {"radius", KeyType::Number, "of the sphere or the capsule (m), > 0", {}, true},
      {"length", KeyType::Number,
       "a capsule: the length of its axis from the tip (m), >= 0; with it, the path's rows give "
       "the axis too"},
      {"path",
       KeyType::Rows,
       "[[t, x, y, z], ...] (with \"length\": [[t, x, y, z, ax, ay, az], ...]): times from "
       "\"from\", strictly increasing; the tip (x, y, z) in world coordinates and the axis "
       "(ax, ay, az) from it; linear between keyframes, held before the first and after the last",
       {},
       true},
      {"mode",
       KeyType::Choice,
       "\"carve\" (default): remove the surface it touches; \"dissect\": only release the "
       "surface from the tissue beneath (its Attachment force fields) where it passes",
       {"carve", "dissect"}},
      {"field", KeyType::String,
       "dissecting: the label of the Attachment to release (default: every Attachment)"},
      {"boundary",
       KeyType::Choice,
       "carving: \"cut\" (default), cut the triangles the swept region's boundary crosses (a "
       "clean hole following the instrument); \"touched\", remove every triangle it touches "
       "whole",
       {"cut", "touched"}},
      {"minAngle", KeyType::Number,
       "carving: smallest-angle target (degrees) of the quality repair around the hole, in "
       "[0, 60) (default 20; 0 turns the repair off)"}},
     {},
     [](const ParameterSource& s) -> std::any { return readCautery(s); },
     [](const std::any& p, const ActionTiming& timing) -> std::unique_ptr<TimelineAction> {
       return std::make_unique<CauteryAction>(std::any_cast<const CauteryParameters&>(p), timing);
     }});

}  // namespace
}  // namespace cutsim::core
