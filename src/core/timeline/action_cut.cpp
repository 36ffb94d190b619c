// The "cut" action: a cut along a polyline at a time, or a progressive cut over an interval (a
// scalpel moving at constant speed along the polyline: after each step the piece covered since the
// last one is cut, starting where the previous piece's cut really ended).
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/core/timeline.hpp"
#include "cutsim/topology/geometry.hpp"
#include "cutsim/topology/triangle_grid.hpp"

namespace cutsim::core {
namespace {

using topology::geometry::closestOnTriangle;
using topology::geometry::dist2;

std::string vecText(const Vec3& p) {
  return "(" + describeNumber(p[0]) + ", " + describeNumber(p[1]) + ", " + describeNumber(p[2]) +
         ")";
}

class CutAction final : public TimelineAction {
 public:
  CutAction(CutParameters p, const ActionTiming& timing) : p_(std::move(p)), timing_(timing) {
    arc_.push_back(0.0);
    for (std::size_t i = 1; i < p_.polyline.size(); ++i)
      arc_.push_back(arc_.back() + std::sqrt(dist2(p_.polyline[i - 1], p_.polyline[i])));
  }

  void dryRun(DryRunContext& c) const override {
    const topology::TriangleGrid grid(c.restMesh());
    for (std::size_t i = 0; i < p_.polyline.size(); ++i) {
      const auto [d, edge] = grid.nearest(p_.polyline[i]);
      if (d > 0.25 * edge)
        c.fail("polyline/" + std::to_string(i),
               "the cut misses the surface: point " + vecText(p_.polyline[i]) + " is " +
                   describeNumber(d) + " away from the rest surface");
    }
    try {
      topology::CutOptions options;
      options.snapTolerance = p_.snapTolerance;
      options.repair.minAngle = p_.minAngle;
      const topology::IncisionResult r = c.topology().cutPolyline(p_.polyline, options);
      // Its path ran along edges that are already border: the lips of an earlier cut (its ends
      // snapped onto them) or the border itself. Said here rather than counted as nothing.
      if (!incisionOpened(r)) c.fail("polyline", opensNothing());
    } catch (const TopologyError& e) {
      c.fail("polyline", std::string("the cut cannot be made on the rest surface: ") + e.what());
    }
  }

  void start(ActionContext& c) override {
    if (!timing_.interval) {
      // (made on the mesh as it is now: one that opens nothing, for example given from Python
      // beside a cut made since the check, is refused the same way; nothing changed)
      if (!incisionOpened(cut(c, p_.polyline))) c.failTopology(opensNothing());
      return;
    }
    minPiece_ = 0.5 * c.meanRestEdge();
    started_ = true;
    afterStep(c);
  }

  bool checkpointable() const override { return true; }
  template <class Archive, class Self>
  static void members(Archive& a, Self& s) {
    fields(a, s.done_, s.started_, s.finished_, s.minPiece_);
  }
  void saveState(ArchiveWriter& out) const override {
    members(out, *this);
    out.boolean(tip_.has_value());
    if (tip_) out.raw(tip_->data(), sizeof(double) * 3);
  }
  void loadState(ArchiveReader& in, const Simulation&) override {
    members(in, *this);
    tip_.reset();
    if (in.boolean()) {
      Vec3 t;
      in.raw(t.data(), sizeof(double) * 3);
      tip_ = t;
    }
    if (!(done_ >= 0 && done_ <= arc_.back()) || !std::isfinite(minPiece_))
      in.fail("a progressive cut's progress of " + std::to_string(done_) + " along " +
              std::to_string(arc_.back()));
  }

  void afterStep(ActionContext& c) override {
    if (!started_ || finished_) return;
    const double total = arc_.back(), t = c.time();
    double s = total * std::clamp((t - timing_.from) / (timing_.to - timing_.from), 0.0, 1.0);
    if (t >= timing_.to - 1e-9 * c.timeStep()) s = total;
    // Never leave a remainder shorter than the smallest piece; never cut a piece shorter than it
    // (except a whole polyline that is shorter).
    if (s < total && total - s < minPiece_) s = total;
    if (s < total && s - done_ < minPiece_) return;
    // A piece that would end within a quarter of a mean edge of a corner of the polyline ends at
    // the corner: a tip just short of (or just past) a corner would leave, between the two, an
    // edge a fraction of the mesh size long that the repair may not remove (the corner stays, and
    // so does the tip while it is one), and such a tiny triangle sets the stable explicit time
    // step. Not the last piece, and no piece or remainder shorter than the smallest piece.
    for (std::size_t i = 1; s < total && i + 1 < arc_.size(); ++i)
      if (std::abs(arc_[i] - s) < 0.5 * minPiece_ && arc_[i] - done_ >= minPiece_ &&
          total - arc_[i] >= minPiece_) {
        s = arc_[i];
        break;
      }
    if (!(s > done_)) return;
    std::vector<Vec3> piece = pieceOf(done_, s);
    if (tip_) piece.front() = *tip_;
    topology::IncisionResult result;
    if (s < total) {
      // A piece that the topology refuses (for example one that ends exactly on an edge in a way
      // its walk does not handle) has changed nothing (a failed operation is rolled back) and is
      // tried again, longer, at the next step; only the last piece must succeed where the
      // scalpel is.
      try {
        result = c.simulation().topology().cutPolyline(piece, options(c));
        if (incisionOpened(result)) c.countCut();
      } catch (const TopologyError&) {
        return;
      }
    } else {
      result = cut(c, piece);
    }
    if (!result.path.empty()) tip_ = c.simulation().topology().restPosition(result.path.back());
    done_ = s;
    if (s >= total) finished_ = true;
  }

 private:
  std::string opensNothing() const {
    return "the cut opens nothing: its path runs along the border or along the lips of an "
           "earlier cut, onto which its points snapped (within snapTolerance, " +
           describeNumber(p_.snapTolerance) +
           " of the local edge length); a cut beside another must be farther from it than that";
  }
  topology::CutOptions options(ActionContext& c) const {
    topology::CutOptions o;
    o.snapTolerance = p_.snapTolerance;
    o.repair = repairOptions(c.simulation(), p_.minAngle);
    return o;
  }
  topology::IncisionResult cut(ActionContext& c, std::span<const Vec3> polyline) {
    try {
      topology::IncisionResult result = c.simulation().topology().cutPolyline(polyline, options(c));
      if (incisionOpened(result)) c.countCut();
      c.recordIncision(result);
      return result;
    } catch (const TopologyError& e) {
      c.failTopology(std::string("the cut failed: ") + e.what());
    }
    return {};  // not reached: failTopology() throws
  }
  Vec3 pointAt(double s) const {
    const auto& p = p_.polyline;
    std::size_t i = 1;
    while (i + 1 < arc_.size() && arc_[i] < s) ++i;
    const double len = arc_[i] - arc_[i - 1];
    const double t = len > 0 ? std::clamp((s - arc_[i - 1]) / len, 0.0, 1.0) : 1.0;
    return {p[i - 1][0] + t * (p[i][0] - p[i - 1][0]), p[i - 1][1] + t * (p[i][1] - p[i - 1][1]),
            p[i - 1][2] + t * (p[i][2] - p[i - 1][2])};
  }
  /// The polyline between arc lengths s0 < s1.
  std::vector<Vec3> pieceOf(double s0, double s1) const {
    std::vector<Vec3> out{pointAt(s0)};
    for (std::size_t i = 1; i + 1 < arc_.size(); ++i)
      if (arc_[i] > s0 && arc_[i] < s1) out.push_back(p_.polyline[i]);
    out.push_back(s1 >= arc_.back() ? p_.polyline.back() : pointAt(s1));
    return out;
  }

  CutParameters p_;
  ActionTiming timing_;
  std::vector<double> arc_;  // cumulative length at each polyline vertex
  double done_ = 0.0;        // arc length cut so far
  bool started_ = false, finished_ = false;
  double minPiece_ = 0.0;
  // Where the previous piece really ended (its last path vertex, which snapping may have put a
  // little off the polyline): the next piece starts there, so that it continues from the cut's tip.
  std::optional<Vec3> tip_;
};

const bool registered = ActionRegistry::instance().add(
    {"cut",
     "a cut along a polyline in rest coordinates, at a time (\"at\") or progressively over an "
     "interval "
     "(\"from\", \"to\": a scalpel at constant speed)",
     {{"at", KeyType::Number, "time of the cut"},
      {"from", KeyType::Number, "start of a progressive cut"},
      {"to", KeyType::Number, "end of a progressive cut"},
      {"polyline",
       KeyType::Points,
       "[[x, y, z], ...] in rest coordinates, at least 2 points",
       {},
       true},
      {"snapTolerance", KeyType::Number,
       "how far (relative to the local edge length) the cut's ends snap onto a vertex or "
       "the border, in [0, 0.5) (default 0.1); without the quality repair, crossings "
       "snap too"},
      {"minAngle", KeyType::Number,
       "smallest-angle target (degrees) of the quality repair around the cut, in [0, 60) "
       "(default 20; 0 turns the repair off)"}},
     {},
     [](const ParameterSource& s) -> std::any {
       CutParameters p;
       p.polyline = s.points("polyline", 2);
       if (s.has("snapTolerance")) {
         p.snapTolerance = s.nonNegative("snapTolerance", p.snapTolerance);
         if (!(p.snapTolerance < 0.5)) s.fail("snapTolerance", "must be < 0.5");
       }
       p.minAngle = readMinAngle(s);
       return p;
     },
     [](const std::any& p, const ActionTiming& timing) -> std::unique_ptr<TimelineAction> {
       return std::make_unique<CutAction>(std::any_cast<const CutParameters&>(p), timing);
     }});

}  // namespace
}  // namespace cutsim::core
