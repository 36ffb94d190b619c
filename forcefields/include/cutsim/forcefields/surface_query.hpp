#pragma once
// Queries of the deformed surface: where a point is nearest on it, where a ray or a segment meets
// it, which triangles a sphere or a capsule overlaps, which triangles a moving segment (a blade)
// or a moving triangle (a jaw) sweeps through. Over the live triangles of a topology at given
// positions, through a bounding volume hierarchy of their boxes (contact's), refitted when the
// positions change and rebuilt when the topology does. What world-space instruments and
// Python's locate ask; each query is tested against a brute force over every triangle
// (tests/forcefields/test_surface_query.cpp).
//
// Distances and hits are those of double-precision geometry (no exact predicates): a hit exactly
// on an edge shared by two triangles may be reported for either or both; the swept queries are
// conservative where noted.
#include <array>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "cutsim/topology/types.hpp"

namespace cutsim::topology {
class Topology;
}

namespace cutsim::forcefields {

/// A point of the surface: its triangle, its barycentric weights there, the point, its distance.
struct SurfacePoint {
  topology::TriangleId triangle;
  std::array<double, 3> weights{};
  topology::Vec3 point{};
  double distance = 0.0;
};

/// Where a ray or a segment meets a triangle: t is the distance from the ray's origin (along its
/// unit direction), or the fraction along a segment from its first end.
struct SurfaceHit {
  topology::TriangleId triangle;
  double t = 0.0;
  std::array<double, 3> weights{};
  topology::Vec3 point{};
};

/// A point of the curve along which a moving segment (a blade) meets the surface: a triangle it
/// lies on and its weights there (a point on an edge is given by the edge's ends, its third weight
/// zero), the point, and where it is on the blade's sweep: `s` in [0, n] counts the sweep's
/// stages (s = k at its k-th position), `u` in [0, 1] runs along the blade from its first end.
struct SweptCrossing {
  topology::TriangleId triangle;
  std::array<double, 3> weights{};
  topology::Vec3 point{};
  double s = 0.0;
  double u = 0.0;
};

class SurfaceQuery {
 public:
  /// Over the live triangles of `topology` at positions x (3 per point slot, as the state's).
  SurfaceQuery(const topology::Topology& topology, std::span<const double> x);
  ~SurfaceQuery();
  SurfaceQuery(const SurfaceQuery&) = delete;
  SurfaceQuery& operator=(const SurfaceQuery&) = delete;

  /// Follows new positions (the boxes are refitted) or a changed topology (rebuilt).
  void update(std::span<const double> x);

  /// The nearest point of the surface to q within maxDistance (none if farther, or no triangle).
  std::optional<SurfacePoint> closestPoint(
      const topology::Vec3& q, double maxDistance = std::numeric_limits<double>::infinity()) const;
  /// closestPoint of many points, answered in the order of a space-filling (Morton) curve
  /// through them, so that consecutive queries walk the same branches of the hierarchy (the
  /// same answers as one by one, in the given order).
  std::vector<std::optional<SurfacePoint>> closestPoints(
      std::span<const topology::Vec3> q,
      double maxDistance = std::numeric_limits<double>::infinity()) const;
  /// The first triangle the ray from origin along direction (not zero; normalised here) meets
  /// within maxT.
  std::optional<SurfaceHit> rayHit(const topology::Vec3& origin, const topology::Vec3& direction,
                                   double maxT = std::numeric_limits<double>::infinity()) const;
  /// Every triangle the segment a-b crosses, by t from a.
  std::vector<SurfaceHit> segmentHits(const topology::Vec3& a, const topology::Vec3& b) const;
  /// The triangles within r of c (ascending ids).
  std::vector<topology::TriangleId> sphereOverlap(const topology::Vec3& c, double r) const;
  /// The triangles within r of the segment a-b (ascending ids).
  std::vector<topology::TriangleId> capsuleOverlap(const topology::Vec3& a, const topology::Vec3& b,
                                                   double r) const;
  /// The triangles a segment meets while it moves linearly from a0-b0 to a1-b1: those within
  /// `within` of the surface it sweeps (two triangles, a0 b0 b1 and a0 b1 a1: its bilinear
  /// surface split along a diagonal) (ascending ids).
  std::vector<topology::TriangleId> sweptSegmentHits(const topology::Vec3& a0,
                                                     const topology::Vec3& b0,
                                                     const topology::Vec3& a1,
                                                     const topology::Vec3& b1,
                                                     double within = 0.0) const;
  /// The triangles a triangle meets while it moves linearly from `from` to `to` (corner by
  /// corner): those within `within` of its swept volume's boundary (both positions and the three
  /// surfaces its edges sweep, each split in two triangles), and those inside that closed
  /// boundary (ascending ids).
  std::vector<topology::TriangleId> sweptTriangleHits(const std::array<topology::Vec3, 3>& from,
                                                      const std::array<topology::Vec3, 3>& to,
                                                      double within = 0.0) const;

  /// Where the surface that a segment sweeps while it moves through the given positions (each a
  /// pair of ends; between consecutive ones linearly, the bilinear surface split along a diagonal)
  /// meets the surface: the curves of crossing points, each ordered by increasing sweep `s`. The
  /// points are where the curve crosses the triangles' edges (the same point for the triangles on
  /// both sides of an edge, so that a curve goes on across it), and its two ends: on the blade's
  /// first or last position, on the path of either end of the blade, or on the border. A curve
  /// ends where the surface ends (a border or the lip of a cut: the triangles on its two sides do
  /// not share the edge). One curve per layer of a fold the blade passes through. Closed curves
  /// (a blade that sweeps around a bump of the surface without leaving it) are not returned.
  std::vector<std::vector<SweptCrossing>> sweptSegmentCurves(
      std::span<const std::array<topology::Vec3, 2>> positions) const;

  /// How many triangles it holds.
  std::size_t size() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cutsim::forcefields
