#pragma once
// Private to the contact wing: the state of a Contact (contact.hpp) and its operations, by
// concern (docs/contact.md, "The wing's files"):
//   tables.cpp        the surface's tables, margins and hierarchies, the obstacles' meshes
//   pair_eval.hpp     a pair's distance, normal and weights; the pairs evaluated at x, packed
//   search.hpp        the penalty's pair search (self, obstacle meshes, round obstacles, planes)
//   search_cache.cpp  the search's cache (a Verlet list) and the bound's search from it
//   bound.cpp         the displacement bound (additive CCD, swept boxes, the limit's passes)
//   exclusions.cpp    the pairs excluded after topology changes
//   contact.cpp       construction, the step's start
//   penalty.cpp       the force field: forces, products, energy, matrices, measures
//   proximity.cpp     the start checks (close pairs, intersections)
//   topology_events.cpp, checkpoint.cpp
// and beside them: pair.hpp (a pair, the law), geometry.hpp (closest points, distances),
// bvh.hpp (the hierarchy), threads.hpp, obstacle.cpp and shapes/ (one file per shape),
// surface_query.cpp (the deformed surface's public queries).
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <set>
#include <span>
#include <utility>
#include <vector>

#include "bvh.hpp"
#include "cutsim/forcefields/contact.hpp"
#include "cutsim/topology/topology.hpp"
#include "geometry.hpp"
#include "pair.hpp"
#include "threads.hpp"

namespace cutsim::forcefields {

using namespace contact;
using topology::Index;
using topology::kInvalidIndex;

struct Contact::Impl {
  topology::Topology& topo;
  const ContactParameters& P;
  std::vector<Obstacle>& O;
  topology::Subscription subscription;

  // ---- the surface's tables (rebuilt when the topology's revision changes) ----
  bool built = false, bvhBuilt = false;
  double meanEdge = 0.0;  // of the rest mesh (the largest displacement a step may propose)
  std::uint64_t revision = 0;
  std::vector<TriangleId> tris;
  std::vector<std::array<std::uint32_t, 3>> triV;
  std::vector<std::array<std::uint32_t, 3>> triE;     // edge i opposite vertex i
  std::vector<std::int32_t> pointOwner, edgeOwner;    // index into tris, -1: none
  std::vector<std::array<std::int32_t, 2>> edgeTris;  // the (at most two) triangles of an edge
  std::vector<std::int32_t> starStart, star;          // the triangles around a point (CSR)
  std::vector<V3> restX;                              // per point slot: its rest position
  /// Per edge slot, at the step's start: how flat the surface is across the edge at the
  /// thickness's scale (flatness()), and the points of the triangles beside it; a self pair of
  /// two edges gets 1 - the product of theirs.
  struct EdgeFlat {
    std::uint32_t stamp = 0;  // the generation it was measured in
    double flat = 0.0;
  };
  mutable std::vector<EdgeFlat> edgeFlat;
  std::vector<Box> boxes;
  Bvh bvh;

  // ---- obstacle meshes (and the analytic shapes' poses) ----
  struct MeshObstacle {
    std::vector<Vec3> vertices;                 // at offset 0
    std::vector<std::array<int, 3>> triangles;  // a box: its twelve faces
    std::vector<std::array<int, 2>> edges;
    std::vector<std::array<int, 3>> triEdges;
    std::vector<int> vertexOwner, edgeOwner;
    std::vector<std::vector<int>> edgeTris, vertexTris;  // (a soup may be non-manifold)
    std::vector<Box> boxes;
    Bvh bvh;
  };
  std::vector<MeshObstacle> meshes;         // per obstacle (empty for analytic ones)
  std::vector<ObstacleShape::Meets> meets;  // per obstacle: how the search meets it
  std::vector<RoundCore> cores;             // per round obstacle: its core and radius
  std::vector<V3> offset, velocity;         // per obstacle, at the step's end (the penalty's pose)
  std::vector<V3> startOffset,
      move;  // per obstacle: at the step's start, and its motion over the step

  // ---- the step's pairs ----
  std::vector<Pair> pairs;
  std::vector<Pair> nearPairs;               // the displacement bound's (kept to reuse its storage)
  std::vector<V3> sweptMotion;               // the displacements it searched with
  std::vector<char> fastPoint;               // per point slot: moved too far for the cache
  std::vector<double> moveLength;            // per point slot: its displacement's length
  std::vector<double> pointSdf, pointReach;  // per point slot, for one analytic obstacle (scratch)
  std::vector<char> seenFeature;             // per point, then edge slot (scratch)
  std::vector<std::uint32_t> featureKeys;    // (scratch)
  std::vector<std::vector<char>> partSeen;   // (analyticPairs', per thread)
  std::vector<std::vector<std::uint32_t>> partKeys;
  std::vector<std::uint32_t> movingScratch, visitScratch;  // (nearFromCache)

  /// Every point's signed distance to analytic obstacle k at x, into pointSdf (a triangle's
  /// corners are shared by about six triangles: measured once per point, not per corner).
  void pointDistances(int k, std::span<const double> x);
  /// The longest edge of the triangle with corners tv (every point of a triangle lies within it
  /// of each corner).
  static double longestEdge(const std::array<V3, 3>& tv) {
    return std::sqrt(std::max({(tv[1] - tv[0]).squaredNorm(), (tv[2] - tv[1]).squaredNorm(),
                               (tv[0] - tv[2]).squaredNorm()}));
  }
  // The penalty's search by margins: a triangle's is the largest of its corners'; a pair of
  // triangles is examined when their boxes, each inflated by its margin, overlap, and a
  // primitive pair is kept within the sum of the margins (an obstacle's margin for its side).
  // (The displacement bound searches by swept boxes and reach instead: `sweep`.)
  std::vector<double> pointMargin, triMargin, obstacleMargin;
  std::vector<double> bound;  // per point slot: gamma times the smallest distance, kInf: none
  std::vector<V3> anchor;     // per point slot: the frame its displacement is bounded in
  bool reframedAny = false;   // the last limit() gave a point an obstacle's frame

  // ---- exclusions after topology changes ----
  /// Excluded pairs by their points (exclusionKey): neighbours in the material within d.
  std::set<std::array<std::uint32_t, 5>> excluded;
  /// Points of neighbours in the material that have separated beyond d once (each pair of a
  /// point of one primitive and a point of the other, lower id first): a pair all of whose
  /// pairs of points are released is a pair as any other.
  std::set<std::pair<std::uint32_t, std::uint32_t>> released;
  std::vector<double> lastX;  // positions of the last beginStep (validate)

  Impl(topology::Topology& t, const ContactParameters& p, std::vector<Obstacle>& o)
      : topo(t), P(p), O(o) {}

  // ---------------------------------------------------------------------------------------------
  V3 surfacePoint(std::span<const double> x, std::uint32_t p) const {
    return {x[3 * p], x[3 * p + 1], x[3 * p + 2]};
  }
  /// Triangle meshes and boxes meet the surface through their triangles, edges and corners.
  bool meshLike(std::size_t k) const { return meets[k] == ObstacleShape::Meets::Mesh; }
  bool roundLike(std::size_t k) const { return meets[k] == ObstacleShape::Meets::Round; }
  /// A round obstacle whose core is a point (a sphere).
  bool roundPoint(std::size_t k) const { return roundLike(k) && cores[k].point; }
  V3 obstaclePoint(int k, std::uint32_t i) const {
    const Vec3& v = meshes[std::size_t(k)].vertices[i];
    return V3(v[0], v[1], v[2]) + offset[std::size_t(k)];
  }
  V3 pointOf(const Pair& p, std::span<const double> x, int i) const {
    return (p.surface >> i) & 1 ? surfacePoint(x, p.id[std::size_t(i)])
                                : obstaclePoint(p.obstacle, p.id[std::size_t(i)]);
  }

  /// The pair's relative velocity (weights frozen at the step's start; obstacles move with their
  /// paths).
  inline V3 relativeVelocity(const Pair& p, std::span<const double> v) const;

  /// Signed distance of q to obstacle k (at its pose `offset`) and its gradient.
  inline double sdf(int k, const V3& q, V3& g) const;

  /// Distance, normal and weights of a pair at x.
  /// With `sided`, an obstacle-mesh pair whose closest points have crossed (their direction
  /// turned against the pair's normal at the step's start) gets a negative distance along that
  /// normal: the penalty goes on pushing the point back to its side, also when a moving obstacle
  /// has gone past it within one step. (Self pairs stay unsigned: a point going round the border
  /// of a flap turns its direction without crossing anything.)
  inline Eval evaluate(const Pair& p, std::span<const double> x, bool sided = false) const;
  inline Eval evaluateUnsided(const Pair& p, std::span<const double> x) const;

  /// A point q[0] and a triangle q[1..3] whose closest point has barycentric weights bw (one
  /// compiled copy: evaluatePoints and the screened classification get the same numbers from
  /// the same weights).
  [[gnu::noinline]] static inline Eval pointTriangleEval(const std::array<V3, 4>& q,
                                                         const std::array<double, 3>& bw,
                                                         const V3& n0);
  /// The same from the pair's points.
  inline Eval evaluatePoints(const Pair& p, const std::array<V3, 4>& q) const;

  /// The closest points of a point (m = 1), an edge (2) or a triangle (3) of the surface and a
  /// sphere or capsule k (a point or a segment, its core, thickened by its radius): the signed
  /// distance to the round surface, the unit normal from the core, the weights on the points.
  inline Eval roundObstacle(int k, const std::array<V3, 4>& q, int m, const V3& fallback) const;

  /// The gap no step lets two primitives close below (a pair found farther apart): a thousandth
  /// of the thickness, where the law's force is about three times its value at d / 100. Without
  /// it a pair pressed harder than the law holds closes by most of its distance every step and
  /// reaches rounding's scale, where no distance proves a side (see docs/contact.md, "The
  /// guarantee").
  double gapFloor() const { return kGapFloor * P.thickness; }
  static constexpr double kGapFloor = 1e-3;
  /// The distance a pair found at d0 is kept above over a step, given the floor: the larger of
  /// a tenth of d0 and the floor, but no more than all but a millionth of d0. So a pair found
  /// above the floor stays above it (to within a millionth), and one found on or below it (a
  /// topology operation, or a pair that reached the floor and is found a rounding below it) may
  /// part but closes by at most a millionth of its distance per step: pressed, it would
  /// otherwise close by most of its distance step after step. The millionth leaves the CCD room
  /// to prove that such a pair parts. Without a floor (zero), a tenth of d0.
  static double keptAbove(double d0, double floorGap) {
    return std::max(kCcdFraction * d0, std::min(floorGap, (1.0 - kLeastClose) * d0));
  }
  static constexpr double kCcdFraction = 0.1;
  static constexpr double kLeastClose = 1e-6;
  /// How far each point of a pair at distance s may move, whatever the direction, for the pair
  /// to stay apart: gamma s (gamma < 1/2: the two primitives cannot meet), and no more than half
  /// of what keeps it above keptAbove(s) (the floor; below the floor, almost nothing).
  double keepApart(double s, double gamma) const {
    if (!(s > 0)) return 0.0;
    return std::min(gamma * s, 0.5 * (s - keptAbove(s, gapFloor())));
  }

  /// Additive continuous collision detection (Li, Kaufman and Jiang 2021) of something whose
  /// distance at time t in [0, 1] is dist(t) and changes by at most lp per unit of t: the part
  /// [0, t] of the step over which the distance provably stays above keptAbove(dist(0), floor)
  /// (1: the whole step).
  template <class Dist>
  static double safeFraction(const Dist& dist, double lp, double floor) {
    return safeFraction(dist, lp, dist(0.0), floor);
  }
  /// The same, given d0 = dist(0).
  template <class Dist>
  static double safeFraction(const Dist& dist, double lp, double d0, double floorGap) {
    if (!(d0 > 0)) return 0.0;
    if (!(lp > 0)) return 1.0;
    const double floor = keptAbove(d0, floorGap);
    double t = 0.0, d = d0;
    // A pair that separates advances by growing steps: 32 advances prove separation from a
    // distance many times smaller than the motion (128 within ten floors, where the first
    // advance may be as small as a millionth of the distance). One that approaches gets the
    // part of the step it provably has.
    const int advances = d0 > floorGap / kCcdFraction ? 32 : 128;
    for (int i = 0; i < advances; ++i) {
      const double next =
          t + 0.9 * (d - floor) / lp;  // the distance cannot fall below `floor` before then
      if (next >= 1.0) return 1.0;
      d = dist(next);
      if (!(d > floor)) return t;
      t = next;
    }
    return t;
  }

  /// Whether a pair moving linearly by the displacements dx (scaled per point) provably stays
  /// apart over the step.
  double pairSafeFraction(const Pair& p, std::span<const double> x0,
                          const std::vector<V3>& dx) const;

  // ---------------------------------------------------------------------------------------------
  // The pairs at some positions, evaluated once per x (the integrators ask at the same x many
  // times: forces, then every product of a CG solve), and packed for the solves' products.
  //
  // A memo, not state: what it returns is a function of x and of the step's pairs alone (pairs,
  // lastX, the obstacles' poses), computed the first time it is asked for; the force field's
  // const methods fill it (the one mutable member of Impl, besides edgeFlat's once-per-step
  // measures). Whoever changes the pairs, lastX or the poses calls invalidate(). Not safe for
  // concurrent calls: the integrators call a force field from one thread at a time.
  class Evaluation {
   public:
    /// The pairs evaluated at x: evals()[i] and closer(i) for pair i. A pair whose points moved
    /// less than (s0 - d) / 2 from the step's start cannot be within d (the weights' magnitudes
    /// sum to at most 2) and is not evaluated (closer(i) false).
    inline const Evaluation& at(const Impl& I, std::span<const double> x);
    const std::vector<Eval>& evals() const { return evals_; }
    bool closer(std::size_t i) const { return closerThanD_[i] != 0; }
    void invalidate() { valid_ = false; }

    // The same, packed for the products of the solves at one (kFactor, bFactor) (CG asks for
    // many at the same ones): df_i += w_i A (sum_j w_j dx_j), A the sum of the penalty's
    // Gauss-Newton stiffness -kFactor h n n^T and friction's bFactor dF/du, one gather and one
    // scatter per pair where the two share their weights (the linearised steps evaluate at the
    // step's start, where they do).
    struct Product {
      std::array<std::uint32_t, 4> id;
      std::uint8_t surface;
      std::array<double, 4> w;
      std::array<double, 6> a;  // A's upper triangle: xx, xy, xz, yy, yz, zz
    };
    /// The products of the last evaluation (at()).
    inline const std::vector<Product>& products(const Impl& I, double kFactor, double bFactor);

    /// The positions a solve's operator holds unchanged (ForceField::beginProducts) from hold()
    /// to release(): an evaluation made at memory that is held since is still that memory's,
    /// and needs no comparison.
    void hold(const Impl& I, std::span<const double> x) {
      at(I, x);  // (evaluated now, with a full comparison: from here on the memory is what it was)
      held_.emplace_back(x.data(), x.size());
    }
    void release(std::span<const double> x) {
      for (std::size_t k = held_.size(); k-- > 0;)
        if (held_[k].first == x.data() && held_[k].second == x.size()) {
          held_.erase(held_.begin() + std::ptrdiff_t(k));
          return;
        }
    }

    /// Whether x holds the same numbers, bit for bit, as y (compared as memory, which is several
    /// times faster than number by number).
    static bool sameBits(std::span<const double> x, const std::vector<double>& y) {
      return x.size() == y.size() &&
             (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0);
    }

   private:
    bool heldAt(std::span<const double> x) const {
      for (const auto& h : held_)
        if (h.first == x.data() && h.second == x.size()) return true;
      return false;
    }
    std::vector<Eval> evals_;
    std::vector<char> closerThanD_;  // per pair: evaluated and closer than d
    std::vector<double> x_;          // where the evaluation was made
    const double* from_ = nullptr;   // the memory it last read x from
    bool valid_ = false;
    std::uint64_t count_ = 0;    // evaluations made (what the packs are valid for)
    std::vector<double> moved_;  // (per point slot: how far it is from lastX)
    std::vector<std::pair<const double*, std::size_t>> held_;
    // Two packs (an implicit step asks at (1, 0) for its right-hand side, then at its own
    // factors), each valid for the evaluation it was made from.
    struct Pack {
      std::vector<Product> list;
      double kFactor = 0.0, bFactor = 0.0;
      std::uint64_t evaluation = 0;  // 0: none
    };
    std::array<Pack, 2> packs_;
    std::size_t lastPack_ = 0;
  };
  mutable Evaluation evaluation;

  // ---------------------------------------------------------------------------------------------
  // Tables

  void rebuildTables();

  /// Flat-on-flat contact, counted once. Where the surface is flat across an edge (its two
  /// triangles in one plane), the distance from a straight edge of the other surface to it
  /// changes linearly along that edge over the two triangles, so a crossing of two such edges
  /// is never nearer than their ends or the bent edges around them, whose pairs are kept: the
  /// pair of two edges that are both flat adds nothing but a second count of the same contact
  /// (between two resting layers of cloth, 3.4 edge pairs a point besides its own), provided
  /// those pairs can exist: the triangles beside the two edges share no point (apart()). An edge's
  /// flatness is 1 where its bend lifts the far corners of its triangles off each other's plane
  /// by at most kFlatBelow d (h sin(theta), h the larger altitude over the edge, theta the bend),
  /// 0 from kFlatAbove d on, with a border edge, a bend beyond 90 degrees or a degenerate
  /// triangle, and a smooth step between; frozen at the step's start, as friction's normal
  /// force is.
  static constexpr double kFlatBelow = 0.05, kFlatAbove = 0.25;
  static double flatness(const V3& a, const V3& b, const V3& c, const V3& e, double d);
  // Measured once per edge and step: when a pair first asks, or beforehand for every edge of the
  // cache's edge pairs (measureCacheFlatness).
  std::uint64_t flatRevision = 0;  // the tables' revision edgeFlat is measured on
  std::uint32_t flatGeneration = 0;
  /// At the step's start: the edges' flatness is measured afresh at x as pairs ask for it.
  void resetFlatness();
  double flatnessOf(std::uint32_t e, std::span<const double> x) const {
    const EdgeFlat& r = edgeFlat[e];
    return r.stamp == flatGeneration ? r.flat : measureFlatness(e, x);
  }
  [[gnu::noinline]] double measureFlatness(std::uint32_t e, std::span<const double> x) const;
  /// A self pair of two edges' share of the law (x: the step's start): 1 - both edges'
  /// flatness, when the triangles beside them share no point: only then can the pairs of their
  /// corners and of their other edges, which make the pair of the two redundant, be pairs at
  /// all (in a tight fold a few triangles wide they share points).
  double edgePairScale(const std::array<std::int32_t, 2>& edges, std::span<const double> x) const;
  /// Whether two inner edges' triangles (both beside each) share no point (false for a border
  /// edge, which is never flat): a property of the mesh.
  bool edgesApart(std::int32_t e1, std::int32_t e2) const;

  void surfaceBoxes(std::span<const double> x, std::vector<Box>& out) const;

  void buildObstacleMeshes();

  void obstacleBoxes(int k, std::vector<Box>& out) const;

  // ---------------------------------------------------------------------------------------------
  // Detection

  bool shares(const std::array<std::uint32_t, 3>& t, std::uint32_t p) const {
    return t[0] == p || t[1] == p || t[2] == p;
  }

  /// What surelyDropped measured of a point-triangle pair it did not drop: the weights of the
  /// point's closest point on the triangle and their snap to a feature, which keepIfNear and
  /// toFeature then take as they are (set: it measured them).
  struct Screen {
    bool set = false;
    std::array<double, 3> closest{}, snapped{};
  };
  /// Keeps the pair if it is closer than r at x, with its distance, normal and weights there.
  /// With `features` (the penalty's pairs), a point and a triangle (t: the triangle's index in
  /// its surface or obstacle mesh) become a pair of the point and the triangle's closest
  /// feature, kept once for that feature (see toFeature), and two edges are kept only when their
  /// closest points are inside both (else they are a point's pair). `screen`: surelyDropped has
  /// already passed it, with what it measured (and an edge pair's share is set).
  inline void keepIfNear(Pair p, std::span<const double> x, double r, std::vector<Pair>& out,
                         bool features = false, int t = -1, const Screen* screen = nullptr) const;

  /// Whether the penalty keeps the pair of edges q0-q1 and q2-q3: their closest points are inside
  /// both, and they are nearer than either edge is to the other's ends (by kFeatureTolerance),
  /// else they meet at an end, which is that point's pair (two aligned layers, an edge over an
  /// edge). One compiled copy, so that the screening and the classification get the same
  /// numbers.
  [[gnu::noinline]] static inline bool edgePairKept(const V3& q0, const V3& q1, const V3& q2,
                                                    const V3& q3);
  /// Two surface edges' points in one order, whichever edge comes first.
  static void orderEdges(std::array<std::uint32_t, 4>& id) {
    const auto a = std::minmax(id[0], id[1]), b = std::minmax(id[2], id[3]);
    if (b < a) id = {id[2], id[3], id[0], id[1]};
  }
  /// Whether the pair's obstacle moves over the step.
  bool obstacleMoves(const Pair& p) const {
    return p.obstacle >= 0 && move[std::size_t(p.obstacle)] != V3::Zero();
  }

  /// Whether the penalty's search drops the pair whatever its distance, told from its closest
  /// points alone (most of the pairs it measures, which then need no distance, normal or
  /// weights): two edges whose closest points are not inside both, a point whose closest
  /// feature of a surface triangle is a corner or an edge that the triangle does not own (or a
  /// corner the pair is kept from the other side). The same tests keepIfNear and toFeature make,
  /// on the same numbers.
  inline bool surelyDropped(Kind kind, std::uint8_t surface, std::int32_t obstacle,
                            std::array<std::uint32_t, 4> id, std::uint8_t shape,
                            std::span<const double> x, int t, Screen* screen = nullptr) const;

  /// The point of a point-triangle pair (e: the pair evaluated at x; t: the triangle's index)
  /// meets the triangle's interior, one of its edges or one of its corners. An edge or corner
  /// becomes the pair's feature (shape 2 or 1) when it is the closest feature of every triangle
  /// around it (the point is in its Voronoi region: no triangle beside it is nearer), and is
  /// kept only from its owner triangle, so that every feature the point meets counts once,
  /// whichever triangles the search pairs the point with. Returns false to drop the pair.
  inline bool toFeature(Pair& p, const Eval& e, std::span<const double> x, int t,
                        const std::array<double, 3>* snapped = nullptr) const;

  /// Every self pair of triangles i, j (as the BVH or the brute force gives them): the VT and EE
  /// pairs that the two triangles own, within r at x.
  // ---- the displacement bound's search ----
  /// The points' displacements over the step (null: the search by margins). Then a pair is
  /// kept when its distance is less than how far its points move relative to each other
  /// (reachOf), and boxes are swept along the displacements.
  const std::vector<V3>* sweep = nullptr;
  bool absoluteReach = false;  // the last resort's reach (see reachOf)
  V3 motionOf(const Pair& p, int i) const {
    return (p.surface >> i) & 1 ? (*sweep)[p.id[std::size_t(i)]] : move[std::size_t(p.obstacle)];
  }
  /// How much the distance of a pair can change over the step (as pairSafeFraction bounds it).
  double reachOf(const Pair& p) const;
  /// The box a point sweeps.
  Box sweptPoint(std::span<const double> x, std::uint32_t v) const;
  /// The triangles' swept boxes (the BVH's) for the displacements dx.
  void prepareSwept(std::span<const double> x, const std::vector<V3>& dx);

  /// The boxes of the triangles and of the edges at x (not grown): cheap tests before the
  /// closest points.
  struct Tight {
    std::vector<Box> tri, edge;  // by index in tris, by edge id
  };
  void tightBoxes(std::span<const double> x, Tight& out) const;
  Tight tight;  // at the x of the last prepare()

  inline void selfTrianglePair(int i, int j, std::span<const double> x, std::vector<Pair>& out,
                               bool features, const Tight& boxesAtX) const;

  /// The displacement bound's pairs of two triangles whose swept boxes overlap: every
  /// point-triangle and edge-edge pair whose points' swept boxes overlap and whose distance
  /// is less than its reach.
  void sweptTrianglePair(int i, int j, std::span<const double> x, std::vector<Pair>& out) const;

  inline void meshTrianglePair(int k, int i, int j, std::span<const double> x,
                               std::vector<Pair>& out, bool features) const;

  /// All pairs within their margins at x (prepare() first): with `features`, the penalty's
  /// (closest features, each once), else every pair of primitives (the displacement bound's).
  void collect(std::span<const double> x, std::vector<Pair>& out, bool features) {
    out.clear();
    searchPairs(x, out, features);
    analyticPairs(x, out);
  }
  /// The self and obstacle-mesh pairs (by the BVHs).
  inline void searchPairs(std::span<const double> x, std::vector<Pair>& out, bool features);
  /// Obstacle mesh k's boxes (grown by its margin) and hierarchy, at its current pose.
  void refitObstacle(std::size_t k);
  /// The displacement bound's pairs among slow points (sweep set), from the cache: those whose
  /// distance (at most what it was, less its points' motion since) is below their reach.
  void nearFromCache(std::span<const double> x, const std::vector<char>& fast,
                     std::vector<Pair>& out);

  /// The displacement bound's pairs that hold a fast point (prepareSwept first): each triangle
  /// with a fast corner against the triangles and obstacle triangles its swept box meets.
  void searchAround(std::span<const double> x, const std::vector<char>& fast,
                    std::vector<Pair>& out);

  /// The pairs with planes, spheres and capsules.
  inline void analyticPairs(std::span<const double> x, std::vector<Pair>& out);

  // ---- the search's cache (a Verlet list) ----
  // Every self and obstacle-mesh pair of primitives within cacheR at cacheX (each with its
  // distance then in s0). A pair not in it was at least cacheR apart, and is still at least
  // cacheR - 2 m apart (m: the farthest any point has moved since; an obstacle pair: cacheR -
  // m - the obstacle's own motion), so while that exceeds what a search asks for, the cache
  // holds every pair the search would find.
  struct Cached {
    Kind kind;
    std::uint8_t surface;
    std::int32_t obstacle;
    std::int32_t tri;  // VT, VO, OV: the triangle's index; EE self pairs: the first edge
    std::array<std::uint32_t, 4> id;
    std::array<std::int32_t, 2> margins;
    std::int32_t edge2;  // EE self pairs: the second edge (in what was padding: 48 bytes a record)
    double s;            // the distance when the cache was built
    Pair pair() const {
      Pair p{.kind = kind, .obstacle = obstacle, .id = id, .surface = surface};
      if (kind == Kind::EE)
        p.edges = {tri, edge2};
      else
        p.tri = tri;
      p.margins = margins;
      return p;
    }
  };
  static_assert(sizeof(Cached) == 48);
  std::vector<Cached> cache;
  std::vector<Cached>* cacheOut = nullptr;  // while the cache is built: where keepIfNear keeps
  std::vector<double> cacheX;
  std::vector<V3> cacheOffset;
  std::uint64_t cacheRevision = 0;
  double cacheR = 0.0;
  bool cacheBuilt = false;
  std::vector<double> sinceCache;  // per point slot: how far it moved since the cache's x
  std::vector<double> obstacleSinceCache;
  double largestSinceCache =
      0.0;  // the largest of the two above (a cached pair shrinks by at most twice it)
  std::size_t cacheUses = 0, cacheBuilds = 0;
  // A cache that was never reused before the points moved out of it cost more than the search
  // it replaced: then the next steps search plainly, for twice as many steps each time (up to
  // 64), before a cache is tried again.
  std::size_t usesSinceBuild = 0, plainSteps = 0, backoff = 1, plainSearches = 0;

  /// Whether the cache holds every self pair within rSelf and every pair with obstacle mesh k
  /// within rObstacle[k] at x (the obstacles at `offset`); fills sinceCache.
  bool cacheCovers(std::span<const double> x, double rSelf, const std::vector<double>& rObstacle);
  /// Searches every self and obstacle-mesh pair within r at x into the cache.
  void buildCache(std::span<const double> x, double r);
  /// The cached pairs' distances, each rounded down to a float, in an array of their own: the
  /// displacement bound skips most pairs by their distance alone, reading 4 bytes a pair where
  /// a record is 48.
  std::vector<float> cacheLow;
  double cacheNearest = kInf;  // the least of cacheLow
  /// Per surface point slot, the cached pairs that hold it (CSR): when a few points move far,
  /// the displacement bound looks only at their pairs (every other pair is farther apart than
  /// four times its points' motion).
  std::vector<std::uint32_t> cacheByPointStart, cacheByPoint;
  void indexCache();
  /// How far a cached pair's distance may have shrunk since the cache was built.
  double cachedShrink(const Cached& c) const;
  /// The search's margin for a cached pair (what selfTrianglePair or meshTrianglePair used).
  double searchMargin(const Cached& c) const {
    const double a = triMargin[std::size_t(c.margins[0])];
    return c.obstacle < 0 ? a + triMargin[std::size_t(c.margins[1])]
                          : a + obstacleMargin[std::size_t(c.obstacle)];
  }

  /// The step's self and obstacle-mesh pairs from the cache: each cached pair that may be within
  /// its margin, classified as the search does (its features, the edge pairs' shares). A large
  /// cache is classified on several threads, each over a contiguous run of records, its pairs
  /// appended in the cache's order: the same pairs in the same order whatever the threads.
  void pairsFromCache(std::span<const double> x, std::vector<Pair>& out);
  /// Classifies cached record ci at x into `to`, as the search would.
  void classifyCached(std::size_t ci, std::span<const double> x, std::vector<Pair>& to) const;
  std::vector<std::uint32_t> cacheVisit, cacheVisitExtra;  // (pairsFromCache's)
  std::vector<std::uint64_t> recordBits;  // (ascendingOnce's, for pairsFromCache and nearFromCache)
  // (per thread: pairsFromCache's, nearFromCache's and analyticPairs', which never run at once)
  std::vector<std::vector<Pair>> partPairs;
  std::size_t cacheEdgePairs = 0;         // the cache's self pairs of two edges (indexCache)
  std::vector<std::uint32_t> cacheEdges;  // their edges, each once, ascending (markApart)
  /// Whether markApart has indexed the cache's apart pairs of two edges: those whose triangles,
  /// beside the one edge and the other, share no point (edgePairScale's condition; a property of
  /// the mesh, kept with the cache until it is built again).
  bool apartIndexed = false;
  /// The records that are not apart pairs of two edges, ascending (markApart).
  std::vector<std::uint32_t> cacheOthers;
  /// Per edge (CSR over the edge slots), the apart pairs of two edges that hold it, and the
  /// edges that hold one, ascending (markApart; edgesApart has checked they are edges: a
  /// restored cache may hold edge pairs whose edges are not).
  std::vector<std::uint32_t> apartByEdgeStart, apartByEdge, apartEdges;
  void markApart();
  static constexpr std::size_t kRecordsPerThread = 16384, kTrianglesPerThread = 8192;
  /// How many threads work on n items, each given at least `least` of them.
  int partsFor(std::size_t n, std::size_t least) const {
    return cutsim::partsFor(n, least, threads);
  }
  int threads = 1;  // the threads contact's loops may use (Contact's constructor sets it)
  /// The flatness at x of every edge of the cache's self pairs of two edges, on `parts` threads
  /// (each edge by one thread: no two threads write one edge's record).
  void measureCacheFlatness(std::span<const double> x, int parts) const;

  /// Brings the tables up to date (a topology change rebuilds them).
  void updateTables();

  /// Triangle margins from the point margins, then the boxes and the BVH at x.
  void triangleMargins();
  void prepare(std::span<const double> x);

  /// A self pair by its points, the same whichever way it was found.
  static std::array<std::uint32_t, 5> exclusionKey(const Pair& p);

  /// The self pair of an exclusion key.
  static Pair fromKey(const std::array<std::uint32_t, 5>& key);
  /// Calls f(a, b) for every pair of a point of one primitive and a point of the other.
  template <class F>
  static void crossPoints(const Pair& p, F&& f) {
    const int split = p.kind == Kind::EE ? 2 : 1, count = p.points();
    for (int i = 0; i < split; ++i)
      for (int j = split; j < count; ++j)
        f(std::minmax(p.id[std::size_t(i)], p.id[std::size_t(j)]));
  }
  /// The closest features of a self pair of whole primitives (its weights at the search): a
  /// point and a triangle's interior, edge or corner; two edges, an edge and a point, or two
  /// points. (The bound skips a pair whose closest features are excluded neighbours.)
  static Pair closestFeature(const Pair& p);

  /// Whether a self pair is within d in the rest configuration (neighbours in the material).
  bool restNeighbours(const Pair& p) const;
  bool isReleased(const Pair& p) const;
  /// A self pair at distance s0 that has no penalty, no friction and no bound: neighbours in the
  /// material within d, not yet separated beyond d.
  bool excludedPair(const Pair& p) const {
    return p.obstacle < 0 && p.s0 <= P.thickness && restNeighbours(p) && !isReleased(p);
  }

  /// Whether sphere k is farther than `within` from the triangle's plane, so from the triangle
  /// (the centre's distance to the plane is at most its distance to the triangle).
  /// A sliver (its corners nearly in line: the cross product's direction is mostly rounding) is
  /// never culled so, and the plane's distance is taken less a margin for rounding.
  bool planeSeparates(int k, const std::array<V3, 3>& tv, double within) const;
  /// Distance of a triangle to a plane, a sphere or a capsule (boxes and meshes meet the
  /// surface through their triangles): 0 if they intersect, -1 if a corner is inside, infinity if
  /// it is surely farther than `within`.
  double triangleObstacleDistance(int k, const std::array<V3, 3>& tv, double within) const {
    V3 g;
    return triangleObstacleDistance(
        k, tv, within, std::min({sdf(k, tv[0], g), sdf(k, tv[1], g), sdf(k, tv[2], g)}));
  }
  /// The same, given smin, the smallest of the corners' signed distances to the obstacle.
  double triangleObstacleDistance(int k, const std::array<V3, 3>& tv, double within,
                                  double smin) const;

  /// The displacement bound after a solve. Every pair the margins let meet (and every triangle
  /// near an analytic obstacle) is checked by additive CCD along the proposed displacements;
  /// the points of a pair that cannot be proven to stay apart are bounded by gamma times the
  /// pair's distance at the step's start (then it provably does: gamma < 1/2), which shortens
  /// their displacements, and the checks run again until nothing changes.
  ///
  /// A point's displacement is anchor + scale (disp - anchor): the anchor is zero, or the
  /// motion over the step of a moving obstacle that the point cannot be proven to clear. Then
  /// the point is bounded in the obstacle's frame: it goes with the obstacle, give or take gamma
  /// times the distance, so that a kinematic obstacle pushes it however slowly the penalty
  /// would; the points of a self pair that holds such a point take its anchor too.
  ///
  /// One pass over a set of near pairs: starts from the given scales and anchors (and
  /// `bound`), returns whether it changed any displacement. With `plain`, every pair is bounded
  /// without CCD.
  bool limit(std::span<const double> x, const std::vector<Pair>& near, const std::vector<V3>& disp,
             std::span<const char> locked, double gamma, std::vector<double>& scale, bool plain);
};

}  // namespace cutsim::forcefields

// The operations every other concern calls in its loops, defined inline (as the whole of the
// contact code was once, in one file): compiled into each caller, so that floating-point
// contraction, and with it every result, is what it has always been.
#include "pair_eval.hpp"
#include "search.hpp"
