// Contact: detection, penalty, friction, displacement bound, exclusions after topology changes
// (contact.hpp).
#include "cutsim/forcefields/contact.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <thread>
#include <unordered_set>
#include <utility>

#include "contact_archive.hpp"
#include "contact_bvh.hpp"
#include "contact_geometry.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/forcefields/registry.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::forcefields {

using namespace contact;
using topology::Index;
using topology::kInvalidIndex;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Runs body(k, begin, end) for k in [0, parts) over contiguous runs that cover [0, n) in
/// order: the first run on this thread, each other on a thread of its own. Every thread is
/// joined before it returns; then the first exception a run threw is thrown again.
template <class Body>
void inParts(std::size_t n, int parts, Body&& body) {
  if (parts <= 1) {
    body(0, std::size_t(0), n);
    return;
  }
  std::vector<std::exception_ptr> failed(static_cast<std::size_t>(parts));
  auto run = [&](int k) {
    try {
      body(k, n * std::size_t(k) / std::size_t(parts), n * std::size_t(k + 1) / std::size_t(parts));
    } catch (...) {
      failed[std::size_t(k)] = std::current_exception();
    }
  };
  std::vector<std::thread> others;
  others.reserve(std::size_t(parts - 1));
  for (int k = 1; k < parts; ++k) {
    try {
      others.emplace_back(run, k);
    } catch (...) {  // (no thread to be had: the run here instead)
      run(k);
    }
  }
  run(0);
  for (std::thread& t : others) t.join();
  for (const std::exception_ptr& e : failed)
    if (e) std::rethrow_exception(e);
}

/// run(begin, end, to) over [0, n) in `parts` contiguous runs (inParts), the first into `out`,
/// each other into a vector of its own in `scratch`, appended to `out` in the runs' order: what
/// one run over [0, n) into `out` appends.
template <class T, class Run>
void gatherInParts(std::size_t n, int parts, std::vector<std::vector<T>>& scratch,
                   std::vector<T>& out, Run&& run) {
  if (parts <= 1) {
    run(std::size_t(0), n, out);
    return;
  }
  scratch.resize(static_cast<std::size_t>(parts));
  const std::size_t before = out.size();
  try {
    inParts(n, parts, [&](int k, std::size_t begin, std::size_t end) {
      std::vector<T>& to = k == 0 ? out : scratch[std::size_t(k)];
      if (k > 0) to.clear();
      run(begin, end, to);
    });
  } catch (...) {
    out.resize(before);  // (as it was: nothing appended)
    throw;
  }
  for (std::size_t k = 1; k < scratch.size(); ++k)
    out.insert(out.end(), scratch[k].begin(), scratch[k].end());
}

/// Record indices, each once and ascending (what sorting them and dropping repeats gives), from
/// a bitset over the records: each(mark) marks them, then they are appended to `out`.
template <class Each>
void ascendingOnce(std::size_t records, std::vector<std::uint64_t>& bits,
                   std::vector<std::uint32_t>& out, Each&& each) {
  bits.assign((records + 63) / 64, 0);
  each([&](std::uint32_t i) { bits[i >> 6] |= std::uint64_t(1) << (i & 63); });
  out.clear();
  for (std::size_t w = 0; w < bits.size(); ++w)
    for (std::uint64_t b = bits[w]; b != 0; b &= b - 1)
      out.push_back(std::uint32_t(64 * w + std::size_t(std::countr_zero(b))));
}

/// The threads contact's loops use when its parameters leave it to the machine: CUTSIM_THREADS
/// when set (a whole number in [1, 256]; InvalidInput otherwise), else the machine's hardware
/// threads.
int defaultThreads() {
  if (const char* s = std::getenv("CUTSIM_THREADS")) {
    char* end = nullptr;
    const long v = std::strtol(s, &end, 10);
    if (end == s || *end != '\0' || v < 1 || v > 256)
      throw InvalidInput(
          "CUTSIM_THREADS",
          "must be a whole number in [1, 256] (the threads contact may use), got \"" +
              std::string(s) + "\"");
    return int(v);
  }
  return int(std::clamp<unsigned>(std::thread::hardware_concurrency(), 1, 256));
}

/// The kinds of pairs.
enum class Kind : std::uint8_t {
  VT,  ///< surface point [0] vs surface triangle [1..3]
  EE,  ///< surface edge [0, 1] vs surface edge [2, 3]
  PO,  ///< surface point [0] vs an analytic obstacle
  VO,  ///< surface point [0] vs obstacle triangle [1..3] (obstacle vertices)
  OV,  ///< obstacle point [0] vs surface triangle [1..3]
  EO,  ///< surface edge [0, 1] vs obstacle edge [2, 3]
  FO,  ///< a surface point [0], edge [0, 1] or triangle [0, 1, 2] vs a sphere or a capsule
};

struct Pair {
  Kind kind;
  std::int32_t obstacle = -1;         ///< -1: self-contact
  std::array<std::uint32_t, 4> id{};  ///< point ids (surface) or vertex indices (obstacle mesh)
  std::uint8_t surface = 0;           ///< bit i: id[i] is a surface point
  bool excluded = false;
  /// VT, VO and OV: what of the triangle the point meets: 3 the triangle (id[1..3]), 2 one of
  /// its edges (id[1..2]), 1 one of its corners (id[1]); unused ids are kInvalidIndex. The
  /// penalty's pairs are the closest features (each met once); the displacement bound checks
  /// whole triangles.
  std::uint8_t shape = 3;
  /// The search's record (for the cache): VT, VO, OV: the triangle's index (in the surface or
  /// the obstacle mesh); `margins`: the surface triangles whose margins the search added.
  std::int32_t tri = -1;
  std::array<std::int32_t, 2> margins{-1, -1};
  /// EE self pairs: the edges (of id[0..1] and id[2..3] as the search met them; the
  /// classification may put the ids in the other order after: the share is symmetric).
  std::array<std::int32_t, 2> edges{-1, -1};
  /// How many ids are in use.
  int points() const {
    switch (kind) {
      case Kind::VT:
      case Kind::VO:
      case Kind::OV:
        return 1 + shape;
      case Kind::EE:
      case Kind::EO:
        return 4;
      default:
        return 4;
    }
  }
  // Frozen at the step's start:
  /// The share of the law a self edge-edge pair gets: 1 - (both edges' flatness), see
  /// Impl::edgeFlat (1 for every other pair).
  double scale = 1.0;
  double s0 = 0.0, lambda = 0.0, mu = 0.0;
  V3 n0 = V3::UnitZ();
  std::array<double, 4> w0{};
  /// dF/du at the step's start, as fa (I - n0 n0^T) + fb ft ft^T (see frictionForce).
  double fa = 0.0, fb = 0.0;
  V3 ft = V3::Zero();
  Eigen::Matrix3d frictionMatrix() const {
    return fa * (Eigen::Matrix3d::Identity() - n0 * n0.transpose()) + fb * ft * ft.transpose();
  }
};

/// The penalty law: E(s) = k/3 (d - s)^3 / s for d / 100 < s < d, zero beyond d with its first
/// two derivatives (C2), steep towards zero (the force at d / 100 is about 3300 k d) and continued
/// quadratically below d / 100 (the force grows linearly on, through zero and below: a pair
/// found at or through zero distance has finite values, and the stiffness stays bounded, so that
/// the solves stay well conditioned).
struct Law {
  double d, k;
  double sm() const { return 1e-2 * d; }
  static double energyAt(double d, double k, double s) {
    return k / 3 * (d - s) * (d - s) * (d - s) / s;
  }
  static double forceAt(double d, double k, double s) {
    const double a = d - s;
    return k * a * a / s + k / 3 * a * a * a / (s * s);
  }
  static double curvatureAt(double d, double k, double s) {
    const double a = d - s, r = a / s;
    return 2 * k * r + 2 * k * r * r + 2 * k / 3 * r * r * r;
  }
  /// E(s).
  double energy(double s) const {
    if (s >= d) return 0.0;
    if (s >= sm()) return energyAt(d, k, s);
    const double m = sm(), t = s - m;
    return energyAt(d, k, m) - forceAt(d, k, m) * t + 0.5 * curvatureAt(d, k, m) * t * t;
  }
  /// -E'(s) >= 0: the magnitude of the normal force.
  double force(double s) const {
    if (s >= d) return 0.0;
    if (s >= sm()) return forceAt(d, k, s);
    return forceAt(d, k, sm()) - curvatureAt(d, k, sm()) * (s - sm());
  }
  /// E''(s) >= 0.
  double curvature(double s) const {
    if (s >= d) return 0.0;
    return curvatureAt(d, k, std::max(s, sm()));
  }
};

/// Distance, unit normal and weights of a pair at some positions.
struct Eval {
  double s = kInf;
  V3 n = V3::UnitZ();
  std::array<double, 4> w{};
};

/// Friction force on the pair's relative velocity u (tangential to n0); with `keep`, its
/// derivative dF/du = fa (I - n0 n0^T) + fb ft ft^T goes into the pair.
V3 frictionForce(const Pair& p, double eps, const V3& u, Pair* keep = nullptr) {
  const V3 ut = u - p.n0 * p.n0.dot(u);
  const double l = ut.norm();
  const double c = p.mu * p.lambda;
  if (l <= eps) {
    if (keep) {
      keep->fa = -(c / eps);
      keep->fb = 0.0;
      keep->ft = V3::Zero();
    }
    return -(c / eps) * ut;
  }
  const V3 t = ut / l;
  if (keep) {
    keep->fa = -(c / l);
    keep->fb = c / l;
    keep->ft = t;
  }
  return -c * t;
}

}  // namespace

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
  std::vector<MeshObstacle> meshes;  // per obstacle (empty for analytic ones)
  std::vector<V3> offset, velocity;  // per obstacle, at the step's end (the penalty's pose)
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
  void pointDistances(int k, std::span<const double> x) {
    const std::size_t n = x.size() / 3;
    pointSdf.resize(n);
    V3 g;
    for (std::size_t p = 0; p < n; ++p) pointSdf[p] = sdf(k, surfacePoint(x, std::uint32_t(p)), g);
  }
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
  bool meshLike(std::size_t k) const {
    return O[k].shape == Obstacle::Shape::Mesh || O[k].shape == Obstacle::Shape::Box;
  }
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
  V3 relativeVelocity(const Pair& p, std::span<const double> v) const {
    V3 u = V3::Zero();
    const int count = p.kind == Kind::PO || p.kind == Kind::FO ? 3 : p.points();
    for (int i = 0; i < count; ++i) {
      if ((p.surface >> i) & 1)
        u += p.w0[std::size_t(i)] * surfacePoint(v, p.id[std::size_t(i)]);
      else if (p.kind != Kind::PO && p.kind != Kind::FO)
        u += p.w0[std::size_t(i)] * velocity[std::size_t(p.obstacle)];
    }
    if (p.kind == Kind::PO || p.kind == Kind::FO) u -= velocity[std::size_t(p.obstacle)];
    return u;
  }

  /// Signed distance of q to an analytic obstacle and its gradient.
  double sdf(int k, const V3& q, V3& g) const {
    const Obstacle& o = O[std::size_t(k)];
    const V3 off = offset[std::size_t(k)];
    const V3 c = V3(o.point[0], o.point[1], o.point[2]) + off;
    switch (o.shape) {
      case Obstacle::Shape::Plane: {
        g = V3(o.normal[0], o.normal[1], o.normal[2]).normalized();
        return g.dot(q - c);
      }
      case Obstacle::Shape::Sphere: {
        const V3 d = q - c;
        const double l = d.norm();
        g = l > 0 ? V3(d / l) : V3(V3::UnitZ());
        return l - o.radius;
      }
      case Obstacle::Shape::Capsule: {
        const V3 b = V3(o.pointB[0], o.pointB[1], o.pointB[2]) + off;
        const V3 ab = b - c;
        const double ll = ab.squaredNorm();
        const double t = ll > 0 ? std::clamp((q - c).dot(ab) / ll, 0.0, 1.0) : 0.0;
        const V3 d = q - (c + t * ab);
        const double l = d.norm();
        g = l > 0 ? V3(d / l) : V3(V3::UnitZ());
        return l - o.radius;
      }
      case Obstacle::Shape::Box: {
        const V3 h(o.halfExtents[0], o.halfExtents[1], o.halfExtents[2]);
        const V3 d = q - c;
        const V3 a = d.cwiseAbs() - h;
        const V3 e = a.cwiseMax(0.0);
        const double outside = e.norm();
        if (outside > 0) {
          g = V3(d.x() < 0 ? -e.x() : e.x(), d.y() < 0 ? -e.y() : e.y(),
                 d.z() < 0 ? -e.z() : e.z()) /
              outside;
          return outside;
        }
        int axis = 0;
        if (a.y() > a[axis]) axis = 1;
        if (a.z() > a[axis]) axis = 2;
        g = V3::Zero();
        g[axis] = d[axis] < 0 ? -1.0 : 1.0;
        return a[axis];
      }
      case Obstacle::Shape::Mesh:
        break;
    }
    g = V3::UnitZ();
    return kInf;
  }

  /// Distance, normal and weights of a pair at x.
  /// With `sided`, an obstacle-mesh pair whose closest points have crossed (their direction
  /// turned against the pair's normal at the step's start) gets a negative distance along that
  /// normal: the penalty goes on pushing the point back to its side, also when a moving obstacle
  /// has gone past it within one step. (Self pairs stay unsigned: a point going round the border
  /// of a flap turns its direction without crossing anything.)
  Eval evaluate(const Pair& p, std::span<const double> x, bool sided = false) const {
    Eval e = evaluateUnsided(p, x);
    if (sided && p.obstacle >= 0 && p.kind != Kind::PO && p.kind != Kind::FO && e.n.dot(p.n0) < 0) {
      e.s = -e.s;
      e.n = -e.n;
    }
    return e;
  }
  Eval evaluateUnsided(const Pair& p, std::span<const double> x) const {
    std::array<V3, 4> q{V3::Zero(), V3::Zero(), V3::Zero(), V3::Zero()};
    if (p.kind == Kind::PO || p.kind == Kind::FO) {
      for (int i = 0; i < 3; ++i)
        if ((p.surface >> i) & 1) q[std::size_t(i)] = surfacePoint(x, p.id[std::size_t(i)]);
      return evaluatePoints(p, q);
    }
    for (int i = 0; i < p.points(); ++i) q[std::size_t(i)] = pointOf(p, x, i);
    return evaluatePoints(p, q);
  }

  /// A point q[0] and a triangle q[1..3] whose closest point has barycentric weights bw (one
  /// compiled copy: evaluatePoints and the screened classification get the same numbers from
  /// the same weights).
  [[gnu::noinline]] static Eval pointTriangleEval(const std::array<V3, 4>& q,
                                                  const std::array<double, 3>& bw, const V3& n0) {
    Eval e;
    const V3 d = q[0] - (bw[0] * q[1] + bw[1] * q[2] + bw[2] * q[3]);
    e.s = d.norm();
    e.n = e.s > 1e-300 ? V3(d / e.s) : n0;
    e.w = {1, -bw[0], -bw[1], -bw[2]};
    return e;
  }
  /// The same from the pair's points.
  Eval evaluatePoints(const Pair& p, const std::array<V3, 4>& q) const {
    Eval e;
    switch (p.kind) {
      case Kind::PO: {
        e.s = sdf(p.obstacle, q[0], e.n);
        e.w = {1, 0, 0, 0};
        return e;
      }
      case Kind::FO: {
        const int m = (p.surface & 4) ? 3 : (p.surface & 2) ? 2 : 1;
        return roundObstacle(p.obstacle, q, m, p.n0);
      }
      case Kind::VT:
      case Kind::VO:
      case Kind::OV: {
        if (p.shape == 2) {
          const double t = closestSegmentSegment(q[0], q[0], q[1], q[2])[1];
          const V3 d = q[0] - (q[1] + t * (q[2] - q[1]));
          e.s = d.norm();
          e.n = e.s > 1e-300 ? V3(d / e.s) : p.n0;
          e.w = {1, -(1 - t), -t, 0};
          return e;
        }
        if (p.shape == 1) {
          const V3 d = q[0] - q[1];
          e.s = d.norm();
          e.n = e.s > 1e-300 ? V3(d / e.s) : p.n0;
          e.w = {1, -1, 0, 0};
          return e;
        }
        return pointTriangleEval(q, closestOnTriangle(q[0], q[1], q[2], q[3]), p.n0);
      }
      case Kind::EE:
      case Kind::EO: {
        const auto st = closestSegmentSegment(q[0], q[1], q[2], q[3]);
        const V3 d = (q[0] + st[0] * (q[1] - q[0])) - (q[2] + st[1] * (q[3] - q[2]));
        e.s = d.norm();
        e.n = e.s > 1e-300 ? V3(d / e.s) : p.n0;
        e.w = {1 - st[0], st[0], -(1 - st[1]), -st[1]};
        return e;
      }
    }
    return e;
  }

  /// The closest points of a point (m = 1), an edge (2) or a triangle (3) of the surface and a
  /// sphere or capsule k (a point or a segment, its core, thickened by its radius): the signed
  /// distance to the round surface, the unit normal from the core, the weights on the points.
  Eval roundObstacle(int k, const std::array<V3, 4>& q, int m, const V3& fallback) const {
    const Obstacle& o = O[std::size_t(k)];
    const V3 a = V3(o.point[0], o.point[1], o.point[2]) + offset[std::size_t(k)];
    const V3 b = o.shape == Obstacle::Shape::Capsule
                     ? V3(V3(o.pointB[0], o.pointB[1], o.pointB[2]) + offset[std::size_t(k)])
                     : a;
    Eval e;
    V3 pf = q[0], pc = a;
    e.w = {1, 0, 0, 0};
    if (m == 1) {
      const auto st = closestSegmentSegment(q[0], q[0], a, b);
      pc = a + st[1] * (b - a);
    } else if (m == 2) {
      const auto st = closestSegmentSegment(q[0], q[1], a, b);
      pf = q[0] + st[0] * (q[1] - q[0]);
      pc = a + st[1] * (b - a);
      e.w = {1 - st[0], st[0], 0, 0};
    } else if ((b - a).squaredNorm() > 0 && segmentCrossesTriangle(a, b, q[0], q[1], q[2])) {
      // The core pierces the triangle: distance -radius at the crossing, along the old normal.
      const V3 n = (q[1] - q[0]).cross(q[2] - q[0]);
      const double s0 = n.dot(a - q[0]), s1 = n.dot(b - q[0]);
      const V3 xp = a + (s0 / (s0 - s1)) * (b - a);
      const auto bw = closestOnTriangle(xp, q[0], q[1], q[2]);
      e.s = -o.radius;
      e.n = fallback;
      e.w = {bw[0], bw[1], bw[2], 0};
      return e;
    } else {
      double best = kInf;
      for (const V3& c : {a, b}) {
        const auto bw = closestOnTriangle(c, q[0], q[1], q[2]);
        const V3 f = bw[0] * q[0] + bw[1] * q[1] + bw[2] * q[2];
        const double dd = (f - c).squaredNorm();
        if (dd < best) {
          best = dd;
          pf = f;
          pc = c;
          e.w = {bw[0], bw[1], bw[2], 0};
        }
      }
      if ((b - a).squaredNorm() > 0)
        for (int i = 0; i < 3; ++i) {
          const int j = (i + 1) % 3;
          const auto st = closestSegmentSegment(q[std::size_t(i)], q[std::size_t(j)], a, b);
          const V3 f = q[std::size_t(i)] + st[0] * (q[std::size_t(j)] - q[std::size_t(i)]);
          const V3 c = a + st[1] * (b - a);
          const double dd = (f - c).squaredNorm();
          if (dd < best) {
            best = dd;
            pf = f;
            pc = c;
            e.w = {0, 0, 0, 0};
            e.w[std::size_t(i)] = 1 - st[0];
            e.w[std::size_t(j)] = st[0];
          }
        }
    }
    const V3 d = pf - pc;
    const double l = d.norm();
    e.s = l - o.radius;
    e.n = l > 1e-300 ? V3(d / l) : fallback;
    return e;
  }

  /// Additive continuous collision detection (Li, Kaufman and Jiang 2021) of something whose
  /// distance at time t in [0, 1] is dist(t) and changes by at most lp per unit of t: the part
  /// [0, t] of the step over which the distance provably stays above a tenth of its start (1:
  /// the whole step).
  template <class Dist>
  static double safeFraction(const Dist& dist, double lp) {
    return safeFraction(dist, lp, dist(0.0));
  }
  /// The same, given d0 = dist(0).
  template <class Dist>
  static double safeFraction(const Dist& dist, double lp, double d0) {
    if (!(d0 > 0)) return 0.0;
    if (!(lp > 0)) return 1.0;
    const double floor = 0.1 * d0;
    double t = 0.0, d = d0;
    // A pair that separates advances by growing steps: 32 advances prove separation from a
    // distance many times smaller than the motion. One that approaches gets the part of the
    // step it provably has.
    for (int i = 0; i < 32; ++i) {
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
                          const std::vector<V3>& dx) const {
    if (p.kind == Kind::PO || p.kind == Kind::FO) return 1.0;  // (bounded per triangle)
    std::array<V3, 4> q0, d;
    q0.fill(V3::Zero());
    d.fill(V3::Zero());
    V3 mean = V3::Zero();
    const int count = p.points();
    for (int i = 0; i < count; ++i) {
      q0[std::size_t(i)] = pointOf(p, x0, i);
      d[std::size_t(i)] =
          (p.surface >> i) & 1 ? dx[p.id[std::size_t(i)]] : move[std::size_t(p.obstacle)];
      mean += d[std::size_t(i)] / double(count);
    }
    // The two primitives' points: [0, split) and [split, count).
    const int split = (p.kind == Kind::EE || p.kind == Kind::EO) ? 2 : 1;
    double a = 0, b = 0;
    for (int i = 0; i < count; ++i) {
      const double m = (d[std::size_t(i)] - mean).norm();
      (i < split ? a : b) = std::max(i < split ? a : b, m);
    }
    return safeFraction(
        [&](double t) {
          std::array<V3, 4> q;
          for (int i = 0; i < 4; ++i)
            q[std::size_t(i)] = q0[std::size_t(i)] + t * d[std::size_t(i)];
          return evaluatePoints(p, q).s;  // (unused points stay at zero)
        },
        a + b);
  }

  // ---------------------------------------------------------------------------------------------
  // The pairs at some positions, evaluated once per x (the integrators ask at the same x many
  // times: forces, then every product of a CG solve). A pair whose points moved less than
  // (s0 - d) / 2 from the step's start cannot be within d (the weights' magnitudes sum to at
  // most 2) and is not evaluated.
  std::vector<Eval> evals;
  std::vector<char> closerThanD;  // per pair: evaluated and closer than d
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
  // Two packs (an implicit step asks at (1, 0) for its right-hand side, then at its own
  // factors), each valid for the evaluation it was made from.
  struct Products {
    std::vector<Product> list;
    double kFactor = 0.0, bFactor = 0.0;
    std::uint64_t evaluation = 0;  // 0: none
  };
  std::array<Products, 2> packs;
  std::size_t lastPack = 0;
  std::uint64_t evaluation = 0;  // counts evaluateAt's evaluations
  const std::vector<Product>& packProducts(double kFactor, double bFactor) {
    for (std::size_t k = 0; k < packs.size(); ++k)
      if (packs[k].evaluation == evaluation && packs[k].kFactor == kFactor &&
          packs[k].bFactor == bFactor) {
        lastPack = k;
        return packs[k].list;
      }
    lastPack = 1 - lastPack;  // (replaces the pack used less recently)
    Products& pack = packs[lastPack];
    std::vector<Product>& products = pack.list;
    products.clear();
    const Law law{P.thickness, P.stiffness};
    auto push = [&](const Pair& p, const std::array<double, 4>& w, const Eigen::Matrix3d& A) {
      products.push_back(
          {p.id, p.surface, w, {A(0, 0), A(0, 1), A(0, 2), A(1, 1), A(1, 2), A(2, 2)}});
    };
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      const Pair& p = pairs[i];
      if (p.excluded) continue;
      const bool penalty = closerThanD[i] && kFactor != 0.0,
                 rubs = p.lambda > 0 && p.mu > 0 && bFactor != 0.0;
      if (!penalty && !rubs) continue;
      const Eigen::Matrix3d K =
          penalty ? Eigen::Matrix3d((-kFactor * p.scale * law.curvature(evals[i].s)) *
                                    (evals[i].n * evals[i].n.transpose()))
                  : Eigen::Matrix3d::Zero();
      const Eigen::Matrix3d F =
          rubs ? Eigen::Matrix3d(bFactor * p.frictionMatrix()) : Eigen::Matrix3d::Zero();
      if (penalty && rubs && evals[i].w == p.w0) {
        push(p, p.w0, K + F);
        continue;
      }
      if (penalty) push(p, evals[i].w, K);
      if (rubs) push(p, p.w0, F);
    }
    pack.kFactor = kFactor;
    pack.bFactor = bFactor;
    pack.evaluation = evaluation;
    return products;
  }
  std::vector<double> evalX;
  std::vector<double> movedScratch;  // (evaluateAt's: per point slot, how far it is from lastX)
  bool evalValid = false;

  /// Whether x holds the same numbers, bit for bit, as y (the integrators ask at the same x
  /// many times: compared as memory, which is several times faster than number by number).
  static bool sameBits(std::span<const double> x, const std::vector<double>& y) {
    return x.size() == y.size() &&
           (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0);
  }
  /// The positions a solve's operator holds unchanged (ForceField::beginProducts), and where
  /// the last evaluation read its x: an evaluation made at memory that is held since is still
  /// that memory's, and needs no comparison.
  std::vector<std::pair<const double*, std::size_t>> held;
  const double* evalFrom = nullptr;
  bool heldAt(std::span<const double> x) const {
    for (const auto& h : held)
      if (h.first == x.data() && h.second == x.size()) return true;
    return false;
  }
  void evaluateAt(std::span<const double> x) {
    if (evalValid && evalFrom == x.data() && x.size() == evalX.size() && heldAt(x)) return;
    if (evalValid && sameBits(x, evalX)) {
      evalFrom = x.data();
      return;
    }
    const double d = P.thickness;
    std::vector<double>& moved = movedScratch;
    const bool atStart = sameBits(x, lastX);
    if (!atStart) {
      moved.assign(x.size() / 3, kInf);
      if (lastX.size() == x.size())
        for (std::size_t p = 0; p < moved.size(); ++p)
          moved[p] =
              (surfacePoint(x, std::uint32_t(p)) - surfacePoint(lastX, std::uint32_t(p))).norm();
    }
    evals.resize(pairs.size());
    closerThanD.assign(pairs.size(), 0);
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      const Pair& p = pairs[i];
      if (p.excluded) continue;
      double m = 0.0;
      if (!atStart)
        for (int k = 0; k < 4; ++k)
          if ((p.surface >> k) & 1) m = std::max(m, moved[p.id[std::size_t(k)]]);
      if (p.s0 - 2 * m >= d) continue;
      // At the step's start a pair is as the search measured it (but for a moving obstacle's,
      // whose distance was taken again where the obstacle ends the step).
      if (atStart && !obstacleMoves(p))
        evals[i] = Eval{p.s0, p.n0, p.w0};
      else
        evals[i] = evaluate(p, x, true);
      closerThanD[i] = evals[i].s < d;
    }
    ++evaluation;
    evalX.assign(x.begin(), x.end());
    evalFrom = x.data();
    evalValid = true;
  }

  // ---------------------------------------------------------------------------------------------
  // Tables

  void rebuildTables() {
    tris = topo.triangles();
    triV.resize(tris.size());
    triE.resize(tris.size());
    pointOwner.assign(topo.pointCapacity(), -1);
    edgeOwner.assign(topo.edgeCapacity(), -1);
    for (std::size_t i = 0; i < tris.size(); ++i) {
      const auto v = topo.triangleVertices(tris[i]);
      const auto e = topo.triangleEdges(tris[i]);
      for (int k = 0; k < 3; ++k) {
        triV[i][std::size_t(k)] = Index(v[std::size_t(k)]);
        triE[i][std::size_t(k)] = Index(e[std::size_t(k)]);
        if (pointOwner[Index(v[std::size_t(k)])] < 0)
          pointOwner[Index(v[std::size_t(k)])] = std::int32_t(i);
        if (edgeOwner[Index(e[std::size_t(k)])] < 0)
          edgeOwner[Index(e[std::size_t(k)])] = std::int32_t(i);
      }
    }
    edgeTris.assign(topo.edgeCapacity(), {-1, -1});
    starStart.assign(topo.pointCapacity() + 1, 0);
    for (std::size_t i = 0; i < tris.size(); ++i)
      for (int k = 0; k < 3; ++k) {
        auto& et = edgeTris[triE[i][std::size_t(k)]];
        (et[0] < 0 ? et[0] : et[1]) = std::int32_t(i);
        ++starStart[triV[i][std::size_t(k)] + 1];
      }
    for (std::size_t p = 0; p + 1 < starStart.size(); ++p) starStart[p + 1] += starStart[p];
    star.assign(std::size_t(starStart.back()), -1);
    {
      std::vector<std::int32_t> fill(starStart.begin(), starStart.end() - 1);
      for (std::size_t i = 0; i < tris.size(); ++i)
        for (int k = 0; k < 3; ++k)
          star[std::size_t(fill[triV[i][std::size_t(k)]]++)] = std::int32_t(i);
    }
    restX.assign(topo.pointCapacity(), V3::Zero());
    for (PointId p : topo.points()) {
      const Vec3 r = topo.restPosition(p);
      restX[Index(p)] = V3(r[0], r[1], r[2]);
    }
    built = true;
    revision = topo.revision();
    double sum = 0.0;
    std::size_t count = 0;
    for (EdgeId e : topo.edges()) {
      const auto v = topo.edgeVertices(e);
      const Vec3 a = topo.restPosition(v[0]), b = topo.restPosition(v[1]);
      sum += std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                       (a[2] - b[2]) * (a[2] - b[2]));
      ++count;
    }
    meanEdge = count ? sum / double(count) : 0.0;
  }

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
  static double flatness(const V3& a, const V3& b, const V3& c, const V3& e, double d) {
    // (a, b: the edge; c, e: the far corners of its two triangles)
    const V3 ab = b - a, n1 = ab.cross(c - a), n2 = (e - a).cross(ab);
    const double l2 = ab.squaredNorm(), q1 = n1.squaredNorm(), q2 = n2.squaredNorm();
    if (!(l2 > 0 && q1 > 0 && q2 > 0) || !(n1.dot(n2) > 0)) return 0.0;
    // (h sin(theta))^2 = max(|n1|, |n2|)^2 / |ab|^2 * |n1 x n2|^2 / (|n1|^2 |n2|^2): no root
    // but in the fade
    const double lift2 = std::max(q1, q2) * n1.cross(n2).squaredNorm() / (l2 * q1 * q2);
    const double lo = kFlatBelow * d, hi = kFlatAbove * d;
    if (lift2 <= lo * lo) return 1.0;
    if (!(lift2 < hi * hi)) return 0.0;
    const double t = (hi - std::sqrt(lift2)) / (hi - lo);
    return t * t * (3 - 2 * t);
  }
  // Measured once per edge and step: when a pair first asks, or beforehand for every edge of the
  // cache's edge pairs (measureCacheFlatness).
  std::uint64_t flatRevision = 0;  // the tables' revision edgeFlat is measured on
  std::uint32_t flatGeneration = 0;
  /// At the step's start: the edges' flatness is measured afresh at x as pairs ask for it.
  void resetFlatness() {
    flatRevision = revision;
    if (edgeFlat.size() != edgeTris.size() || ++flatGeneration == 0) {
      flatGeneration = 1;
      edgeFlat.assign(edgeTris.size(), EdgeFlat{});
    }
  }
  double flatnessOf(std::uint32_t e, std::span<const double> x) const {
    const EdgeFlat& r = edgeFlat[e];
    return r.stamp == flatGeneration ? r.flat : measureFlatness(e, x);
  }
  [[gnu::noinline]] double measureFlatness(std::uint32_t e, std::span<const double> x) const {
    EdgeFlat& r = edgeFlat[e];
    r.stamp = flatGeneration;
    r.flat = 0.0;
    const auto& et = edgeTris[e];
    if (et[0] < 0 || et[1] < 0) return r.flat;  // (a border: never flat)
    const auto& A = triV[std::size_t(et[0])];
    const auto& B = triV[std::size_t(et[1])];
    int k = 0;
    while (k < 2 && triE[std::size_t(et[0])][std::size_t(k)] != e) ++k;
    const std::uint32_t a = A[std::size_t((k + 1) % 3)], b = A[std::size_t((k + 2) % 3)];
    std::uint32_t far = B[0];
    for (int j = 0; j < 3; ++j)
      if (B[std::size_t(j)] != a && B[std::size_t(j)] != b) far = B[std::size_t(j)];
    r.flat = (flatness(surfacePoint(x, a), surfacePoint(x, b), surfacePoint(x, A[std::size_t(k)]),
                       surfacePoint(x, far), P.thickness));
    return r.flat;
  }
  /// A self pair of two edges' share of the law (x: the step's start): 1 - both edges'
  /// flatness, when the triangles beside them share no point: only then can the pairs of their
  /// corners and of their other edges, which make the pair of the two redundant, be pairs at
  /// all (in a tight fold a few triangles wide they share points).
  double edgePairScale(const std::array<std::int32_t, 2>& edges, std::span<const double> x) const {
    if (edgeFlat.empty() || flatRevision != revision || edges[0] < 0 || edges[1] < 0) return 1.0;
    const double fa = flatnessOf(std::uint32_t(edges[0]), x);
    if (fa == 0.0) return 1.0;
    const double fb = flatnessOf(std::uint32_t(edges[1]), x);
    if (fb == 0.0) return 1.0;
    return edgesApart(edges[0], edges[1]) ? 1.0 - fa * fb : 1.0;
  }
  /// Whether two inner edges' triangles (both beside each) share no point (false for a border
  /// edge, which is never flat): a property of the mesh.
  bool edgesApart(std::int32_t e1, std::int32_t e2) const {
    auto patch = [&](std::int32_t e, std::array<std::uint32_t, 6>& out) {
      if (e < 0 || std::size_t(e) >= edgeTris.size()) return false;
      int m = 0;
      for (const std::int32_t t : edgeTris[std::size_t(e)]) {
        if (t < 0) return false;
        for (const std::uint32_t q : triV[std::size_t(t)]) out[std::size_t(m++)] = q;
      }
      return true;
    };
    std::array<std::uint32_t, 6> a, b;
    if (!patch(e1, a) || !patch(e2, b)) return false;
    for (const std::uint32_t q : a)
      if (std::find(b.begin(), b.end(), q) != b.end()) return false;
    return true;
  }

  void surfaceBoxes(std::span<const double> x, std::vector<Box>& out) const {
    out.resize(tris.size());
    for (std::size_t i = 0; i < tris.size(); ++i) {
      Box b;
      for (int k = 0; k < 3; ++k) b.add(surfacePoint(x, triV[i][std::size_t(k)]));
      b.inflate(triMargin[i]);
      out[i] = b;
    }
  }

  void buildObstacleMeshes() {
    meshes.assign(O.size(), {});
    for (std::size_t k = 0; k < O.size(); ++k) {
      if (!meshLike(k)) continue;
      MeshObstacle& m = meshes[k];
      if (O[k].shape == Obstacle::Shape::Box)
        O[k].surface({0, 0, 0}, 0.0, m.vertices, m.triangles);
      else {
        m.vertices = O[k].vertices;
        m.triangles = O[k].triangles;
      }
      const auto& T = m.triangles;
      m.vertexOwner.assign(m.vertices.size(), -1);
      std::map<std::pair<int, int>, int> edgeIndex;
      m.triEdges.resize(T.size());
      for (std::size_t t = 0; t < T.size(); ++t) {
        for (int c = 0; c < 3; ++c) {
          const int a = T[t][std::size_t((c + 1) % 3)], b = T[t][std::size_t((c + 2) % 3)];
          const auto key = std::minmax(a, b);
          auto it = edgeIndex.find(key);
          if (it == edgeIndex.end()) {
            it = edgeIndex.emplace(key, int(m.edges.size())).first;
            m.edges.push_back({key.first, key.second});
            m.edgeOwner.push_back(int(t));
          }
          m.triEdges[t][std::size_t(c)] = it->second;
          if (m.vertexOwner[std::size_t(T[t][std::size_t(c)])] < 0)
            m.vertexOwner[std::size_t(T[t][std::size_t(c)])] = int(t);
        }
      }
      m.edgeTris.assign(m.edges.size(), {});
      m.vertexTris.assign(m.vertices.size(), {});
      for (std::size_t t = 0; t < T.size(); ++t)
        for (int c = 0; c < 3; ++c) {
          m.edgeTris[std::size_t(m.triEdges[t][std::size_t(c)])].push_back(int(t));
          m.vertexTris[std::size_t(T[t][std::size_t(c)])].push_back(int(t));
        }
    }
  }

  void obstacleBoxes(int k, std::vector<Box>& out) const {
    const double inflate = obstacleMargin[std::size_t(k)];
    const auto& T = meshes[std::size_t(k)].triangles;
    out.resize(T.size());
    for (std::size_t t = 0; t < T.size(); ++t) {
      Box b;
      for (int c = 0; c < 3; ++c) b.add(obstaclePoint(k, std::uint32_t(T[t][std::size_t(c)])));
      b.inflate(inflate);
      out[t] = b;
    }
  }

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
  void keepIfNear(Pair p, std::span<const double> x, double r, std::vector<Pair>& out,
                  bool features = false, int t = -1, const Screen* screen = nullptr) const {
    if (features && p.kind == Kind::EE) {
      if (!screen) p.scale = edgePairScale(p.edges, x);  // (screened: the caller set it)
      if (!(p.scale > 0)) return;  // (two flat edges: their corners' pairs hold the contact)
      orderEdges(p.id);            // (the same classification whichever way they were met)
    }
    Screen own;
    if (features && !screen) {
      if (surelyDropped(p.kind, p.surface, p.obstacle, p.id, p.shape, x, t, &own)) return;
      screen = &own;
    }
    // (a point and a triangle that the screening measured: its closest point, as evaluate's)
    const bool measured = features && screen && screen->set && p.kind == Kind::VT && p.shape == 3;
    Eval e = measured ? pointTriangleEval({pointOf(p, x, 0), pointOf(p, x, 1), pointOf(p, x, 2),
                                           pointOf(p, x, 3)},
                                          screen->closest, p.n0)
                      : evaluate(p, x);
    if (!(e.s < r)) return;
    if (features) {
      if (p.kind == Kind::EE || p.kind == Kind::EO) {
        if (!edgePairKept(pointOf(p, x, 0), pointOf(p, x, 1), pointOf(p, x, 2), pointOf(p, x, 3)))
          return;
      } else if (p.kind == Kind::VT || p.kind == Kind::VO || p.kind == Kind::OV) {
        if (!toFeature(p, e, x, t, measured ? &screen->snapped : nullptr)) return;
        if (p.shape != 3) e = evaluate(p, x);
      }
    }
    if (cacheOut) {  // (the cache's build: its compact record only)
      const bool ee = p.kind == Kind::EE;
      cacheOut->push_back({p.kind, p.surface, p.obstacle, ee ? p.edges[0] : p.tri, p.id, p.margins,
                           ee ? p.edges[1] : -1, e.s});
      return;
    }
    p.s0 = e.s;
    p.n0 = e.n;
    p.w0 = e.w;
    out.push_back(p);
  }

  /// Whether the penalty keeps the pair of edges q0-q1 and q2-q3: their closest points are inside
  /// both, and they are nearer than either edge is to the other's ends (by kFeatureTolerance),
  /// else they meet at an end, which is that point's pair (two aligned layers, an edge over an
  /// edge). One compiled copy, so that the screening and the classification get the same
  /// numbers.
  [[gnu::noinline]] static bool edgePairKept(const V3& q0, const V3& q1, const V3& q2,
                                             const V3& q3) {
    std::array<double, 2> st;
    if (!closestInsideSegments(q0, q1, q2, q3, st)) return false;
    const double s2 = ((q0 + st[0] * (q1 - q0)) - (q2 + st[1] * (q3 - q2))).squaredNorm();
    const double ends =
        std::min({pointSegmentDistance2(q0, q2, q3), pointSegmentDistance2(q1, q2, q3),
                  pointSegmentDistance2(q2, q0, q1), pointSegmentDistance2(q3, q0, q1)});
    constexpr double shrink = (1 - kFeatureTolerance) * (1 - kFeatureTolerance);
    return s2 < ends * shrink;
  }
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
  bool surelyDropped(Kind kind, std::uint8_t surface, std::int32_t obstacle,
                     std::array<std::uint32_t, 4> id, std::uint8_t shape, std::span<const double> x,
                     int t, Screen* screen = nullptr) const {
    auto point = [&](int i) {
      return (surface >> i) & 1 ? surfacePoint(x, id[std::size_t(i)])
                                : obstaclePoint(obstacle, id[std::size_t(i)]);
    };
    if (kind == Kind::EE || kind == Kind::EO) {
      if (kind == Kind::EE) orderEdges(id);  // (as keepIfNear orders them)
      return !edgePairKept(point(0), point(1), point(2), point(3));
    }
    if (kind != Kind::VT || shape != 3 || t < 0) return false;
    const V3 q0 = surfacePoint(x, id[0]), q1 = surfacePoint(x, id[1]), q2 = surfacePoint(x, id[2]),
             q3 = surfacePoint(x, id[3]);
    const auto closest = closestOnTriangle(q0, q1, q2, q3);
    const auto bw = snapToFeature(q0, q1, q2, q3, closest);  // (closestFeatureOnTriangle)
    if (screen) *screen = Screen{true, closest, bw};
    int on[3], m = 0;
    for (int c = 0; c < 3; ++c)
      if (-bw[std::size_t(c)] != 0.0) on[m++] = c;
    if (m == 1) {
      const std::uint32_t c = id[std::size_t(on[0] + 1)];
      return c < id[0] || pointOwner[c] != t;
    }
    if (m == 2) return edgeOwner[triE[std::size_t(t)][std::size_t(3 - on[0] - on[1])]] != t;
    return false;
  }

  /// The point of a point-triangle pair (e: the pair evaluated at x; t: the triangle's index)
  /// meets the triangle's interior, one of its edges or one of its corners. An edge or corner
  /// becomes the pair's feature (shape 2 or 1) when it is the closest feature of every triangle
  /// around it (the point is in its Voronoi region: no triangle beside it is nearer), and is
  /// kept only from its owner triangle, so that every feature the point meets counts once,
  /// whichever triangles the search pairs the point with. Returns false to drop the pair.
  bool toFeature(Pair& p, const Eval& e, std::span<const double> x, int t,
                 const std::array<double, 3>* snapped = nullptr) const {
    const V3 q = pointOf(p, x, 0);
    // (at a corner or on an edge within kFeatureTolerance: aligned surfaces; `snapped`: the
    // screening's snap of the same weights)
    const auto w = snapped ? *snapped
                           : snapToFeature(q, pointOf(p, x, 1), pointOf(p, x, 2), pointOf(p, x, 3),
                                           {-e.w[1], -e.w[2], -e.w[3]});
    int on[3], m = 0;
    for (int c = 0; c < 3; ++c)
      if (w[std::size_t(c)] != 0.0) on[m++] = c;
    if (m == 3 || m == 0) return true;
    const bool obstacleSide = p.kind == Kind::VO;  // the triangle is an obstacle's
    const MeshObstacle* mesh = obstacleSide ? &meshes[std::size_t(p.obstacle)] : nullptr;
    // The feature's squared distance (a snapped feature's is up to (1 + kFeatureTolerance)^2 of
    // the triangle's), and another triangle is nearer below (1 - kFeatureTolerance)^2 of it (as
    // the brute force compares distances): then the triangle a point was snapped from is never
    // nearer than the feature, and the feature's owner keeps the pair.
    const double d2 =
        (q - (w[0] * pointOf(p, x, 1) + w[1] * pointOf(p, x, 2) + w[2] * pointOf(p, x, 3)))
            .squaredNorm();
    constexpr double shrink = (1 - kFeatureTolerance) * (1 - kFeatureTolerance);
    const double near2 = d2 * shrink - 1e-300;
    // The squared distance from q to triangle u of the same side.
    auto dist2 = [&](int u) {
      std::array<V3, 3> c;
      for (int k = 0; k < 3; ++k)
        c[std::size_t(k)] =
            obstacleSide
                ? obstaclePoint(p.obstacle,
                                std::uint32_t(mesh->triangles[std::size_t(u)][std::size_t(k)]))
                : surfacePoint(x, triV[std::size_t(u)][std::size_t(k)]);
      const auto bw = closestOnTriangle(q, c[0], c[1], c[2]);
      return (q - (bw[0] * c[0] + bw[1] * c[1] + bw[2] * c[2])).squaredNorm();
    };
    // A triangle that holds the pair's own point (a self pair's neighbours) is not its contact.
    auto holdsPoint = [&](int u) {
      return p.kind == Kind::VT && shares(triV[std::size_t(u)], p.id[0]);
    };
    auto nearer = [&](int u) { return u != t && !holdsPoint(u) && dist2(u) < near2; };
    const std::uint32_t inv = kInvalidIndex;
    if (m == 2) {
      const int opposite = 3 - on[0] - on[1];
      const std::uint32_t a = p.id[std::size_t(on[0] + 1)], b = p.id[std::size_t(on[1] + 1)];
      if (obstacleSide) {
        const int edge = mesh->triEdges[std::size_t(t)][std::size_t(opposite)];
        if (mesh->edgeOwner[std::size_t(edge)] != t) return false;
        for (int u : mesh->edgeTris[std::size_t(edge)])
          if (nearer(u)) return false;
      } else {
        const std::uint32_t edge = triE[std::size_t(t)][std::size_t(opposite)];
        if (edgeOwner[edge] != t) return false;
        for (std::int32_t u : edgeTris[edge])
          if (u >= 0 && (holdsPoint(u) || nearer(u)))
            return false;  // (a triangle's own corner and edge: no pair)
      }
      p.id = {p.id[0], a, b, inv};
      p.shape = 2;
    } else {
      const std::uint32_t c = p.id[std::size_t(on[0] + 1)];
      // Two points: the pair is kept once (from the lower id for self pairs, from the surface's
      // point for obstacles), and when each is the other's closest feature.
      if (p.kind == Kind::OV || (p.kind == Kind::VT && c < p.id[0])) return false;
      // Kept only from the corner's owner triangle (checked first: it is the cheap test, and the
      // corner's other triangles, which the search also pairs with the point, all end here).
      if (obstacleSide ? mesh->vertexOwner[c] != t : pointOwner[c] != t) return false;
      const V3 qc = obstacleSide ? obstaclePoint(p.obstacle, c) : surfacePoint(x, c);
      for (std::int32_t k = starStart[p.id[0]]; k < starStart[p.id[0] + 1]; ++k) {
        const auto& U = triV[std::size_t(star[std::size_t(k)])];
        if (!obstacleSide && shares(U, c)) continue;
        const auto bw = closestOnTriangle(qc, surfacePoint(x, U[0]), surfacePoint(x, U[1]),
                                          surfacePoint(x, U[2]));
        const V3 f = bw[0] * surfacePoint(x, U[0]) + bw[1] * surfacePoint(x, U[1]) +
                     bw[2] * surfacePoint(x, U[2]);
        if ((qc - f).squaredNorm() < near2) return false;
      }
      if (obstacleSide) {
        for (int u : mesh->vertexTris[c])
          if (nearer(u)) return false;
      } else {
        for (std::int32_t k = starStart[c]; k < starStart[c + 1]; ++k)
          if (holdsPoint(star[std::size_t(k)]) || nearer(star[std::size_t(k)]))
            return false;  // (neighbours: no pair)
      }
      p.id = {p.id[0], c, inv, inv};
      p.shape = 1;
    }
    const std::uint8_t sides = p.kind == Kind::VO ? 0b0001 : p.kind == Kind::OV ? 0b0000 : 0b0001;
    p.surface = std::uint8_t(sides | (p.kind == Kind::VO ? 0 : (p.shape == 2 ? 0b0110 : 0b0010)));
    return true;
  }

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
  double reachOf(const Pair& p) const {
    const int count = p.points(), split = (p.kind == Kind::EE || p.kind == Kind::EO) ? 2 : 1;
    if (absoluteReach) {
      // Each primitive's largest displacement: shortening displacements keeps it valid.
      double a = 0, b = 0;
      for (int i = 0; i < count; ++i)
        (i < split ? a : b) = std::max(i < split ? a : b, motionOf(p, i).norm());
      return a + b;
    }
    V3 mean = V3::Zero();
    for (int i = 0; i < count; ++i) mean += motionOf(p, i) / double(count);
    double a = 0, b = 0;
    for (int i = 0; i < count; ++i)
      (i < split ? a : b) = std::max(i < split ? a : b, (motionOf(p, i) - mean).norm());
    return a + b;
  }
  /// The box a point sweeps.
  Box sweptPoint(std::span<const double> x, std::uint32_t v) const {
    Box b;
    const V3 q = surfacePoint(x, v);
    b.add(q);
    b.add(q + (*sweep)[v]);
    return b;
  }
  /// The triangles' swept boxes (the BVH's) for the displacements dx.
  void prepareSwept(std::span<const double> x, const std::vector<V3>& dx) {
    const bool rebuild = !bvhBuilt;
    bvhBuilt = true;
    tightBoxes(x, tight);
    boxes.resize(tris.size());
    const double eps = 1e-9 * std::max(meanEdge, 1e-300);
    for (std::size_t i = 0; i < tris.size(); ++i) {
      Box b = tight.tri[i];
      for (int k = 0; k < 3; ++k)
        b.add(surfacePoint(x, triV[i][std::size_t(k)]) + dx[triV[i][std::size_t(k)]]);
      b.inflate(eps);
      boxes[i] = b;
    }
    if (rebuild || bvh.size() != boxes.size())
      bvh.build(boxes);
    else
      bvh.refit(boxes);
  }

  /// The boxes of the triangles and of the edges at x (not grown): cheap tests before the
  /// closest points.
  struct Tight {
    std::vector<Box> tri, edge;  // by index in tris, by edge id
  };
  void tightBoxes(std::span<const double> x, Tight& out) const {
    out.tri.resize(tris.size());
    out.edge.resize(edgeOwner.size());
    for (std::size_t i = 0; i < tris.size(); ++i) {
      const auto& T = triV[i];
      const V3 a = surfacePoint(x, T[0]), b = surfacePoint(x, T[1]), c = surfacePoint(x, T[2]);
      Box& t = out.tri[i];
      t.lo = a.cwiseMin(b).cwiseMin(c);
      t.hi = a.cwiseMax(b).cwiseMax(c);
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t e = triE[i][std::size_t(k)];
        if (edgeOwner[e] != std::int32_t(i)) continue;
        const V3 p = surfacePoint(x, T[std::size_t((k + 1) % 3)]),
                 q = surfacePoint(x, T[std::size_t((k + 2) % 3)]);
        out.edge[e].lo = p.cwiseMin(q);
        out.edge[e].hi = p.cwiseMax(q);
      }
    }
  }
  Tight tight;  // at the x of the last prepare()

  void selfTrianglePair(int i, int j, std::span<const double> x, std::vector<Pair>& out,
                        bool features, const Tight& boxesAtX) const {
    const auto& A = triV[std::size_t(i)];
    const auto& B = triV[std::size_t(j)];
    if (sweep) {
      sweptTrianglePair(i, j, x, out);
      return;
    }
    const double r = triMargin[std::size_t(i)] + triMargin[std::size_t(j)];
    // The triangles' own boxes, grown by r: a primitive outside the other's cannot be within r.
    Box ba = boxesAtX.tri[std::size_t(i)], bb = boxesAtX.tri[std::size_t(j)];
    ba.inflate(r);
    bb.inflate(r);
    auto vt = [&](std::uint32_t v, int t, const Box& box) {
      const auto& T = triV[std::size_t(t)];
      if (!shares(T, v) && box.contains(surfacePoint(x, v))) {
        Pair p{Kind::VT, -1, {v, T[0], T[1], T[2]}, 0b1111};
        p.tri = t;
        p.margins = {i, j};
        keepIfNear(p, x, r, out, features, t);
      }
    };
    for (int k = 0; k < 3; ++k) {
      if (pointOwner[A[std::size_t(k)]] == i) vt(A[std::size_t(k)], j, bb);
      if (pointOwner[B[std::size_t(k)]] == j) vt(B[std::size_t(k)], i, ba);
    }
    for (int a = 0; a < 3; ++a) {
      const std::uint32_t ea = triE[std::size_t(i)][std::size_t(a)];
      if (edgeOwner[ea] != i) continue;
      const std::uint32_t a0 = A[std::size_t((a + 1) % 3)], a1 = A[std::size_t((a + 2) % 3)];
      Box sa = boxesAtX.edge[ea];
      sa.inflate(r);
      if (!sa.overlaps(bb)) continue;
      for (int b = 0; b < 3; ++b) {
        const std::uint32_t eb = triE[std::size_t(j)][std::size_t(b)];
        if (edgeOwner[eb] != j) continue;
        const std::uint32_t b0 = B[std::size_t((b + 1) % 3)], b1 = B[std::size_t((b + 2) % 3)];
        if (a0 == b0 || a0 == b1 || a1 == b0 || a1 == b1) continue;
        if (!sa.overlaps(boxesAtX.edge[eb])) continue;
        Pair p{Kind::EE, -1, {a0, a1, b0, b1}, 0b1111};
        p.margins = {i, j};
        p.edges = {std::int32_t(ea), std::int32_t(eb)};
        keepIfNear(p, x, r, out, features);
      }
    }
  }

  /// The displacement bound's pairs of two triangles whose swept boxes overlap: every
  /// point-triangle and edge-edge pair whose points' swept boxes overlap and whose distance
  /// is less than its reach.
  void sweptTrianglePair(int i, int j, std::span<const double> x, std::vector<Pair>& out) const {
    const auto& A = triV[std::size_t(i)];
    const auto& B = triV[std::size_t(j)];
    const Box& ba = boxes[std::size_t(i)];
    const Box& bb = boxes[std::size_t(j)];
    auto keep = [&](const Pair& p) { keepIfNear(p, x, reachOf(p), out); };
    auto vt = [&](std::uint32_t v, int t, const Box& box) {
      const auto& T = triV[std::size_t(t)];
      if (!shares(T, v) && box.overlaps(sweptPoint(x, v)))
        keep(Pair{Kind::VT, -1, {v, T[0], T[1], T[2]}, 0b1111});
    };
    for (int k = 0; k < 3; ++k) {
      if (pointOwner[A[std::size_t(k)]] == i) vt(A[std::size_t(k)], j, bb);
      if (pointOwner[B[std::size_t(k)]] == j) vt(B[std::size_t(k)], i, ba);
    }
    for (int a = 0; a < 3; ++a) {
      if (edgeOwner[triE[std::size_t(i)][std::size_t(a)]] != i) continue;
      const std::uint32_t a0 = A[std::size_t((a + 1) % 3)], a1 = A[std::size_t((a + 2) % 3)];
      Box sa = sweptPoint(x, a0);
      sa.add(sweptPoint(x, a1));
      if (!sa.overlaps(bb)) continue;
      for (int b = 0; b < 3; ++b) {
        if (edgeOwner[triE[std::size_t(j)][std::size_t(b)]] != j) continue;
        const std::uint32_t b0 = B[std::size_t((b + 1) % 3)], b1 = B[std::size_t((b + 2) % 3)];
        if (a0 == b0 || a0 == b1 || a1 == b0 || a1 == b1) continue;
        Box sb = sweptPoint(x, b0);
        sb.add(sweptPoint(x, b1));
        if (sa.overlaps(sb)) keep(Pair{Kind::EE, -1, {a0, a1, b0, b1}, 0b1111});
      }
    }
  }

  void meshTrianglePair(int k, int i, int j, std::span<const double> x, std::vector<Pair>& out,
                        bool features) const {
    const MeshObstacle& m = meshes[std::size_t(k)];
    const auto& A = triV[std::size_t(i)];
    const auto& T = m.triangles[std::size_t(j)];
    auto keep = [&](Pair p, int t) {
      p.tri = t;
      p.margins = {i, -1};
      const double r =
          sweep ? reachOf(p) : triMargin[std::size_t(i)] + obstacleMargin[std::size_t(k)];
      keepIfNear(p, x, r, out, features, t);
    };
    for (int c = 0; c < 3; ++c) {
      if (pointOwner[A[std::size_t(c)]] == i)
        keep(
            Pair{Kind::VO,
                 k,
                 {A[std::size_t(c)], std::uint32_t(T[0]), std::uint32_t(T[1]), std::uint32_t(T[2])},
                 0b0001},
            j);
      if (m.vertexOwner[std::size_t(T[std::size_t(c)])] == j)
        keep(Pair{Kind::OV, k, {std::uint32_t(T[std::size_t(c)]), A[0], A[1], A[2]}, 0b1110}, i);
    }
    for (int a = 0; a < 3; ++a) {
      if (edgeOwner[triE[std::size_t(i)][std::size_t(a)]] != i) continue;
      const std::uint32_t a0 = A[std::size_t((a + 1) % 3)], a1 = A[std::size_t((a + 2) % 3)];
      for (int b = 0; b < 3; ++b) {
        const int eb = m.triEdges[std::size_t(j)][std::size_t(b)];
        if (m.edgeOwner[std::size_t(eb)] != j) continue;
        keep(Pair{Kind::EO,
                  k,
                  {a0, a1, std::uint32_t(m.edges[std::size_t(eb)][0]),
                   std::uint32_t(m.edges[std::size_t(eb)][1])},
                  0b0011},
             -1);
      }
    }
  }

  /// All pairs within their margins at x (prepare() first): with `features`, the penalty's
  /// (closest features, each once), else every pair of primitives (the displacement bound's).
  void collect(std::span<const double> x, std::vector<Pair>& out, bool features) {
    out.clear();
    searchPairs(x, out, features);
    analyticPairs(x, out);
  }
  /// The self and obstacle-mesh pairs (by the BVHs).
  void searchPairs(std::span<const double> x, std::vector<Pair>& out, bool features) {
    if (P.selfContact)
      bvh.selfPairs([&](int i, int j) { selfTrianglePair(i, j, x, out, features, tight); });
    for (std::size_t k = 0; k < O.size(); ++k) {
      if (!meshLike(k)) continue;
      refitObstacle(k);
      bvh.crossPairs(meshes[k].bvh,
                     [&](int i, int j) { meshTrianglePair(int(k), i, j, x, out, features); });
    }
  }
  /// Obstacle mesh k's boxes (grown by its margin) and hierarchy, at its current pose.
  void refitObstacle(std::size_t k) {
    MeshObstacle& m = meshes[k];
    obstacleBoxes(int(k), m.boxes);
    if (m.bvh.size() != m.boxes.size() || m.bvh.empty())
      m.bvh.build(m.boxes);
    else
      m.bvh.refit(m.boxes);
  }
  /// The displacement bound's pairs among slow points (sweep set), from the cache: those whose
  /// distance (at most what it was, less its points' motion since) is below their reach.
  void nearFromCache(std::span<const double> x, const std::vector<char>& fast,
                     std::vector<Pair>& out) {
    // (a pair's reach is at most twice its points' largest displacement, doubled)
    moveLength.resize(sweep->size());
    double largest =
        0.0;  // of every point's and obstacle's displacement (infinity: one is not finite)
    bool finite = true;
    for (std::size_t p = 0; p < sweep->size(); ++p) {
      moveLength[p] = (*sweep)[p].norm();
      finite = finite && std::isfinite(moveLength[p]);
      largest = std::max(largest, moveLength[p]);
    }
    for (const V3& m : move) {
      finite = finite && std::isfinite(m.norm());
      largest = std::max(largest, m.norm());
    }
    if (!finite) largest = kInf;
    const double shrink = 2 * largestSinceCache;
    auto visit = [&](std::size_t ci, std::vector<Pair>& to) {
      const Cached& c = cache[ci];
      bool slow = true;
      double largestMove = 0.0;
      for (int i = 0; i < 4; ++i) {
        if ((c.surface >> i) & 1) {
          const std::uint32_t q = c.id[std::size_t(i)];
          slow = slow && !fast[q];
          largestMove = std::max(largestMove, moveLength[q]);
        } else if (c.obstacle >= 0) {
          largestMove = std::max(largestMove, move[std::size_t(c.obstacle)].norm());
        }
      }
      if (!slow) return;  // (found around the fast points)
      const double lower = c.s - cachedShrink(c);
      if (lower >= 4 * largestMove) return;
      const Pair p = c.pair();
      const double reach = reachOf(p);
      if (lower < reach) keepIfNear(p, x, reach, to);
    };
    // (visited on several threads when there are many: runs of the visits, their pairs
    // appended in order, as one thread would have found them)
    // A pair is skipped below when its distance less its shrink is at least four times its
    // points' largest motion. Every pair is at least cacheNearest apart at the cache's build:
    // when only a few points move more than a quarter of cacheNearest - shrink (and no obstacle
    // does), only their pairs can pass, and they are visited (in the cache's order, as the
    // whole pass would).
    const double still = 0.25 * (cacheNearest - shrink);
    bool obstaclesStill = true;
    for (const V3& m : move) obstaclesStill = obstaclesStill && m.norm() <= still;
    std::vector<std::uint32_t>& moving = movingScratch;
    moving.clear();
    // (the index covers the points of the cache's pairs; a point beyond it is in none)
    const bool indexed = still > 0 && obstaclesStill && !cacheByPointStart.empty() &&
                         cacheByPointStart.size() <= moveLength.size() + 1;
    if (indexed)
      for (std::size_t p = 0; p + 1 < cacheByPointStart.size(); ++p)
        if (!(moveLength[p] <= still)) moving.push_back(std::uint32_t(p));
    if (indexed && 16 * moving.size() < moveLength.size()) {
      std::vector<std::uint32_t>& visits = visitScratch;
      ascendingOnce(cache.size(), recordBits, visits, [&](auto&& mark) {
        for (const std::uint32_t p : moving)
          for (std::uint32_t k = cacheByPointStart[p]; k < cacheByPointStart[p + 1]; ++k)
            mark(cacheByPoint[k]);
      });
      gatherInParts(visits.size(), partsFor(visits.size(), kRecordsPerThread), partPairs, out,
                    [&](std::size_t begin, std::size_t end, std::vector<Pair>& to) {
                      for (std::size_t k = begin; k < end; ++k)
                        if (!(double(cacheLow[visits[k]]) - shrink >= 4 * largest))
                          visit(visits[k], to);
                    });
      return;
    }
    gatherInParts(cache.size(), partsFor(cache.size(), kRecordsPerThread), partPairs, out,
                  [&](std::size_t begin, std::size_t end, std::vector<Pair>& to) {
                    for (std::size_t ci = begin; ci < end; ++ci) {
                      if (double(cacheLow[ci]) - shrink >= 4 * largest)
                        continue;  // (the test below, with bounds for every pair)
                      visit(ci, to);
                    }
                  });
  }

  /// The displacement bound's pairs that hold a fast point (prepareSwept first): each triangle
  /// with a fast corner against the triangles and obstacle triangles its swept box meets.
  void searchAround(std::span<const double> x, const std::vector<char>& fast,
                    std::vector<Pair>& out) {
    auto hasFast = [&](std::size_t t) {
      return fast[triV[t][0]] || fast[triV[t][1]] || fast[triV[t][2]];
    };
    for (std::size_t k = 0; k < O.size(); ++k)
      if (meshLike(k)) refitObstacle(k);
    for (std::size_t i = 0; i < tris.size(); ++i) {
      if (!hasFast(i)) continue;
      if (P.selfContact)
        bvh.query(boxes[i], [&](int j) {
          // Each pair of triangles once: from the lower index when both hold a fast point.
          if (std::size_t(j) == i || (hasFast(std::size_t(j)) && std::size_t(j) < i)) return;
          sweptTrianglePair(int(i), j, x, out);
        });
      for (std::size_t k = 0; k < O.size(); ++k)
        if (meshLike(k))
          meshes[k].bvh.query(boxes[i],
                              [&](int j) { meshTrianglePair(int(k), int(i), j, x, out, false); });
    }
  }

  /// The pairs with planes, spheres and capsules.
  void analyticPairs(std::span<const double> x, std::vector<Pair>& out) {
    for (std::size_t k = 0; k < O.size(); ++k) {
      if (meshLike(k)) {
        continue;
      } else if (O[k].shape == Obstacle::Shape::Sphere || O[k].shape == Obstacle::Shape::Capsule) {
        // Each triangle's closest feature (its interior, an edge, a corner), each feature once
        // (from the first triangle that meets it). On several threads when there are many
        // triangles: each over a contiguous run of them, each feature once within its run; the
        // runs' pairs are then appended in order, each feature once, so from the first triangle
        // that meets it, as one thread would.
        pointDistances(int(k), x);
        // (a feature's key: a corner's point id, or an edge's id + the number of point slots)
        auto run = [&](std::size_t begin, std::size_t end, std::vector<char>& seen,
                       std::vector<Pair>& to, std::vector<std::uint32_t>& keys) {
          for (std::size_t t = begin; t < end; ++t) {
            const auto& T = triV[t];
            const double within =
                triMargin[t] + obstacleMargin[k];  // (the obstacle's motion included)
            const double smin = std::min({pointSdf[T[0]], pointSdf[T[1]], pointSdf[T[2]]});
            const std::array<V3, 4> q{surfacePoint(x, T[0]), surfacePoint(x, T[1]),
                                      surfacePoint(x, T[2]), V3::Zero()};
            if (smin - longestEdge({q[0], q[1], q[2]}) >= within) continue;
            if (O[k].shape == Obstacle::Shape::Sphere &&
                planeSeparates(int(k), {q[0], q[1], q[2]}, within))
              continue;
            const Eval e = roundObstacle(int(k), q, 3, V3::UnitZ());
            if (!(e.s < within)) continue;
            Pair pr{Kind::FO, std::int32_t(k), {0, 0, 0, 0}, 0};
            int m = 0;
            for (int c = 0; c < 3; ++c)
              if (e.w[std::size_t(c)] > 0) {
                pr.id[std::size_t(m)] = T[std::size_t(c)];
                pr.w0[std::size_t(m)] = e.w[std::size_t(c)];
                ++m;
              }
            if (m == 0) continue;
            std::uint32_t key = std::uint32_t(kInvalidIndex);
            if (m == 1) {
              key = pr.id[0];
            } else if (m == 2) {
              const int opposite = e.w[0] > 0 ? (e.w[1] > 0 ? 2 : 1) : 0;
              key = std::uint32_t(pointOwner.size()) + triE[t][std::size_t(opposite)];
            }
            if (m < 3 && std::exchange(seen[key], 1)) continue;
            pr.surface = std::uint8_t((1 << m) - 1);
            // (the triangle's interior: the pair is the triangle itself, as just measured)
            const Eval f = m == 3 ? e : evaluate(pr, x);
            pr.s0 = f.s;
            pr.n0 = f.n;
            pr.w0 = f.w;
            to.push_back(pr);
            keys.push_back(key);
          }
        };
        const std::size_t slots = pointOwner.size() + edgeOwner.size();
        const int parts = partsFor(tris.size(), kTrianglesPerThread);
        if (parts <= 1) {
          seenFeature.assign(slots, 0);
          featureKeys.clear();
          run(0, tris.size(), seenFeature, out, featureKeys);
        } else {
          partPairs.resize(std::size_t(parts));
          partSeen.resize(std::size_t(parts));
          partKeys.resize(std::size_t(parts));
          inParts(tris.size(), parts, [&](int j, std::size_t begin, std::size_t end) {
            const std::size_t u = std::size_t(j);
            partSeen[u].assign(slots, 0);
            partPairs[u].clear();
            partKeys[u].clear();
            run(begin, end, partSeen[u], partPairs[u], partKeys[u]);
          });
          seenFeature.assign(slots, 0);
          for (std::size_t u = 0; u < partPairs.size(); ++u)
            for (std::size_t i = 0; i < partPairs[u].size(); ++i) {
              const std::uint32_t key = partKeys[u][i];
              if (key != std::uint32_t(kInvalidIndex) && std::exchange(seenFeature[key], 1))
                continue;
              out.push_back(partPairs[u][i]);
            }
        }
      } else {
        for (std::uint32_t p = 0; p < pointOwner.size(); ++p) {
          if (pointOwner[p] < 0) continue;
          V3 g;
          const double s = sdf(int(k), surfacePoint(x, p), g);
          if (s < pointMargin[p] + obstacleMargin[k]) {
            Pair pr{Kind::PO, std::int32_t(k), {p, 0, 0, 0}, 0b0001};
            pr.s0 = s;
            pr.n0 = g;
            pr.w0 = {1, 0, 0, 0};
            out.push_back(pr);
          }
        }
      }
    }
  }

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
      Pair p{kind, obstacle, id, surface};
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
  bool cacheCovers(std::span<const double> x, double rSelf, const std::vector<double>& rObstacle) {
    if (!(P.searchSlack > 0) || !cacheBuilt || cacheRevision != topo.revision() ||
        cacheX.size() != x.size())
      return false;
    const std::size_t n = x.size() / 3;
    sinceCache.assign(n, 0.0);
    double m = 0.0;
    for (std::size_t p = 0; p < n; ++p)
      if (p < pointOwner.size() && pointOwner[p] >= 0) {
        sinceCache[p] =
            (surfacePoint(x, std::uint32_t(p)) - surfacePoint(cacheX, std::uint32_t(p))).norm();
        m = std::max(m, sinceCache[p]);
      }
    if (!(m < kInf)) return false;
    if (P.selfContact && !(cacheR - 2 * m >= rSelf)) return false;
    obstacleSinceCache.assign(O.size(), 0.0);
    largestSinceCache = m;
    for (std::size_t k = 0; k < O.size(); ++k) {
      if (!meshLike(k)) continue;
      obstacleSinceCache[k] = (offset[k] - cacheOffset[k]).norm();
      largestSinceCache = std::max(largestSinceCache, obstacleSinceCache[k]);
      if (!(cacheR - m - obstacleSinceCache[k] >= rObstacle[k])) return false;
    }
    return true;
  }
  /// Searches every self and obstacle-mesh pair within r at x into the cache.
  void buildCache(std::span<const double> x, double r) {
    const std::vector<double> savedPoint = pointMargin, savedObstacle = obstacleMargin;
    pointMargin.assign(x.size() / 3, 0.5 * r);
    obstacleMargin.assign(O.size(), 0.5 * r);
    prepare(x);
    cache.clear();
    cacheBuilt = false;
    cacheOut = &cache;
    try {
      searchPairs(x, nearPairs, false);
    } catch (...) {
      cacheOut = nullptr;
      cache.clear();
      pointMargin = savedPoint;
      obstacleMargin = savedObstacle;
      throw;
    }
    cacheOut = nullptr;
    pointMargin = savedPoint;
    obstacleMargin = savedObstacle;
    triangleMargins();
    indexCache();
    cacheX.assign(x.begin(), x.end());
    cacheOffset = offset;
    cacheRevision = topo.revision();
    cacheR = r;
    cacheBuilt = true;
    ++cacheBuilds;
  }
  /// The cached pairs' distances, each rounded down to a float, in an array of their own: the
  /// displacement bound skips most pairs by their distance alone, reading 4 bytes a pair where
  /// a record is 48.
  std::vector<float> cacheLow;
  double cacheNearest = kInf;  // the least of cacheLow
  /// Per surface point slot, the cached pairs that hold it (CSR): when a few points move far,
  /// the displacement bound looks only at their pairs (every other pair is farther apart than
  /// four times its points' motion).
  std::vector<std::uint32_t> cacheByPointStart, cacheByPoint;
  void indexCache() {
    apartIndexed = false;
    cacheEdgePairs = std::size_t(std::count_if(cache.begin(), cache.end(),
                                               [](const Cached& c) { return c.kind == Kind::EE; }));
    cacheLow.resize(cache.size());
    cacheNearest = kInf;
    for (std::size_t i = 0; i < cache.size(); ++i) {
      float f = float(cache[i].s);
      if (double(f) > cache[i].s) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
      cacheLow[i] = f;
      cacheNearest = std::min(cacheNearest, double(f));
    }
    std::size_t n = 0;
    for (const Cached& c : cache)
      for (int i = 0; i < 4; ++i)
        if (((c.surface >> i) & 1) && c.id[std::size_t(i)] != std::uint32_t(kInvalidIndex))
          n = std::max<std::size_t>(n, c.id[std::size_t(i)] + 1);
    cacheByPointStart.assign(n + 1, 0);
    for (const Cached& c : cache)
      for (int i = 0; i < 4; ++i)
        if (((c.surface >> i) & 1) && c.id[std::size_t(i)] != std::uint32_t(kInvalidIndex))
          ++cacheByPointStart[c.id[std::size_t(i)] + 1];
    for (std::size_t p = 0; p < n; ++p) cacheByPointStart[p + 1] += cacheByPointStart[p];
    cacheByPoint.resize(cacheByPointStart.back());
    std::vector<std::uint32_t> fill(cacheByPointStart.begin(), cacheByPointStart.end() - 1);
    for (std::size_t ci = 0; ci < cache.size(); ++ci)
      for (int i = 0; i < 4; ++i)
        if (((cache[ci].surface >> i) & 1) &&
            cache[ci].id[std::size_t(i)] != std::uint32_t(kInvalidIndex))
          cacheByPoint[fill[cache[ci].id[std::size_t(i)]]++] = std::uint32_t(ci);
  }
  /// How far a cached pair's distance may have shrunk since the cache was built.
  double cachedShrink(const Cached& c) const {
    // (the cache holds whole primitives: four points each)
    const int split = (c.kind == Kind::EE || c.kind == Kind::EO) ? 2 : 1;
    double a = 0, b = 0;
    for (int i = 0; i < 4; ++i) {
      const double m = (c.surface >> i) & 1 ? sinceCache[c.id[std::size_t(i)]]
                                            : obstacleSinceCache[std::size_t(c.obstacle)];
      (i < split ? a : b) = std::max(i < split ? a : b, m);
    }
    return a + b;
  }
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
  void pairsFromCache(std::span<const double> x, std::vector<Pair>& out) {
    // Between flat layers most cached pairs are of two edges that are both flat, whose triangles
    // share no point (their share is 0: edgePairScale drops them). Such a pair is not read at
    // all: of the apart pairs of two edges (markApart), only the records of the edges that are
    // not flat now (flatness below exactly 1) are visited.
    const bool flatFirst = cacheEdgePairs > 0 && !edgeFlat.empty() && flatRevision == revision;
    if (!flatFirst) {
      gatherInParts(cache.size(), partsFor(cache.size(), kRecordsPerThread), partPairs, out,
                    [&](std::size_t begin, std::size_t end, std::vector<Pair>& to) {
                      for (std::size_t ci = begin; ci < end; ++ci) classifyCached(ci, x, to);
                    });
      return;
    }
    if (!apartIndexed) markApart();
    // The records visited, ascending: every record but the apart edge pairs (cacheOthers), and
    // those apart edge pairs that hold an edge that is not flat now.
    measureCacheFlatness(x, partsFor(cacheEdges.size(), kRecordsPerThread));
    ascendingOnce(cache.size(), recordBits, cacheVisitExtra, [&](auto&& mark) {
      for (const std::uint32_t e : apartEdges)
        if (flatnessOf(e, x) != 1.0)
          for (std::uint32_t k = apartByEdgeStart[e]; k < apartByEdgeStart[e + 1]; ++k)
            mark(apartByEdge[k]);
    });
    cacheVisit.resize(cacheOthers.size() + cacheVisitExtra.size());
    std::merge(cacheOthers.begin(), cacheOthers.end(), cacheVisitExtra.begin(),
               cacheVisitExtra.end(), cacheVisit.begin());
    gatherInParts(cacheVisit.size(), partsFor(cacheVisit.size(), kRecordsPerThread), partPairs, out,
                  [&](std::size_t begin, std::size_t end, std::vector<Pair>& to) {
                    for (std::size_t k = begin; k < end; ++k) classifyCached(cacheVisit[k], x, to);
                  });
  }
  /// Classifies cached record ci at x into `to`, as the search would.
  void classifyCached(std::size_t ci, std::span<const double> x, std::vector<Pair>& to) const {
    const Cached& c = cache[ci];
    const double within = searchMargin(c);
    // (it cannot be within its margin; the shrink is at most twice the largest motion)
    if (c.s >= within && (c.s - 2 * largestSinceCache >= within || c.s - cachedShrink(c) >= within))
      return;
    Pair p = c.pair();
    if (c.kind == Kind::EE && !((p.scale = edgePairScale(p.edges, x)) > 0))
      return;  // (as keepIfNear would)
    const int t =
        c.kind == Kind::EE ? -1 : c.tri;  // (an edge pair's record holds its first edge there)
    Screen screen;
    if (surelyDropped(c.kind, c.surface, c.obstacle, c.id, 3, x, t, &screen)) return;
    keepIfNear(p, x, within, to, true, t, &screen);
  }
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
  void markApart() {
    std::vector<std::uint8_t> apart(cache.size(), 0);
    cacheEdges.clear();
    for (const Cached& c : cache)
      if (c.kind == Kind::EE) {
        cacheEdges.push_back(std::uint32_t(c.tri));
        cacheEdges.push_back(std::uint32_t(c.edge2));
      }
    std::sort(cacheEdges.begin(), cacheEdges.end());
    cacheEdges.erase(std::unique(cacheEdges.begin(), cacheEdges.end()), cacheEdges.end());
    cacheOthers.clear();
    apartByEdgeStart.assign(edgeTris.size() + 1, 0);
    for (std::size_t ci = 0; ci < cache.size(); ++ci) {
      const Cached& c = cache[ci];
      if (c.kind == Kind::EE) apart[ci] = edgesApart(c.tri, c.edge2);
      if (!apart[ci]) {
        cacheOthers.push_back(std::uint32_t(ci));
        continue;
      }
      ++apartByEdgeStart[std::size_t(c.tri) + 1];
      ++apartByEdgeStart[std::size_t(c.edge2) + 1];
    }
    apartEdges.clear();
    for (std::size_t e = 0; e + 1 < apartByEdgeStart.size(); ++e) {
      if (apartByEdgeStart[e + 1] > 0) apartEdges.push_back(std::uint32_t(e));
      apartByEdgeStart[e + 1] += apartByEdgeStart[e];
    }
    apartByEdge.resize(apartByEdgeStart.back());
    std::vector<std::uint32_t> fill(apartByEdgeStart.begin(), apartByEdgeStart.end() - 1);
    for (std::size_t ci = 0; ci < cache.size(); ++ci)
      if (apart[ci]) {
        apartByEdge[fill[std::size_t(cache[ci].tri)]++] = std::uint32_t(ci);
        apartByEdge[fill[std::size_t(cache[ci].edge2)]++] = std::uint32_t(ci);
      }
    apartIndexed = true;
  }
  static constexpr std::size_t kRecordsPerThread = 16384, kTrianglesPerThread = 8192;
  /// How many threads work on n items, each given at least `least` of them.
  int partsFor(std::size_t n, std::size_t least) const {
    const std::size_t most = std::max<std::size_t>(1, n / std::max<std::size_t>(1, least));
    return int(std::min<std::size_t>(std::size_t(threads), most));
  }
  int threads = 1;  // the threads contact's loops may use (Contact's constructor sets it)
  /// The flatness at x of every edge of the cache's self pairs of two edges, on `parts` threads
  /// (each edge by one thread: no two threads write one edge's record).
  void measureCacheFlatness(std::span<const double> x, int parts) const {
    if (edgeFlat.empty() || flatRevision != revision) return;
    inParts(cacheEdges.size(), parts, [&](int, std::size_t begin, std::size_t end) {
      for (std::size_t k = begin; k < end; ++k) {
        const std::uint32_t e = cacheEdges[k];
        if (e < edgeFlat.size() && edgeFlat[e].stamp != flatGeneration) measureFlatness(e, x);
      }
    });
  }

  /// Brings the tables up to date (a topology change rebuilds them).
  void updateTables() {
    if (!built || revision != topo.revision()) {
      rebuildTables();
      bvhBuilt = false;
    }
  }

  /// Triangle margins from the point margins, then the boxes and the BVH at x.
  void triangleMargins() {
    triMargin.resize(tris.size());
    for (std::size_t i = 0; i < tris.size(); ++i) {
      triMargin[i] =
          std::max({pointMargin[triV[i][0]], pointMargin[triV[i][1]], pointMargin[triV[i][2]]});
    }
  }
  void prepare(std::span<const double> x) {
    triangleMargins();
    const bool rebuild = !bvhBuilt;
    bvhBuilt = true;
    tightBoxes(x, tight);
    surfaceBoxes(x, boxes);
    if (rebuild || bvh.size() != boxes.size())
      bvh.build(boxes);
    else
      bvh.refit(boxes);
  }

  /// A self pair by its points, the same whichever way it was found.
  static std::array<std::uint32_t, 5> exclusionKey(const Pair& p) {
    std::array<std::uint32_t, 4> id = p.id;
    if (p.kind == Kind::EE) {
      std::array<std::uint32_t, 2> a{std::min(id[0], id[1]), std::max(id[0], id[1])};
      std::array<std::uint32_t, 2> b{std::min(id[2], id[3]), std::max(id[2], id[3])};
      if (b < a) std::swap(a, b);
      id = {a[0], a[1], b[0], b[1]};
    } else {
      std::sort(id.begin() + 1, id.end());
    }
    return {std::uint32_t(p.kind), id[0], id[1], id[2], id[3]};
  }

  /// The self pair of an exclusion key.
  static Pair fromKey(const std::array<std::uint32_t, 5>& key) {
    Pair p{Kind(key[0]), -1, {key[1], key[2], key[3], key[4]}, 0};
    int used = 0;
    for (int i = 0; i < 4; ++i)
      if (p.id[std::size_t(i)] != std::uint32_t(kInvalidIndex)) ++used;
    if (p.kind == Kind::VT) p.shape = std::uint8_t(used - 1);
    p.surface = std::uint8_t((1 << used) - 1);
    return p;
  }
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
  static Pair closestFeature(const Pair& p) {
    Pair f = p;
    const std::uint32_t inv = kInvalidIndex;
    if (p.kind == Kind::VT) {
      std::array<std::uint32_t, 3> on{inv, inv, inv};
      int m = 0;
      for (int c = 0; c < 3; ++c)
        if (std::abs(p.w0[std::size_t(c + 1)]) > 1e-9)
          on[std::size_t(m++)] = p.id[std::size_t(c + 1)];
      if (m == 0 || m == 3) return f;
      f.id = {p.id[0], on[0], on[1], inv};
      f.shape = std::uint8_t(m);
      f.surface = std::uint8_t((1 << (m + 1)) - 1);
      return f;
    }
    if (p.kind != Kind::EE) return f;
    // An end of an edge stands for the edge.
    auto side = [&](std::uint32_t a, std::uint32_t b, double t, std::array<std::uint32_t, 2>& out) {
      if (t <= 1e-9)
        out = {a, inv};
      else if (t >= 1 - 1e-9)
        out = {b, inv};
      else
        out = {a, b};
      return out[1] == inv ? 1 : 2;
    };
    std::array<std::uint32_t, 2> A, B;
    const int na = side(p.id[0], p.id[1], p.w0[1], A), nb = side(p.id[2], p.id[3], -p.w0[3], B);
    if (na == 2 && nb == 2) return f;
    if (na == 1)
      f.id = {A[0], B[0], B[1], inv};
    else
      f.id = {B[0], A[0], A[1], inv};
    f.kind = Kind::VT;
    f.shape = std::uint8_t(na == 1 ? nb : na);
    f.surface = std::uint8_t((1 << (f.shape + 1)) - 1);
    return f;
  }

  /// Whether a self pair is within d in the rest configuration (neighbours in the material).
  bool restNeighbours(const Pair& p) const {
    std::array<V3, 4> rest;
    rest.fill(V3::Zero());
    const int count = p.points(), split = (p.kind == Kind::EE || p.kind == Kind::EO) ? 2 : 1;
    for (int i = 0; i < count; ++i) rest[std::size_t(i)] = restX[p.id[std::size_t(i)]];
    // (primitives whose boxes are farther apart than d along an axis are: most pairs, between
    // layers of a fold that are far apart in the material)
    V3 loA = rest[0], hiA = rest[0], loB = rest[std::size_t(split)], hiB = rest[std::size_t(split)];
    for (int i = 1; i < split; ++i) {
      loA = loA.cwiseMin(rest[std::size_t(i)]);
      hiA = hiA.cwiseMax(rest[std::size_t(i)]);
    }
    for (int i = split + 1; i < count; ++i) {
      loB = loB.cwiseMin(rest[std::size_t(i)]);
      hiB = hiB.cwiseMax(rest[std::size_t(i)]);
    }
    if (((loB - hiA).maxCoeff() > P.thickness) || ((loA - hiB).maxCoeff() > P.thickness))
      return false;
    return evaluatePoints(p, rest).s <= P.thickness;
  }
  bool isReleased(const Pair& p) const {
    if (released.empty()) return false;
    bool all = true;
    crossPoints(p, [&](const std::pair<std::uint32_t, std::uint32_t>& ab) {
      all = all && released.count(ab);
    });
    return all;
  }
  /// A self pair at distance s0 that has no penalty, no friction and no bound: neighbours in the
  /// material within d, not yet separated beyond d.
  bool excludedPair(const Pair& p) const {
    return p.obstacle < 0 && p.s0 <= P.thickness && restNeighbours(p) && !isReleased(p);
  }

  /// Whether sphere k is farther than `within` from the triangle's plane, so from the triangle
  /// (the centre's distance to the plane is at most its distance to the triangle).
  /// A sliver (its corners nearly in line: the cross product's direction is mostly rounding) is
  /// never culled so, and the plane's distance is taken less a margin for rounding.
  bool planeSeparates(int k, const std::array<V3, 3>& tv, double within) const {
    const Obstacle& o = O[std::size_t(k)];
    const V3 c = V3(o.point[0], o.point[1], o.point[2]) + offset[std::size_t(k)];
    const V3 e1 = tv[1] - tv[0], e2 = tv[2] - tv[0], r = c - tv[0];
    const V3 normal = e1.cross(e2);
    const double area2 = normal.norm();
    if (!(area2 >= 1e-6 * e1.norm() * e2.norm())) return false;
    const double margin = 1e-9 * (r.norm() + e1.norm() + e2.norm());
    return std::abs(normal.dot(r)) / area2 - margin - o.radius >= within;
  }
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
                                  double smin) const {
    const Obstacle& o = O[std::size_t(k)];
    if (smin <= 0) return -1.0;
    // (a plane's distance is linear over the triangle: the smallest corner's)
    if (o.shape == Obstacle::Shape::Plane) return smin >= within ? kInf : smin;
    if (smin - longestEdge(tv) >= within) return kInf;
    double D = smin;
    const V3 c = V3(o.point[0], o.point[1], o.point[2]) + offset[std::size_t(k)];
    switch (o.shape) {
      case Obstacle::Shape::Plane:
        break;
      case Obstacle::Shape::Sphere: {
        if (planeSeparates(k, tv, within)) return kInf;
        D = pointTriangleDistance(c, tv[0], tv[1], tv[2]) - o.radius;
        break;
      }
      case Obstacle::Shape::Capsule: {
        const V3 b = V3(o.pointB[0], o.pointB[1], o.pointB[2]) + offset[std::size_t(k)];
        D = segmentTriangleDistance(c, b, tv[0], tv[1], tv[2]) - o.radius;
        break;
      }
      case Obstacle::Shape::Box:
      case Obstacle::Shape::Mesh:
        break;
    }
    return std::max(D, 0.0);
  }

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
             std::span<const char> locked, double gamma, std::vector<double>& scale, bool plain) {
    bool any = false;
    reframedAny = false;
    struct TriangleItem {
      int k;
      std::size_t t;
      double D;
    };
    auto at = [&](std::size_t p) -> V3 { return anchor[p] + scale[p] * (disp[p] - anchor[p]); };
    std::vector<TriangleItem> items;
    for (std::size_t k = 0; k < O.size(); ++k) {
      if (meshLike(k)) continue;
      const V3& m = move[k];
      // Per point: how far it travels relative to the obstacle, and its distance to it (each
      // measured once, not once per triangle around the point).
      pointDistances(int(k), x);
      pointReach.resize(disp.size());
      for (std::size_t p = 0; p < disp.size(); ++p) pointReach[p] = (at(p) - m).norm();
      auto run = [&](std::size_t begin, std::size_t end, std::vector<TriangleItem>& to) {
        for (std::size_t t = begin; t < end; ++t) {
          const auto& T = triV[t];
          // How far the triangle's points travel relative to the obstacle.
          const double reach = std::max({pointReach[T[0]], pointReach[T[1]], pointReach[T[2]]});
          if (!(reach > 0)) continue;
          const std::array<V3, 3> tv{surfacePoint(x, T[0]), surfacePoint(x, T[1]),
                                     surfacePoint(x, T[2])};
          const double smin = std::min({pointSdf[T[0]], pointSdf[T[1]], pointSdf[T[2]]});
          // Dropped only at 1.25 times its reach or more, where the CCD below would take the
          // whole step at its first advance (0.81 D / lp >= 1): the same bounds as measuring it.
          const double D = triangleObstacleDistance(int(k), tv, 1.25 * reach, smin);
          // Already touching or inside (a corner inside, or made so by a topology operation):
          // not bounded, the penalty pushes it out; bounding it at zero would freeze it there.
          if (D > 0 && D < kInf) to.push_back({int(k), t, D});
        }
      };
      // (on several threads over a large surface: runs of triangles, appended in order)
      std::vector<std::vector<TriangleItem>> partItems;
      gatherInParts(tris.size(), partsFor(tris.size(), kTrianglesPerThread), partItems, items, run);
    }
    std::vector<const Pair*> pairsToCheck;
    for (const Pair& p : near) {
      if (p.kind == Kind::PO || p.kind == Kind::FO || !(p.s0 > 0))
        continue;  // (at zero distance: as above)
      // Excluded pairs (new after a cut) have no penalty but are kept apart like the others; at
      // zero distance (the lips themselves) they cannot be, and are left to separate.
      if (p.obstacle < 0 && p.s0 <= P.thickness && excludedPair(closestFeature(p))) continue;
      pairsToCheck.push_back(&p);
    }
    std::vector<V3> dx(disp.size());
    for (std::size_t p = 0; p < disp.size(); ++p) dx[p] = at(p);
    // Points changed in the last round (the pairs that hold one are checked again).
    std::vector<char> moved(disp.size(), 1), movedNext(disp.size(), 0);
    auto touched = [&](const Pair& p) {
      for (int i = 0; i < 4; ++i)
        if (((p.surface >> i) & 1) && moved[p.id[std::size_t(i)]]) return true;
      return false;
    };
    // The frame a pair is bounded in: its obstacle's motion, else its points' common anchor.
    auto frameOf = [&](const Pair& p, bool& common) {
      common = true;
      if (p.obstacle >= 0) return move[std::size_t(p.obstacle)];
      V3 a = V3::Zero();
      bool first = true;
      for (int i = 0; i < 4; ++i) {
        if (!((p.surface >> i) & 1)) continue;
        const V3& b = anchor[p.id[std::size_t(i)]];
        if (first)
          a = b;
        else if (b != a)
          common = false;
        first = false;
      }
      return a;
    };
    // Every point of the pair already moves less than gamma times its distance in the pair's
    // frame: it stays apart.
    auto withinBound = [&](const Pair& p) {
      bool common = true;
      const V3 f = frameOf(p, common);
      if (!common) return false;
      const double b = gamma * p.s0;
      for (int i = 0; i < 4; ++i)
        if (((p.surface >> i) & 1) && (dx[p.id[std::size_t(i)]] - f).squaredNorm() > b * b)
          return false;
      return true;
    };
    // A pair's bound on its free points: gamma times its distance, less what its prescribed
    // points (a grasp) travel, which cannot be shortened.
    auto pairBound = [&](const Pair& p, const V3& frame) {
      double lockedMove = 0.0;
      for (int i = 0; i < 4; ++i) {
        const std::uint32_t q = p.id[std::size_t(i)];
        if (((p.surface >> i) & 1) && q < locked.size() && locked[q])
          lockedMove = std::max(lockedMove, (dx[q] - frame).norm());
      }
      return gamma * std::max(p.s0 - lockedMove, 0.0);
    };
    // Bounds point p by b in the frame f (a point keeps the first moving frame it is given).
    auto restrict = [&](std::uint32_t p, double b, const V3& f, bool& changed) {
      if (p < locked.size() && locked[p]) return;  // prescribed: it pushes, like a moving obstacle
      bool reframed = false;
      if (f != anchor[p] && anchor[p] == V3::Zero()) {
        anchor[p] = f;
        reframed = true;
        reframedAny = true;
      }
      if (!(b < bound[p]) && !reframed) return;
      bound[p] = std::min(bound[p], b);
      const double l = (disp[p] - anchor[p]).norm();
      const double s = l > bound[p] ? bound[p] / l : 1.0;
      if (reframed || s < scale[p]) {
        scale[p] = reframed ? s : std::min(scale[p], s);
        dx[p] = at(p);
        changed = true;
        movedNext[p] = 1;
      }
    };
    // (The plain bound is repeated until it holds: a point that takes an obstacle's frame
    // changes what its earlier pairs see.)
    for (int round = 0; round < (plain ? 1000 : 8); ++round) {
      bool changed = false;
      for (const Pair* p : pairsToCheck) {
        if (round > 0 && !touched(*p)) continue;  // nothing of it changed since its last check
        const double safe = plain ? 0.0 : withinBound(*p) ? 1.0 : pairSafeFraction(*p, x, dx);
        if (safe >= 1.0) continue;
        bool common = true;
        const V3 f = frameOf(*p, common);
        V3 frame = f;
        if (!common)  // a self pair with a point that goes with an obstacle: all its points do
          for (int i = 0; i < 4; ++i)
            if (((p->surface >> i) & 1) && anchor[p->id[std::size_t(i)]] != V3::Zero())
              frame = anchor[p->id[std::size_t(i)]];
        // Each point keeps the part of its motion the pair provably has (or gamma times the
        // distance, which suffices alone).
        const double b = pairBound(*p, frame);
        for (int i = 0; i < 4; ++i)
          if ((p->surface >> i) & 1) {
            const std::uint32_t q = p->id[std::size_t(i)];
            restrict(q, std::max(b, safe * (dx[q] - frame).norm()), frame, changed);
          }
      }
      for (const TriangleItem& it : items) {
        const auto& T = triV[it.t];
        if (round > 0 && !moved[T[0]] && !moved[T[1]] && !moved[T[2]]) continue;
        const V3& m = move[std::size_t(it.k)];
        if (!plain) {
          const std::array<V3, 3> c0{surfacePoint(x, T[0]), surfacePoint(x, T[1]),
                                     surfacePoint(x, T[2])};
          const double lp =
              std::max({(dx[T[0]] - m).norm(), (dx[T[1]] - m).norm(), (dx[T[2]] - m).norm()});
          const auto dist = [&](double t) {
            // Relative to the obstacle, which moves by `move` over the step.
            const std::array<V3, 3> c{c0[0] + t * (dx[T[0]] - m), c0[1] + t * (dx[T[1]] - m),
                                      c0[2] + t * (dx[T[2]] - m)};
            const double D = triangleObstacleDistance(it.k, c, kInf);
            return D < 0 ? 0.0 : D;
          };
          // From its distance at the start (x and the obstacles' start do not change), unless a
          // displacement is not finite (then measured: not finite, nothing of the step is safe).
          const bool finite = dx[T[0]].allFinite() && dx[T[1]].allFinite() && dx[T[2]].allFinite();
          const double safe = finite ? safeFraction(dist, lp, it.D) : safeFraction(dist, lp);
          if (safe >= 1.0) continue;
          for (std::uint32_t p : T)
            restrict(p, std::max(gamma * it.D, safe * (dx[p] - m).norm()), m, changed);
          continue;
        }
        for (std::uint32_t p : T) restrict(p, gamma * it.D, m, changed);
      }
      any = any || changed;
      if (!changed) break;
      std::swap(moved, movedNext);
      std::fill(movedNext.begin(), movedNext.end(), 0);
    }
    return any;
  }
};

// -------------------------------------------------------------------------------------------------

Contact::Contact(topology::Topology& topology, ContactParameters parameters,
                 std::vector<Obstacle> obstacles)
    : parameters_(parameters), obstacles_(std::move(obstacles)) {
  parameters_.validate();
  for (std::size_t k = 0; k < obstacles_.size(); ++k) {
    Obstacle& o = obstacles_[k];
    try {
      o.validate();
    } catch (const InvalidInput& e) {
      throw InvalidInput(
          "obstacles/" + std::to_string(k) + (e.where().empty() ? "" : "/" + e.where()),
          e.message());
    }
    if (o.shape == Obstacle::Shape::Plane) {
      const double l = std::sqrt(o.normal[0] * o.normal[0] + o.normal[1] * o.normal[1] +
                                 o.normal[2] * o.normal[2]);
      for (double& c : o.normal) c /= l;
    }
    if (o.name.empty()) o.name = o.shapeName() + std::to_string(k);
  }
  impl_ = std::make_unique<Impl>(topology, parameters_, obstacles_);
  impl_->threads = parameters_.threads > 0 ? parameters_.threads : defaultThreads();
  impl_->buildObstacleMeshes();
  impl_->offset.assign(obstacles_.size(), V3::Zero());
  impl_->velocity.assign(obstacles_.size(), V3::Zero());
  impl_->move.assign(obstacles_.size(), V3::Zero());
  for (std::size_t k = 0; k < obstacles_.size(); ++k) {
    const Vec3 o = obstacles_[k].offsetAt(0.0);
    impl_->offset[k] = V3(o[0], o[1], o[2]);
  }
  impl_->startOffset = impl_->offset;
  impl_->subscription = topology.subscribe(*this);
}

Contact::~Contact() = default;

void Contact::moveObstacle(std::size_t k, double now, const Vec3& delta, double duration) {
  if (k >= obstacles_.size()) throw InvalidInput("obstacle", "no obstacle " + std::to_string(k));
  Obstacle& o = obstacles_[k];
  const std::string where = "obstacle \"" + o.name + "\"";
  if (!std::isfinite(now) || !(duration > 0) || !std::isfinite(duration))
    throw InvalidInput(where,
                       "a move needs a finite duration > 0 (an obstacle sweeps; it does not jump)");
  for (double c : delta)
    if (!std::isfinite(c)) throw InvalidInput(where, "non-finite displacement");
  const Vec3 d0 = o.offsetAt(now);
  std::vector<ObstacleKey> path;
  for (const ObstacleKey& key : o.path)
    if (key.time < now) path.push_back(key);
  path.push_back({now, d0});
  path.push_back({now + duration, {d0[0] + delta[0], d0[1] + delta[1], d0[2] + delta[2]}});
  o.path = std::move(path);
}

const std::vector<double>& Contact::bounds() const {
  return impl_->bound;
}
std::size_t Contact::cachedPairs() const {
  return impl_->cacheBuilt ? impl_->cache.size() : 0;
}
std::size_t Contact::searches() const {
  return impl_->cacheBuilds + impl_->plainSearches;
}
std::size_t Contact::searchesReused() const {
  return impl_->cacheUses;
}

void Contact::beginStep(std::span<const double> x, std::span<const double> v, double t0,
                        double dt) {
  Impl& I = *impl_;
  const ContactParameters& P = parameters_;
  // Obstacles at the step's end.
  for (std::size_t k = 0; k < obstacles_.size(); ++k) {
    const Vec3 a = obstacles_[k].offsetAt(t0), b = obstacles_[k].offsetAt(t0 + dt);
    I.offset[k] = V3(b[0], b[1], b[2]);
    I.startOffset[k] = V3(a[0], a[1], a[2]);
    I.move[k] = I.offset[k] - I.startOffset[k];
    I.velocity[k] = dt > 0 ? V3(I.move[k] / dt) : V3(V3::Zero());
  }
  // The penalty's pairs: those within 1.5 d at the step's start (the linearised integrators take
  // forces and stiffness there; a pair that comes closer during the step is bounded by
  // limitDisplacement and found at the next step).
  const std::size_t n = x.size() / 3;
  I.updateTables();
  I.resetFlatness();
  // Margins: 0.75 d plus what the points may travel relative to the surface's mean motion (with
  // room to spare: 4 |v - mean| dt), so that Newton's iterations find the pairs they approach.
  V3 mean = V3::Zero();
  double live = 0;
  for (std::size_t p = 0; p < n && p < v.size() / 3; ++p)
    if (I.pointOwner.size() > p && I.pointOwner[p] >= 0) {
      mean += V3(v[3 * p], v[3 * p + 1], v[3 * p + 2]);
      ++live;
    }
  if (live > 0) mean /= live;
  I.pointMargin.assign(n, 0.5 * P.thickness);
  for (std::size_t p = 0; p < n && p < v.size() / 3; ++p)
    if (I.pointOwner.size() > p && I.pointOwner[p] >= 0)
      I.pointMargin[p] += 4 * (V3(v[3 * p], v[3 * p + 1], v[3 * p + 2]) - mean).norm() * dt;
  const double shift = 0.5 * P.thickness + 4 * mean.norm() * dt;  // (the obstacles stay put)
  I.obstacleMargin.assign(obstacles_.size(), 0.0);
  for (std::size_t k = 0; k < obstacles_.size(); ++k) {
    const Vec3 a = obstacles_[k].offsetAt(t0), b = obstacles_[k].offsetAt(t0 + dt);
    I.obstacleMargin[k] = shift + (V3(b[0], b[1], b[2]) - V3(a[0], a[1], a[2])).norm();
  }
  // The pairs are found with the obstacles where they start the step (which side of them each
  // point is on), then measured where they end it (the penalty's pose), on that side.
  const std::vector<V3> endOffset = I.offset;
  I.offset = I.startOffset;
  bool fromCache = false;
  double widest = 0.0;
  for (std::size_t p = 0; p < n; ++p)
    if (I.pointOwner.size() > p && I.pointOwner[p] >= 0)
      widest = std::max(widest, I.pointMargin[p]);
  if (P.searchSlack > 0 && I.plainSteps > 0) {
    --I.plainSteps;
  } else if (P.searchSlack > 0 && widest <= 1.5 * P.thickness) {
    // From the cache, searched again when the points or the obstacles have moved too far. (The
    // cache is searched with the widest margin for every point: when some point moves fast, a
    // plain search, with each point's own margin, is used instead.)
    I.triangleMargins();
    const double rSelf = 2 * widest;
    std::vector<double> rObstacle(obstacles_.size(), 0.0);
    double r = rSelf;
    for (std::size_t k = 0; k < obstacles_.size(); ++k)
      r = std::max(r, rObstacle[k] = widest + I.obstacleMargin[k]);
    fromCache = true;
    if (I.cacheCovers(x, rSelf, rObstacle)) {
      ++I.cacheUses;
      ++I.usesSinceBuild;
    } else if (I.cacheBuilt && I.usesSinceBuild == 0 && I.cacheRevision == I.topo.revision()) {
      // The last cache was never reused: search plainly for a while.
      I.plainSteps = I.backoff;
      I.backoff = std::min<std::size_t>(2 * I.backoff, 64);
      I.cacheBuilt = false;
      fromCache = false;
    } else {
      if (I.usesSinceBuild > 0) I.backoff = 1;
      I.buildCache(x, r + P.searchSlack * P.thickness);
      I.cacheCovers(x, rSelf, rObstacle);
      I.usesSinceBuild = 0;
    }
  }
  if (fromCache) {
    I.pairs.clear();
    I.pairsFromCache(x, I.pairs);
    I.analyticPairs(x, I.pairs);
  } else {
    I.prepare(x);
    I.collect(x, I.pairs, true);
    ++I.plainSearches;
  }
  I.offset = endOffset;
  for (Pair& p : I.pairs)
    if (I.obstacleMoves(p)) {
      const Eval e = I.evaluate(p, x, true);
      p.s0 = e.s;
    }
  I.lastX.assign(x.begin(), x.end());
  I.evalValid = false;

  // Exclusions. A self pair within d whose primitives are within d of each other in the rest
  // configuration (neighbours in the material: the two lips of a cut, which start at distance
  // zero, the small triangles a repair leaves next to a cut) has no penalty, no friction and no
  // bound (the lips of a cut may slide along each other) until its distance first exceeds d;
  // then it is a pair like any other.
  // The pairs excluded at the last step that are now farther apart than d release their points
  // for good (whichever features the search pairs them by now: a point sliding along a lip
  // meets a corner, then an edge, then a triangle).
  for (const auto& key : I.excluded) {
    const Pair p = Impl::fromKey(key);
    bool alive = true;
    for (int i = 0; i < p.points(); ++i)
      alive = alive && I.topo.isPointAlive(PointId(p.id[std::size_t(i)]));
    if (alive && I.evaluate(p, x).s > P.thickness)
      Impl::crossPoints(
          p, [&](const std::pair<std::uint32_t, std::uint32_t>& ab) { I.released.insert(ab); });
  }
  std::set<std::array<std::uint32_t, 5>> stillClose;
  for (Pair& p : I.pairs) {
    if (!I.excludedPair(p)) continue;
    p.excluded = true;
    stillClose.insert(Impl::exclusionKey(p));
  }
  I.excluded = std::move(stillClose);

  // Frozen normal forces and friction coefficients.
  const Law law{P.thickness, P.stiffness};
  for (Pair& p : I.pairs) {
    p.lambda = p.scale * law.force(p.s0);
    p.mu = p.obstacle < 0 ? P.friction : obstacles_[std::size_t(p.obstacle)].friction;
    if (p.lambda > 0 && p.mu > 0 && !p.excluded)
      frictionForce(p, P.stickVelocity, I.relativeVelocity(p, v), &p);
  }
}

std::size_t Contact::limitDisplacement(std::span<const double> x0, std::span<double> x1,
                                       std::span<double> v1, double dt,
                                       std::span<const char> constrained) const {
  Impl& I = *impl_;
  const std::size_t n = x0.size() / 3;
  I.updateTables();
  // Margins: the proposed displacements. A pair farther apart than its two primitives' largest
  // displacements cannot meet; the others bound their points.
  std::vector<V3> disp(n, V3::Zero());
  for (std::size_t p = 0; p < n; ++p)
    if (I.topo.isPointAlive(PointId(Index(p))))
      disp[p] =
          V3(x1[3 * p] - x0[3 * p], x1[3 * p + 1] - x0[3 * p + 1], x1[3 * p + 2] - x0[3 * p + 2]);
  std::vector<double> scale(n, 1.0);
  I.bound.assign(n, kInf);
  I.anchor.assign(n, V3::Zero());
  auto dxOf = [&](std::size_t p) -> V3 { return I.anchor[p] + scale[p] * (disp[p] - I.anchor[p]); };
  // No point travels more than two mean rest edges in a step (a solve that proposes more is far
  // from the motion it linearised; the step splits): this also keeps the search below local.
  const double travel = 2.0 * I.meanEdge;
  if (travel > 0)
    for (std::size_t p = 0; p < n; ++p) {
      const double l = disp[p].norm();
      if (l > travel && !(p < constrained.size() && constrained[p])) {
        scale[p] = travel / l;
        I.bound[p] = travel;
      }
    }
  // The obstacles from where they start the step, moving by `move` along it (the penalty took
  // them where they end it).
  const std::vector<V3> endOffset = I.offset;
  I.offset = I.startOffset;
  // Two primitives cannot meet when they are farther apart than how far their points move
  // relative to each other (reachOf). Shortening a displacement changes the relative motions:
  // the pairs are found again for the shortened displacements until a pass changes nothing. The
  // last resort takes each primitive's whole displacement as its reach (which shortening keeps
  // valid), bounds every pair it finds, and repeats until it changes nothing.
  const int passes = 5;
  int lastRepeats = 0;
  for (int pass = 0; pass <= passes; ++pass) {
    const bool last = pass == passes;
    // The search: boxes swept along the displacements (obstacle meshes grown by their motion),
    // pairs within their reach.
    std::vector<V3>& dx = I.sweptMotion;
    dx.resize(n);
    for (std::size_t p = 0; p < n; ++p) dx[p] = dxOf(p);
    I.obstacleMargin.assign(obstacles_.size(), 0.0);
    for (std::size_t k = 0; k < obstacles_.size(); ++k)
      I.obstacleMargin[k] = I.move[k].norm() + 1e-9 * I.meanEdge;
    std::vector<Pair>& near = I.nearPairs;
    near.clear();
    I.sweep = &dx;
    I.absoluteReach = last;
    // From the search's cache when it holds every pair within reach (a pair's distance changes
    // by at most 4 times the largest displacement), else by swept boxes.
    // A point is slow when it has moved less than a quarter of the cache's reach since the
    // cache was built, displacement (doubled) included: a pair of slow points that the cache
    // does not hold was at least cacheR apart then, and cannot meet now. The pairs that hold a
    // fast point are searched by swept boxes, from the fast points' triangles.
    std::vector<double> none(obstacles_.size(), 0.0);
    std::vector<char>& fast = I.fastPoint;
    fast.assign(n, 1);
    bool cached = I.cacheCovers(x0, 0.0, none);
    std::size_t fastCount = 0;
    if (cached) {
      for (std::size_t p = 0; p < n; ++p) {
        fast[p] = !(I.sinceCache[p] + 2 * dx[p].norm() < 0.25 * I.cacheR);
        fastCount += fast[p] && I.pointOwner.size() > p && I.pointOwner[p] >= 0;
      }
      for (std::size_t k = 0; k < obstacles_.size(); ++k)
        if (I.meshLike(k) && !(I.obstacleSinceCache[k] + 2 * I.move[k].norm() < 0.25 * I.cacheR))
          cached = false;
      if (10 * fastCount > n) cached = false;  // (then one search is cheaper)
    }
    if (cached) {
      I.nearFromCache(x0, fast, near);
      if (fastCount > 0) {
        I.prepareSwept(x0, dx);
        I.searchAround(x0, fast, near);
      }
    } else {
      I.prepareSwept(x0, dx);
      I.searchPairs(x0, near, false);
    }
    I.sweep = nullptr;
    I.absoluteReach = false;
    if (!I.limit(x0, near, disp, constrained, parameters_.displacementFraction, scale, last)) break;
    // The last resort searches again until it changes nothing: a point that took an obstacle's
    // frame may move farther than it was searched with, and a shortened motion changes the
    // displacement a frame's point ends with.
    if (last && ++lastRepeats < 100) --pass;
  }
  I.offset = endOffset;
  std::size_t clamped = 0;
  for (std::size_t p = 0; p < n; ++p) {
    const V3 dx = dxOf(p);
    if (dx == disp[p]) continue;
    for (int c = 0; c < 3; ++c) {
      x1[3 * p + std::size_t(c)] = x0[3 * p + std::size_t(c)] + dx[c];
      v1[3 * p + std::size_t(c)] = dx[c] / dt;
    }
    ++clamped;
  }
  return clamped;
}

// -------------------------------------------------------------------------------------------------
// The force field

void Contact::addForce(std::span<const double> x, std::span<const double> v,
                       std::span<double> f) const {
  Impl& I = *impl_;
  const Law law{parameters_.thickness, parameters_.stiffness};
  I.evaluateAt(x);
  for (std::size_t pi = 0; pi < I.pairs.size(); ++pi) {
    const Pair& p = I.pairs[pi];
    if (p.excluded) continue;
    const Eval& e = I.evals[pi];
    if (I.closerThanD[pi]) {
      const double mag = p.scale * law.force(e.s);
      for (int i = 0; i < 4; ++i)
        if ((p.surface >> i) & 1)
          for (int c = 0; c < 3; ++c)
            f[3 * p.id[std::size_t(i)] + std::size_t(c)] += mag * e.w[std::size_t(i)] * e.n[c];
    }
    if (p.lambda > 0 && p.mu > 0) {
      const V3 ff = frictionForce(p, parameters_.stickVelocity, I.relativeVelocity(p, v));
      for (int i = 0; i < 4; ++i)
        if ((p.surface >> i) & 1)
          for (int c = 0; c < 3; ++c)
            f[3 * p.id[std::size_t(i)] + std::size_t(c)] += p.w0[std::size_t(i)] * ff[c];
    }
  }
}

void Contact::beginProducts(std::span<const double> x) const {
  // (evaluated now, with a full comparison: from here on the held memory is what it was)
  impl_->evaluateAt(x);
  impl_->held.emplace_back(x.data(), x.size());
}

void Contact::endProducts(std::span<const double> x) const {
  auto& held = impl_->held;
  for (std::size_t k = held.size(); k-- > 0;)
    if (held[k].first == x.data() && held[k].second == x.size()) {
      held.erase(held.begin() + std::ptrdiff_t(k));
      return;
    }
}

void Contact::addDForce(std::span<const double> x, std::span<const double> dx, std::span<double> df,
                        double kFactor, double bFactor) const {
  Impl& I = *impl_;
  I.evaluateAt(x);
  auto at = [&](std::uint32_t p) { return Eigen::Map<const V3>(dx.data() + 3 * std::size_t(p)); };
  auto to = [&](std::uint32_t p) { return Eigen::Map<V3>(df.data() + 3 * std::size_t(p)); };
  for (const Impl::Product& c : I.packProducts(kFactor, bFactor)) {
    V3 u = V3::Zero();
    for (int i = 0; i < 4; ++i)
      if ((c.surface >> i) & 1) u += c.w[std::size_t(i)] * at(c.id[std::size_t(i)]);
    const auto& a = c.a;
    const V3 g(a[0] * u[0] + a[1] * u[1] + a[2] * u[2], a[1] * u[0] + a[3] * u[1] + a[4] * u[2],
               a[2] * u[0] + a[4] * u[1] + a[5] * u[2]);
    for (int i = 0; i < 4; ++i)
      if ((c.surface >> i) & 1) to(c.id[std::size_t(i)]) += c.w[std::size_t(i)] * g;
  }
}

double Contact::potentialEnergy(std::span<const double> x) const {
  Impl& I = *impl_;
  const Law law{parameters_.thickness, parameters_.stiffness};
  double E = 0.0;
  I.evaluateAt(x);
  for (std::size_t pi = 0; pi < I.pairs.size(); ++pi) {
    const Eval& e = I.evals[pi];
    if (I.closerThanD[pi]) E += I.pairs[pi].scale * law.energy(e.s);
  }
  return E;
}

namespace {
/// Adds w_i w_j B to block (i, j) of every pair of the pair's surface points; where a block has
/// no place in the accumulator's pattern, adds |w_i| (sum_j |w_j|) B to the diagonal blocks
/// instead (B is semi-definite: the lumped blocks bound the true ones in the same direction, by
/// Cauchy-Schwarz), and says so.
void addPairBlocks(const Pair& p, const std::array<double, 4>& w, const Eigen::Matrix3d& B,
                   MatrixAccumulator& m) {
  if (m.diagonalOnly()) {
    for (int i = 0; i < 4; ++i)
      if ((p.surface >> i) & 1)
        m.addBlock(PointId(p.id[std::size_t(i)]), PointId(p.id[std::size_t(i)]),
                   (w[std::size_t(i)] * w[std::size_t(i)]) * B);
    return;
  }
  bool fits = true;
  double sum = 0.0;
  for (int i = 0; i < 4; ++i) {
    if (!((p.surface >> i) & 1)) continue;
    sum += std::abs(w[std::size_t(i)]);
    for (int j = 0; j < i && fits; ++j)
      if ((p.surface >> j) & 1)
        fits = m.contains(PointId(p.id[std::size_t(i)]), PointId(p.id[std::size_t(j)]));
  }
  if (!fits) m.approximated();
  for (int i = 0; i < 4; ++i) {
    if (!((p.surface >> i) & 1)) continue;
    if (!fits) {
      m.addBlock(PointId(p.id[std::size_t(i)]), PointId(p.id[std::size_t(i)]),
                 (std::abs(w[std::size_t(i)]) * sum) * B);
      continue;
    }
    for (int j = 0; j < 4; ++j)
      if ((p.surface >> j) & 1)
        m.addBlock(PointId(p.id[std::size_t(i)]), PointId(p.id[std::size_t(j)]),
                   (w[std::size_t(i)] * w[std::size_t(j)]) * B);
  }
}
}  // namespace

void Contact::addKToMatrix(std::span<const double> x, MatrixAccumulator& m, double kFactor) const {
  Impl& I = *impl_;
  const Law law{parameters_.thickness, parameters_.stiffness};
  I.evaluateAt(x);
  for (std::size_t pi = 0; pi < I.pairs.size(); ++pi) {
    const Pair& p = I.pairs[pi];
    if (!I.closerThanD[pi]) continue;
    const Eval& e = I.evals[pi];
    const Eigen::Matrix3d nn = (-kFactor * p.scale * law.curvature(e.s)) * (e.n * e.n.transpose());
    addPairBlocks(p, e.w, nn, m);
  }
}

void Contact::addBToMatrix(std::span<const double> /*x*/, MatrixAccumulator& m,
                           double bFactor) const {
  const Impl& I = *impl_;
  for (const Pair& p : I.pairs) {
    if (p.excluded || !(p.lambda > 0 && p.mu > 0)) continue;
    addPairBlocks(p, p.w0, bFactor * p.frictionMatrix(), m);
  }
}

ContactMeasure Contact::measure(std::span<const double> x, std::span<const double> v) const {
  Impl& I = *impl_;
  const Law law{parameters_.thickness, parameters_.stiffness};
  I.evaluateAt(x);
  ContactMeasure m;
  m.obstacleNormal.assign(obstacles_.size(), 0.0);
  m.obstacleFriction.assign(obstacles_.size(), 0.0);
  for (std::size_t pi = 0; pi < I.pairs.size(); ++pi) {
    const Pair& p = I.pairs[pi];
    ++m.candidates;
    if (p.excluded) {
      ++m.excluded;
      continue;
    }
    const Eval& e = I.evals[pi];
    double fn = 0.0, ft = 0.0;
    if (I.closerThanD[pi]) {
      ++m.active;
      fn = p.scale * law.force(e.s);
    }
    if (p.lambda > 0 && p.mu > 0)
      ft = frictionForce(p, parameters_.stickVelocity, I.relativeVelocity(p, v)).norm();
    if (p.obstacle < 0) {
      m.selfNormal += fn;
      m.selfFriction += ft;
    } else {
      m.obstacleNormal[std::size_t(p.obstacle)] += fn;
      m.obstacleFriction[std::size_t(p.obstacle)] += ft;
    }
  }
  return m;
}

std::vector<ContactProximity> Contact::closePairs(std::span<const double> x, double within,
                                                  std::size_t limit) const {
  Impl& I = *impl_;
  I.updateTables();
  // (every kind of pair within the sum of two margins: within)
  I.pointMargin.assign(x.size() / 3, 0.5 * within);
  I.obstacleMargin.assign(obstacles_.size(), 0.5 * within);
  I.prepare(x);
  std::vector<Pair> found;
  I.collect(x, found, false);
  I.pairs.clear();
  I.evalValid = false;
  std::sort(found.begin(), found.end(), [](const Pair& a, const Pair& b) { return a.s0 < b.s0; });
  std::vector<ContactProximity> out;
  for (const Pair& p : found) {
    if (out.size() >= limit) break;
    std::ostringstream s;
    const std::string obstacle =
        p.obstacle >= 0 ? "obstacle \"" + obstacles_[std::size_t(p.obstacle)].name + "\"" : "";
    switch (p.kind) {
      case Kind::VT:
        s << "point " << p.id[0] << " and the triangle of points " << p.id[1] << ", " << p.id[2]
          << ", " << p.id[3];
        break;
      case Kind::EE:
        s << "the edge of points " << p.id[0] << ", " << p.id[1] << " and the edge of points "
          << p.id[2] << ", " << p.id[3];
        break;
      case Kind::PO:
        s << "point " << p.id[0] << " and " << obstacle;
        break;
      case Kind::FO:
        s << "point " << p.id[0] << " and " << obstacle;
        break;
      case Kind::VO:
        s << "point " << p.id[0] << " and " << obstacle;
        break;
      case Kind::OV:
        s << obstacle << " (its vertex " << p.id[0] << ") and the triangle of points " << p.id[1]
          << ", " << p.id[2] << ", " << p.id[3];
        break;
      case Kind::EO:
        s << "the edge of points " << p.id[0] << ", " << p.id[1] << " and " << obstacle;
        break;
    }
    out.push_back({s.str(), p.s0});
  }
  return out;
}

std::vector<ContactProximity> Contact::intersections(std::span<const double> x,
                                                     std::size_t limit) const {
  Impl& I = *impl_;
  I.updateTables();
  I.pointMargin.assign(x.size() / 3, 0.0);
  I.obstacleMargin.assign(obstacles_.size(), 0.0);
  I.prepare(x);
  std::vector<ContactProximity> out;
  auto corners = [&](int i) {
    const auto& T = I.triV[std::size_t(i)];
    return std::array<V3, 3>{I.surfacePoint(x, T[0]), I.surfacePoint(x, T[1]),
                             I.surfacePoint(x, T[2])};
  };
  auto name = [&](int i) {
    const auto& T = I.triV[std::size_t(i)];
    std::ostringstream s;
    s << "the triangle of points " << T[0] << ", " << T[1] << ", " << T[2];
    return s.str();
  };
  if (parameters_.selfContact)
    I.bvh.selfPairs([&](int i, int j) {
      if (out.size() >= limit) return;
      for (std::uint32_t p : I.triV[std::size_t(i)])
        if (I.shares(I.triV[std::size_t(j)], p)) return;
      if (triangleTriangleDistance(corners(i), corners(j)) == 0.0)
        out.push_back({name(i) + " and " + name(j), 0.0});
    });
  for (std::size_t k = 0; k < obstacles_.size() && out.size() < limit; ++k) {
    const std::string obstacle = "obstacle \"" + obstacles_[k].name + "\"";
    if (I.meshLike(k)) {
      Impl::MeshObstacle& m = I.meshes[k];
      I.obstacleBoxes(int(k), m.boxes);
      m.bvh.build(m.boxes);
      if (obstacles_[k].shape == Obstacle::Shape::Box)
        for (std::uint32_t p = 0; p < I.pointOwner.size() && out.size() < limit; ++p) {
          V3 g;
          if (I.pointOwner[p] >= 0 && I.sdf(int(k), I.surfacePoint(x, p), g) < 0)
            out.push_back({"point " + std::to_string(p) + " is inside " + obstacle, 0.0});
        }
      I.bvh.crossPairs(m.bvh, [&](int i, int j) {
        if (out.size() >= limit) return;
        const auto& T = m.triangles[std::size_t(j)];
        const std::array<V3, 3> u{I.obstaclePoint(int(k), std::uint32_t(T[0])),
                                  I.obstaclePoint(int(k), std::uint32_t(T[1])),
                                  I.obstaclePoint(int(k), std::uint32_t(T[2]))};
        if (triangleTriangleDistance(corners(int(i)), u) == 0.0)
          out.push_back(
              {name(i) + " and " + obstacle + " (its triangle " + std::to_string(j) + ")", 0.0});
      });
      continue;
    }
    for (std::size_t t = 0; t < I.tris.size() && out.size() < limit; ++t) {
      const double D = I.triangleObstacleDistance(int(k), corners(int(t)), 1e-300);
      if (D == 0.0 || D < 0)
        out.push_back(
            {name(int(t)) + (D < 0 ? " has a corner inside " : " crosses ") + obstacle, 0.0});
    }
  }
  return out;
}

// -------------------------------------------------------------------------------------------------
// Following the topology

void Contact::onPointsRenumbered(const topology::Topology&, const topology::Renumbering& r) {
  Impl& I = *impl_;
  // Unused ids (a pair of a point and an edge or a corner) stay unused.
  bool gone = false;
  auto map = [&](std::uint32_t p) {
    if (p == std::uint32_t(kInvalidIndex)) return p;
    const std::uint32_t q =
        p < r.oldToNew.size() ? std::uint32_t(r.oldToNew[p]) : std::uint32_t(kInvalidIndex);
    if (q == std::uint32_t(kInvalidIndex)) gone = true;
    return q;
  };
  // Pairs by their points: renumbered, and dropped when a point is gone.
  auto remap = [&](std::set<std::array<std::uint32_t, 5>>& keys) {
    std::set<std::array<std::uint32_t, 5>> out;
    for (const auto& key : keys) {
      gone = false;
      Pair p{Kind(key[0]), -1, {map(key[1]), map(key[2]), map(key[3]), map(key[4])}, 0b1111};
      if (!gone) out.insert(Impl::exclusionKey(p));
    }
    keys = std::move(out);
  };
  remap(I.excluded);
  std::set<std::pair<std::uint32_t, std::uint32_t>> released;
  for (const auto& [a, b] : I.released) {
    gone = false;
    const std::uint32_t na = map(a), nb = map(b);
    if (!gone) released.insert(std::minmax(na, nb));
  }
  I.released = std::move(released);
}

void Contact::onTransactionEnd(const topology::Topology&, const topology::TransactionSummary&) {
  // The tables and the BVH are rebuilt at the next step's start (the revision changed); the
  // pairs of the last step refer to points that may be gone: drop them now.
  Impl& I = *impl_;
  I.pairs.clear();
  I.evalValid = false;
}

void Contact::validate(const topology::Topology& topology,
                       std::vector<std::string>& problems) const {
  const Impl& I = *impl_;
  if (!I.built || I.revision != topology.revision() ||
      I.lastX.size() < 3 * topology.pointCapacity())
    return;
  if (I.tris != topology.triangles()) {
    problems.push_back("Contact: its triangle list differs from the topology's");
    return;
  }
  for (std::size_t i = 0; i < I.tris.size(); ++i) {
    const auto v = topology.triangleVertices(I.tris[i]);
    for (int k = 0; k < 3; ++k)
      if (I.triV[i][std::size_t(k)] != Index(v[std::size_t(k)]))
        problems.push_back("Contact: triangle " + std::to_string(Index(I.tris[i])) +
                           " has other corners in its table");
  }
  std::vector<Box> boxes;
  I.surfaceBoxes(I.lastX, boxes);
  // The hierarchy against the boxes it was last given (the search's, swept or grown by the
  // cache's margins), then refitted to the step's margins at the step's start.
  I.bvh.check(I.boxes, problems);
  Bvh refitted = I.bvh;
  refitted.refit(boxes);
  refitted.check(boxes, problems);
  // The BVH's pairs against every pair of triangles (small meshes).
  if (I.tris.size() > 3000 || !parameters_.selfContact) return;
  auto keys = [](const std::vector<Pair>& ps) {
    std::set<std::array<std::uint32_t, 5>> out;
    for (const Pair& p : ps) {
      if (p.obstacle >= 0) continue;
      std::array<std::uint32_t, 4> id = p.id;
      if (p.kind == Kind::EE) {  // either edge may come first
        std::array<std::uint32_t, 2> a{std::min(id[0], id[1]), std::max(id[0], id[1])};
        std::array<std::uint32_t, 2> b{std::min(id[2], id[3]), std::max(id[2], id[3])};
        if (b < a) std::swap(a, b);
        id = {a[0], a[1], b[0], b[1]};
      }
      out.insert({std::uint32_t(p.kind), id[0], id[1], id[2], id[3]});
    }
    return out;
  };
  Impl::Tight tight;
  I.tightBoxes(I.lastX, tight);
  std::vector<Pair> brute;
  for (std::size_t i = 0; i < I.tris.size(); ++i)
    for (std::size_t j = i + 1; j < I.tris.size(); ++j)
      if (boxes[i].overlaps(boxes[j]))
        I.selfTrianglePair(int(i), int(j), I.lastX, brute, true, tight);
  std::vector<Pair> fast;
  refitted.selfPairs([&](int i, int j) { I.selfTrianglePair(i, j, I.lastX, fast, true, tight); });
  const auto a = keys(brute), b = keys(fast);
  if (a != b || brute.size() != fast.size()) {
    std::ostringstream s;
    s << "Contact: the BVH finds " << fast.size() << " self pairs, every pair of triangles gives "
      << brute.size();
    problems.push_back(s.str());
  }
}

// ---- checkpoints ----

namespace {
void saveV3s(ArchiveWriter& out, const std::vector<V3>& v) {
  contact::saveRecords(out, v);
}
void loadV3s(ArchiveReader& in, std::vector<V3>& v, const char* what) {
  contact::loadRecords(in, v, what);
}
}  // namespace

void Contact::saveState(ArchiveWriter& out) const {
  const Impl& I = *impl_;
  using contact::saveRecords;
  out.u64(obstacles_.size());
  for (const Obstacle& o : obstacles_) saveRecords(out, o.path);
  out.u64(last_.candidates);
  out.u64(last_.active);
  out.u64(last_.excluded);
  out.f64(last_.selfNormal);
  out.f64(last_.selfFriction);
  out.f64s(last_.obstacleNormal);
  out.f64s(last_.obstacleFriction);

  out.boolean(I.built);
  out.u64(I.revision);
  out.boolean(I.bvhBuilt);
  out.f64(I.meanEdge);
  saveRecords(out, I.boxes);
  I.bvh.save(out);
  for (const auto& m : I.meshes) {
    saveRecords(out, m.boxes);
    m.bvh.save(out);
  }
  saveV3s(out, I.offset);
  saveV3s(out, I.velocity);
  saveV3s(out, I.startOffset);
  saveV3s(out, I.move);
  saveRecords(out, I.pairs);
  saveRecords(out, I.nearPairs);
  saveV3s(out, I.sweptMotion);
  saveRecords(out, I.fastPoint);
  out.f64s(I.moveLength);
  out.f64s(I.pointMargin);
  out.f64s(I.triMargin);
  out.f64s(I.obstacleMargin);
  out.f64s(I.bound);
  saveV3s(out, I.anchor);
  out.boolean(I.reframedAny);
  out.boolean(I.absoluteReach);
  saveRecords(out, I.tight.tri);
  saveRecords(out, I.tight.edge);
  out.u64(I.excluded.size());
  for (const auto& key : I.excluded) out.raw(key.data(), sizeof(key));
  out.u64(I.released.size());
  for (const auto& [a, b] : I.released) {
    out.u64(a);
    out.u64(b);
  }
  out.f64s(I.lastX);
  saveRecords(out, I.cache);
  out.f64s(I.cacheX);
  saveV3s(out, I.cacheOffset);
  out.u64(I.cacheRevision);
  out.f64(I.cacheR);
  out.boolean(I.cacheBuilt);
  out.f64s(I.sinceCache);
  out.f64s(I.obstacleSinceCache);
  for (std::size_t v :
       {I.cacheUses, I.cacheBuilds, I.usesSinceBuild, I.plainSteps, I.backoff, I.plainSearches})
    out.u64(v);
}

void Contact::loadState(ArchiveReader& in) {
  Impl& I = *impl_;
  using contact::loadRecords;
  if (in.u64() != obstacles_.size())
    in.fail("contact: the saved run has another number of obstacles");
  for (Obstacle& o : obstacles_) {
    loadRecords(in, o.path, "an obstacle's path");
    try {
      o.validate();
    } catch (const InvalidInput& e) {
      in.fail("contact: obstacle \"" + o.name + "\": " + e.what());
    }
  }
  last_.candidates = std::size_t(in.u64());
  last_.active = std::size_t(in.u64());
  last_.excluded = std::size_t(in.u64());
  last_.selfNormal = in.f64();
  last_.selfFriction = in.f64();
  last_.obstacleNormal = in.f64s();
  last_.obstacleFriction = in.f64s();

  const bool built = in.boolean();
  const std::uint64_t revision = in.u64();
  // The tables of the topology as it is. A checkpoint written right after a topology change holds
  // the tables of the mesh before it, which the next step rebuilds (dropping the hierarchy):
  // the saved revision says so, and the restored contact does the same.
  I.rebuildTables();
  I.built = built;
  I.revision = revision;
  const bool current = built && revision == I.topo.revision();
  I.bvhBuilt = in.boolean();
  I.meanEdge = in.f64();
  loadRecords(in, I.boxes, "boxes");
  I.bvh.load(in);
  for (auto& m : I.meshes) {
    loadRecords(in, m.boxes, "obstacle boxes");
    m.bvh.load(in);
  }
  loadV3s(in, I.offset, "obstacle offsets");
  loadV3s(in, I.velocity, "obstacle velocities");
  loadV3s(in, I.startOffset, "obstacle offsets");
  loadV3s(in, I.move, "obstacle moves");
  loadRecords(in, I.pairs, "pairs");
  loadRecords(in, I.nearPairs, "pairs");
  loadV3s(in, I.sweptMotion, "motions");
  loadRecords(in, I.fastPoint, "fast points");
  I.moveLength = in.f64s();
  I.pointMargin = in.f64s();
  I.triMargin = in.f64s();
  I.obstacleMargin = in.f64s();
  I.bound = in.f64s();
  loadV3s(in, I.anchor, "anchors");
  I.reframedAny = in.boolean();
  I.absoluteReach = in.boolean();
  loadRecords(in, I.tight.tri, "boxes");
  loadRecords(in, I.tight.edge, "boxes");
  const std::uint64_t excluded = in.u64();
  if (excluded > in.remaining() / (5 * sizeof(std::uint32_t)))
    in.fail("contact: a count of " + std::to_string(excluded) + " exclusions");
  I.excluded.clear();
  for (std::uint64_t k = 0; k < excluded; ++k) {
    std::array<std::uint32_t, 5> key;
    in.raw(key.data(), sizeof(key));
    I.excluded.insert(key);
  }
  const std::uint64_t released = in.u64();
  if (released > in.remaining() / 16)
    in.fail("contact: a count of " + std::to_string(released) + " released pairs");
  I.released.clear();
  for (std::uint64_t k = 0; k < released; ++k) {
    const auto a = std::uint32_t(in.u64()), b = std::uint32_t(in.u64());
    I.released.insert({a, b});
  }
  I.lastX = in.f64s();
  loadRecords(in, I.cache, "cached pairs");
  I.cacheX = in.f64s();
  loadV3s(in, I.cacheOffset, "cached offsets");
  I.cacheRevision = in.u64();
  I.cacheR = in.f64();
  I.cacheBuilt = in.boolean();
  I.sinceCache = in.f64s();
  I.obstacleSinceCache = in.f64s();
  for (std::size_t* v : {&I.cacheUses, &I.cacheBuilds, &I.usesSinceBuild, &I.plainSteps, &I.backoff,
                         &I.plainSearches})
    *v = std::size_t(in.u64());
  I.evalValid = false;
  I.sweep = nullptr;
  // Every index the records hold must be one of this mesh's.
  const std::size_t points = I.topo.pointCapacity(), tris = I.tris.size();
  auto checkPair = [&](auto kind, std::int32_t obstacle, std::uint8_t surface,
                       const std::array<std::uint32_t, 4>& id) {
    if (obstacle < -1 || obstacle >= std::int32_t(obstacles_.size()) ||
        std::uint8_t(kind) > std::uint8_t(Kind::FO))
      in.fail("contact: a pair of an obstacle or a kind that does not exist");
    for (int i = 0; i < 4; ++i)
      if (((surface >> i) & 1) && id[std::size_t(i)] != kInvalidIndex &&
          id[std::size_t(i)] >= points)
        in.fail("contact: a pair of a point that does not exist");
  };
  for (const Pair& p : I.pairs) checkPair(p.kind, p.obstacle, p.surface, p.id);
  for (const Pair& p : I.nearPairs) checkPair(p.kind, p.obstacle, p.surface, p.id);
  for (const auto& c : I.cache) {
    checkPair(c.kind, c.obstacle, c.surface, c.id);
    if (I.cacheRevision == I.topo.revision() &&
        (c.margins[0] >= std::int32_t(tris) || c.margins[1] >= std::int32_t(tris)))
      in.fail("contact: a cached pair of a triangle that does not exist");
    // (a self pair of edges holds its edges; a point's pair its triangle, of the surface or of
    // an obstacle mesh)
    const bool edgesOk =
        c.kind != Kind::EE || c.obstacle >= 0 ||
        (c.tri >= -1 && c.edge2 >= -1 && c.tri < std::int32_t(I.topo.edgeCapacity()) &&
         c.edge2 < std::int32_t(I.topo.edgeCapacity()));
    const bool triOk =
        c.kind == Kind::EE || c.tri < 0 || c.obstacle >= 0 || c.tri < std::int32_t(tris);
    if (I.cacheRevision == I.topo.revision() && !(edgesOk && triOk))
      in.fail("contact: a cached pair of an edge or a triangle that does not exist");
  }
  I.indexCache();  // (by point: after the points are checked)
  if (current && I.bvhBuilt && I.bvh.size() != tris)
    in.fail("contact: a hierarchy over another number of triangles");
  // Per point slot, per triangle, per obstacle: never longer than the mesh and the obstacles
  // (tables of the mesh before a change are replaced at the next step, unread).
  const std::size_t k = obstacles_.size(), edges = I.topo.edgeCapacity();
  auto size = [&](std::size_t got, std::size_t most, const char* what) {
    if (current && got > most)
      in.fail(std::string("contact: ") + what + " for " + std::to_string(got) +
              " elements, at most " + std::to_string(most));
  };
  size(I.boxes.size(), tris, "boxes");
  size(I.fastPoint.size(), points, "fast points");
  size(I.moveLength.size(), points, "displacements");
  size(I.pointMargin.size(), points, "point margins");
  size(I.triMargin.size(), tris, "triangle margins");
  size(I.bound.size(), points, "bounds");
  size(I.anchor.size(), points, "anchors");
  size(I.sweptMotion.size(), points, "motions");
  size(I.sinceCache.size(), points, "cache distances");
  size(I.lastX.size(), 3 * points, "positions");
  size(I.cacheX.size(), 3 * points, "cached positions");
  size(I.tight.tri.size(), tris, "boxes");
  size(I.tight.edge.size(), edges, "edge boxes");
  if (I.offset.size() != k || I.velocity.size() != k || I.startOffset.size() != k ||
      I.move.size() != k || I.obstacleMargin.size() > k || I.obstacleSinceCache.size() > k ||
      I.cacheOffset.size() > k)
    in.fail("contact: poses for another number of obstacles");
  for (std::size_t j = 0; j < I.meshes.size(); ++j)
    if (I.meshes[j].bvh.size() > I.meshes[j].triangles.size())
      in.fail("contact: an obstacle's hierarchy over other triangles");
}

}  // namespace cutsim::forcefields
