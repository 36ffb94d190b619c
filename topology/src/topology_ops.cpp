// Topology operations: add points and triangles, remove triangles (carving), split an edge or a
// triangle, incise along a path of edges, tear at an edge. Each is one transaction; requests are
// checked before anything changes.
#include <CGAL/boost/graph/Euler_operations.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <numeric>
#include <set>
#include <unordered_set>

#include "cutsim/base/union_find.hpp"
#include "topology_impl.hpp"

namespace cutsim::topology {

namespace {
std::string pt(Index i) {
  return std::to_string(i);
}
std::string edgeName(Index a, Index b) {
  return "(" + pt(a) + ", " + pt(b) + ")";
}
}  // namespace

std::vector<PointId> Topology::addPoints(std::span<const Vec3> restPositions) {
  for (std::size_t i = 0; i < restPositions.size(); ++i)
    for (double c : restPositions[i])
      if (!std::isfinite(c))
        throw TopologyError("addPoints: point " + std::to_string(i) +
                            " has a non-finite coordinate");
  Impl& I = *impl_;
  return I.committed(*this, "addPoints", [&] {
    std::vector<PointId> out;
    for (const Vec3& p : restPositions) out.push_back(PointId(I.newFreePoint(toPoint(p)).idx()));
    return out;
  });
}

std::vector<TriangleId> Topology::addTriangles(std::span<const TriangleVertices> triangles) {
  Impl& I = *impl_;
  const Mesh& m = I.mesh;
  // Directed edges must be free; the final fan around each vertex must be a single one.
  std::set<std::pair<Index, Index>> directed;
  std::unordered_map<Index, std::vector<std::array<Index, 2>>> newAround;  // v -> other two
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    const auto& t = triangles[i];
    const std::string where = "addTriangles: triangle " + std::to_string(i) + " " + "(" +
                              pt(t[0].idx()) + ", " + pt(t[1].idx()) + ", " + pt(t[2].idx()) + ")";
    for (PointId v : t)
      if (!I.vertexAlive(VI(v.idx())))
        throw TopologyError(where + ": point " + pt(v.idx()) + " does not exist");
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
      throw TopologyError(where + ": repeated vertex");
    for (int k = 0; k < 3; ++k) {
      Index a = t[k].idx(), b = t[(k + 1) % 3].idx();
      if (!directed.insert({a, b}).second)
        throw TopologyError(where + ": edge " + edgeName(a, b) +
                            " is used twice in the same direction by the new triangles");
      HI h = I.findHalfedge(VI(a), VI(b));
      if (h.is_valid() && !m.is_border(h))
        throw TopologyError(where + ": edge " + edgeName(a, b) + " already has triangle " +
                            pt(m.face(h).idx()) +
                            " on that side (non-manifold or wrongly oriented)");
      newAround[t[k].idx()].push_back({t[(k + 1) % 3].idx(), t[(k + 2) % 3].idx()});
    }
  }
  // One fan per vertex: faces around v connected through shared edges (v, w).
  for (auto& [v, added] : newAround) {
    std::vector<std::array<Index, 2>> around = added;
    std::vector<HI> hs;
    I.incomingHalfedges(VI(v), hs);
    for (HI h : hs)
      if (FI f = m.face(h); f.is_valid()) {
        auto tv = I.verticesOf(f);
        std::array<Index, 2> o{};
        int k = 0;
        for (PointId x : tv)
          if (x.idx() != v) o[k++] = x.idx();
        around.push_back(o);
      }
    UnionFind fans(around.size());
    std::unordered_map<Index, std::size_t> byNeighbour;
    for (std::size_t i = 0; i < around.size(); ++i)
      for (Index w : around[i]) {
        auto [it, ins] = byNeighbour.emplace(w, i);
        if (!ins) fans.unite(i, it->second);
      }
    std::size_t roots = 0;
    for (std::size_t i = 0; i < around.size(); ++i) roots += fans.find(i) == i ? 1 : 0;
    if (roots > 1)
      throw TopologyError("addTriangles: point " + pt(v) + " would join " + std::to_string(roots) +
                          " separate fans of triangles (a non-manifold vertex)");
  }
  std::vector<std::array<VI, 3>> faces;
  for (const auto& t : triangles) faces.push_back({VI(t[0].idx()), VI(t[1].idx()), VI(t[2].idx())});
  std::vector<FI> added = I.committed(*this, "addTriangles", [&] { return I.attachFaces(faces); });
  std::vector<TriangleId> out;
  for (FI f : added) out.push_back(TriangleId(f.idx()));
  return out;
}

void Topology::removeTriangles(std::span<const TriangleId> triangles) {
  removeTriangles(triangles, RepairOptions{});
}

RepairReport Topology::removeTriangles(std::span<const TriangleId> triangles,
                                       const RepairOptions& repair) {
  checkRepairOptions(repair, "removeTriangles");
  Impl& I = *impl_;
  std::vector<TriangleId> ts(triangles.begin(), triangles.end());
  std::sort(ts.begin(), ts.end());
  if (std::adjacent_find(ts.begin(), ts.end()) != ts.end())
    throw TopologyError("removeTriangles: triangle " +
                        pt(std::adjacent_find(ts.begin(), ts.end())->idx()) + " is listed twice");
  for (TriangleId t : ts)
    if (!I.faceAlive(FI(t.idx())))
      throw TopologyError("removeTriangles: triangle " + pt(t.idx()) + " does not exist");
  if (ts.empty()) return {};
  return I.committed(*this, "removeTriangles", [&] {
    for (TriangleId t : ts) I.detachFace(FI(t.idx()));
    // Removal may leave a vertex with two fans (a bowtie): give each extra fan its own copy.
    std::vector<VI> candidates = I.touched;
    I.splitFans(candidates, nullptr, {}, nullptr, nullptr);
    std::unordered_map<Index, Index> replaced;
    return I.repairNoTxn(candidates, repair, replaced);
  });
}

VI Topology::Impl::splitEdgeNoTxn(EI e, VI from, double t) {
  HI h0 = mesh.halfedge(e);
  VI a = mesh.source(h0), b = mesh.target(h0);
  if (from != a) std::swap(a, b);
  VI m = newPoint({{PointId(a.idx()), 1.0 - t}, {PointId(b.idx()), t}});
  std::vector<FI> old;
  std::vector<std::array<VI, 3>> added;
  for (HI h : {h0, mesh.opposite(h0)}) {
    FI f = mesh.face(h);
    if (!f.is_valid()) continue;
    VI p = mesh.source(h), q = mesh.target(h), o = mesh.target(mesh.next(h));
    old.push_back(f);
    added.push_back({p, m, o});
    added.push_back({m, q, o});
  }
  for (FI f : old) detachFace(f);
  attachFaces(added);
  return m;
}

VI Topology::Impl::splitFaceNoTxn(FI f, const std::array<double, 3>& bary) {
  TriangleVertices t = verticesOf(f);
  return splitFaceNoTxn(f, {VI(t[0].idx()), VI(t[1].idx()), VI(t[2].idx())}, bary);
}

VI Topology::Impl::splitFaceNoTxn(FI f, const std::array<VI, 3>& corners,
                                  const std::array<double, 3>& weights) {
  TriangleVertices t = verticesOf(f);
  VI m = newPoint({{PointId(corners[0].idx()), weights[0]},
                   {PointId(corners[1].idx()), weights[1]},
                   {PointId(corners[2].idx()), weights[2]}});
  detachFace(f);
  VI a(t[0].idx()), b(t[1].idx()), c(t[2].idx());
  attachFaces({{a, b, m}, {b, c, m}, {c, a, m}});
  return m;
}

PointId Topology::splitEdge(EdgeId e, double t) {
  Impl& I = *impl_;
  if (!I.edgeAlive(EI(e.idx())))
    throw TopologyError("splitEdge: edge " + pt(e.idx()) + " does not exist");
  if (!(t > 0.0 && t < 1.0))
    throw TopologyError("splitEdge: parameter " + std::to_string(t) + " on edge " + pt(e.idx()) +
                        " is not strictly between 0 and 1");
  VI from = I.mesh.source(I.mesh.halfedge(EI(e.idx())));
  VI m = I.committed(*this, "splitEdge", [&] { return I.splitEdgeNoTxn(EI(e.idx()), from, t); });
  return PointId(m.idx());
}

PointId Topology::splitTriangle(TriangleId t, const std::array<double, 3>& bary) {
  Impl& I = *impl_;
  if (!I.faceAlive(FI(t.idx())))
    throw TopologyError("splitTriangle: triangle " + pt(t.idx()) + " does not exist");
  double s = bary[0] + bary[1] + bary[2];
  if (!(bary[0] > 0 && bary[1] > 0 && bary[2] > 0) || !(std::abs(s - 1.0) < 1e-9))
    throw TopologyError("splitTriangle: barycentric weights of triangle " + pt(t.idx()) +
                        " must be positive and sum to 1");
  VI m = I.committed(*this, "splitTriangle", [&] { return I.splitFaceNoTxn(FI(t.idx()), bary); });
  return PointId(m.idx());
}

void Topology::Impl::inciseNoTxn(std::vector<VI> path, IncisionResult& result) {
  auto isBorderPoint = [&](VI v) { return mesh.is_border(v, true); };
  if (path.size() == 2 && !isBorderPoint(path[0]) && !isBorderPoint(path[1])) {
    HI h = findHalfedge(path[0], path[1]);
    VI m = splitEdgeNoTxn(mesh.edge(h), path[0], 0.5);
    result.insertedPoints.push_back(PointId(m.idx()));
    path = {path[0], m, path[1]};
  }
  path.erase(std::unique(path.begin(), path.end()), path.end());
  std::unordered_set<std::uint32_t> cutEdges;
  std::unordered_map<std::uint32_t, FI> keep;
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    HI h = findHalfedge(path[i], path[i + 1]);
    if (!h.is_valid())
      throw TopologyError("internal error in '" + operation + "': path points " +
                          pt(path[i].idx()) + " and " + pt(path[i + 1].idx()) +
                          " are not joined by an edge");
    cutEdges.insert(mesh.edge(h).idx());
    FI right = mesh.face(mesh.opposite(h));  // h runs along the path: its face is on the left
    if (right.is_valid()) {
      keep.emplace(path[i].idx(), right);
      keep.emplace(path[i + 1].idx(), right);
    }
  }
  for (VI v : path) result.path.push_back(PointId(v.idx()));
  splitFans(
      path, [&](EI e) { return cutEdges.count(e.idx()) > 0; }, keep, &result.copies,
      &result.copiedFrom);
}

IncisionResult Topology::incise(std::span<const PointId> path) {
  Impl& I = *impl_;
  if (path.size() < 2) throw TopologyError("incise: a path needs at least two points");
  std::set<std::pair<Index, Index>> used;
  for (std::size_t i = 0; i < path.size(); ++i) {
    if (!I.vertexAlive(VI(path[i].idx())))
      throw TopologyError("incise: point " + pt(path[i].idx()) + " (path position " +
                          std::to_string(i) + ") does not exist");
    if (i == 0) continue;
    PointId a = path[i - 1], b = path[i];
    if (a == b)
      throw TopologyError("incise: point " + pt(a.idx()) + " is repeated at path position " +
                          std::to_string(i));
    HI h = I.findHalfedge(VI(a.idx()), VI(b.idx()));
    if (!h.is_valid())
      throw TopologyError("incise: the path is not connected: no edge joins points " + pt(a.idx()) +
                          " and " + pt(b.idx()) + " (path positions " + std::to_string(i - 1) +
                          ", " + std::to_string(i) + ")");
    if (I.mesh.is_border(I.mesh.edge(h)))
      throw TopologyError("incise: edge " + edgeName(a.idx(), b.idx()) +
                          " of the path is on the border: there is nothing to open");
    if (!used.insert({std::min(a, b).idx(), std::max(a, b).idx()}).second)
      throw TopologyError("incise: edge " + edgeName(a.idx(), b.idx()) +
                          " appears twice in the path");
  }
  std::vector<VI> vs;
  for (PointId p : path) vs.push_back(VI(p.idx()));
  return I.committed(*this, "incise", [&] {
    IncisionResult result;
    I.inciseNoTxn(vs, result);
    return result;
  });
}

IncisionResult Topology::tear(EdgeId e) {
  return tear(e, RepairOptions{});
}

IncisionResult Topology::tear(EdgeId e, const RepairOptions& repair) {
  checkRepairOptions(repair, "tear");
  Impl& I = *impl_;
  if (!I.edgeAlive(EI(e.idx())))
    throw TopologyError("tear: edge " + pt(e.idx()) + " does not exist");
  if (I.mesh.is_border(EI(e.idx())))
    throw TopologyError("tear: edge " + pt(e.idx()) +
                        " is on the border: there is nothing to tear");
  HI h = I.mesh.halfedge(EI(e.idx()));
  return I.committed(*this, "tear", [&] {
    IncisionResult result;
    I.inciseNoTxn({I.mesh.source(h), I.mesh.target(h)}, result);
    I.repairIncision(repair, result);
    return result;
  });
}

}  // namespace cutsim::topology

namespace cutsim::topology {

RepairReport Topology::carve(const std::function<double(const Vec3&)>& phi,
                             const RepairOptions& repair, std::size_t* removed) {
  if (!phi) throw TopologyError("carve: no region function given");
  return carve([&phi](const Vec3& rest, PointWeights) { return phi(rest); }, repair, removed);
}

RepairReport Topology::carve(const std::function<double(const Vec3&, PointWeights)>& phi,
                             const RepairOptions& repair, std::size_t* removed, bool moveBorder) {
  checkRepairOptions(repair, "carve");
  if (!phi) throw TopologyError("carve: no region function given");
  using Weight = std::pair<PointId, double>;
  const auto at = [&phi](const Vec3& rest, std::initializer_list<Weight> weights) {
    return phi(rest, PointWeights(weights.begin(), weights.size()));
  };
  Impl& I = *impl_;
  Mesh& m = I.mesh;
  if (removed) *removed = 0;
  // phi at every live point (a removal looks at the whole surface, as selecting by centroid does).
  std::unordered_map<Index, double> value;
  for (VI v : m.vertices()) {
    const double x = at(toVec(m.point(v)), {{PointId(v.idx()), 1.0}});
    if (!std::isfinite(x))
      throw TopologyError("carve: the region's function is not finite at point " + pt(v.idx()));
    value[v.idx()] = x;
  }
  // The crossed edges (one end inside, phi <= 0, the other outside), and where phi first rises
  // above zero along each (bisection on the function itself: exact where the boundary is flat).
  // Points in `skip` (moved onto the boundary) cross nothing.
  struct Crossing {
    VI a, b;
    double t;
  };
  std::unordered_set<Index> onBoundary;
  auto findCrossings = [&](bool& anyInside) {
    std::vector<Crossing> out;
    anyInside = false;
    for (EI e : m.edges()) {
      HI h = m.halfedge(e);
      VI a = m.source(h), b = m.target(h);
      if (onBoundary.count(a.idx()) || onBoundary.count(b.idx())) continue;
      double fa = value[a.idx()], fb = value[b.idx()];
      anyInside |= fa <= 0 || fb <= 0;
      if ((fa <= 0) == (fb <= 0)) continue;
      if (fa > 0) {
        std::swap(a, b);
        std::swap(fa, fb);
      }  // a inside
      const Vec3 pa = toVec(m.point(a)), pb = toVec(m.point(b));
      double lo = 0, hi = 1;
      for (int it = 0; it < 40; ++it) {
        const double mid = 0.5 * (lo + hi);
        const Vec3 q{pa[0] + mid * (pb[0] - pa[0]), pa[1] + mid * (pb[1] - pa[1]),
                     pa[2] + mid * (pb[2] - pa[2])};
        (at(q, {{PointId(a.idx()), 1.0 - mid}, {PointId(b.idx()), mid}}) <= 0 ? lo : hi) = mid;
      }
      // Never exactly on an end (the split needs 0 < t < 1); slivers are the repair's to fix.
      out.push_back({a, b, std::clamp(0.5 * (lo + hi), 1e-6, 1.0 - 1e-6)});
    }
    return out;
  };
  bool anyInside = false;
  std::vector<Crossing> crossings = findCrossings(anyInside);
  if (!anyInside) return {};
  std::size_t removedHere = 0;  // told once the transaction is done (not if it is rolled back)
  RepairReport report = I.committed(*this, "carve", [&] {
    std::unordered_map<Index, char> inside;  // points that existed: phi <= 0
    for (auto& [v, x] : value) inside[v] = x <= 0 ? 1 : 0;
    // A point next to a crossing (within a quarter of the edge) moves onto it, so that the
    // boundary passes through it instead of leaving a sliver: a new point on that edge (its
    // ancestors the edge's ends), the old one destroyed; not the border, not locked points, only
    // where its star is flat (2 degrees) and its triangles stay the right way up; an inside point
    // only while a neighbour stays inside (so the region keeps a point inside it).
    std::unordered_set<Index> locked;
    for (PointId p : repair.locked) locked.insert(p.idx());
    struct Snap {
      double dist;
      VI v, w;
      double s;
    };
    std::vector<Snap> snaps;
    for (const Crossing& c : crossings) {
      const double len = std::sqrt(CGAL::squared_distance(m.point(c.a), m.point(c.b)));
      if (c.t < 0.25) snaps.push_back({c.t * len, c.a, c.b, c.t});            // a is inside
      if (c.t > 0.75) snaps.push_back({(1 - c.t) * len, c.b, c.a, 1 - c.t});  // b is outside
    }
    std::sort(snaps.begin(), snaps.end(),
              [](const Snap& x, const Snap& y) { return x.dist < y.dist; });
    std::unordered_set<Index> moved;
    std::unordered_map<Index, std::array<Weight, 2>> made;  // new points: what they are made of
    for (const Snap& sn : snaps) {
      if (moved.count(sn.v.idx()) || moved.count(sn.w.idx()) || onBoundary.count(sn.w.idx()))
        continue;
      // (with moveBorder, border points too: the outline within a quarter of an edge of the
      // region moves onto its boundary. Only border points inside, or those within 1/1000 or
      // 1/20 of an edge outside, left a 900-point sheet with a 7 cm groove at 1204 and 1047
      // points, its shortest edges 1e-5 and 1e-4 of the mean: the rim a pass leaves lies outside
      // the next pass's region by a fraction of an edge, the tissue having moved since)
      if (locked.count(sn.v.idx()) || (!moveBorder && m.is_border(sn.v, true)) ||
          !I.findHalfedge(sn.v, sn.w).is_valid())
        continue;
      if (value[sn.v.idx()] <= 0) {
        // An inside point moves only if another inside point next to it stays inside: the
        // region keeps a point inside it, so its triangles are still recognised as inside.
        bool keeps = false;
        for (HI h : CGAL::halfedges_around_target(m.halfedge(sn.v), m)) {
          const VI w = m.source(h);
          if (w != sn.w && !onBoundary.count(w.idx()) && !moved.count(w.idx()) &&
              value.count(w.idx()) && value[w.idx()] <= 0)
            keeps = true;
        }
        if (!keeps) continue;
      }
      const Point3 target = m.point(sn.v) + sn.s * (m.point(sn.w) - m.point(sn.v));
      std::vector<FI> star;
      bool ok = true;
      for (HI h : CGAL::halfedges_around_target(m.halfedge(sn.v), m)) {
        FI f = m.face(h);
        if (!f.is_valid()) continue;
        star.push_back(f);
        HI fh = m.halfedge(f);
        std::array<Point3, 3> x{m.point(m.source(fh)), m.point(m.target(fh)),
                                m.point(m.target(m.next(fh)))};
        const auto n0 = CGAL::cross_product(x[1] - x[0], x[2] - x[0]);
        for (auto& q : x)
          if (q == m.point(sn.v)) q = target;
        const auto n1 = CGAL::cross_product(x[1] - x[0], x[2] - x[0]);
        if (!(n0 * n1 > 0.1 * std::sqrt(n0.squared_length() * n1.squared_length()))) ok = false;
        if (!star.empty()) {  // flat star: the move stays on the rest surface
          HI gh = m.halfedge(star.front());
          const auto g0 =
              CGAL::cross_product(m.point(m.target(gh)) - m.point(m.source(gh)),
                                  m.point(m.target(m.next(gh))) - m.point(m.source(gh)));
          if (!(g0 * n0 >= std::cos(2.0 * 3.141592653589793 / 180) *
                               std::sqrt(g0.squared_length() * n0.squared_length())))
            ok = false;
        }
      }
      if (!ok || star.empty()) continue;
      VI nv = I.newPoint({{PointId(sn.v.idx()), 1.0 - sn.s}, {PointId(sn.w.idx()), sn.s}});
      made[nv.idx()] = {Weight{PointId(sn.v.idx()), 1.0 - sn.s}, Weight{PointId(sn.w.idx()), sn.s}};
      std::unordered_map<std::uint64_t, VI> subst;
      for (FI f : star) subst[Impl::faceVertexKey(f, sn.v)] = nv;
      I.reattach(star, subst);
      moved.insert(sn.v.idx());
      onBoundary.insert(nv.idx());
      value[nv.idx()] = 0.0;
    }
    if (!moved.empty()) crossings = findCrossings(anyInside);
    for (const Crossing& c : crossings) {
      HI h = I.findHalfedge(c.a, c.b);
      if (!h.is_valid()) throw TopologyError("internal error: carve lost a crossed edge");
      const VI nv = I.splitEdgeNoTxn(m.edge(h), c.a, c.t);
      made[nv.idx()] = {Weight{PointId(c.a.idx()), 1.0 - c.t}, Weight{PointId(c.b.idx()), c.t}};
    }
    // Every triangle now lies on one side: inside when its earlier points are (the new points are
    // on the boundary); a triangle of new points only, by its centroid.
    std::vector<FI> gone;
    for (FI f : m.faces()) {
      auto tv = I.verticesOf(f);
      int in = -1;
      for (PointId p : tv)
        if (auto it = inside.find(p.idx()); it != inside.end()) in = std::max(in, int(it->second));
      if (in < 0) {  // (its points are all new: each is made of two that existed)
        Vec3 c{0, 0, 0};
        std::vector<Weight> weights;
        for (PointId p : tv) {
          for (int k = 0; k < 3; ++k)
            c[std::size_t(k)] += toVec(m.point(VI(p.idx())))[std::size_t(k)] / 3;
          const auto it = made.find(p.idx());
          if (it == made.end()) throw TopologyError("internal error: carve lost a new point");
          for (const Weight& w : it->second) weights.push_back({w.first, w.second / 3});
        }
        in = phi(c, weights) <= 0 ? 1 : 0;
      }
      if (in == 1) gone.push_back(f);
    }
    for (FI f : gone) I.detachFace(f);
    removedHere = gone.size();
    std::vector<VI> candidates = I.touched;
    I.splitFans(candidates, nullptr, {}, nullptr, nullptr);
    std::unordered_map<Index, Index> replaced;
    return I.repairNoTxn(candidates, repair, replaced);
  });
  if (removed) *removed = removedHere;
  return report;
}

}  // namespace cutsim::topology
