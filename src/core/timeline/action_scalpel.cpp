// The "scalpel" action: a blade moving in the world along a path of keyframes that cuts the
// surface where it is now. The blade is a segment from its tip along its axis, `depth` long. After
// each step, the surface the blade swept since its last cut is met with the surface as it is
// (forcefields::SurfaceQuery::sweptSegmentCurves); the curves found (one per layer it passed
// through) are carried to rest coordinates through their triangles' weights and cut there, one
// topology transaction each (snapping, the quality repair). An incision the blade is still in
// goes on from its tip at the next cut. docs/instruments.md.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/core/timeline.hpp"
#include "cutsim/forcefields/surface_query.hpp"
#include "cutsim/topology/geometry.hpp"
#include "tool_path.hpp"

namespace cutsim::core {
namespace {

using topology::geometry::dist2;
using topology::geometry::lerp;

/// The swept surface between two poses is bilinear: a turning blade is sampled every few degrees.
constexpr double kSampleTurn = 5.0;

struct ScalpelParameters {
  ToolPath path;       ///< the tip in world coordinates, the axis from the tip along the blade
  double depth = 0.0;  ///< the blade's length from its tip
  double snapTolerance = 0.1;
  double minAngle = kDefaultMinAngle;
};

/// Whether a point of an incision curve is on the path of the blade's tip or of the end of its
/// edge (where the blade enters or leaves the tissue through its own movement), not a border.
bool onBladePath(const forcefields::SweptCrossing& x) {
  return x.u <= 1e-6 || x.u >= 1.0 - 1e-6;
}

/// The polyline without the points that lie on the segment between their neighbours kept (within
/// eps): a straight incision in rest coordinates (a flat sheet at rest) is given to the cut as its
/// two ends, as a polyline cut along the same path is, so that both walk and snap alike.
std::vector<Vec3> straightened(const std::vector<Vec3>& p, double eps) {
  if (p.size() < 3) return p;
  std::vector<Vec3> out{p.front()};
  std::size_t anchor = 0;
  for (std::size_t k = 2; k < p.size(); ++k) {
    bool straight = true;
    for (std::size_t j = anchor + 1; j < k && straight; ++j)
      straight = topology::geometry::distanceToSegment(p[j], p[anchor], p[k]) <= eps;
    if (!straight) {
      out.push_back(p[k - 1]);
      anchor = k - 1;
    }
  }
  out.push_back(p.back());
  return out;
}

/// The polyline without the interior points nearer than `gap` to the point kept before them (the
/// last point stays; an interior point nearer than `gap` to it goes): the cut inserts a vertex at
/// each point, and a curve that crosses many edges near a vertex, or starts just past the tip it
/// continues from (a border vertex, onto which nothing snaps), would leave edges a small fraction
/// of the mesh's long, whose tiny masses and stiff springs the solves then struggle with.
std::vector<Vec3> thinned(const std::vector<Vec3>& p, double gap) {
  if (p.size() < 3) return p;
  std::vector<Vec3> out{p.front()};
  const double g2 = gap * gap;
  for (std::size_t k = 1; k + 1 < p.size(); ++k)
    if (dist2(p[k], out.back()) >= g2) out.push_back(p[k]);
  if (out.size() > 1 && dist2(p.back(), out.back()) < g2)
    out.back() = p.back();
  else
    out.push_back(p.back());
  return out;
}

class ScalpelAction final : public TimelineAction {
 public:
  ScalpelAction(ScalpelParameters p, const ActionTiming& timing)
      : p_(std::move(p)), timing_(timing) {}

  // Nothing to check on the rest mesh: the blade cuts the surface where the run has put it.
  void dryRun(DryRunContext&) const override {}
  bool rehearsed() const override { return false; }

  void start(ActionContext& c) override {
    minPiece_ = 0.5 * c.meanRestEdge();
    last_ = 0.0;
    started_ = true;
    afterStep(c);
  }

  void instruments(double time, std::vector<std::array<Vec3, 2>>& out) const override {
    const double eps = 1e-9 * std::max(1.0, std::abs(timing_.to));
    if (time >= timing_.from - eps && time <= timing_.to + eps)
      out.push_back(pose(std::clamp(time, timing_.from, timing_.to) - timing_.from));
  }

  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override {
    fields(out, started_, finished_, last_, minPiece_);
    const std::size_t n = tips_.size();
    out.raw(&n, sizeof n);
    for (const Vec3& t : tips_) out.raw(t.data(), sizeof(double) * 3);
  }
  void loadState(ArchiveReader& in, const Simulation&) override {
    fields(in, started_, finished_, last_, minPiece_);
    std::size_t n = 0;
    in.raw(&n, sizeof n);
    if (n > 1000000) in.fail("a scalpel's " + std::to_string(n) + " incision tips");
    tips_.assign(n, Vec3{});
    for (Vec3& t : tips_) {
      in.raw(t.data(), sizeof(double) * 3);
      if (!std::isfinite(t[0]) || !std::isfinite(t[1]) || !std::isfinite(t[2]))
        in.fail("a scalpel's incision tip that is not a finite point");
    }
    if (!(last_ >= 0 && last_ <= timing_.to - timing_.from) || !std::isfinite(minPiece_))
      in.fail("a scalpel's progress of " + std::to_string(last_));
    query_.reset();
  }

  void afterStep(ActionContext& c) override {
    if (!started_ || finished_) return;
    Simulation& sim = c.simulation();
    const bool final = c.time() >= timing_.to - 1e-9 * c.timeStep();
    const double now = std::min(c.time(), timing_.to) - timing_.from;
    if (!(now > last_)) return;
    const std::vector<std::array<Vec3, 2>> poses = posesBetween(last_, now);
    if (poses.size() < 2) {
      // The blade has not moved since its last cut (it pauses): nothing swept, the incisions it
      // is in kept as they are.
      if (final) finished_ = true;
      return;
    }
    if (!query_)
      query_ = std::make_unique<forcefields::SurfaceQuery>(sim.topology(), sim.state().x());
    else
      query_->update(sim.state().x());
    const auto curves = query_->sweptSegmentCurves(poses);
    const double last = double(poses.size() - 1);

    // Each curve in rest coordinates, going on from the tip of the incision it continues.
    struct Piece {
      std::vector<Vec3> rest;
      bool endsInside = false;  // on the blade's current position: it goes on next time
      // Its end is where the blade left the surface, not a border: on its current position, or
      // on the path of its tip (it rose out of the tissue, or the tissue fell away from it) or of
      // the end of its edge. The incision's tip is kept: a curve that starts near it later (the
      // blade back in) goes on from it.
      bool keepsTip = false;
    };
    std::vector<Piece> pieces;
    std::vector<char> claimed(tips_.size(), 0);
    const topology::Topology& topo = sim.topology();
    for (const auto& curve : curves) {
      Piece piece;
      piece.endsInside = curve.back().s >= last - 1e-6;
      piece.keepsTip = piece.endsInside || onBladePath(curve.back());
      std::vector<Vec3> rest;
      for (const forcefields::SweptCrossing& x : curve)
        rest.push_back(topo.restPositionOn(x.triangle, x.weights));
      // A curve starting on the blade's previous position continues the incision whose tip is
      // nearest its start (the surface moved under the blade since: the point is near the tip,
      // behind it or ahead): from the tip, on from the curve's point nearest it.
      // Each tip goes on in one curve at most (two curves near one tip: the nearer one takes it).
      std::size_t from = 0;
      std::size_t tipIndex = tips_.size();  // the tip it goes on from (none: tips_.size())
      if ((curve.front().s <= 1e-9 || onBladePath(curve.front())) && !tips_.empty()) {
        const Vec3* tip = nullptr;
        double best = minPiece_ * minPiece_;
        for (std::size_t k = 0; k < tips_.size(); ++k)
          if (!claimed[k] && dist2(tips_[k], rest.front()) < best) {
            best = dist2(tips_[k], rest.front());
            tip = &tips_[k];
          }
        if (tip) {
          tipIndex = std::size_t(tip - tips_.data());
          claimed[tipIndex] = 1;
          best = dist2(*tip, rest.front());
          for (std::size_t k = 1; k < rest.size(); ++k)
            if (dist2(*tip, rest[k]) < best) {
              best = dist2(*tip, rest[k]);
              from = k;
            }
          piece.rest.push_back(*tip);
          ++from;
        }
      }
      for (std::size_t k = from; k < rest.size(); ++k)
        if (piece.rest.empty() || dist2(piece.rest.back(), rest[k]) > 1e-18 * minPiece_ * minPiece_)
          piece.rest.push_back(rest[k]);
      piece.rest = thinned(straightened(piece.rest, 1e-9 * minPiece_), 0.2 * minPiece_);
      // (a piece not cut leaves the tip it would have gone on from as it is)
      const auto unclaim = [&] {
        if (tipIndex < tips_.size()) claimed[tipIndex] = 0;
      };
      if (piece.rest.size() < 2) {
        if (!final && piece.endsInside) return;  // the blade has not moved on from the tip yet
        unclaim();
        continue;
      }
      double length = 0.0;
      for (std::size_t k = 1; k < piece.rest.size(); ++k)
        length += std::sqrt(dist2(piece.rest[k - 1], piece.rest[k]));
      // A piece shorter than half a mean edge inside the surface waits until it is longer: cut
      // piece by piece at every step, the incision would leave slivers a fraction of an edge long.
      if (!final && piece.endsInside && length < minPiece_) return;
      // A piece the blade has left (its tip came out, or it reached the border) that is shorter
      // than a tenth of a mean edge is below what the mesh can show: not cut.
      if (length < 0.2 * minPiece_) {
        unclaim();
        continue;
      }
      pieces.push_back(std::move(piece));
    }

    std::vector<Vec3> tips;
    bool cutSome = false;
    for (const Piece& piece : pieces) {
      topology::IncisionResult result;
      try {
        result = sim.topology().cutPolyline(piece.rest, options(sim));
      } catch (const TopologyError& e) {
        // A piece the topology refuses has changed nothing: it is tried again, longer, at the
        // next step, unless the blade is done or another layer's piece was cut already.
        if (!final && !cutSome) return;
        c.failTopology(std::string("the scalpel's cut failed: ") + e.what());
      }
      cutSome = true;
      if (incisionOpened(result)) c.countCut();
      if (piece.keepsTip && !result.path.empty())
        tips.push_back(sim.topology().restPosition(result.path.back()));
    }
    // The tips no curve went on from stay (the blade may come back into the tissue there).
    for (std::size_t k = 0; k < tips_.size(); ++k)
      if (!claimed[k]) tips.push_back(tips_[k]);
    tips_ = std::move(tips);
    last_ = now;
    if (final) finished_ = true;
  }

 private:
  topology::CutOptions options(const Simulation& sim) const {
    topology::CutOptions o;
    o.snapTolerance = p_.snapTolerance;
    o.repair = repairOptions(sim, p_.minAngle);
    return o;
  }

  /// The blade at time t from the action's start: its tip and the end of its cutting edge.
  std::array<Vec3, 2> pose(double t) const {
    const auto [tip, axis] = p_.path.at(t);
    return {tip, lerp(tip, {tip[0] + axis[0], tip[1] + axis[1], tip[2] + axis[2]}, p_.depth)};
  }

  /// The blade's positions from time t0 to t1: both, every keyframe between, and enough between
  /// those that the axis turns by at most a few degrees from one to the next; a position the same
  /// as the one before is dropped (a blade that holds still sweeps nothing).
  std::vector<std::array<Vec3, 2>> posesBetween(double t0, double t1) const {
    const std::vector<double> times =
        p_.path.samples(t0, t1, kSampleTurn, std::numeric_limits<double>::infinity());
    std::vector<std::array<Vec3, 2>> out{pose(t0)};
    const double same = 1e-24 * p_.depth * p_.depth;
    for (std::size_t i = 1; i < times.size(); ++i) {
      const auto next = pose(times[i]);
      if (dist2(next[0], out.back()[0]) > same || dist2(next[1], out.back()[1]) > same)
        out.push_back(next);
    }
    return out;
  }

  ScalpelParameters p_;
  ActionTiming timing_;
  bool started_ = false, finished_ = false;
  double last_ = 0.0;  // time (from the action's start) of the blade's position at the last cut
  double minPiece_ = 0.0;
  std::vector<Vec3> tips_;  // rest positions of the tips of the incisions the blade is in
  std::unique_ptr<forcefields::SurfaceQuery> query_;
};

ScalpelParameters readScalpel(const ParameterSource& s) {
  ScalpelParameters p;
  if (!s.has("from") || !s.has("to"))
    s.fail(s.has("from") ? "to" : "from",
           "a scalpel moves over an interval: give \"from\" and \"to\" (not \"at\")");
  p.path = ToolPath::read(s, true, "the blade");
  s.require("depth");
  p.depth = s.number("depth");
  if (!(p.depth > 0) || !std::isfinite(p.depth))
    s.fail("depth", "the blade's length must be a positive finite number");
  if (s.has("snapTolerance")) {
    p.snapTolerance = s.nonNegative("snapTolerance", p.snapTolerance);
    if (!(p.snapTolerance < 0.5)) s.fail("snapTolerance", "must be < 0.5");
  }
  p.minAngle = readMinAngle(s);
  return p;
}

const bool registered = ActionRegistry::instance().add(
    {"scalpel",
     "a blade moving in world coordinates along a path of keyframes over an interval (\"from\", "
     "\"to\"): after each step it cuts the surface where the surface now is, every layer it "
     "passes through",
     {{"from", KeyType::Number, "when the blade starts moving (and cutting)", {}, true},
      {"to", KeyType::Number, "when it stops cutting", {}, true},
      {"path",
       KeyType::Rows,
       "[[t, x, y, z, ax, ay, az], ...]: times from \"from\", strictly increasing; the blade's "
       "tip (x, y, z) in world coordinates and its axis (ax, ay, az), from the tip along the "
       "blade; linear between keyframes, held before the first and after the last",
       {},
       true},
      {"depth",
       KeyType::Number,
       "the blade's cutting length from its tip (m): what lies within it along the axis is cut",
       {},
       true},
      {"snapTolerance", KeyType::Number,
       "how far (relative to the local edge length) the incision's ends snap onto a vertex or "
       "the border, in [0, 0.5) (default 0.1)"},
      {"minAngle", KeyType::Number,
       "smallest-angle target (degrees) of the quality repair around the incision, in [0, 60) "
       "(default 20; 0 turns the repair off)"}},
     {},
     [](const ParameterSource& s) -> std::any { return readScalpel(s); },
     [](const std::any& p, const ActionTiming& timing) -> std::unique_ptr<TimelineAction> {
       return std::make_unique<ScalpelAction>(std::any_cast<const ScalpelParameters&>(p), timing);
     }});

}  // namespace
}  // namespace cutsim::core
