#pragma once
// Nearest-triangle queries on a triangle mesh (MeshData): a uniform grid of cells holding the
// triangles whose bounding boxes meet them, and its brute-force twin.
#include <array>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include "cutsim/topology/mesh_io.hpp"
#include "cutsim/topology/types.hpp"

namespace cutsim::topology {

/// The distance from p to the nearest triangle of `mesh` and that triangle's longest edge, by a
/// look at every triangle (infinity and 0 for a mesh without triangles).
std::pair<double, double> nearestTriangleBruteForce(const MeshData& mesh, const Vec3& p);

/// The same through a uniform grid of cells (about a mean longest edge wide, at most a million
/// along an axis) holding the triangles whose bounding boxes they meet. A query looks at rings of
/// cells around the point's until no triangle in a farther ring can be nearer: a long polyline
/// checked against a large mesh costs its points times a few cells, not times every triangle.
/// Points more than two cells outside the mesh's box go to the brute force. The mesh must outlive
/// the grid.
class TriangleGrid {
 public:
  explicit TriangleGrid(const MeshData& mesh);
  std::pair<double, double> nearest(const Vec3& p) const;

 private:
  long cellOf(double v, std::size_t axis) const;
  static std::uint64_t key(long x, long y, long z);
  const MeshData& mesh_;
  Vec3 lo_{}, hi_{};
  double h_ = 1.0;
  std::array<long, 3> n_{1, 1, 1};
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells_;
};

}  // namespace cutsim::topology
