// Cutting along a polyline given in rest (material) coordinates, and the triangle locator.
//
// The cut is found by walking over the surface from triangle to triangle (never by scanning the
// mesh): the start point is located with a hash grid of triangle boxes, then each segment of the
// polyline is followed across triangles, projecting the target into each triangle's plane, so a
// curved rest surface is followed too. The walk runs twice: first on the unchanged mesh to check
// the request (a polyline that leaves the surface is rejected before anything changes), then from
// vertex to vertex, inserting every crossing as a vertex (an edge split, or a triangle split at a
// corner), snapped to an existing vertex or edge when closer than snapTolerance times the local
// edge length. That inserting walk is planned on a copy of the triangles around the cut (a patch,
// grown until the walk stays inside it), because snapping moves the path and the walk from a
// snapped vertex can still fail: a failed plan rejects the request with the mesh untouched. A
// successful plan is a list of edge and triangle splits, replayed on the mesh; the resulting
// path of edges is then incised. The cost follows the size of the cut, not of the mesh.
#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <sstream>

#include "cutsim/topology/geometry.hpp"
#include "topology_impl.hpp"

namespace cutsim::topology {

namespace {

using Vector3 = Kernel::Vector_3;

/// Added to the errors of a polyline that misses the surface: the likeliest cause on a deformed
/// surface.
const std::string kRestHint =
    " (a cut's polyline is in rest coordinates, where the surface is at rest, not where it is "
    "now)";

std::string fmt(const Point3& p) {
  std::ostringstream s;
  s.precision(6);
  s << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
  return s.str();
}

std::array<Point3, 3> corners(const Mesh& m, FI f) {
  HI h = m.halfedge(f);
  return {m.point(m.source(h)), m.point(m.target(h)), m.point(m.target(m.next(h)))};
}

/// Barycentric coordinates of the projection of q onto the plane of c. nullopt if degenerate.
std::optional<std::array<double, 3>> barycentric(const std::array<Point3, 3>& c, const Point3& q) {
  Vector3 v0 = c[1] - c[0], v1 = c[2] - c[0], v2 = q - c[0];
  double d00 = v0 * v0, d01 = v0 * v1, d11 = v1 * v1, d20 = v2 * v0, d21 = v2 * v1;
  double denom = d00 * d11 - d01 * d01;
  if (!(denom > 1e-300) || denom <= 1e-14 * d00 * d11) return std::nullopt;
  double b = (d11 * d20 - d01 * d21) / denom;
  double g = (d00 * d21 - d01 * d20) / denom;
  return std::array<double, 3>{1.0 - b - g, b, g};
}

/// Closest point of triangle c to p (geometry.hpp's, on CGAL points).
Point3 closestOnTriangle(const std::array<Point3, 3>& c, const Point3& p) {
  return toPoint(geometry::closestOnTriangle(toVec(p), toVec(c[0]), toVec(c[1]), toVec(c[2])));
}

double longestEdge(const std::array<Point3, 3>& c) {
  return geometry::longestEdge(toVec(c[0]), toVec(c[1]), toVec(c[2]));
}

/// Squared distance between segments p1q1 and p2q2 (Ericson 5.1.9).
double segmentDistance2(const Point3& p1, const Point3& q1, const Point3& p2, const Point3& q2) {
  Vector3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  double a = d1 * d1, e = d2 * d2, f = d2 * r;
  double s = 0, t = 0;
  const double eps = 1e-30;
  if (a <= eps && e <= eps) return r * r;
  if (a <= eps) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    double c = d1 * r;
    if (e <= eps) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      double b = d1 * d2, denom = a * e - b * b;
      s = denom > eps ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0) {
        t = 0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1) {
        t = 1;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  Vector3 d = (p1 + s * d1) - (p2 + t * d2);
  return d * d;
}

/// One step of the walk inside face f from p (barycentric lp in f, on f's closure) towards q.
struct Step {
  bool enters = false;
  double margin = -1e300;      // how clearly the direction enters f (larger is better)
  bool reached = false;        // q (projected) lies in f
  std::array<double, 3> at{};  // barycentric coordinates of the end of the step in f
  int exitEdge = -1;           // local index of the vertex opposite the exit edge
};

/// The step in f from lp towards the target whose barycentric coordinates in f's plane are lq.
Step ordinaryStep(const std::array<double, 3>& lp, const std::array<double, 3>& lq) {
  Step s;
  const double eps = 1e-10;
  std::array<double, 3> d{lq[0] - lp[0], lq[1] - lp[1], lq[2] - lp[2]};
  double norm = std::max({std::abs(d[0]), std::abs(d[1]), std::abs(d[2]), 1e-300});
  double margin = 1e300;
  for (int j = 0; j < 3; ++j)
    if (lp[j] <= eps) margin = std::min(margin, d[j] / norm);
  s.margin = margin == 1e300 ? 1.0 : margin;
  s.enters = s.margin >= -1e-9;
  // A target on an edge of f (within rounding: a polyline ending exactly on the border) is
  // reached, not left through that edge.
  double sExit = 1.0 - 1e-9;
  int exitJ = -1;
  for (int j = 0; j < 3; ++j)
    if (d[j] < 0 && lp[j] > eps) {
      double sj = lp[j] / -d[j];
      if (sj < sExit) {
        sExit = sj;
        exitJ = j;
      }
    }
  if (exitJ < 0) {
    s.reached = true;
    s.at = lq;
    for (double& x : s.at) x = std::max(0.0, x);
    double sum = s.at[0] + s.at[1] + s.at[2];
    for (double& x : s.at) x /= sum;
  } else {
    for (int j = 0; j < 3; ++j) s.at[j] = std::max(0.0, lp[j] + sExit * d[j]);
    s.at[exitJ] = 0.0;
    double sum = s.at[0] + s.at[1] + s.at[2];
    for (double& x : s.at) x /= sum;
    s.exitEdge = exitJ;
  }
  return s;
}

Point3 fromBary(const std::array<Point3, 3>& c, const std::array<double, 3>& l) {
  return Point3(l[0] * c[0].x() + l[1] * c[1].x() + l[2] * c[2].x(),
                l[0] * c[0].y() + l[1] * c[1].y() + l[2] * c[2].y(),
                l[0] * c[0].z() + l[1] * c[1].z() + l[2] * c[2].z());
}

Step stepIn(const std::array<Point3, 3>& c, const std::array<double, 3>& lp, const Point3& q) {
  auto lq = barycentric(c, q);
  if (!lq) return Step{};
  const Step ordinary = ordinaryStep(lp, *lq);
  if (ordinary.enters) return ordinary;
  // Neither entering f nor reaching the target: the target may lie right over (or under) where
  // the walk is, a curved surface's sagitta off f's plane and no farther from it along the plane,
  // and is reached here. Above a ridge of a curved rest surface (a path drawn on the smooth
  // surface the mesh samples), the target projects a little beyond the shared edge into each
  // plane, so neither triangle would be entered nor the target reached. The smallest margin
  // that enters: a triangle the walk can enter (across a crease, say) is always preferred.
  const Point3 here = fromBary(c, lp), foot = fromBary(c, *lq);
  const double along = std::sqrt(CGAL::squared_distance(here, foot));
  const double off = std::sqrt(CGAL::squared_distance(q, foot));
  if (along > 0 && along <= off && off <= 0.05 * longestEdge(c)) {
    Step s;
    s.enters = true;
    s.margin = -1e-9;
    s.reached = true;
    s.at = lp;
    return s;
  }
  return ordinary;
}

}  // namespace

// ------------------------------------------------------------------------------------------
// TriangleGrid

TriangleGrid::Key TriangleGrid::key(long i, long j, long k) const {
  auto u = [](long x) { return std::uint64_t(x + (1L << 20)) & 0x1FFFFFu; };
  return (u(i) << 42) | (u(j) << 21) | u(k);
}

void TriangleGrid::cellRange(const std::array<Point3, 3>& c, long lo[3], long hi[3]) const {
  for (int a = 0; a < 3; ++a) {
    double mn = std::min({c[0][a], c[1][a], c[2][a]}), mx = std::max({c[0][a], c[1][a], c[2][a]});
    lo[a] = long(std::floor(mn / cell_));
    hi[a] = long(std::floor(mx / cell_));
  }
}

void TriangleGrid::build(const Mesh& mesh) {
  cells_.clear();
  if (chosen_ <= 0) {
    double sum = 0;
    std::size_t n = 0;
    for (auto e : mesh.edges()) {
      sum += std::sqrt(CGAL::squared_distance(mesh.point(mesh.source(mesh.halfedge(e))),
                                              mesh.point(mesh.target(mesh.halfedge(e)))));
      ++n;
    }
    chosen_ = n ? std::max(2.0 * sum / double(n), 1e-300) : 1.0;
  }
  cell_ = chosen_;
  built_ = true;
  for (FI f : mesh.faces()) insert(mesh, f);
}

void TriangleGrid::insert(const Mesh& mesh, FI f) {
  auto c = corners(mesh, f);
  long lo[3], hi[3];
  cellRange(c, lo, hi);
  for (long i = lo[0]; i <= hi[0]; ++i)
    for (long j = lo[1]; j <= hi[1]; ++j)
      for (long k = lo[2]; k <= hi[2]; ++k) cells_[key(i, j, k)].push_back(f);
}

void TriangleGrid::erase(const std::array<Point3, 3>& c, FI f) {
  long lo[3], hi[3];
  cellRange(c, lo, hi);
  for (long i = lo[0]; i <= hi[0]; ++i)
    for (long j = lo[1]; j <= hi[1]; ++j)
      for (long k = lo[2]; k <= hi[2]; ++k) {
        auto it = cells_.find(key(i, j, k));
        if (it == cells_.end()) continue;
        auto& v = it->second;
        auto pos = std::find(v.begin(), v.end(), f);
        if (pos != v.end()) {
          *pos = v.back();
          v.pop_back();
        }
        if (v.empty()) cells_.erase(it);
      }
}

void TriangleGrid::query(const Point3& p, double r, std::vector<FI>& out) const {
  out.clear();
  long lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = long(std::floor((p[a] - r) / cell_));
    hi[a] = long(std::floor((p[a] + r) / cell_));
  }
  for (long i = lo[0]; i <= hi[0]; ++i)
    for (long j = lo[1]; j <= hi[1]; ++j)
      for (long k = lo[2]; k <= hi[2]; ++k)
        if (auto it = cells_.find(key(i, j, k)); it != cells_.end())
          out.insert(out.end(), it->second.begin(), it->second.end());
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

// ------------------------------------------------------------------------------------------
// The walk

namespace {

struct Location {
  FI face;
  std::array<double, 3> bary;  // in face
};

/// Thrown by a walk on a patch that reached a triangle whose surroundings the patch lacks.
struct PatchTooSmall {};

/// One split of the planned insertion, in the patch's vertices.
struct PlannedSplit {
  bool onEdge = false;
  VI a, b;  // onEdge: the edge a-b split at parameter u from a
  double u = 0.0;
  std::array<VI, 3> corners;  // otherwise: the triangle with these corners, at these weights
  std::array<double, 3> weights{};
  VI created;  // the patch vertex it created
};

class Walker {
 public:
  Walker(Topology::Impl& impl, double snap) : I(impl), m(impl.mesh), snap_(snap) {}
  /// Walking on a patch: `frontier[v]` marks the patch vertices whose triangles are not all in it.
  void setFrontier(const std::vector<char>* frontier) { frontier_ = frontier; }
  /// A location this close (absolute) to a vertex of its triangle is that vertex, whatever the
  /// triangle's size: the barycentric tolerance alone depends on how small the triangle is, and
  /// the cut's own splits make small ones (an end a micron past an edge the path has just crossed
  /// would stay a second point there, a micron from the crossing, which no repair may remove).
  void setSamePoint(double distance) { same_ = distance; }

  /// Nearest surface point to p, within `tolerance` times the local edge length.
  Location locate(const Point3& p, std::size_t index) {
    if (!I.grid.built()) I.grid.build(m);
    std::vector<FI> cand;
    double r = I.grid.cellSize();
    for (int attempt = 0; attempt < 2 && cand.empty(); ++attempt, r *= 2) I.grid.query(p, r, cand);
    double best = 1e300;
    FI bestF;
    for (FI f : cand) {
      auto c = corners(m, f);
      double d = CGAL::squared_distance(closestOnTriangle(c, p), p);
      if (d < best) {
        best = d;
        bestF = f;
      }
    }
    if (!bestF.is_valid())
      throw TopologyError("cutPolyline: point " + std::to_string(index) + " " + fmt(p) +
                          " is not on the surface (no triangle near it)" + kRestHint);
    auto c = corners(m, bestF);
    double tol = 0.25 * longestEdge(c);
    if (std::sqrt(best) > tol)
      throw TopologyError("cutPolyline: point " + std::to_string(index) + " " + fmt(p) +
                          " is not on the surface (nearest triangle " +
                          std::to_string(bestF.idx()) + " is " + std::to_string(std::sqrt(best)) +
                          " away)" + kRestHint);
    Point3 onSurface = closestOnTriangle(c, p);
    auto l = barycentric(c, onSurface);
    if (!l)
      throw TopologyError("cutPolyline: point " + std::to_string(index) + " " + fmt(p) +
                          " lies on a degenerate triangle " + std::to_string(bestF.idx()));
    for (double& x : *l) x = std::max(0.0, x);
    double s = (*l)[0] + (*l)[1] + (*l)[2];
    for (double& x : *l) x /= s;
    return {bestF, *l};
  }

  /// Candidate faces containing the location, with its barycentric coordinates in each.
  std::vector<Location> around(const Location& loc) {
    const double eps = 1e-10;
    std::vector<int> zeros;
    for (int j = 0; j < 3; ++j)
      if (loc.bary[j] <= eps) zeros.push_back(j);
    std::vector<Location> out;
    HI h = m.halfedge(loc.face);
    std::array<VI, 3> fv{m.source(h), m.target(h), m.target(m.next(h))};
    if (zeros.size() >= 2) {  // at a vertex
      int k = 3 - zeros[0] - zeros[1];
      return aroundVertex(fv[k]);
    }
    out.push_back(loc);
    if (zeros.size() == 1) {  // on an edge: the face across too
      int j = zeros[0];
      VI a = fv[(j + 1) % 3], b = fv[(j + 2) % 3];
      HI across = I.findHalfedge(b, a);
      if (across.is_valid() && m.face(across).is_valid()) {
        FI g = m.face(across);
        auto c = corners(m, g);
        auto l = barycentric(c, fromBary(corners(m, loc.face), loc.bary));
        if (l) {
          for (double& x : *l) x = std::max(0.0, x);
          HI gh = m.halfedge(g);
          std::array<VI, 3> gv{m.source(gh), m.target(gh), m.target(m.next(gh))};
          for (int t = 0; t < 3; ++t)
            if (gv[t] != a && gv[t] != b) (*l)[t] = 0.0;
          double s = (*l)[0] + (*l)[1] + (*l)[2];
          for (double& x : *l) x /= s;
          out.push_back({g, *l});
        }
      }
    }
    return out;
  }

  std::vector<Location> aroundVertex(VI v) {
    std::vector<Location> out;
    std::vector<HI> hs;
    I.incomingHalfedges(v, hs);
    for (HI h : hs) {
      FI f = m.face(h);
      if (!f.is_valid()) continue;
      HI fh = m.halfedge(f);
      std::array<VI, 3> fv{m.source(fh), m.target(fh), m.target(m.next(fh))};
      std::array<double, 3> l{0, 0, 0};
      for (int t = 0; t < 3; ++t)
        if (fv[t] == v) l[t] = 1.0;
      out.push_back({f, l});
    }
    return out;
  }

  /// Best step from one of the candidate locations towards q.
  std::optional<std::pair<Location, Step>> bestStep(const std::vector<Location>& cands,
                                                    const Point3& q) {
    std::optional<std::pair<Location, Step>> best;
    for (const Location& l : cands) {
      Step s = stepIn(corners(m, l.face), l.bary, q);
      if (!s.enters) continue;
      if (!best || s.margin > best->second.margin) best = std::make_pair(l, s);
    }
    return best;
  }

  /// The checking walk on the unchanged mesh: throws if the polyline leaves the surface.
  void check(const std::vector<Point3>& poly) {
    Location loc = locate(poly[0], 0);
    start = loc;
    corridor.push_back(loc.face);
    for (std::size_t k = 1; k < poly.size(); ++k) {
      locate(poly[k], k);  // each polyline point must be on the surface too
      std::size_t guard = 0;
      while (true) {
        if (++guard > 100000 + 4 * m.number_of_faces())
          throw TopologyError("cutPolyline: the walk along segment " + std::to_string(k) +
                              " does not end");
        auto st = bestStep(around(loc), poly[k]);
        Point3 here = fromBary(corners(m, loc.face), loc.bary);
        if (!st)
          throw TopologyError("cutPolyline: segment " + std::to_string(k - 1) + "-" +
                              std::to_string(k) + " leaves the surface at " + fmt(here) +
                              kRestHint);
        Location next{st->first.face, st->second.at};
        corridor.push_back(next.face);
        if (st->second.reached) {
          loc = next;
          break;
        }
        // Crossing the exit edge: the face across must exist.
        int j = st->second.exitEdge;
        HI fh = m.halfedge(next.face);
        std::array<VI, 3> fv{m.source(fh), m.target(fh), m.target(m.next(fh))};
        VI a = fv[(j + 1) % 3], b = fv[(j + 2) % 3];
        HI across = I.findHalfedge(b, a);
        bool atVertex = next.bary[(j + 1) % 3] <= 1e-10 || next.bary[(j + 2) % 3] <= 1e-10;
        if (!atVertex && (!across.is_valid() || !m.face(across).is_valid()))
          throw TopologyError("cutPolyline: segment " + std::to_string(k - 1) + "-" +
                              std::to_string(k) + " leaves the surface at " +
                              fmt(fromBary(corners(m, next.face), next.bary)) +
                              " through border edge (" + std::to_string(a.idx()) + ", " +
                              std::to_string(b.idx()) + ")");
        if (fromBary(corners(m, next.face), next.bary) == here && guard > 3) {
          // No progress from a vertex: the direction leaves the surface there.
          throw TopologyError("cutPolyline: segment " + std::to_string(k - 1) + "-" +
                              std::to_string(k) + " leaves the surface at " + fmt(here) +
                              kRestHint);
        }
        loc = next;
      }
    }
  }

  /// Inserts a vertex at location l (snapping), returns it. Snapping moves the path by up to
  /// snapTolerance of the local edge length; it never moves it ONTO the border (a border vertex or
  /// edge is used only where the polyline really meets it), so that the path cannot leave the
  /// surface that the checking walk found it on.
  VI insertAt(const Location& l) {
    const double exact = 1e-9;
    HI fh = m.halfedge(l.face);
    std::array<VI, 3> fv{m.source(fh), m.target(fh), m.target(m.next(fh))};
    if (frontier_)  // border tests need every triangle around the three corners
      for (VI v : fv)
        if (v.idx() < frontier_->size() && (*frontier_)[v.idx()]) throw PatchTooSmall{};
    auto edgeIsBorder = [&](int j) {
      return m.is_border(m.edge(I.findHalfedge(fv[(j + 1) % 3], fv[(j + 2) % 3])));
    };
    int onBorderEdge = -1;  // the location lies on this border edge: it may snap along it
    for (int j = 0; j < 3; ++j)
      if (l.bary[j] <= exact && edgeIsBorder(j)) onBorderEdge = j;
    // The same point as a vertex within same_ (see setSamePoint; measured only when it is on).
    std::array<Point3, 3> c;
    Point3 here;
    if (same_ > 0) {
      c = corners(m, l.face);
      here = fromBary(c, l.bary);
    }
    // Only a vertex the location lies towards (a crossing on the edge opposite the walk's own
    // vertex, in a sliver, must not snap back onto that vertex: the walk would not move on).
    auto nearVertex = [&](int k) {
      return same_ > 0 && l.bary[k] > 0.5 && CGAL::squared_distance(here, c[k]) <= same_ * same_;
    };
    for (int k = 0; k < 3; ++k) {
      bool mayMove = !m.is_border(fv[k], true) || (onBorderEdge >= 0 && onBorderEdge != k);
      if (l.bary[k] >= 1.0 - exact || ((l.bary[k] >= 1.0 - snap_ || nearVertex(k)) && mayMove))
        return fv[k];
    }
    int edge = -1;
    for (int j = 0; j < 3; ++j) {
      VI a = fv[(j + 1) % 3], b = fv[(j + 2) % 3];
      HI h = I.findHalfedge(a, b);
      bool border = m.is_border(m.edge(h));
      if (l.bary[j] <= exact || (l.bary[j] <= snap_ && !border))
        if (edge < 0 || l.bary[j] < l.bary[edge]) edge = j;
    }
    if (edge >= 0) {
      int j = edge;
      VI a = fv[(j + 1) % 3], b = fv[(j + 2) % 3];
      double u = l.bary[(j + 2) % 3] / (l.bary[(j + 1) % 3] + l.bary[(j + 2) % 3]);
      u = std::clamp(u, 1e-6, 1.0 - 1e-6);
      HI h = I.findHalfedge(a, b);
      VI v = I.splitEdgeNoTxn(m.edge(h), a, u);
      inserted.push_back(PointId(v.idx()));
      plan.push_back({true, a, b, u, {}, {}, v});
      keepPathConnected(a, b, v);
      return v;
    }
    VI v = I.splitFaceNoTxn(l.face, l.bary);
    inserted.push_back(PointId(v.idx()));
    plan.push_back({false, {}, {}, 0.0, fv, l.bary, v});
    return v;
  }

  /// A split of an edge that the path already runs along (the polyline comes back along itself)
  /// puts the new point into the path between the edge's ends, so the path stays a chain of edges.
  void keepPathConnected(VI a, VI b, VI mid) {
    for (std::size_t i = path_.size(); i-- > 1;)
      if ((path_[i - 1] == a && path_[i] == b) || (path_[i - 1] == b && path_[i] == a))
        path_.insert(path_.begin() + std::ptrdiff_t(i), mid);
  }

  /// The inserting walk from `from` (the located first point): every crossing becomes a vertex.
  /// Returns the path of vertices.
  std::vector<VI> insert(const std::vector<Point3>& poly, const Location& from) {
    std::vector<VI>& path = path_;
    path.clear();
    VI cur = insertAt(from);
    path.push_back(cur);
    for (std::size_t k = 1; k < poly.size(); ++k) {
      std::size_t guard = 0;
      while (true) {
        if (++guard > 100000 + 4 * m.number_of_faces())
          throw TopologyError("the walk along segment " + std::to_string(k - 1) + "-" +
                              std::to_string(k) + " does not end");
        auto st = bestStep(aroundVertex(cur), poly[k]);
        if (!st)
          throw TopologyError("segment " + std::to_string(k - 1) + "-" + std::to_string(k) +
                              " cannot be followed from " + fmt(m.point(cur)) +
                              ", where a crossing snapped to");
        const auto& [l, s] = *st;
        VI v = insertAt({l.face, s.at});
        if (v != cur) {
          path.push_back(v);
          cur = v;
        }
        if (s.reached) break;
      }
    }
    return path;
  }

  std::vector<PointId> inserted;
  std::vector<PlannedSplit> plan;  // the splits insert() made, in order
  Location start{};                // check(): the located first point
  std::vector<FI> corridor;        // check(): the triangles the walk went through

 private:
  const std::vector<char>* frontier_ = nullptr;
  std::vector<VI> path_;
  Topology::Impl& I;
  Mesh& m;
  double snap_;
  double same_ = 0.0;
};

/// A copy of the triangles around a cut, on which the inserting walk is planned. A patch vertex
/// whose triangles are not all in the patch is on its frontier: its border status in the patch is
/// not the mesh's, so the walk stops (PatchTooSmall) before it uses a triangle touching one. Such
/// a vertex gets one copy per fan of patch triangles around it, so that the patch is manifold.
struct Patch {
  Topology::Impl impl;
  std::vector<VI> toMesh;      // patch vertex -> mesh vertex (the vertices the patch started with)
  std::vector<char> frontier;  // by patch vertex
  std::unordered_map<std::uint32_t, FI> faceOf;  // mesh triangle -> patch triangle
  bool hasFrontier = false;
};

std::unique_ptr<Patch> buildPatch(const Topology::Impl& I,
                                  const std::unordered_set<std::uint32_t>& faces) {
  const Mesh& m = I.mesh;
  auto P = std::make_unique<Patch>();
  std::vector<std::uint32_t> sorted(faces.begin(), faces.end());
  std::sort(sorted.begin(), sorted.end());
  std::unordered_map<std::uint64_t, VI> corner;  // (mesh face, mesh vertex) -> patch vertex
  std::unordered_set<std::uint32_t> seen;
  std::vector<HI> hs;
  auto addVertex = [&](VI v, bool onFrontier) {
    VI pv = P->impl.newFreePoint(m.point(v));
    P->toMesh.push_back(v);
    P->frontier.push_back(onFrontier ? 1 : 0);
    return pv;
  };
  for (std::uint32_t fi : sorted) {
    HI fh = m.halfedge(FI(fi));
    for (VI v : {m.source(fh), m.target(fh), m.target(m.next(fh))}) {
      if (!seen.insert(v.idx()).second) continue;
      I.incomingHalfedges(v, hs);
      std::vector<char> in(hs.size());
      bool onFrontier = false;
      for (std::size_t k = 0; k < hs.size(); ++k) {
        FI f = m.face(hs[k]);
        in[k] = f.is_valid() && faces.count(f.idx()) ? 1 : 0;
        if (f.is_valid() && !in[k]) onFrontier = true;
      }
      if (!onFrontier) {
        VI pv = addVertex(v, false);
        for (std::size_t k = 0; k < hs.size(); ++k)
          if (in[k]) corner[Topology::Impl::faceVertexKey(m.face(hs[k]), v)] = pv;
        continue;
      }
      // One copy per run of consecutive patch triangles around v (consecutive ones share an edge).
      P->hasFrontier = true;
      std::size_t n = hs.size(), gap = 0;
      while (in[gap]) ++gap;  // a frontier vertex has a triangle outside the patch
      VI pv;
      for (std::size_t s = 1; s <= n; ++s) {
        std::size_t k = (gap + s) % n;
        if (!in[k]) continue;
        if (!in[(k + n - 1) % n]) pv = addVertex(v, true);
        corner[Topology::Impl::faceVertexKey(m.face(hs[k]), v)] = pv;
      }
    }
  }
  std::vector<std::array<VI, 3>> tris;
  for (std::uint32_t fi : sorted) {
    HI fh = m.halfedge(FI(fi));
    std::array<VI, 3> t;
    int k = 0;
    for (VI v : {m.source(fh), m.target(fh), m.target(m.next(fh))})
      t[std::size_t(k++)] = corner.at(Topology::Impl::faceVertexKey(FI(fi), v));
    tris.push_back(t);
  }
  std::vector<FI> made = P->impl.attachFaces(tris);
  for (std::size_t k = 0; k < sorted.size(); ++k) P->faceOf[sorted[k]] = made[k];
  P->impl.begin("cutPolyline (plan)");  // the splits below journal as in the mesh; never committed
  return P;
}

/// Adds every triangle around a vertex of the given triangles.
void growByOneRing(const Topology::Impl& I, std::unordered_set<std::uint32_t>& faces) {
  const Mesh& m = I.mesh;
  std::vector<std::uint32_t> current(faces.begin(), faces.end());
  std::unordered_set<std::uint32_t> done;
  std::vector<HI> hs;
  for (std::uint32_t fi : current) {
    HI fh = m.halfedge(FI(fi));
    for (VI v : {m.source(fh), m.target(fh), m.target(m.next(fh))}) {
      if (!done.insert(v.idx()).second) continue;
      I.incomingHalfedges(v, hs);
      for (HI h : hs)
        if (m.face(h).is_valid()) faces.insert(m.face(h).idx());
    }
  }
}

/// The location of mesh location `l` in the patch.
Location inPatch(const Patch& P, const Mesh& m, const Location& l) {
  FI pf = P.faceOf.at(l.face.idx());
  const Mesh& pm = P.impl.mesh;
  HI fh = m.halfedge(l.face), ph = pm.halfedge(pf);
  std::array<VI, 3> mv{m.source(fh), m.target(fh), m.target(m.next(fh))};
  std::array<VI, 3> pv{pm.source(ph), pm.target(ph), pm.target(pm.next(ph))};
  Location out{pf, {}};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (P.toMesh[pv[std::size_t(i)].idx()] == mv[std::size_t(j)])
        out.bary[std::size_t(i)] = l.bary[std::size_t(j)];
  return out;
}

/// The first two non-adjacent segments of the polyline that meet, if any.
std::optional<std::pair<std::size_t, std::size_t>> selfCrossing(const std::vector<Point3>& poly) {
  for (std::size_t i = 0; i + 1 < poly.size(); ++i)
    for (std::size_t j = i + 2; j + 1 < poly.size(); ++j) {
      double d2 = segmentDistance2(poly[i], poly[i + 1], poly[j], poly[j + 1]);
      double len = std::min(std::sqrt(CGAL::squared_distance(poly[i], poly[i + 1])),
                            std::sqrt(CGAL::squared_distance(poly[j], poly[j + 1])));
      if (d2 <= 1e-18 * len * len || d2 == 0.0) return std::make_pair(i, j);
    }
  return std::nullopt;
}

/// The polyline with its two ends moved onto the nearest vertex within snap (in barycentric
/// terms, as the walk snaps), else onto the nearest edge within snap, of the triangle each lies in.
std::vector<Point3> snapEnds(Topology::Impl& I, std::vector<Point3> poly, double snap,
                             bool borderOnly) {
  Walker walker(I, snap);
  const Mesh& m = I.mesh;
  for (std::size_t end : {std::size_t(0), poly.size() - 1}) {
    Location l = walker.locate(poly[end], end);
    auto c = corners(I.mesh, l.face);
    // The face's corners and edges (edge j is opposite corner j) on the border.
    HI fh = m.halfedge(l.face);
    std::array<VI, 3> cv{m.source(fh), m.target(fh), m.target(m.next(fh))};
    auto vertexOk = [&](int k) { return !borderOnly || m.is_border(cv[std::size_t(k)], true); };
    auto edgeOk = [&](int j) {
      if (!borderOnly) return true;
      HI h = I.findHalfedge(cv[std::size_t((j + 1) % 3)], cv[std::size_t((j + 2) % 3)]);
      return h.is_valid() && m.is_border(m.edge(h));
    };
    int vertex = -1, edge = -1;
    for (int k = 0; k < 3; ++k)
      if (l.bary[std::size_t(k)] >= 1.0 - snap && vertexOk(k)) vertex = k;
    for (int j = 0; j < 3; ++j)
      if (l.bary[std::size_t(j)] <= snap && edgeOk(j) &&
          (edge < 0 || l.bary[std::size_t(j)] < l.bary[std::size_t(edge)]))
        edge = j;
    if (vertex >= 0) {
      poly[end] = c[std::size_t(vertex)];
    } else if (edge >= 0) {
      std::array<double, 3> b = l.bary;
      b[std::size_t(edge)] = 0.0;
      const double sum = b[0] + b[1] + b[2];
      for (double& x : b) x /= sum;
      poly[end] = fromBary(c, b);
    }
  }
  return poly;
}

}  // namespace

IncisionResult Topology::cutPolyline(std::span<const Vec3> polyline, const CutOptions& options) {
  Impl& I = *impl_;
  if (!(options.snapTolerance >= 0.0 && options.snapTolerance < 0.5))
    throw TopologyError("cutPolyline: snapTolerance " + std::to_string(options.snapTolerance) +
                        " must be in [0, 0.5)");
  checkRepairOptions(options.repair, "cutPolyline");
  std::vector<Point3> poly;
  for (std::size_t i = 0; i < polyline.size(); ++i) {
    for (double c : polyline[i])
      if (!std::isfinite(c))
        throw TopologyError("cutPolyline: point " + std::to_string(i) +
                            " has a non-finite coordinate");
    Point3 p = toPoint(polyline[i]);
    if (poly.empty() || p != poly.back()) poly.push_back(p);
  }
  if (poly.size() < 2) throw TopologyError("cutPolyline: a polyline needs two distinct points");
  if (I.mesh.number_of_faces() == 0)
    throw TopologyError("cutPolyline: the surface has no triangles");
  // A polyline that crosses itself would need the walk to split its own path: rejected.
  if (auto crossing = selfCrossing(poly))
    throw TopologyError("cutPolyline: the polyline crosses itself (segments " +
                        std::to_string(crossing->first) + " and " +
                        std::to_string(crossing->second) + "); cut it as separate polylines");
  Walker checked(I, options.snapTolerance);
  checked.check(poly);  // throws before anything changes; its corridor serves the plan below

  // Plan the inserting walk on a patch around the checked walk, growing the patch until the walk
  // stays inside. First with the polyline's ends snapped (onto a vertex, else an edge, within the
  // tolerance, the border included) so that no sliver is left next to an end; if that variant
  // leaves the surface or cannot be inserted, with the polyline as given. A request for which no
  // plan succeeds is rejected before the mesh changes.
  std::unique_ptr<Patch> patch;
  std::vector<VI> planned;
  std::optional<Walker> planner;
  // With the quality repair on, crossings snap only within kSamePoint of a vertex or an edge:
  // the path follows the polyline (the lips lie on the cut) and the repair removes the slivers
  // (snapping further would leave kinks in the path that no repair may straighten). Closer than
  // that, the polyline's point is the vertex or the edge as given with a rounding, or as lifted
  // off a curved rest surface by its sagitta (a path drawn on the smooth surface the mesh
  // samples): a point kept there would leave triangles too thin to repair, around which
  // refinement would crowd. The ends still snap, so a cut reaches the border.
  // The same, absolute: kSamePoint of the mesh's mean edge (the locating grid's cell is twice it).
  const double samePoint = I.grid.cellSize() > 0 ? 0.5 * kSamePoint * I.grid.cellSize() : 0.0;
  double snap = options.repair.minAngle > 0 ? std::min(kSamePoint, options.snapTolerance)
                                            : options.snapTolerance;
  auto plan = [&](const std::vector<Point3>& line, const Walker& walker) {
    std::unordered_set<std::uint32_t> faces;
    for (FI f : walker.corridor) faces.insert(f.idx());
    growByOneRing(I, faces);
    while (true) {
      patch = buildPatch(I, faces);
      planner.emplace(patch->impl, snap);
      planner->setFrontier(&patch->frontier);
      planner->setSamePoint(snap > 0 ? samePoint : 0.0);  // the retry unsnapped: none
      try {
        planned = planner->insert(line, inPatch(*patch, I.mesh, walker.start));
        return;
      } catch (const PatchTooSmall&) {
        if (!patch->hasFrontier)
          throw TopologyError("internal error: cutPolyline's patch cannot grow");
        growByOneRing(I, faces);
      }
    }
  };
  // One attempt: the line's walk checked (unless `checkedWalk` is that of this very line), then
  // planned. Returns why it cannot be (nullopt: planned). A failure injected by a test is a
  // failure of the whole request.
  auto attempt = [&](const std::vector<Point3>& line, double walkSnap,
                     const Walker* checkedWalk) -> std::optional<std::string> {
    try {
      std::optional<Walker> own;
      if (!checkedWalk) {
        own.emplace(I, walkSnap);
        own->check(line);
        checkedWalk = &*own;
      }
      plan(line, *checkedWalk);
      return std::nullopt;
    } catch (const InjectedFailure&) {
      throw;
    } catch (const TopologyError& e) {
      return std::string(e.what());
    }
  };
  // The plans, in order, until one succeeds:
  // 1. The polyline with its ends snapped. With the repair on, an end snaps only onto the border
  //    (so that a cut ending just inside it reaches it): elsewhere it stays on the polyline, where
  //    the repair may straighten the lips. (Snapping may make the ends meet or touch another
  //    segment: then this plan is skipped.)
  std::optional<std::string> failed = "not planned";
  const std::vector<Point3> snapped =
      snapEnds(I, poly, options.snapTolerance, options.repair.minAngle > 0);
  if (snapped != poly && snapped.front() != snapped.back() && !selfCrossing(snapped))
    failed = attempt(snapped, options.snapTolerance, nullptr);
  // 2. The polyline as given.
  if (failed) failed = attempt(poly, options.snapTolerance, &checked);
  // 3. The polyline as given, its crossings not snapped: snapping moves the path, and the walk
  //    from a snapped crossing can fail where the polyline as given passes; the slivers this may
  //    leave are the quality repair's to fix.
  if (failed) {
    const bool retried = snap > 0;
    snap = 0.0;
    const std::optional<std::string> unsnapped = attempt(poly, snap, &checked);
    if (unsnapped) {
      // 4. An end exactly on the border (within rounding) can defeat the walk where the same end
      //    a little inside, snapped onto the border edge, does not: the ends pulled 1% of their
      //    segment inwards and snapped onto the border.
      std::vector<Point3> nudged = poly;
      const std::size_t n = nudged.size();
      nudged[0] = nudged[0] + 0.01 * (poly[1] - poly[0]);
      nudged[n - 1] = nudged[n - 1] + 0.01 * (poly[n - 2] - poly[n - 1]);
      const std::vector<Point3> inside = nudged;
      nudged = snapEnds(I, nudged, std::max(options.snapTolerance, 0.02), true);
      // An end that did not snap onto the border was not on it: it stays where it was given.
      if (nudged[0] == inside[0]) nudged[0] = poly[0];
      if (nudged[n - 1] == inside[n - 1]) nudged[n - 1] = poly[n - 1];
      failed = "the nudged ends meet or cross";
      if (nudged.front() != nudged.back() && !selfCrossing(nudged))
        failed = attempt(nudged, snap, nullptr);
      if (failed)
        throw TopologyError(std::string("cutPolyline: the cut cannot be inserted") +
                            (retried ? " (also tried without snapping): " : ": ") + *unsnapped +
                            "; nothing was changed");
    }
  }

  // Replay the plan on the mesh: the same splits, in the same order. Should the replay fail
  // (not expected: the plan ran the same splits), the undo journal puts the mesh back and the
  // request is refused with nothing changed.
  return I.committed(*this, "cutPolyline", [&] {
    IncisionResult result;
    std::vector<VI> path;
    std::vector<PointId> inserted;
    std::unordered_map<std::uint32_t, VI> toMesh;  // patch vertex -> mesh vertex
    auto mapped = [&](VI pv) {
      if (pv.idx() < patch->toMesh.size()) return patch->toMesh[pv.idx()];
      return toMesh.at(pv.idx());
    };
    for (const PlannedSplit& s : planner->plan) {
      VI v;
      if (s.onEdge) {
        VI a = mapped(s.a), b = mapped(s.b);
        HI h = I.findHalfedge(a, b);
        if (!h.is_valid())
          throw TopologyError(
              "internal error: cutPolyline's plan lost an edge; nothing was changed");
        v = I.splitEdgeNoTxn(I.mesh.edge(h), a, s.u);
      } else {
        std::array<VI, 3> c{mapped(s.corners[0]), mapped(s.corners[1]), mapped(s.corners[2])};
        HI h = I.findHalfedge(c[0], c[1]);
        if (!h.is_valid() || !I.mesh.face(h).is_valid() || I.mesh.target(I.mesh.next(h)) != c[2])
          throw TopologyError(
              "internal error: cutPolyline's plan lost a triangle; nothing was changed");
        v = I.splitFaceNoTxn(I.mesh.face(h), c, s.weights);
      }
      toMesh[s.created.idx()] = v;
      inserted.push_back(PointId(v.idx()));
    }
    for (VI pv : planned) path.push_back(mapped(pv));
    result.insertedPoints = inserted;
    if (path.size() >= 2) {
      std::vector<PointId> ins = result.insertedPoints;
      I.inciseNoTxn(path, result);
      result.insertedPoints.insert(result.insertedPoints.begin(), ins.begin(), ins.end());
    } else {
      for (VI v : path) result.path.push_back(PointId(v.idx()));
    }
    I.repairIncision(options.repair, result);
    return result;
  });
}

}  // namespace cutsim::topology
