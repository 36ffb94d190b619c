// Quality repair of the triangles around an operation (a cut, a tear, a removal), in rest
// coordinates: greedy local edge flips, edge collapses, vertex relocations and border splits,
// then Delaunay refinement (Ruppert) of what they leave under the target smallest angle.
//
// Every change is made with the transaction's own primitives (detach and attach triangles, new
// points with ancestry), so observers follow it through the usual events:
//   flip        two triangles and their shared edge destroyed; two triangles and the other
//               diagonal created;
//   collapse    (a -> b, "half-edge collapse") a's triangles re-attached to b, the two (one on the
//               border) across a-b destroyed, a destroyed; no new point, b does not move;
//   relocation  v replaced by a new point v' inside v's star, whose ancestors are the corners of
//               the star triangle holding it (v among them: an ancestor destroyed in the same
//               transaction, whose data observers still hold until the transaction ends), so
//               state interpolated at v' lies on the deformed surface where it was;
//   split       a border edge split at the foot of a nearly flat triangle's apex (then the apex
//               collapses onto it), or a segment split by refinement: the usual edge split;
//   insertion   a point at a circumcentre (refinement): the usual triangle split, then flips.
// The border never changes shape: a border point moves or disappears only where the border is
// straight (its two border edges within 1e-6 rad of a straight angle), along the border; cut lips
// stay on the cut path, a cut's tip and corners stay where they are. Locked points (fixed or
// grasped) never move or disappear. Flips and relocations only happen where the rest surface is
// flat within RepairOptions::flatness, so they do not change the rest shape.
#include <algorithm>
#include <array>
#include <boost/container/small_vector.hpp>
#include <cmath>
#include <numbers>
#include <set>
#include <span>
#include <unordered_set>

#include "topology_impl.hpp"

namespace cutsim::topology {

namespace {

using Vector3 = Kernel::Vector_3;

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kStraight = 1e-6;  // rad: a border point whose border edges are this straight
constexpr double kImprove = 1e-4;   // rad: a change must raise the local worst angle this much
// Ruppert's refinement is proven to end for a smallest angle up to arcsin(1 / (2 sqrt 2)) =
// 20.7 degrees; it aims no higher (above, it can refine without end).
constexpr double kRefinable = 20.7 * std::numbers::pi / 180.0;

double angleBetween(const Vector3& u, const Vector3& v) {
  return std::atan2(std::sqrt(CGAL::cross_product(u, v).squared_length()), u * v);
}

/// Smallest angle of triangle (a, b, c), radians.
double minAngle(const Point3& a, const Point3& b, const Point3& c) {
  return std::min(
      {angleBetween(b - a, c - a), angleBetween(c - b, a - b), angleBetween(a - c, b - c)});
}

Vector3 normal(const Point3& a, const Point3& b, const Point3& c) {
  return CGAL::cross_product(b - a, c - a);
}

/// The two normals agree within `tol` radians (and neither is degenerate).
bool aligned(const Vector3& n1, const Vector3& n2, double tol) {
  const double l = std::sqrt(n1.squared_length() * n2.squared_length());
  if (!(l > 0)) return false;
  return n1 * n2 >= std::cos(tol) * l;
}

class Repairer {
 public:
  Repairer(Topology::Impl& impl, const RepairOptions& o, std::unordered_map<Index, Index>& replaced)
      : I_(impl),
        m_(impl.mesh),
        target_(o.minAngle * kDeg),
        flat_(o.flatness * kDeg),
        replaced_(replaced) {
    for (PointId p : o.locked) locked_.insert(p.idx());
  }

  RepairReport run(const std::vector<VI>& seeds) {
    for (VI v : seeds) addWithRing(v);
    measure(report_.minAngleBefore, report_.meanMinBefore, report_.belowTargetBefore);
    median_ = medianEdge();
    shortEdge_ = 0.2 * median_;
    for (int pass = 0; pass < 12; ++pass) {
      bool changed = false;
      for (FI f : worstFirst()) {
        if (!alive(f)) continue;
        if (quality(f) < target_) {
          changed |= fixTriangle(f);
        } else if (shortestEdge(f) < shortEdge_) {
          changed |= collapseShortEdge(f);
        }
      }
      changed |= flipPass();
      changed |= smoothPass();
      if (!changed) break;
    }
    refine();
    report_.triangles = patchFaces().size();
    measure(report_.minAngleAfter, report_.meanMinAfter, report_.belowTargetAfter);
    return report_;
  }

 private:
  // ---- the patch ----
  bool live(VI v) const { return I_.vertexAlive(v) && !m_.is_isolated(v); }
  bool alive(FI f) const { return I_.faceAlive(f); }
  bool isLocked(VI v) const { return locked_.count(v.idx()) > 0; }
  bool inPatch(VI v) const { return patch_.count(v.idx()) > 0; }
  /// v joins the patch (during refinement, noted so that its older triangles are looked at).
  void join(VI v) {
    if (patch_.insert(v.idx()).second && refining_) joined_.push_back(v);
  }
  void addWithRing(VI v) {
    if (!live(v)) return;
    patch_.insert(v.idx());
    for (VI w : neighbours(v)) patch_.insert(w.idx());
  }
  std::vector<VI> neighbours(VI v) const {
    std::vector<VI> out;
    for (HI h : CGAL::halfedges_around_target(m_.halfedge(v), m_)) out.push_back(m_.source(h));
    return out;
  }
  std::vector<FI> facesAround(VI v) const {
    std::vector<FI> out;
    for (HI h : CGAL::halfedges_around_target(m_.halfedge(v), m_))
      if (FI f = m_.face(h); f.is_valid()) out.push_back(f);
    return out;
  }
  /// The triangles around the patch's points, and every triangle made since the operation began
  /// (a flip or a collapse on the patch's rim can make one with no corner in the patch; it is
  /// measured and refined like the others).
  std::vector<FI> patchFaces() const {
    std::unordered_set<std::uint32_t> seen;
    std::vector<FI> out;
    for (Index vi : patch_) {
      VI v(vi);
      if (!live(v)) continue;
      for (FI f : facesAround(v))
        if (seen.insert(f.idx()).second) out.push_back(f);
    }
    for (Index f = I_.fBefore; f < m_.num_faces(); ++f)  // made since the operation began
      if (alive(FI(f)) && seen.insert(f).second) out.push_back(FI(f));
    std::sort(out.begin(), out.end());
    return out;
  }
  std::vector<FI> worstFirst() const {
    std::vector<std::pair<double, FI>> q;
    for (FI f : patchFaces()) q.emplace_back(quality(f), f);
    std::sort(q.begin(), q.end());
    std::vector<FI> out;
    for (auto& [a, f] : q) out.push_back(f);
    return out;
  }
  void measure(double& minDeg, double& meanDeg, std::size_t& below) const {
    std::vector<FI> fs = patchFaces();
    double mn = fs.empty() ? 0.0 : 1e300, sum = 0;
    below = 0;
    for (FI f : fs) {
      const double q = quality(f);
      mn = std::min(mn, q);
      sum += q;
      if (q < target_) ++below;
    }
    minDeg = mn / kDeg;
    meanDeg = fs.empty() ? 0.0 : sum / double(fs.size()) / kDeg;
  }

  // ---- geometry ----
  std::array<VI, 3> cornersOf(FI f) const {
    HI h = m_.halfedge(f);
    return {m_.source(h), m_.target(h), m_.target(m_.next(h))};
  }
  const Point3& P(VI v) const { return m_.point(v); }
  /// Where v is among the corners c (0, 1 or 2; v must be one of them).
  static int cornerIndex(const std::array<VI, 3>& c, VI v) {
    return c[0] == v ? 0 : c[1] == v ? 1 : 2;
  }
  double quality(FI f) const {
    auto c = cornersOf(f);
    return minAngle(P(c[0]), P(c[1]), P(c[2]));
  }
  Vector3 normalOf(FI f) const {
    auto c = cornersOf(f);
    return normal(P(c[0]), P(c[1]), P(c[2]));
  }
  /// The triangles fs (and their corners) are flat within the flatness tolerance: no corner lies
  /// farther off the plane of their summed (area-weighted) normals, through their centroid, than
  /// tan(flatness / 4) times the patch's extent along that plane (the largest distance of a corner
  /// from the centroid along it). Two triangles bent by t along their shared edge reach that at
  /// t = flatness (for near-equilateral ones; the measure is the patch's, whatever the triangles'
  /// shapes), a regular star on a sphere at a bend of about 0.6 flatness from one triangle to the
  /// next. Measured on the points, not by comparing the triangles' own normals: a sliver's normal
  /// can point anywhere when its corners lie a rounding or a curved surface's sagitta off its
  /// neighbours' plane, so on a curved rest surface a normal test takes slivers for creases and
  /// the repair meant to remove them stops there.
  bool flatTriangles(std::span<const FI> fs) const {
    if (fs.empty()) return false;
    Vector3 n(0, 0, 0);
    boost::container::small_vector<VI, 16> pts;  // (no allocation for a star of ordinary size)
    for (FI f : fs) {
      n = n + normalOf(f);
      for (VI c : cornersOf(f))
        if (std::find(pts.begin(), pts.end(), c) == pts.end()) pts.push_back(c);
    }
    const double nl = std::sqrt(n.squared_length());
    if (!(nl > 0)) return false;
    n = n / nl;
    Vector3 centroid(0, 0, 0);
    for (VI c : pts) centroid = centroid + (P(c) - CGAL::ORIGIN);
    const Point3 o = CGAL::ORIGIN + centroid / double(pts.size());
    double off = 0, extent = 0, reach = 0;
    for (VI c : pts) {
      const Vector3 r = P(c) - o;
      const double h = std::abs(r * n), r2 = r.squared_length();
      off = std::max(off, h);
      extent = std::max(extent, std::sqrt(std::max(0.0, r2 - h * h)));
      reach = std::max(reach, std::sqrt(r2));
    }
    return off <= std::tan(0.25 * flat_) * extent + 1e-12 * reach;
  }
  /// v's star is flat within the flatness tolerance.
  bool flatStar(VI v) const { return flatTriangles(facesAround(v)); }
  /// For a border point: its two border neighbours (prev along the border, next), if it has
  /// exactly one border gap.
  bool borderNeighbours(VI v, VI& a, VI& b) const {
    int gaps = 0;
    for (HI h : CGAL::halfedges_around_target(m_.halfedge(v), m_)) {
      if (m_.is_border(h)) {  // h: source -> v, border on its side
        ++gaps;
        a = m_.source(h);
        b = m_.target(m_.next(h));
      }
    }
    return gaps == 1;
  }
  bool straightBorderPoint(VI v, VI& a, VI& b) const {
    if (!borderNeighbours(v, a, b) || a == b) return false;
    return straightThrough(v, a, b);
  }
  /// The path a -> v -> b goes straight on at v: within kStraight; or, where the surface bends
  /// there (a lip crossing triangles that are not coplanar, on a curved rest surface), turning
  /// within the flatness with v within kSamePoint of |ab| of the chord a-b along the surface's
  /// tangent plane. (Following a polyline's segment across triangles that are not coplanar, a cut
  /// meets each triangle's plane a little aside of the segment, so its lips turn in the tangent
  /// plane too: by a fraction of a degree where a lip edge is a few microns long, by a rounding of
  /// the point's place.) On a flat sheet: kStraight.
  bool straightThrough(VI v, VI a, VI b) const {
    const Vector3 u = P(v) - P(a), w = P(b) - P(v);
    const double lu = std::sqrt(u.squared_length()), lw = std::sqrt(w.squared_length());
    if (!(lu > 0 && lw > 0)) return false;  // a border edge of no length: a corner
    const double turn = angleBetween(u, w);
    if (turn <= kStraight) return true;
    if (!(turn <= flat_)) return false;
    Vector3 n(0, 0, 0);
    for (FI f : facesAround(v)) n = n + normalOf(f);
    const double nl = std::sqrt(n.squared_length());
    if (!(nl > 0)) return false;
    n = n / nl;
    const double bend = std::abs((u * n) / lu - (w * n) / lw);  // out of the tangent plane
    if (!(bend > kStraight)) return false;
    const Vector3 ab = P(b) - P(a), r = P(v) - P(a);
    const double l2 = ab.squared_length();
    const Vector3 off = r - ((r * ab) / l2) * ab;
    const Vector3 inPlane = off - (off * n) * n;
    return inPlane.squared_length() <= kSamePoint * kSamePoint * l2;
  }
  bool isBorder(VI v) const { return m_.is_border(v, true); }

  /// The quality of v's star with v at position p (radians); -1 if a triangle would flip over
  /// or become degenerate. Faces in `skip` are left out (they disappear).
  double starQuality(VI v, const Point3& p, const std::vector<FI>& fs,
                     const std::unordered_set<std::uint32_t>& skip = {}) const {
    double q = 1e300;
    // The star's plane (its area-weighted normal): a new triangle may turn from it by no more
    // than the flatness allows, so that moving a point over a curved star does not fold it.
    Vector3 ns(0, 0, 0);
    for (FI f : fs) ns = ns + normalOf(f);
    for (FI f : fs) {
      if (skip.count(f.idx())) continue;
      auto c = cornersOf(f);
      std::array<Point3, 3> x{P(c[0]), P(c[1]), P(c[2])};
      for (int k = 0; k < 3; ++k)
        if (c[std::size_t(k)] == v) x[std::size_t(k)] = p;
      const Vector3 n = normal(x[0], x[1], x[2]);
      if (!aligned(n, normalOf(f), 60 * kDeg)) return -1.0;
      if (!aligned(n, ns, 2 * flat_)) return -1.0;
      q = std::min(q, minAngle(x[0], x[1], x[2]));
    }
    return q;
  }
  double worstOf(const std::vector<FI>& fs) const {
    double q = 1e300;
    for (FI f : fs) q = std::min(q, quality(f));
    return q;
  }

  /// The median edge length of the patch (before the repair): the local mesh size.
  double medianEdge() const {
    std::vector<double> ls;
    for (FI f : patchFaces()) {
      auto c = cornersOf(f);
      for (int k = 0; k < 3; ++k)
        ls.push_back(std::sqrt(
            CGAL::squared_distance(P(c[std::size_t(k)]), P(c[std::size_t((k + 1) % 3)]))));
    }
    if (ls.empty()) return 0.0;
    std::nth_element(ls.begin(), ls.begin() + std::ptrdiff_t(ls.size() / 2), ls.end());
    return ls[ls.size() / 2];
  }
  double shortestEdge(FI f) const {
    auto c = cornersOf(f);
    double l = 1e300;
    for (int k = 0; k < 3; ++k)
      l = std::min(l, CGAL::squared_distance(P(c[std::size_t(k)]), P(c[std::size_t((k + 1) % 3)])));
    return std::sqrt(l);
  }
  /// A well-shaped but tiny triangle (an edge under a fifth of the local mesh size, which sets
  /// the stable explicit time step): collapse its short edge, if that leaves every triangle
  /// around at least at the target (or as good as before).
  bool collapseShortEdge(FI f) {
    auto c = cornersOf(f);
    for (int k = 0; k < 3; ++k) {
      VI a = c[std::size_t(k)], b = c[std::size_t((k + 1) % 3)];
      if (std::sqrt(CGAL::squared_distance(P(a), P(b))) >= shortEdge_) continue;
      sizeMode_ = true;
      const bool done = collapse(a, b) || collapse(b, a);
      sizeMode_ = false;
      if (done) return true;
    }
    return false;
  }

  // ---- the operations ----
  bool fixTriangle(FI f) {
    auto c = cornersOf(f);
    // Edges by length, shortest first.
    std::array<int, 3> order{0, 1, 2};
    auto len = [&](int k) {
      return CGAL::squared_distance(P(c[std::size_t(k)]), P(c[std::size_t((k + 1) % 3)]));
    };
    std::sort(order.begin(), order.end(), [&](int i, int j) { return len(i) < len(j); });
    for (int k : order) {
      VI a = c[std::size_t(k)], b = c[std::size_t((k + 1) % 3)];
      if (collapse(a, b) || collapse(b, a)) return true;
    }
    for (int k : order) {
      HI h = I_.findHalfedge(c[std::size_t(k)], c[std::size_t((k + 1) % 3)]);
      if (h.is_valid() && flip(m_.edge(h))) return true;
    }
    if (splitCap(f)) return true;
    for (VI v : c)
      if (relocate(v)) return true;
    return false;
  }

  bool flipPass() {
    bool changed = false;
    std::vector<EI> edges;
    for (FI f : patchFaces())
      for (HI h : CGAL::halfedges_around_face(m_.halfedge(f), m_)) edges.push_back(m_.edge(h));
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
    for (EI e : edges)
      if (I_.edgeAlive(e)) changed |= flip(e);
    return changed;
  }

  bool smoothPass() {
    bool changed = false;
    std::vector<Index> vs(patch_.begin(), patch_.end());
    std::sort(vs.begin(), vs.end());
    for (Index vi : vs) {
      VI v(vi);
      if (!live(v)) continue;
      if (worstOf(facesAround(v)) >= target_) continue;
      changed |= relocate(v);
    }
    return changed;
  }

  /// Flips e when the two triangles across it are flat within the tolerance, form a convex
  /// quadrilateral and the other diagonal raises their smaller smallest angle.
  bool flip(EI e) {
    if (m_.is_border(e)) return false;
    HI h = m_.halfedge(e);
    VI a = m_.source(h), b = m_.target(h), c = m_.target(m_.next(h));
    VI d = m_.target(m_.next(m_.opposite(h)));
    if (!inPatch(a) && !inPatch(b)) return false;
    if (c == d || I_.findHalfedge(c, d).is_valid()) return false;
    FI f1 = m_.face(h), f2 = m_.face(m_.opposite(h));
    const Vector3 n1 = normalOf(f1), n2 = normalOf(f2);
    if (!flatTriangles(std::array<FI, 2>{f1, f2})) return false;
    const Vector3 m1 = normal(P(c), P(a), P(d)), m2 = normal(P(d), P(b), P(c));
    if (!aligned(m1, n1 + n2, 60 * kDeg) || !aligned(m2, n1 + n2, 60 * kDeg)) return false;
    const double before = std::min(quality(f1), quality(f2));
    const double after = std::min(minAngle(P(c), P(a), P(d)), minAngle(P(d), P(b), P(c)));
    if (!(after > before + kImprove)) return false;
    flipNow(h);
    return true;
  }

  /// Half-edge collapse a -> b: a's triangles go to b, a disappears, b does not move.
  bool collapse(VI a, VI b) {
    if (!inPatch(a) || isLocked(a) || !live(a) || !live(b)) return false;
    HI hab = I_.findHalfedge(a, b);
    if (!hab.is_valid()) return false;
    const bool edgeOnBorder = m_.is_border(m_.edge(hab));
    if (isBorder(a)) {
      VI p, q;
      if (!edgeOnBorder || !straightBorderPoint(a, p, q)) return false;
    }
    if (!flatStar(a)) return false;
    // Link condition: the common neighbours of a and b are the apexes of the triangles on a-b.
    std::vector<VI> na = neighbours(a), nb = neighbours(b), common, apex;
    std::sort(na.begin(), na.end());
    std::sort(nb.begin(), nb.end());
    std::set_intersection(na.begin(), na.end(), nb.begin(), nb.end(), std::back_inserter(common));
    for (HI h : {hab, m_.opposite(hab)})
      if (FI f = m_.face(h); f.is_valid()) apex.push_back(m_.target(m_.next(h)));
    std::sort(apex.begin(), apex.end());
    if (common != apex) return false;
    const std::vector<FI> fs = facesAround(a);
    std::unordered_set<std::uint32_t> gone;
    for (HI h : {hab, m_.opposite(hab)})
      if (FI f = m_.face(h); f.is_valid()) gone.insert(f.idx());
    if (gone.size() == fs.size()) return false;  // a would leave nothing behind
    const double after = starQuality(a, P(b), fs, gone);
    const double before = worstOf(fs);
    if (sizeMode_ ? !(after >= std::min(target_, before)) : !(after > before + kImprove))
      return false;
    // b must keep one fan: a border a on a border b joins b's border neighbours only along a-b.
    std::unordered_map<std::uint64_t, VI> subst;
    std::vector<FI> moved;
    for (FI f : fs)
      if (!gone.count(f.idx())) {
        subst[Topology::Impl::faceVertexKey(f, a)] = b;
        moved.push_back(f);
      }
    for (std::uint32_t f : gone) I_.detachFace(FI(f));
    I_.reattach(moved, subst);
    replaced_[a.idx()] = b.idx();
    ++report_.collapses;
    return true;
  }

  /// Moves v to a better place inside its star, as a new point: an interior point by a pattern
  /// search over its tangent plane (from the mean of its neighbours and from where it is) that
  /// maximises the smallest angle of its star; a straight border point likewise along the border.
  bool relocate(VI v) {
    if (!inPatch(v) || isLocked(v) || !live(v) || !flatStar(v)) return false;
    const std::vector<FI> fs = facesAround(v);
    const double before = worstOf(fs);
    const bool border = isBorder(v);
    VI a, b;
    if (border && !straightBorderPoint(v, a, b)) return false;
    // Search directions: along the border, or two orthonormal tangents.
    Vector3 n(0, 0, 0);
    for (FI f : fs) n = n + normalOf(f);
    Vector3 t1, t2;
    double h = 0;  // the star's mean edge length
    std::vector<VI> ns = neighbours(v);
    for (VI w : ns) h += std::sqrt(CGAL::squared_distance(P(v), P(w)));
    h /= double(ns.size());
    if (border) {
      t1 = P(b) - P(a);
      t1 = t1 / std::sqrt(t1.squared_length());
    } else {
      const Vector3 any = std::abs(n.x()) < 0.9 * std::sqrt(n.squared_length()) ? Vector3(1, 0, 0)
                                                                                : Vector3(0, 1, 0);
      t1 = CGAL::cross_product(n, any);
      t1 = t1 / std::sqrt(t1.squared_length());
      t2 = CGAL::cross_product(n, t1);
      t2 = t2 / std::sqrt(t2.squared_length());
    }
    // Candidates must stay on the surface: inside the star (interior) or between a and b.
    auto valid = [&](const Point3& p) {
      if (border) {
        const double s = ((p - P(a)) * (P(b) - P(a))) / (P(b) - P(a)).squared_length();
        return s > 0.02 && s < 0.98;
      }
      std::vector<std::pair<PointId, double>> w;
      return locateInStar(fs, p, w);
    };
    auto score = [&](const Point3& p) { return valid(p) ? starQuality(v, p, fs) : -1.0; };
    Point3 best = P(v);
    double bestQ = before;
    if (!border) {
      double x = 0, y = 0, z = 0;
      for (VI w : ns) {
        x += P(w).x();
        y += P(w).y();
        z += P(w).z();
      }
      const double k = double(ns.size());
      const Point3 mean(x / k, y / k, z / k);
      if (const double q = score(mean); q > bestQ) {
        best = mean;
        bestQ = q;
      }
    }
    for (double step = 0.25 * h; step > 1e-3 * h; step *= 0.5) {
      for (bool moved = true; moved;) {
        moved = false;
        const int dirs = border ? 2 : 8;
        for (int d = 0; d < dirs; ++d) {
          Vector3 dir = border ? (d == 0 ? t1 : -t1)
                               : std::cos(d * std::numbers::pi / 4) * t1 +
                                     std::sin(d * std::numbers::pi / 4) * t2;
          const Point3 p = best + step * dir;
          if (const double q = score(p); q > bestQ + 1e-9) {
            best = p;
            bestQ = q;
            moved = true;
          }
        }
      }
    }
    if (!(bestQ > before + kImprove)) return false;
    std::vector<std::pair<PointId, double>> ancestors;
    if (border) {
      // On edge v-a or v-b: weights along it.
      const bool towardA = (best - P(v)) * (P(a) - P(v)) > 0;
      VI w = towardA ? a : b;
      const double t =
          std::sqrt(CGAL::squared_distance(P(v), best) / CGAL::squared_distance(P(v), P(w)));
      ancestors = {{PointId(v.idx()), 1.0 - t}, {PointId(w.idx()), t}};
    } else if (!locateInStar(fs, best, ancestors)) {
      return false;
    }
    double x = 0, y = 0, z = 0;  // where the new point will be (summed as newPoint sums)
    for (auto& [p, w] : ancestors) {
      x += w * P(VI(p.idx())).x();
      y += w * P(VI(p.idx())).y();
      z += w * P(VI(p.idx())).z();
    }
    if (!(starQuality(v, Point3(x, y, z), fs) > before + kImprove)) return false;
    VI nv = I_.newPoint(ancestors);
    std::unordered_map<std::uint64_t, VI> subst;
    for (FI f : fs) subst[Topology::Impl::faceVertexKey(f, v)] = nv;
    I_.reattach(fs, subst);
    replaced_[v.idx()] = nv.idx();
    patch_.insert(nv.idx());
    ++report_.relocations;
    return true;
  }

  /// The star triangle holding the projection of p, as barycentric weights on its corners.
  bool locateInStar(const std::vector<FI>& fs, const Point3& p,
                    std::vector<std::pair<PointId, double>>& out) const {
    for (FI f : fs) {
      auto c = cornersOf(f);
      const std::array<double, 3> b = bary(f, p);
      if (std::isnan(b[0]) || b[0] < -1e-12 || b[1] < -1e-12 || b[2] < -1e-12) continue;
      std::array<double, 3> w{std::max(b[0], 0.0), std::max(b[1], 0.0), std::max(b[2], 0.0)};
      const double s = w[0] + w[1] + w[2];
      out.clear();
      for (int k = 0; k < 3; ++k)
        if (w[std::size_t(k)] > 0)
          out.emplace_back(PointId(c[std::size_t(k)].idx()), w[std::size_t(k)] / s);
      return true;
    }
    return false;
  }

  /// A nearly flat triangle whose longest edge is on the border (so it cannot be flipped away):
  /// split that edge at the foot of the apex and collapse the apex onto the new point.
  bool splitCap(FI f) {
    auto c = cornersOf(f);
    for (int k = 0; k < 3; ++k) {
      VI apex = c[std::size_t(k)], a = c[std::size_t((k + 1) % 3)], b = c[std::size_t((k + 2) % 3)];
      const double angle = angleBetween(P(a) - P(apex), P(b) - P(apex));
      if (angle < 120 * kDeg) continue;
      HI h = I_.findHalfedge(a, b);
      if (!h.is_valid()) continue;
      if (!m_.is_border(m_.edge(h))) {
        if (splitInterior(f, h, apex)) return true;
        continue;
      }
      if (!inPatch(apex) || isLocked(apex) || isBorder(apex) || !flatStar(apex)) continue;
      if (isLocked(a) && isLocked(b)) continue;  // a point between two held ones would be free
      const Vector3 ab = P(b) - P(a);
      const double t = ((P(apex) - P(a)) * ab) / ab.squared_length();
      if (!(t > 0.05 && t < 0.95)) continue;
      // The apex's star with the apex at the foot must be valid and better (the two halves of f
      // vanish there).
      const Point3 foot = P(a) + t * ab;
      std::vector<FI> fs = facesAround(apex);
      std::unordered_set<std::uint32_t> skip{f.idx()};
      const double after = starQuality(apex, foot, fs, skip);
      if (!(after > worstOf(fs) + kImprove)) continue;
      VI mid = I_.splitEdgeNoTxn(m_.edge(h), a, t);
      ++report_.splits;
      patch_.insert(mid.idx());
      if (!collapse(apex, mid)) return true;  // the split alone changed nothing for the worse
      return true;
    }
    return false;
  }

  /// A nearly flat triangle f = (a, b, apex) whose apex cannot move (a corner of a cut, say) and
  /// whose long edge a-b is interior, with d across it: a new point m inside the quadrilateral
  /// (a, d, b, apex) replaces a-b by four triangles, placed (pattern search) where their smallest
  /// angle is largest; done only if that beats the two triangles it replaces.
  bool splitInterior(FI f, HI h, VI apex) {
    VI a = m_.source(h), b = m_.target(h);
    if (m_.face(h) != f) std::swap(a, b);  // f runs a -> b
    HI hf = I_.findHalfedge(a, b);
    if (!hf.is_valid() || m_.face(hf) != f) return false;
    FI g = m_.face(m_.opposite(hf));
    if (!g.is_valid() || (!inPatch(a) && !inPatch(b)) || (isLocked(a) && isLocked(b))) return false;
    VI d = m_.target(m_.next(m_.opposite(hf)));
    const Vector3 n = normalOf(f) + normalOf(g);
    if (!flatTriangles(std::array<FI, 2>{f, g})) return false;
    auto quad = [&](const Point3& p) {
      double q = 1e300;
      const std::array<std::array<Point3, 3>, 4> tris{
          {{P(a), p, P(apex)}, {p, P(b), P(apex)}, {P(b), p, P(d)}, {p, P(a), P(d)}}};
      for (const auto& t : tris) {
        if (!aligned(normal(t[0], t[1], t[2]), n, 60 * kDeg)) return -1.0;
        q = std::min(q, minAngle(t[0], t[1], t[2]));
      }
      return q;
    };
    const double before = std::min(quality(f), quality(g));
    const Vector3 ab = P(b) - P(a);
    const double tFoot = std::clamp(((P(apex) - P(a)) * ab) / ab.squared_length(), 0.2, 0.8);
    Point3 best = P(a) + tFoot * ab;
    double bestQ = quad(best);
    Vector3 t1 = ab / std::sqrt(ab.squared_length());
    Vector3 t2 = CGAL::cross_product(n, t1);
    t2 = t2 / std::sqrt(t2.squared_length());
    const double h0 = std::sqrt(ab.squared_length());
    for (double step = 0.25 * h0; step > 1e-3 * h0; step *= 0.5)
      for (bool moved = true; moved;) {
        moved = false;
        for (int k = 0; k < 8; ++k) {
          const Point3 p = best + step * (std::cos(k * std::numbers::pi / 4) * t1 +
                                          std::sin(k * std::numbers::pi / 4) * t2);
          if (const double q = quad(p); q > bestQ + 1e-9) {
            best = p;
            bestQ = q;
            moved = true;
          }
        }
      }
    if (!(bestQ > before + kImprove)) return false;
    // The point on a-b, then moved to `best` inside its new star.
    VI mid = I_.splitEdgeNoTxn(m_.edge(hf), a, tFoot);
    ++report_.splits;
    patch_.insert(mid.idx());
    std::vector<FI> fs = facesAround(mid);
    std::vector<std::pair<PointId, double>> ancestors;
    if (!locateInStar(fs, best, ancestors)) return true;
    VI nv = I_.newPoint(ancestors);
    std::unordered_map<std::uint64_t, VI> subst;
    for (FI x : fs) subst[Topology::Impl::faceVertexKey(x, mid)] = nv;
    I_.reattach(fs, subst);
    replaced_[mid.idx()] = nv.idx();
    patch_.insert(nv.idx());
    ++report_.relocations;
    return true;
  }

  // ---- Delaunay refinement (Ruppert's algorithm, on the flat parts of the patch) ----
  //
  // What the greedy passes leave under the target is refined: the patch is made Delaunay by
  // flips, then each bad triangle gets a new point at its circumcentre, unless that point would
  // lie beyond a segment or inside a segment's diametral circle, in which case the segment is
  // split instead. Segments are the edges that must stay: the border (the sheet's and every
  // cut's lips), and creases (edges whose two triangles are not flat within the tolerance).
  // A segment meeting another at a corner is split on concentric shells around the corner
  // (powers of two), so that refinement between two segments meeting at a small angle ends.
  // Insertions never move a point; a new point's ancestors are the corners of the triangle (or
  // the ends of the edge) holding it. A triangle whose small angle is fixed by the input (a
  // border point whose whole fan is too narrow for the target) is left as it is.

  bool isSegment(HI h) const {
    if (m_.is_border(m_.edge(h))) return true;
    return !flatTriangles(std::array<FI, 2>{m_.face(h), m_.face(m_.opposite(h))});
  }
  /// The angle at corner v of triangle f.
  double angleAt(FI f, VI v) const {
    auto c = cornersOf(f);
    const int k = cornerIndex(c, v);
    return angleBetween(P(c[std::size_t((k + 1) % 3)]) - P(v),
                        P(c[std::size_t((k + 2) % 3)]) - P(v));
  }
  /// The sum of the angles at v of its triangles.
  double fan(VI v) const {
    double s = 0;
    for (FI f : facesAround(v)) s += angleAt(f, v);
    return s;
  }
  /// The input fixes f's small angles: each lies at a border point whose whole fan f spans (a cut
  /// meeting the border or itself more sharply than the target, kept at the input's angle).
  bool excused(FI f, double goal) const {
    for (VI v : cornersOf(f)) {
      const double a = angleAt(f, v);
      if (a >= goal) continue;
      if (!isBorder(v) || !(a >= fan(v) - 1e-9)) return false;
    }
    return true;
  }

  /// Flips the interior edge of h (no checks): the triangles (a, b, c) and (b, a, d) become
  /// (c, a, d) and (d, b, c).
  void flipNow(HI h) {
    VI a = m_.source(h), b = m_.target(h), c = m_.target(m_.next(h));
    VI d = m_.target(m_.next(m_.opposite(h)));
    FI f1 = m_.face(h), f2 = m_.face(m_.opposite(h));
    I_.detachFace(f1);
    I_.detachFace(f2);
    I_.attachFaces({{c, a, d}, {d, b, c}});
    ++report_.flips;
  }
  /// The edge of h is not a segment, is not Delaunay (the angles opposite it sum to more than
  /// pi), and can be flipped (the quadrilateral is convex, the other diagonal is no edge yet).
  bool delaunayFlippable(HI h) const {
    if (m_.is_border(m_.edge(h)) || isSegment(h)) return false;
    VI a = m_.source(h), b = m_.target(h), c = m_.target(m_.next(h));
    VI d = m_.target(m_.next(m_.opposite(h)));
    if (c == d || I_.findHalfedge(c, d).is_valid()) return false;
    const double opposite =
        angleBetween(P(a) - P(c), P(b) - P(c)) + angleBetween(P(a) - P(d), P(b) - P(d));
    if (!(opposite > std::numbers::pi + 1e-9)) return false;
    // The other diagonal must be Delaunay itself: a quadrilateral that is not quite flat can fail
    // the test both ways, and its flips would go back and forth.
    const double across =
        angleBetween(P(c) - P(a), P(d) - P(a)) + angleBetween(P(c) - P(b), P(d) - P(b));
    if (!(across < std::numbers::pi - 1e-9)) return false;
    const Vector3 n = normalOf(m_.face(h)) + normalOf(m_.face(m_.opposite(h)));
    return aligned(normal(P(c), P(a), P(d)), n, 60 * kDeg) &&
           aligned(normal(P(d), P(b), P(c)), n, 60 * kDeg);
  }
  /// f was made since the operation began.
  bool madeHere(FI f) const { return f.is_valid() && f.idx() >= I_.fBefore; }
  /// Lawson's flips until the link of every point in `around` is Delaunay (for a new point:
  /// the edges opposite it, then those the flips expose). Only edges with an end in the patch,
  /// or on a triangle made since the operation began, flip; a flip's new diagonal joins the
  /// patch, so a chain of non-Delaunay edges is followed.
  void restoreDelaunay(std::vector<std::pair<VI, VI>> work) {
    std::size_t guard = 0;
    while (!work.empty() && ++guard < 100000) {
      auto [u, w] = work.back();
      work.pop_back();
      HI h = I_.findHalfedge(u, w);
      if (!h.is_valid() || m_.is_border(m_.edge(h))) continue;
      if (!inPatch(u) && !inPatch(w) && !madeHere(m_.face(h)) && !madeHere(m_.face(m_.opposite(h))))
        continue;
      if (!delaunayFlippable(h)) continue;
      VI c = m_.target(m_.next(h)), d = m_.target(m_.next(m_.opposite(h)));
      flipNow(h);
      join(c);
      join(d);
      work.push_back({u, c});
      work.push_back({c, w});
      work.push_back({u, d});
      work.push_back({d, w});
    }
  }
  /// Every edge of the patch's triangles.
  std::vector<std::pair<VI, VI>> patchEdges() const {
    std::vector<std::pair<VI, VI>> out;
    for (FI f : patchFaces()) {
      auto c = cornersOf(f);
      for (int k = 0; k < 3; ++k) out.push_back({c[std::size_t(k)], c[std::size_t((k + 1) % 3)]});
    }
    return out;
  }
  /// The edges opposite v in its star.
  std::vector<std::pair<VI, VI>> linkOf(VI v) const {
    std::vector<std::pair<VI, VI>> out;
    for (FI f : facesAround(v)) {
      auto c = cornersOf(f);
      const int k = cornerIndex(c, v);
      out.push_back({c[std::size_t((k + 1) % 3)], c[std::size_t((k + 2) % 3)]});
    }
    return out;
  }

  /// The centre of the circle through a, b and c; false for a (nearly) degenerate triangle.
  static bool circumcentre(const Point3& a, const Point3& b, const Point3& c, Point3& out) {
    const Vector3 ab = b - a, ac = c - a, n = CGAL::cross_product(ab, ac);
    const double n2 = n.squared_length(), l2 = std::max(ab.squared_length(), ac.squared_length());
    if (!(n2 > 1e-20 * l2 * l2)) return false;
    const Vector3 num = ac.squared_length() * CGAL::cross_product(n, ab) +
                        ab.squared_length() * CGAL::cross_product(ac, n);
    out = a + num / (2.0 * n2);
    return true;
  }
  /// Barycentric weights of p's projection on f's plane, in the order of cornersOf(f) (NaN for a
  /// degenerate triangle).
  std::array<double, 3> bary(FI f, const Point3& p) const {
    auto c = cornersOf(f);
    const Vector3 e0 = P(c[1]) - P(c[0]), e1 = P(c[2]) - P(c[0]), r = p - P(c[0]);
    const double d00 = e0 * e0, d01 = e0 * e1, d11 = e1 * e1, d20 = r * e0, d21 = r * e1;
    const double den = d00 * d11 - d01 * d01;
    if (!(den > 1e-20 * d00 * d11)) return {std::nan(""), std::nan(""), std::nan("")};
    const double wb = (d11 * d20 - d01 * d21) / den, wc = (d00 * d21 - d01 * d20) / den;
    return {1.0 - wb - wc, wb, wc};
  }
  /// The halfedge of f from its corner k+1 to k+2 (opposite corner k).
  HI oppositeEdge(FI f, int k) const {
    auto c = cornersOf(f);
    return I_.findHalfedge(c[std::size_t((k + 1) % 3)], c[std::size_t((k + 2) % 3)]);
  }

  /// A border point where the border turns (not straight), or a point on a crease that is not
  /// straight either: segments meet there.
  bool isCorner(VI v) const {
    int segments = 0;
    std::vector<VI> ends;
    for (HI h : CGAL::halfedges_around_target(m_.halfedge(v), m_)) {
      if (m_.is_border(h) || m_.is_border(m_.opposite(h)) || isSegment(h)) {
        ++segments;
        ends.push_back(m_.source(h));
      }
    }
    if (segments == 0) return false;
    if (segments != 2) return true;
    return !straightThrough(v, ends[0], ends[1]);
  }
  /// Splits the border segment a-b: at its midpoint, or, when one end is a corner, on the
  /// concentric shell (a power of two away from that corner) nearest to the midpoint. A crease is
  /// not split: refinement stops there (splitting it would keep the angle beside it, again and
  /// again, on a curved rest surface).
  bool splitSegment(VI a, VI b) {
    HI h = I_.findHalfedge(a, b);
    if (!h.is_valid() || !m_.is_border(m_.edge(h))) return false;
    if (isLocked(a) && isLocked(b)) return false;  // a point between two held ones would be free
    const double L = std::sqrt(CGAL::squared_distance(P(a), P(b)));
    if (!(0.35 * L >= smallest_)) return false;  // no piece may be shorter than the floor
    const bool ca = isCorner(a), cb = isCorner(b);
    double t = 0.5;
    if (ca != cb) {
      const double shell = std::exp2(std::round(std::log2(0.5 * L)));
      t = ca ? shell / L : 1.0 - shell / L;
    }
    if (!(t > 0.2 && t < 0.8)) t = 0.5;
    VI m = I_.splitEdgeNoTxn(m_.edge(h), a, t);
    patch_.insert(m.idx());
    ++report_.splits;
    restoreDelaunay(linkOf(m));
    return true;
  }

  /// One step of refinement for the bad triangle f: a point at its circumcentre, or a split of
  /// the segment that the circumcentre lies beyond or encroaches. False if neither can be done.
  bool refineTriangle(FI f) {
    auto c = cornersOf(f);
    Point3 q;
    if (!circumcentre(P(c[0]), P(c[1]), P(c[2]), q)) return false;
    // Walk from f towards q over flat, non-segment edges.
    FI cur = f;
    std::array<double, 3> w{};
    for (int steps = 0;; ++steps) {
      if (steps > 200) return false;
      w = bary(cur, q);
      if (std::isnan(w[0])) return false;
      int k = 0;
      for (int j = 1; j < 3; ++j)
        if (w[std::size_t(j)] < w[std::size_t(k)]) k = j;
      if (w[std::size_t(k)] >= -1e-12) break;
      HI h = oppositeEdge(cur, k);
      if (!h.is_valid()) return false;
      if (isSegment(h)) return splitSegment(m_.source(h), m_.target(h));
      cur = m_.face(m_.opposite(h));
    }
    // The Delaunay cavity of q: no segment it reaches may be encroached by q.
    std::vector<FI> cavity{cur}, todo{cur};
    std::unordered_set<std::uint32_t> seen{cur.idx()};
    while (!todo.empty()) {
      FI g = todo.back();
      todo.pop_back();
      for (HI h : CGAL::halfedges_around_face(m_.halfedge(g), m_)) {
        VI a = m_.source(h), b = m_.target(h);
        if (isSegment(h)) {
          const Point3 mid = CGAL::midpoint(P(a), P(b));
          if (CGAL::squared_distance(q, mid) <
              0.25 * CGAL::squared_distance(P(a), P(b)) * (1 - 1e-9))
            return splitSegment(a, b);
          continue;
        }
        FI n = m_.face(m_.opposite(h));
        if (seen.count(n.idx())) continue;
        auto nc = cornersOf(n);
        Point3 o;
        if (!circumcentre(P(nc[0]), P(nc[1]), P(nc[2]), o)) continue;
        if (CGAL::squared_distance(q, o) < CGAL::squared_distance(P(nc[0]), o) * (1 - 1e-9)) {
          seen.insert(n.idx());
          todo.push_back(n);
          cavity.push_back(n);
        }
      }
    }
    // No edge to the new point may be shorter than the floor (the cavity's corners become its
    // neighbours).
    auto cc = cornersOf(cur);
    for (FI g : cavity)
      for (VI v : cornersOf(g))
        if (CGAL::squared_distance(P(v), q) < smallest_ * smallest_) return false;
    int k = 0;
    for (int j = 1; j < 3; ++j)
      if (w[std::size_t(j)] < w[std::size_t(k)]) k = j;
    VI nv;
    if (w[std::size_t(k)] < 1e-6) {
      // On the edge opposite corner k (an interior, non-segment edge): split it there.
      HI h = oppositeEdge(cur, k);
      if (!h.is_valid()) return false;
      VI a = m_.source(h), b = m_.target(h);
      const int ia = cornerIndex(cc, a), ib = cornerIndex(cc, b);
      const double t = w[std::size_t(ib)] / (w[std::size_t(ia)] + w[std::size_t(ib)]);
      if (!(t > 1e-3 && t < 1 - 1e-3)) return false;
      if (isLocked(a) && isLocked(b)) return false;  // a point between two held ones would be free
      nv = I_.splitEdgeNoTxn(m_.edge(h), a, t);
    } else {
      const double s = w[0] + w[1] + w[2];
      nv = I_.splitFaceNoTxn(cur, cc, {w[0] / s, w[1] / s, w[2] / s});
    }
    patch_.insert(nv.idx());
    ++report_.insertions;
    restoreDelaunay(linkOf(nv));
    return true;
  }

  /// Refines the patch's flat triangles under the target (see above). Bounded: at most a few
  /// insertions per triangle of the patch.
  void refine() {
    const double goal = std::min(target_, kRefinable);
    smallest_ = 1e-5 * median_;
    // Nothing to refine: the mesh is left as the greedy passes left it.
    bool needed = false;
    for (FI f : patchFaces()) needed = needed || (quality(f) < goal && !excused(f, goal));
    if (!needed) return;
    restoreDelaunay(patchEdges());
    // The triangles under the goal, worst first. Nothing moves during refinement, so a triangle's
    // angles are fixed while it lives: the set gains the triangles each step makes (fresh
    // indices, at the end) and those around points that join the patch, and loses the dead ones.
    const std::vector<FI> faces = patchFaces();
    std::set<std::pair<double, std::uint32_t>> bad;
    std::unordered_set<std::uint32_t>
        hopeless;  // could not be refined (an attempt changes nothing)
    for (FI f : faces)
      if (const double q = quality(f); q < goal) bad.emplace(q, f.idx());
    std::size_t budget = 8 * faces.size() + 64;
    refining_ = true;
    joined_.clear();
    while (budget > 0 && !bad.empty()) {
      const Index mark = Index(m_.num_faces());
      // A segment of a bad triangle encroached by its opposite corner (the angle there exceeds a
      // right one) is split first.
      bool did = false;
      for (auto it = bad.begin(); it != bad.end() && !did;) {
        const FI f(it->second);
        if (!alive(f)) {
          it = bad.erase(it);
          continue;
        }
        for (HI h : CGAL::halfedges_around_face(m_.halfedge(f), m_)) {
          if (!isSegment(h)) continue;
          VI a = m_.source(h), b = m_.target(h), o = m_.target(m_.next(h));
          if (angleBetween(P(a) - P(o), P(b) - P(o)) <= 0.5 * std::numbers::pi + 1e-9) continue;
          if (splitSegment(a, b)) {
            did = true;
            break;
          }
        }
        ++it;
      }
      // Otherwise the worst that can be refined (an excused triangle stays excused: its angles
      // and its corners' fans do not change while it exists).
      for (auto it = bad.begin(); it != bad.end() && !did; ++it) {
        const FI f(it->second);
        if (!alive(f) || hopeless.count(f.idx())) continue;
        if (!excused(f, goal) && refineTriangle(f))
          did = true;
        else
          hopeless.insert(f.idx());
      }
      if (!did) break;
      --budget;
      for (Index f = mark; f < m_.num_faces(); ++f)
        if (alive(FI(f)))
          if (const double q = quality(FI(f)); q < goal) bad.emplace(q, f);
      // Points the step's flips brought into the patch bring their older triangles.
      for (VI v : joined_)
        for (FI f : facesAround(v))
          if (const double q = quality(f); q < goal) bad.emplace(q, f.idx());
      joined_.clear();
    }
    refining_ = false;
    if (budget == 0) {
      // Spent: say so if anything is still to do.
      for (const auto& [q, f] : bad)
        if (alive(FI(f)) && !hopeless.count(f) && !excused(FI(f), goal)) report_.budgetSpent = true;
    }
  }

  Topology::Impl& I_;
  Mesh& m_;
  double target_, flat_;
  std::unordered_map<Index, Index>& replaced_;
  std::unordered_set<Index> locked_;
  std::unordered_set<Index> patch_;
  RepairReport report_;
  double shortEdge_ = 0;   // edges shorter than this are collapsed even in good triangles
  bool sizeMode_ = false;  // collapse(): accept what keeps the target (not only improvements)
  double median_ = 0;      // the patch's median edge before the repair
  double smallest_ = 0;    // refinement's floor (1e-5 of the median edge; see refine())
  bool refining_ = false;  // join() notes the points that join the patch
  std::vector<VI> joined_;
};

Index follow(const std::unordered_map<Index, Index>& replaced, Index p) {
  for (auto it = replaced.find(p); it != replaced.end(); it = replaced.find(p)) p = it->second;
  return p;
}

}  // namespace

void checkRepairOptions(const RepairOptions& o, const char* operation) {
  if (!(o.minAngle >= 0.0 && o.minAngle < 60.0))
    throw TopologyError(std::string(operation) + ": the repair's minAngle " +
                        std::to_string(o.minAngle) +
                        " must be in [0, 60) degrees (0 turns the repair off)");
  if (!(o.flatness >= 0.0 && o.flatness < 90.0))
    throw TopologyError(std::string(operation) + ": the repair's flatness " +
                        std::to_string(o.flatness) + " must be in [0, 90) degrees");
}

RepairReport Topology::Impl::repairNoTxn(const std::vector<VI>& seeds, const RepairOptions& options,
                                         std::unordered_map<Index, Index>& replacedBy) {
  if (!(options.minAngle > 0)) return {};
  std::vector<VI> all = seeds;
  for (Index v = vBefore; v < mesh.num_vertices(); ++v) all.push_back(VI(v));
  for (VI v : touched) all.push_back(v);
  Repairer r(*this, options, replacedBy);
  return r.run(all);
}

void Topology::Impl::repairIncision(const RepairOptions& options, IncisionResult& result) {
  if (!(options.minAngle > 0)) return;
  std::vector<VI> seeds;
  for (PointId p : result.path) seeds.push_back(VI(p.idx()));
  for (PointId p : result.copies) seeds.push_back(VI(p.idx()));
  std::unordered_map<Index, Index> replaced;
  result.repair = repairNoTxn(seeds, options, replaced);
  if (replaced.empty()) return;
  auto remap = [&](std::vector<PointId>& ps, bool dedupe) {
    for (PointId& p : ps) p = PointId(follow(replaced, p.idx()));
    if (dedupe) ps.erase(std::unique(ps.begin(), ps.end()), ps.end());
  };
  remap(result.path, true);
  remap(result.copies, false);
  remap(result.copiedFrom, false);
  remap(result.insertedPoints, false);
  // A point that disappeared into another may now be listed twice.
  std::sort(result.insertedPoints.begin(), result.insertedPoints.end());
  result.insertedPoints.erase(
      std::unique(result.insertedPoints.begin(), result.insertedPoints.end()),
      result.insertedPoints.end());
}

RepairReport Topology::repair(std::span<const PointId> around, const RepairOptions& options) {
  checkRepairOptions(options, "repair");
  if (!(options.minAngle > 0)) return {};  // off: no transaction at all
  Impl& I = *impl_;
  std::vector<VI> seeds;
  for (PointId p : around)
    if (I.vertexAlive(VI(p.idx()))) seeds.push_back(VI(p.idx()));
  return I.committed(*this, "repair", [&] {
    std::unordered_map<Index, Index> replaced;
    return I.repairNoTxn(seeds, options, replaced);
  });
}

}  // namespace cutsim::topology
