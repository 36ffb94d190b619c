// The "suture" action: stitches placed where a needle, given as a path in the world, pierces the
// surface. Each needle path (a polyline) must pierce it at least twice: the first two places it
// does (going in through one lip, coming out through the other) become points of the mesh,
// exactly at those material points, and a thread of the scene's Sutures force field ties them,
// tightened from its length then to `length` over `tighten` seconds. A running suture gives
// several needle paths: a stitch each. docs/instruments.md.
#include <algorithm>
#include <cmath>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/core/timeline.hpp"
#include "cutsim/forcefields/surface_query.hpp"
#include "cutsim/forcefields/sutures.hpp"
#include "cutsim/topology/geometry.hpp"

namespace cutsim::core {
namespace {

using topology::geometry::dist2;

struct SutureParameters {
  std::vector<std::vector<Vec3>> needles;  ///< world coordinates, a stitch each
  double length = 0.0;                     ///< the threads' length once tightened (m)
  double tighten = 0.0;                    ///< over how long (s; 0: at once)
  std::string field;                       ///< the Sutures field's label ("": the only one)
  double minAngle = kDefaultMinAngle;
};

class SutureAction final : public TimelineAction {
 public:
  explicit SutureAction(SutureParameters p) : p_(std::move(p)) {}

  void dryRun(DryRunContext& c) const override {
    const auto* fields = c.forceFields();
    if (!fields) return;
    std::size_t found = 0;
    for (const auto& [type, label] : *fields)
      found += type == "Sutures" && (p_.field.empty() || label == p_.field) ? 1 : 0;
    if (found == 0)
      c.fail(p_.field.empty() ? "" : "field",
             p_.field.empty()
                 ? "stitches need a Sutures force field (their threads): the scene has none"
                 : "no Sutures force field is labelled \"" + p_.field + "\"");
    if (found > 1)
      c.fail("", "the scene has several Sutures force fields: say which with \"field\"");
  }
  bool rehearsed() const override { return false; }

  void start(ActionContext& c) override {
    Simulation& sim = c.simulation();
    forcefields::Sutures& threads = field(c);
    topology::Topology& topo = sim.topology();
    // Where each needle pierces the surface now (world), the first two places along it.
    std::vector<std::array<Vec3, 2>> pierced;
    {
      forcefields::SurfaceQuery query(topo, sim.state().x());
      const double same = 1e-18 * c.meanRestEdge() * c.meanRestEdge();
      for (std::size_t i = 0; i < p_.needles.size(); ++i) {
        const auto& needle = p_.needles[i];
        std::vector<Vec3> hits;
        for (std::size_t k = 0; k + 1 < needle.size() && hits.size() < 2; ++k)
          for (const forcefields::SurfaceHit& h : query.segmentHits(needle[k], needle[k + 1]))
            if (hits.size() < 2 && (hits.empty() || dist2(hits.back(), h.point) > same))
              hits.push_back(h.point);
        if (hits.size() < 2) {
          std::string where = p_.needles.size() > 1 ? " (stitch " + std::to_string(i) + ")" : "";
          c.fail(hits.empty()
                     ? "the needle" + where +
                           " misses the surface: its path meets no triangle where the surface is "
                           "now (world coordinates)"
                     : "the needle" + where + " pierces the surface once only, at (" +
                           describeNumber(hits[0][0]) + ", " + describeNumber(hits[0][1]) + ", " +
                           describeNumber(hits[0][2]) +
                           "): a stitch goes through both lips (pass the needle on through the "
                           "other)");
        }
        pierced.push_back({hits[0], hits[1]});
      }
    }
    // The pierced material points as points of the mesh, one at a time (each insertion changes
    // the triangles around it: the next is found again where it is, which no insertion moves).
    std::vector<std::array<PointId, 2>> ends;
    std::vector<PointId> made;
    try {
      for (const auto& pair : pierced) {
        std::array<PointId, 2> e{};
        for (int k = 0; k < 2; ++k) {
          forcefields::SurfaceQuery query(topo, sim.state().x());
          const auto at = query.closestPoint(pair[k]);
          if (!at) c.fail("the surface is gone where the needle pierced it");
          e[k] = pointAt(topo, at->triangle, at->weights);
          made.push_back(e[k]);
        }
        if (e[0] == e[1])
          c.fail(
              "the needle pierces the surface twice at one point of the mesh: a stitch ties "
              "two");
        ends.push_back(e);
      }
      if (p_.minAngle > 0) {
        topology::RepairOptions repair = repairOptions(sim, p_.minAngle);
        repair.locked.insert(repair.locked.end(), made.begin(), made.end());
        topo.repair(made, repair);
      }
    } catch (const TopologyError& e) {
      c.failTopology(std::string("the suture cannot pierce the surface: ") + e.what());
    }
    const auto x = sim.state().x();
    const auto position = [&x](PointId p) {
      return Vec3{x[3 * p.idx()], x[3 * p.idx() + 1], x[3 * p.idx() + 2]};
    };
    start_ = c.time();
    for (const auto& e : ends) {
      const double l0 = std::sqrt(dist2(position(e[0]), position(e[1])));
      stitches_.push_back(threads.addStitch(e[0], e[1], l0));
      initial_.push_back(l0);
    }
    tighten(threads, c.time());
  }

  void afterStep(ActionContext& c) override {
    if (stitches_.empty() || done_) return;
    tighten(field(c), c.time());
  }

  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override {
    fields(out, stitches_, initial_, start_, done_);
  }
  void loadState(ArchiveReader& in, const Simulation&) override {
    fields(in, stitches_, initial_, start_, done_);
    if (stitches_.size() != initial_.size()) in.fail("a suture's stitches and lengths differ");
  }

 private:
  forcefields::Sutures& field(ActionContext& c) const {
    Model& model = c.simulation().model();
    forcefields::Sutures* found = nullptr;
    for (std::size_t i = 0; i < model.numForceFields(); ++i) {
      auto* s = dynamic_cast<forcefields::Sutures*>(&model.forceField(i));
      if (s && (p_.field.empty() || model.forceFieldLabel(i) == p_.field)) found = s;
    }
    if (!found)
      c.fail(p_.field.empty() ? "stitches need a Sutures force field: the run has none"
                              : "no Sutures force field is labelled \"" + p_.field + "\"");
    return *found;
  }

  /// Each thread's length at time t: from its length when placed to the target, linearly.
  void tighten(forcefields::Sutures& threads, double t) {
    const double f = p_.tighten > 0 ? std::clamp((t - start_) / p_.tighten, 0.0, 1.0) : 1.0;
    for (std::size_t i = 0; i < stitches_.size(); ++i)
      if (stitches_[i] < threads.stitches().size() && threads.stitches()[stitches_[i]].alive)
        threads.setLength(stitches_[i], initial_[i] + f * (p_.length - initial_[i]));
    done_ = f >= 1.0;
  }

  SutureParameters p_;
  std::vector<std::size_t> stitches_;  // in the Sutures field
  std::vector<double> initial_;        // their lengths when placed
  double start_ = 0.0;
  bool done_ = false;
};

SutureParameters readSuture(const ParameterSource& s) {
  SutureParameters p;
  const std::string_view key = s.oneOf({"needle", "stitches"});
  if (key == "needle") {
    p.needles.push_back(s.points("needle", 2));
  } else {
    // Each stitch from its entry a to its exit b: the needle goes in `bite` above a down to
    // `bite` below it, across, and up through b (along `up`).
    const auto rows = s.rows("stitches", 6, 1);
    const Vec3 up = s.has("up") ? s.vec3("up") : Vec3{0, 0, 1};
    const double n = std::sqrt(up[0] * up[0] + up[1] * up[1] + up[2] * up[2]);
    if (!(n > 0) || !std::isfinite(n)) s.fail("up", "must be a finite direction, not zero");
    s.require("bite");
    const double h = s.number("bite");
    if (!(h > 0)) s.fail("bite", "must be a positive depth (m)");
    const auto off = [&](const Vec3& q, double sign) {
      return Vec3{q[0] + sign * h * up[0] / n, q[1] + sign * h * up[1] / n,
                  q[2] + sign * h * up[2] / n};
    };
    for (const auto& r : rows) {
      const Vec3 a{r[0], r[1], r[2]}, b{r[3], r[4], r[5]};
      p.needles.push_back({off(a, 1), off(a, -1), off(b, -1), off(b, 1)});
    }
  }
  if (key == "needle")
    for (const char* k : {"bite", "up"})
      if (s.has(k)) s.fail(k, "is for a running suture (\"stitches\")");
  for (std::size_t i = 0; i < p.needles.size(); ++i)
    for (std::size_t k = 0; k < p.needles[i].size(); ++k)
      for (double v : p.needles[i][k])
        if (!std::isfinite(v))
          s.fail(key == "needle" ? "needle/" + std::to_string(k) : "stitches/" + std::to_string(i),
                 "must be finite numbers");
  if (s.has("length")) {
    p.length = s.number("length");
    if (!(p.length >= 0)) s.fail("length", "must be >= 0 (m)");
  }
  p.tighten = s.nonNegative("tighten", 0.0);
  if (s.has("field")) p.field = s.string("field");
  p.minAngle = readMinAngle(s);
  return p;
}

const bool registered = ActionRegistry::instance().add(
    {"suture",
     "stitches where a needle, a path in world coordinates, pierces the surface: the first two "
     "places it does become points of the mesh, tied by a thread of the scene's Sutures force "
     "field, tightened to a length over a time",
     {{"at", KeyType::Number, "time the stitches are placed"},
      {"needle", KeyType::Points,
       "[[x, y, z], ...]: the needle's path in world coordinates, in through one lip and out "
       "through the other (a stitch)"},
      {"stitches", KeyType::Rows,
       "[[xa, ya, za, xb, yb, zb], ...]: a running suture, a stitch each from its entry a to its "
       "exit b (world coordinates): the needle goes in `bite` above a, down to `bite` below it, "
       "across below b and up through it, along `up`"},
      {"bite", KeyType::Number,
       "with \"stitches\": how far above and below the surface the "
       "needle passes (m, > 0), required"},
      {"up", KeyType::Point,
       "with \"stitches\": the direction out of the surface (default "
       "[0, 0, 1])"},
      {"length", KeyType::Number, "of each thread once tightened (m, >= 0; default 0)"},
      {"tighten", KeyType::Number,
       "over how long (s, >= 0) the threads are shortened from their length when placed to "
       "\"length\" (default 0: at once)"},
      {"field", KeyType::String,
       "the label of the Sutures force field (default: the scene's only one)"},
      {"minAngle", KeyType::Number,
       "smallest-angle target (degrees) of the quality repair around the pierced points, in "
       "[0, 60) (default 20; 0 turns it off)"}},
     {},
     [](const ParameterSource& s) -> std::any { return readSuture(s); },
     [](const std::any& p, const ActionTiming&) -> std::unique_ptr<TimelineAction> {
       return std::make_unique<SutureAction>(std::any_cast<const SutureParameters&>(p));
     }});

}  // namespace
}  // namespace cutsim::core
