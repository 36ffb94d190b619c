// The "fracture" action: cracks that run through the material from their tips.
//
// A crack tip is the interior end of a slit (a border point whose triangles span a full turn in
// rest coordinates: the tip of a notch, of a cut, of an earlier crack). After each step, at each
// tip, the Green strain tensor of the triangles whose rest centroid lies within `length` of the
// tip is averaged (weighted by rest area, in the tip's tangent plane). The stress at a crack tip
// grows without bound as the mesh is refined, but its average over a disc of a stated physical
// radius converges: so the criterion, "the largest principal value of the averaged strain exceeds
// criticalStrain", gives the same load at initiation on any mesh fine enough to resolve `length`.
// (The average is of the strain, which every field has, StretchSprings included; for an isotropic
// linear membrane the stress is a fixed linear function of it.)
//
// When the criterion holds, the crack advances from the tip, perpendicular to the principal
// direction, in pieces cut by Topology::cutPolyline (through triangles, not along edges, with the
// quality repair), at most `speed` x dt of length per step (the budget carries over), so the
// torn length per unit time does not depend on the time step. A piece is half a mean rest edge long
// (at least), so the path is resolved per cell. A piece that would leave the surface (the crack
// reaches the border, a hole or another cut) is cut to where its line meets the border, when that
// is within the piece: the crack ends there. Tips are looked for again whenever the mesh changed
// other than by this action (a later notch, a removal that took a tip away). `length` must be at
// least 1.5 mean rest edges.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <unordered_set>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/core/timeline.hpp"
#include "cutsim/topology/geometry.hpp"
#include "timeline/tearing.hpp"

namespace cutsim::core {
namespace {

using topology::Index;
using topology::PointId;
using topology::TriangleId;

Vec3 sub(const Vec3& a, const Vec3& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
Vec3 add(const Vec3& a, const Vec3& b) {
  return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
Vec3 scale(const Vec3& a, double s) {
  return {a[0] * s, a[1] * s, a[2] * s};
}
double dot(const Vec3& a, const Vec3& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec3 unit(const Vec3& a) {
  const double l = std::sqrt(dot(a, a));
  return l > 0 ? scale(a, 1.0 / l) : Vec3{0, 0, 0};
}

/// The sum of the angles at p of its triangles, in rest coordinates.
double fanAngle(const topology::Topology& t, PointId p) {
  double sum = 0;
  for (TriangleId f : t.trianglesAroundPoint(p)) {
    auto v = t.triangleVertices(f);
    for (int k = 0; k < 3; ++k)
      if (v[std::size_t(k)] == p) {
        const Vec3 a = sub(t.restPosition(v[std::size_t((k + 1) % 3)]), t.restPosition(p));
        const Vec3 b = sub(t.restPosition(v[std::size_t((k + 2) % 3)]), t.restPosition(p));
        sum += std::atan2(std::sqrt(dot(cross(a, b), cross(a, b))), dot(a, b));
      }
  }
  return sum;
}

struct Tip {
  PointId point;
  Vec3 direction;     ///< the way the crack runs (rest coordinates)
  double budget = 0;  ///< length the crack may still advance (speed x time, while loaded)
};

/// The averaged strain at a tip: its largest principal value and the in-plane direction across
/// which the crack runs (perpendicular to the principal direction).
struct TipLoad {
  double strain = 0;
  Vec3 crackDirection{0, 0, 0};
};

class FractureAction final : public TimelineAction {
 public:
  explicit FractureAction(FractureParameters p) : p_(p) {}

  void dryRun(DryRunContext&) const override {}
  bool rehearsed() const override { return false; }  // at rest nothing tears

  void start(ActionContext& c) override {
    const double edge = c.meanRestEdge();
    if (p_.length < 1.5 * edge)
      c.fail("fracture: length " + describeNumber(p_.length) +
             " is shorter than 1.5 mean rest edges (" + describeNumber(1.5 * edge) +
             "): the mesh cannot resolve the disc the strain is averaged over");
    piece_ = std::max(0.5 * edge, 1e-12);
    on_ = true;
    detectTips(c.simulation().topology());
  }

  /// Every slit tip of the mesh (a border point whose triangles span a full turn), keeping the
  /// budget of tips already known. Run when the topology changed other than by this action (a
  /// later notch, a removal that took a tip away).
  void detectTips(const topology::Topology& t) {
    std::vector<Tip> found;
    for (PointId p : t.points()) {
      if (!t.isBoundaryPoint(p) || fanAngle(t, p) < 1.9 * std::numbers::pi) continue;
      // The slit behind the tip: the crack continues away from the tip's border neighbours.
      Vec3 behind{0, 0, 0};
      int n = 0;
      for (auto e : t.edgesAroundPoint(p))
        if (t.isBoundaryEdge(e)) {
          auto v = t.edgeVertices(e);
          behind = add(behind, t.restPosition(v[0] == p ? v[1] : v[0]));
          ++n;
        }
      if (n == 0) continue;
      Tip tip{p, unit(sub(t.restPosition(p), scale(behind, 1.0 / n)))};
      for (const Tip& old : tips_)
        if (old.point == p) tip = old;
      found.push_back(tip);
    }
    tips_ = std::move(found);
    revision_ = t.revision();
  }

  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override {
    fields(out, on_, piece_, revision_);
    out.u64(tips_.size());
    for (const Tip& t : tips_) {
      out.u64(t.point.idx());
      out.raw(t.direction.data(), sizeof(double) * 3);
      out.f64(t.budget);
    }
  }
  void loadState(ArchiveReader& in, const Simulation& sim) override {
    fields(in, on_, piece_, revision_);
    const std::uint64_t n = in.u64();
    if (n > in.remaining()) in.fail("fracture: a count of " + std::to_string(n) + " crack tips");
    tips_.assign(n, Tip{});
    for (Tip& t : tips_) {
      const std::uint64_t p = in.u64();
      if (p >= sim.topology().pointCapacity() ||
          !sim.topology().isPointAlive(PointId(topology::Index(p))))
        in.fail("fracture: a crack tip at point " + std::to_string(p) +
                ", which the mesh does not have");
      t.point = PointId(topology::Index(p));
      in.raw(t.direction.data(), sizeof(double) * 3);
      t.budget = in.f64();
    }
  }

  void afterStep(ActionContext& c) override {
    if (!on_) return;
    const topology::Topology& topo = c.simulation().topology();
    if (topo.revision() != revision_) detectTips(topo);
    std::vector<Tip> next;
    for (Tip tip : tips_) {
      // The crack speed bounds the length torn per unit time: the budget grows by speed x dt
      // and is spent in pieces while the tip is loaded; an
      // unloaded tip keeps at most one piece of it (no run ahead after a long wait).
      tip.budget += p_.speed * c.timeStep();
      bool alive = true, loaded = true;
      while (alive && tip.budget >= piece_) {
        const TipLoad load = loadAt(c, tip);
        if (!(load.strain > p_.criticalStrain)) {
          loaded = false;
          break;
        }
        alive = advance(c, tip, load);
        tip.budget -= piece_;
      }
      if (!loaded) tip.budget = std::min(tip.budget, piece_);
      if (alive) next.push_back(tip);
    }
    tips_ = std::move(next);
    revision_ = topo.revision();
  }

 private:
  TipLoad loadAt(ActionContext& c, const Tip& tip) const {
    Simulation& sim = c.simulation();
    const topology::Topology& t = sim.topology();
    const std::span<const double> x = sim.state().x();
    const Vec3 X = t.restPosition(tip.point);
    // Triangles within `length` of the tip: a walk outwards from the tip's triangles (the cost
    // is that of the disc, not of the mesh).
    std::vector<TriangleId> todo = t.trianglesAroundPoint(tip.point), disc;
    std::unordered_set<Index> seen;
    for (TriangleId f : todo) seen.insert(f.idx());
    double m[3][3] = {}, area = 0;
    Vec3 normal{0, 0, 0};
    while (!todo.empty()) {
      const TriangleId f = todo.back();
      todo.pop_back();
      auto v = t.triangleVertices(f);
      const Vec3 a = t.restPosition(v[0]), b = t.restPosition(v[1]), d = t.restPosition(v[2]);
      const Vec3 centroid = scale(add(add(a, b), d), 1.0 / 3);
      const bool aroundTip = v[0] == tip.point || v[1] == tip.point || v[2] == tip.point;
      if (dot(sub(centroid, X), sub(centroid, X)) > p_.length * p_.length && !aroundTip) continue;
      disc.push_back(f);
      const Vec3 n = cross(sub(b, a), sub(d, a));
      const double A = 0.5 * std::sqrt(dot(n, n));
      if (!(A > 0)) continue;
      normal = add(normal, n);
      // The triangle's strain in its rest frame (e1 along a->b), lifted to 3D.
      const auto E = triangleGreenStrain(t, x, f);
      const Vec3 e1 = unit(sub(b, a)), e2 = unit(cross(unit(n), e1));
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          m[i][j] += A * (E[0] * e1[std::size_t(i)] * e1[std::size_t(j)] +
                          E[1] * (e1[std::size_t(i)] * e2[std::size_t(j)] +
                                  e2[std::size_t(i)] * e1[std::size_t(j)]) +
                          E[2] * e2[std::size_t(i)] * e2[std::size_t(j)]);
      area += A;
      for (PointId p : v)
        for (TriangleId g : t.trianglesAroundPoint(p))
          if (seen.insert(g.idx()).second) todo.push_back(g);
    }
    TipLoad load;
    if (!(area > 0)) return load;
    // In the tip's tangent plane: a frame (u, w) with u along the crack's current direction.
    const Vec3 nn = unit(normal);
    Vec3 u = unit(sub(tip.direction, scale(nn, dot(tip.direction, nn))));
    if (dot(u, u) == 0) return load;
    const Vec3 w = cross(nn, u);
    auto q = [&](const Vec3& a, const Vec3& b) {
      double s = 0;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) s += a[std::size_t(i)] * m[i][j] * b[std::size_t(j)];
      return s / area;
    };
    const double euu = q(u, u), euw = q(u, w), eww = q(w, w);
    const double mean = 0.5 * (euu + eww), dev = 0.5 * (euu - eww);
    load.strain = mean + std::sqrt(dev * dev + euw * euw);
    // Principal direction angle theta (from u); the crack runs perpendicular to it, forwards.
    const double theta = 0.5 * std::atan2(2 * euw, euu - eww);
    Vec3 dir = add(scale(u, -std::sin(theta)), scale(w, std::cos(theta)));
    if (dot(dir, u) < 0) dir = scale(dir, -1.0);
    load.crackDirection = dir;
    return load;
  }

  /// Cuts one piece from the tip; false when the crack ended (it reached a border).
  bool advance(ActionContext& c, Tip& tip, const TipLoad& load) {
    topology::Topology& t = c.simulation().topology();
    const Vec3 from = t.restPosition(tip.point);
    const Vec3 to = add(from, scale(load.crackDirection, piece_));
    topology::CutOptions options;
    options.repair = repairOptions(c.simulation(), p_.minAngle);
    try {
      topology::IncisionResult r = t.cutPolyline(std::vector<Vec3>{from, to}, options);
      c.countCut();
      if (r.path.empty() || t.isPointAlive(r.path.back()) == false) return false;
      const PointId end = r.path.back();
      // An end on the border (snapped there) parted the material: the crack is done.
      if (fanAngle(t, end) < 1.9 * std::numbers::pi) return false;
      tip.point = end;
      tip.direction = load.crackDirection;
      return true;
    } catch (const TopologyError&) {  // it leaves the surface: below
    }
    // The piece leaves the surface: cut to where its line first meets the border, if that is
    // within the piece (else the tip waits: the next step's strain decides again).
    const std::optional<Vec3> hit = borderHit(t, tip.point, from, load.crackDirection);
    if (!hit || std::sqrt(dot(sub(*hit, from), sub(*hit, from))) > 1.5 * piece_) return true;
    // Exactly on the border, else a little short of it (the end then snaps onto the border).
    for (double back : {0.0, 0.02, 0.05}) {
      const Vec3 end = sub(*hit, scale(load.crackDirection, back * piece_));
      try {
        t.cutPolyline(std::vector<Vec3>{from, end}, options);
        c.countCut();
        return false;
      } catch (const TopologyError&) {  // (a cut ending exactly on the border can fail)
      }
    }
    return false;
  }

  /// The first point where the ray from `from` along `dir` meets a border edge not at the tip.
  static std::optional<Vec3> borderHit(const topology::Topology& t, PointId tipPoint,
                                       const Vec3& from, const Vec3& dir) {
    double best = std::numeric_limits<double>::infinity();
    std::optional<Vec3> out;
    for (auto e : t.edges()) {
      if (!t.isBoundaryEdge(e)) continue;
      auto v = t.edgeVertices(e);
      if (v[0] == tipPoint || v[1] == tipPoint) continue;
      const Vec3 a = t.restPosition(v[0]), b = t.restPosition(v[1]);
      // Solve from + s dir = a + r (b - a) in the plane spanned by dir and b - a (least squares).
      const Vec3 ab = sub(b, a), fa = sub(a, from);
      const double d00 = dot(dir, dir), d01 = -dot(dir, ab), d11 = dot(ab, ab);
      const double r0 = dot(dir, fa), r1 = -dot(ab, fa);
      const double den = d00 * d11 - d01 * d01;
      if (!(std::abs(den) > 1e-14 * d00 * d11)) continue;
      const double s = (r0 * d11 - d01 * r1) / den, r = (d00 * r1 - d01 * r0) / den;
      if (s <= 0 || r < 0 || r > 1) continue;
      const Vec3 p = add(from, scale(dir, s)), q2 = add(a, scale(ab, r));
      if (dot(sub(p, q2), sub(p, q2)) > 1e-12 * d11) continue;
      if (s < best) {
        best = s;
        out = q2;
      }
    }
    return out;
  }

  FractureParameters p_;
  bool on_ = false;
  std::vector<Tip> tips_;
  double piece_ = 0;
  std::uint64_t revision_ = 0;  // the topology's revision when the tips were last known
};

const bool registered = ActionRegistry::instance().add(
    {"fracture",
     "from its time on, cracks run from the tips of slits (notches, cuts) through the triangles, "
     "perpendicular to the largest principal strain averaged over a disc of radius \"length\" "
     "around "
     "each tip, while that strain exceeds \"criticalStrain\", at most \"speed\" m/s (slit tips are "
     "looked for again whenever the mesh changes)",
     {{"at", KeyType::Number, "time fracture starts"},
      {"criticalStrain",
       KeyType::Number,
       "Green strain, averaged over the disc, above which a crack advances, > 0 "
       "(required)",
       {},
       true},
      {"length",
       KeyType::Number,
       "radius of the disc around a tip the strain is averaged over (m), > 0 (required): "
       "a material length, which the mesh must resolve",
       {},
       true},
      {"speed",
       KeyType::Number,
       "largest crack speed (m/s), > 0 (required): the torn length per unit time, whatever "
       "the time step",
       {},
       true},
      {"minAngle", KeyType::Number,
       "smallest-angle target (degrees) of the quality repair along the crack, in "
       "[0, 60) (default 20)"}},
     {},
     [](const ParameterSource& s) -> std::any {
       FractureParameters p;
       s.require("criticalStrain");
       s.require("length");
       s.require("speed");
       p.criticalStrain = s.positive("criticalStrain", 0.0);
       p.length = s.positive("length", 0.0);
       p.speed = s.positive("speed", 0.0);
       p.minAngle = readMinAngle(s);
       return p;
     },
     [](const std::any& p, const ActionTiming&) -> std::unique_ptr<TimelineAction> {
       return std::make_unique<FractureAction>(std::any_cast<const FractureParameters&>(p));
     }});

}  // namespace
}  // namespace cutsim::core
