#pragma once
// The contact tests' oracle: an exact check (CGAL's exact predicates, CGAL's box intersection for
// the broad phase) that no two triangles of a surface intersect, independent of cutsim's own
// contact code. Triangles that share a point are checked with that point excluded (the edge
// opposite it in each triangle against the other triangle); triangles that share an edge only for
// a fold onto each other (the opposite corner of one inside the other). Pairs the caller excludes
// (the zero-distance lips of a cut) are skipped.
#include <array>
#include <functional>
#include <string>
#include <vector>

#include "cutsim/core/simulation.hpp"

namespace cutsim::test {

struct Intersection {
  /// Triangle slots (simulationIntersections: an obstacle triangle k is triangleCapacity() + k).
  std::size_t a = 0, b = 0;
  std::string describe() const;
};

/// The intersecting pairs of the triangles (corner indices into points), at most `limit`.
/// skip(i, j) excludes a pair.
std::vector<Intersection> findIntersections(
    const std::vector<std::array<double, 3>>& points,
    const std::vector<std::array<std::size_t, 3>>& triangles,
    const std::function<bool(std::size_t, std::size_t)>& skip = {}, std::size_t limit = 10);

/// The simulation's live triangles at its current positions, excluding pairs of triangles that
/// are within `restNear` of each other in the rest configuration (neighbours in the material: the
/// lips of a cut, which the contact excludes until they separate; 0 skips only the triangles that
/// touch there) when `skipLips`; optionally also against obstacle triangles
/// (extra points and triangles appended, checked like the rest but never among themselves).
std::vector<Intersection> simulationIntersections(
    const core::Simulation& sim, bool skipLips = true,
    const std::vector<std::array<double, 3>>& obstaclePoints = {},
    const std::vector<std::array<std::size_t, 3>>& obstacleTriangles = {}, double restNear = 0.0);

}  // namespace cutsim::test
