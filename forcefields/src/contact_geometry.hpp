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
    return lo.x() <= p.x() && p.x() <= hi.x() && lo.y() <= p.y() && p.y() <= hi.y() && lo.z() <= p.z() && p.z() <= hi.z();
  }
  bool contains(const Box& b) const {
    return (lo.array() <= b.lo.array()).all() && (hi.array() >= b.hi.array()).all();
  }
};

}  // namespace cutsim::forcefields::contact
