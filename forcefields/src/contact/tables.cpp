// The surface's tables (rebuilt when the topology's revision changes), the edges' flatness,
// the margins and the hierarchies; the obstacles' meshes
// (contact_impl.hpp).
#include "contact_impl.hpp"

namespace cutsim::forcefields {

void Contact::Impl::pointDistances(int k, std::span<const double> x) {
  const std::size_t n = x.size() / 3;
  pointSdf.resize(n);
  V3 g;
  for (std::size_t p = 0; p < n; ++p) pointSdf[p] = sdf(k, surfacePoint(x, std::uint32_t(p)), g);
}

void Contact::Impl::rebuildTables() {
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

double Contact::Impl::flatness(const V3& a, const V3& b, const V3& c, const V3& e, double d) {
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

void Contact::Impl::resetFlatness() {
  flatRevision = revision;
  if (edgeFlat.size() != edgeTris.size() || ++flatGeneration == 0) {
    flatGeneration = 1;
    edgeFlat.assign(edgeTris.size(), EdgeFlat{});
  }
}

double Contact::Impl::measureFlatness(std::uint32_t e, std::span<const double> x) const {
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

double Contact::Impl::edgePairScale(const std::array<std::int32_t, 2>& edges,
                                    std::span<const double> x) const {
  if (edgeFlat.empty() || flatRevision != revision || edges[0] < 0 || edges[1] < 0) return 1.0;
  const double fa = flatnessOf(std::uint32_t(edges[0]), x);
  if (fa == 0.0) return 1.0;
  const double fb = flatnessOf(std::uint32_t(edges[1]), x);
  if (fb == 0.0) return 1.0;
  return edgesApart(edges[0], edges[1]) ? 1.0 - fa * fb : 1.0;
}

bool Contact::Impl::edgesApart(std::int32_t e1, std::int32_t e2) const {
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

void Contact::Impl::surfaceBoxes(std::span<const double> x, std::vector<Box>& out) const {
  out.resize(tris.size());
  for (std::size_t i = 0; i < tris.size(); ++i) {
    Box b;
    for (int k = 0; k < 3; ++k) b.add(surfacePoint(x, triV[i][std::size_t(k)]));
    b.inflate(triMargin[i]);
    out[i] = b;
  }
}

void Contact::Impl::buildObstacleMeshes() {
  meshes.assign(O.size(), {});
  for (std::size_t k = 0; k < O.size(); ++k) {
    if (!meshLike(k)) continue;
    MeshObstacle& m = meshes[k];
    O[k].shape->triangles(m.vertices, m.triangles);
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

void Contact::Impl::obstacleBoxes(int k, std::vector<Box>& out) const {
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

void Contact::Impl::refitObstacle(std::size_t k) {
  MeshObstacle& m = meshes[k];
  obstacleBoxes(int(k), m.boxes);
  if (m.bvh.size() != m.boxes.size() || m.bvh.empty())
    m.bvh.build(m.boxes);
  else
    m.bvh.refit(m.boxes);
}

void Contact::Impl::updateTables() {
  if (!built || revision != topo.revision()) {
    rebuildTables();
    bvhBuilt = false;
  }
}

void Contact::Impl::triangleMargins() {
  triMargin.resize(tris.size());
  for (std::size_t i = 0; i < tris.size(); ++i) {
    triMargin[i] =
        std::max({pointMargin[triV[i][0]], pointMargin[triV[i][1]], pointMargin[triV[i][2]]});
  }
}

void Contact::Impl::prepare(std::span<const double> x) {
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

}  // namespace cutsim::forcefields
