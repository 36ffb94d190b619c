#include "timeline/tearing.hpp"

#include <algorithm>
#include <cmath>

#include "cutsim/base/errors.hpp"

namespace cutsim::core {
namespace {

using topology::Vec3;

Vec3 sub(const Vec3& a, const Vec3& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
double dot(const Vec3& a, const Vec3& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

Vec3 at(std::span<const double> x, topology::PointId p) {
  return {x[3 * p.idx()], x[3 * p.idx() + 1], x[3 * p.idx() + 2]};
}

/// The deformation of a triangle: rest edge vectors R1 = X1 - X0, R2 = X2 - X0 and their current
/// images r1, r2. A rest-plane vector m = a R1 + b R2 maps to a r1 + b r2.
struct TriangleMap {
  Vec3 R1, R2, r1, r2;
  double g11 = 0, g12 = 0, g22 = 0, det = 0;  // Gram matrix of R1, R2
  bool ok = false;
};

TriangleMap triangleMap(const topology::Topology& topo, std::span<const double> x,
                        topology::TriangleId t) {
  const topology::TriangleVertices v = topo.triangleVertices(t);
  TriangleMap m;
  const Vec3 X0 = topo.restPosition(v[0]);
  m.R1 = sub(topo.restPosition(v[1]), X0);
  m.R2 = sub(topo.restPosition(v[2]), X0);
  const Vec3 x0 = at(x, v[0]);
  m.r1 = sub(at(x, v[1]), x0);
  m.r2 = sub(at(x, v[2]), x0);
  m.g11 = dot(m.R1, m.R1);
  m.g12 = dot(m.R1, m.R2);
  m.g22 = dot(m.R2, m.R2);
  m.det = m.g11 * m.g22 - m.g12 * m.g12;
  m.ok = m.det > 1e-24 * m.g11 * m.g22 && m.det > 0;
  return m;
}

/// Green strain along the unit rest-plane vector m: (|F m|^2 - 1) / 2.
double strainAlong(const TriangleMap& tm, const Vec3& m) {
  // m = a R1 + b R2: solve the Gram system [g11 g12; g12 g22] (a, b) = (m.R1, m.R2).
  const double p = dot(m, tm.R1), q = dot(m, tm.R2);
  const double a = (tm.g22 * p - tm.g12 * q) / tm.det;
  const double b = (tm.g11 * q - tm.g12 * p) / tm.det;
  const Vec3 Fm{a * tm.r1[0] + b * tm.r2[0], a * tm.r1[1] + b * tm.r2[1],
                a * tm.r1[2] + b * tm.r2[2]};
  return 0.5 * (dot(Fm, Fm) - 1.0);
}

}  // namespace

std::array<double, 3> triangleGreenStrain(const topology::Topology& topology,
                                          std::span<const double> x, topology::TriangleId t) {
  const TriangleMap tm = triangleMap(topology, x, t);
  if (!tm.ok) return {0, 0, 0};
  // Orthonormal rest frame: e1 along R1, e2 in the plane, perpendicular to it.
  const double l1 = std::sqrt(tm.g11);
  const Vec3 e1{tm.R1[0] / l1, tm.R1[1] / l1, tm.R1[2] / l1};
  const double c = dot(tm.R2, e1);
  Vec3 e2{tm.R2[0] - c * e1[0], tm.R2[1] - c * e1[1], tm.R2[2] - c * e1[2]};
  const double l2 = std::sqrt(dot(e2, e2));
  e2 = {e2[0] / l2, e2[1] / l2, e2[2] / l2};
  // F e_i, and E_ij = (F e_i . F e_j - delta_ij) / 2.
  auto image = [&](const Vec3& m) {
    const double p = dot(m, tm.R1), q = dot(m, tm.R2);
    const double a = (tm.g22 * p - tm.g12 * q) / tm.det;
    const double b = (tm.g11 * q - tm.g12 * p) / tm.det;
    return Vec3{a * tm.r1[0] + b * tm.r2[0], a * tm.r1[1] + b * tm.r2[1],
                a * tm.r1[2] + b * tm.r2[2]};
  };
  const Vec3 f1 = image(e1), f2 = image(e2);
  return {0.5 * (dot(f1, f1) - 1.0), 0.5 * dot(f1, f2), 0.5 * (dot(f2, f2) - 1.0)};
}

double maxPrincipalStrain(const topology::Topology& topology, std::span<const double> x,
                          topology::TriangleId t) {
  const auto [a, b, c] = triangleGreenStrain(topology, x, t);
  const double mean = 0.5 * (a + c), d = 0.5 * (a - c);
  return mean + std::sqrt(d * d + b * b);
}

double strainNormalToEdge(const topology::Topology& topology, std::span<const double> x,
                          topology::TriangleId t, topology::EdgeId e) {
  const TriangleMap tm = triangleMap(topology, x, t);
  if (!tm.ok) return 0.0;
  const topology::EdgeVertices ev = topology.edgeVertices(e);
  const Vec3 d = sub(topology.restPosition(ev[1]), topology.restPosition(ev[0]));
  // The rest-plane normal direction to the edge: the component of (X_opposite - X_edge0)
  // perpendicular to the edge.
  const Vec3 w =
      sub(topology.restPosition(topology.oppositeVertex(t, e)), topology.restPosition(ev[0]));
  const double dd = dot(d, d);
  if (!(dd > 0)) return 0.0;
  const double s = dot(w, d) / dd;
  Vec3 m{w[0] - s * d[0], w[1] - s * d[1], w[2] - s * d[2]};
  const double lm = std::sqrt(dot(m, m));
  if (!(lm > 0)) return 0.0;
  m = {m[0] / lm, m[1] / lm, m[2] / lm};
  return strainAlong(tm, m);
}

std::vector<TearCandidate> tearCandidates(const topology::Topology& topology,
                                          std::span<const double> x, double threshold) {
  std::vector<TearCandidate> out;
  for (topology::EdgeId e : topology.edges()) {
    const auto tris = topology.edgeTriangles(e);
    if (tris[0].idx() == topology::kInvalidIndex || tris[1].idx() == topology::kInvalidIndex)
      continue;
    const double s0 = strainNormalToEdge(topology, x, tris[0], e);
    if (!(s0 > threshold)) continue;
    const double s1 = strainNormalToEdge(topology, x, tris[1], e);
    if (!(s1 > threshold)) continue;
    out.push_back({e, std::min(s0, s1)});
  }
  std::sort(out.begin(), out.end(), [](const TearCandidate& a, const TearCandidate& b) {
    return a.strain != b.strain ? a.strain > b.strain : a.edge < b.edge;
  });
  return out;
}

int tearOverstrained(topology::Topology& topology, std::span<const double> x, double threshold,
                     int maxPerStep, const topology::RepairOptions& repair) {
  // x is read only here: a tear creates points, which may move the state's storage.
  const std::vector<TearCandidate> candidates = tearCandidates(topology, x, threshold);
  int torn = 0;
  for (const TearCandidate& c : candidates) {
    if (torn >= maxPerStep) break;
    if (!topology.isEdgeAlive(c.edge) || topology.isBoundaryEdge(c.edge)) continue;
    try {
      if (repair.minAngle > 0)
        topology.tear(c.edge, repair);
      else
        topology.tear(c.edge);
      ++torn;
    } catch (const TopologyError&) {
      // The topology refuses this edge (for example a cut that would leave it ill-formed): the
      // mesh is unchanged; try the next one.
    }
  }
  return torn;
}

}  // namespace cutsim::core
