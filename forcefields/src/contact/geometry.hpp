#pragma once
// Private to the contact code: closest points between the primitives of two triangle surfaces
// (point-triangle, segment-segment), the triangle-triangle and segment-triangle distances that
// bound a step's displacements, and axis-aligned boxes. Plain doubles, no CGAL: CGAL's exact
// predicates are the tests' oracle, not the runtime.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace cutsim::forcefields::contact {

using V3 = Eigen::Vector3d;

/// Closest point of triangle (a, b, c) to p, as barycentric weights (Ericson, Real-Time Collision
/// Detection, 5.1.5); the point is w[0] a + w[1] b + w[2] c.
inline std::array<double, 3> closestOnTriangle(const V3& p, const V3& a, const V3& b, const V3& c) {
  const V3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return {1, 0, 0};
  const V3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return {0, 1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const V3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return {0, 0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const double denom = va + vb + vc;
  if (!(denom > 0)) {  // a degenerate (zero-area) triangle: its closest edge point
    double best = std::numeric_limits<double>::infinity();
    std::array<double, 3> out{1, 0, 0};
    const V3* v[3] = {&a, &b, &c};
    for (int i = 0; i < 3; ++i) {
      const V3& s = *v[i];
      const V3 e = *v[(i + 1) % 3] - s;
      const double ee = e.squaredNorm();
      const double t = ee > 0 ? std::clamp((p - s).dot(e) / ee, 0.0, 1.0) : 0.0;
      const double d = (s + t * e - p).squaredNorm();
      if (d < best) {
        best = d;
        out = {0, 0, 0};
        out[std::size_t(i)] = 1 - t;
        out[std::size_t((i + 1) % 3)] = t;
      }
    }
    return out;
  }
  const double v = vb / denom, w = vc / denom;
  return {1 - v - w, v, w};
}

/// How near, relative to the distance, a closest point must be to a corner or an edge to count
/// as at that corner or on that edge (and two edges' closest points as at an end). Where two
/// surfaces are aligned (a point over a point, an edge over an edge) the closest points lie on
/// the boundary between features, and rounding alone would put them on either side: a point
/// over a corner would then also meet the corner's edges and triangles. Rounding errs by about
/// 1e-16 m in coordinates of a metre, 5e-14 of a 2 mm gap and 3e-12 of a 40 micrometre one (a
/// hundredth of a 4 mm thickness); sideways, 1e-11 of the distance is a band of about 4.5e-6 of
/// it (sqrt(2e-11)), where triangles that meet at an angle, or a point near two edges, may
/// still snap a point unlike each other (docs/contact.md, "Aligned surfaces").
inline constexpr double kFeatureTolerance = 1e-11;

/// Barycentric weights w of p's closest point on triangle (a, b, c) (closestOnTriangle's), moved
/// to a corner or onto an edge (weights exactly 1, or 0 off the edge) when that is within
/// kFeatureTolerance of p's distance to the triangle's plane (or to the triangle, if less): the
/// corners first, in order, then the edges. The plane, not the triangle: triangles in one plane
/// around a corner or an edge then snap a point alike, whichever of them it is over, so that the
/// feature's owner triangle makes the snap that the others leave to it.
/// (One compiled copy, so that the screening and the classification get the same numbers.)
[[gnu::noinline]] inline std::array<double, 3> snapToFeature(const V3& p, const V3& a, const V3& b,
                                                             const V3& c, std::array<double, 3> w) {
  const int m = (w[0] != 0.0) + (w[1] != 0.0) + (w[2] != 0.0);
  if (m <= 1) return w;
  constexpr double grow = (1 + kFeatureTolerance) * (1 + kFeatureTolerance);
  const V3 n = (b - a).cross(c - a);
  const double nn = n.squaredNorm(), h = n.dot(p - a);
  const double toTriangle = (p - (w[0] * a + w[1] * b + w[2] * c)).squaredNorm();
  const double lim = (nn > 0 ? std::min(h * h / nn, toTriangle) : toTriangle) * grow;
  const V3* v[3] = {&a, &b, &c};
  for (std::size_t k = 0; k < 3; ++k)
    if ((p - *v[k]).squaredNorm() <= lim) {
      std::array<double, 3> out{0, 0, 0};
      out[k] = 1;
      return out;
    }
  if (m == 3)
    for (std::size_t k = 0; k < 3; ++k) {
      const V3& s = *v[k];
      const V3 e = *v[(k + 1) % 3] - s;
      const double ee = e.squaredNorm();
      const double t = ee > 0 ? std::clamp((p - s).dot(e) / ee, 0.0, 1.0) : 0.0;
      if ((s + t * e - p).squaredNorm() <= lim) {
        std::array<double, 3> out{0, 0, 0};
        out[k] = 1 - t;
        out[(k + 1) % 3] = t;
        return out;
      }
    }
  return w;
}

/// closestOnTriangle, at a corner or on an edge within kFeatureTolerance (snapToFeature).
inline std::array<double, 3> closestFeatureOnTriangle(const V3& p, const V3& a, const V3& b,
                                                      const V3& c) {
  return snapToFeature(p, a, b, c, closestOnTriangle(p, a, b, c));
}

/// Squared distance from p to segment a-b.
inline double pointSegmentDistance2(const V3& p, const V3& a, const V3& b) {
  const V3 e = b - a;
  const double ee = e.squaredNorm();
  const double t = ee > 0 ? std::clamp((p - a).dot(e) / ee, 0.0, 1.0) : 0.0;
  return (a + t * e - p).squaredNorm();
}

/// Closest points of segments p0-p1 and q0-q1: p0 + s (p1 - p0) and q0 + t (q1 - q0), s and t in
/// [0, 1] (Ericson 5.1.9, with the parallel and degenerate cases).
inline std::array<double, 2> closestSegmentSegment(const V3& p0, const V3& p1, const V3& q0,
                                                   const V3& q1) {
  const V3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  constexpr double tiny = 1e-300;
  double s = 0, t = 0;
  if (a <= tiny && e <= tiny) return {0, 0};
  if (a <= tiny) {
    t = std::clamp(f / e, 0.0, 1.0);
    return {0, t};
  }
  const double c = d1.dot(r);
  if (e <= tiny) {
    s = std::clamp(-c / a, 0.0, 1.0);
    return {s, 0};
  }
  const double b = d1.dot(d2);
  const double denom = a * e - b * b;
  s = denom > 1e-14 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  t = (b * s + f) / e;
  if (t < 0) {
    t = 0;
    s = std::clamp(-c / a, 0.0, 1.0);
  } else if (t > 1) {
    t = 1;
    s = std::clamp((b - c) / a, 0.0, 1.0);
  }
  return {s, t};
}

/// Whether closestSegmentSegment's closest points are inside both segments (0 < s, t < 1), and
/// then s and t, the same numbers; told without a division for most segments that are not: the
/// screening of edge pairs, most of which meet at an end.
inline bool closestInsideSegments(const V3& p0, const V3& p1, const V3& q0, const V3& q1,
                                  std::array<double, 2>& st) {
  const V3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm();
  constexpr double tiny = 1e-300;
  if (a <= tiny || e <= tiny) return false;  // (s or t is 0)
  const double b = d1.dot(d2), denom = a * e - b * b;
  if (!(denom > 1e-14 * a * e)) return false;  // (parallel: s is 0, or t is 0 or 1)
  const double c = d1.dot(r), f = d2.dot(r), num = b * f - c * e;
  // s = clamp(num / denom) is 0 or 1 here; a t outside [0, 1] then makes t 0 or 1.
  if (!(num > 0 && num < denom)) return false;
  const double s = std::clamp(num / denom, 0.0, 1.0), t = (b * s + f) / e;
  if (!(t > 0 && t < 1 && s > 0 && s < 1)) return false;  // (t < 0 or t > 1: clamped to 0 or 1)
  st = {s, t};
  return true;
}

inline double pointTriangleDistance(const V3& p, const V3& a, const V3& b, const V3& c) {
  const auto w = closestOnTriangle(p, a, b, c);
  return (p - (w[0] * a + w[1] * b + w[2] * c)).norm();
}

inline double segmentSegmentDistance(const V3& p0, const V3& p1, const V3& q0, const V3& q1) {
  const auto st = closestSegmentSegment(p0, p1, q0, q1);
  return ((p0 + st[0] * (p1 - p0)) - (q0 + st[1] * (q1 - q0))).norm();
}

/// Whether segment p0-p1 crosses the triangle (a, b, c) (a proper or touching crossing of its
/// plane inside the triangle; a segment in the triangle's plane counts as not crossing: its
/// distance is then found by the edge-edge terms).
inline bool segmentCrossesTriangle(const V3& p0, const V3& p1, const V3& a, const V3& b,
                                   const V3& c) {
  const V3 n = (b - a).cross(c - a);
  const double s0 = n.dot(p0 - a), s1 = n.dot(p1 - a);
  if ((s0 > 0 && s1 > 0) || (s0 < 0 && s1 < 0) || s0 == s1) return false;
  const V3 x = p0 + (s0 / (s0 - s1)) * (p1 - p0);
  const double e0 = n.dot((b - a).cross(x - a)), e1 = n.dot((c - b).cross(x - b)),
               e2 = n.dot((a - c).cross(x - c));
  return (e0 >= 0 && e1 >= 0 && e2 >= 0) || (e0 <= 0 && e1 <= 0 && e2 <= 0);
}

/// Distance between segment p0-p1 and triangle (a, b, c) (0 if it crosses).
inline double segmentTriangleDistance(const V3& p0, const V3& p1, const V3& a, const V3& b,
                                      const V3& c) {
  if (segmentCrossesTriangle(p0, p1, a, b, c)) return 0.0;
  double d = std::min(pointTriangleDistance(p0, a, b, c), pointTriangleDistance(p1, a, b, c));
  d = std::min(d, segmentSegmentDistance(p0, p1, a, b));
  d = std::min(d, segmentSegmentDistance(p0, p1, b, c));
  d = std::min(d, segmentSegmentDistance(p0, p1, c, a));
  return d;
}

/// Distance between two triangles (0 if they intersect).
inline double triangleTriangleDistance(const std::array<V3, 3>& t, const std::array<V3, 3>& u) {
  double d = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) {
    d = std::min(d, segmentTriangleDistance(t[i], t[(i + 1) % 3], u[0], u[1], u[2]));
    d = std::min(d, pointTriangleDistance(u[i], t[0], t[1], t[2]));
    for (int k = 0; k < 3; ++k) {
      if (segmentCrossesTriangle(u[k], u[(k + 1) % 3], t[0], t[1], t[2])) return 0.0;
    }
  }
  return d;
}

/// An axis-aligned box.
struct Box {
  V3 lo = V3::Constant(std::numeric_limits<double>::infinity());
  V3 hi = V3::Constant(-std::numeric_limits<double>::infinity());
  void add(const V3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void add(const Box& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  void inflate(double r) {
    lo.array() -= r;
    hi.array() += r;
  }
  bool overlaps(const Box& b) const {
    return lo.x() <= b.hi.x() && b.lo.x() <= hi.x() && lo.y() <= b.hi.y() && b.lo.y() <= hi.y() &&
           lo.z() <= b.hi.z() && b.lo.z() <= hi.z();
  }
  V3 center() const { return 0.5 * (lo + hi); }
  bool contains(const V3& p) const {
    return lo.x() <= p.x() && p.x() <= hi.x() && lo.y() <= p.y() && p.y() <= hi.y() &&
           lo.z() <= p.z() && p.z() <= hi.z();
  }
  bool contains(const Box& b) const {
    return (lo.array() <= b.lo.array()).all() && (hi.array() >= b.hi.array()).all();
  }
};

}  // namespace cutsim::forcefields::contact
