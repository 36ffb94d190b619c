// Nearest-triangle queries through a uniform grid (triangle_grid.hpp).
#include "cutsim/topology/triangle_grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "cutsim/topology/geometry.hpp"

namespace cutsim::topology {

using geometry::closestOnTriangle;
using geometry::dist2;

std::pair<double, double> nearestTriangleBruteForce(const MeshData& mesh, const Vec3& p) {
  double best = std::numeric_limits<double>::infinity(), edge = 0;
  for (const auto& t : mesh.triangles) {
    const Vec3 &a = mesh.points[t[0].idx()], &b = mesh.points[t[1].idx()],
               &c = mesh.points[t[2].idx()];
    const double d = dist2(p, closestOnTriangle(p, a, b, c));
    if (d < best ||
        (d == best && geometry::longestEdge(a, b, c) > edge)) {  // ties: the longer edge
      best = d;
      edge = geometry::longestEdge(a, b, c);
    }
  }
  return {std::sqrt(best), edge};
}

TriangleGrid::TriangleGrid(const MeshData& mesh) : mesh_(mesh) {
  lo_ = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
         std::numeric_limits<double>::infinity()};
  hi_ = {-lo_[0], -lo_[1], -lo_[2]};
  double edges = 0.0;
  for (const auto& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const Vec3& q = mesh.points[t[std::size_t(k)].idx()];
      for (std::size_t a = 0; a < 3; ++a) {
        lo_[a] = std::min(lo_[a], q[a]);
        hi_[a] = std::max(hi_[a], q[a]);
      }
    }
    edges += geometry::longestEdge(mesh.points[t[0].idx()], mesh.points[t[1].idx()],
                                   mesh.points[t[2].idx()]);
  }
  if (mesh.triangles.empty()) return;
  double extent = 0.0;
  for (std::size_t a = 0; a < 3; ++a) extent = std::max(extent, hi_[a] - lo_[a]);
  h_ = std::max({edges / double(mesh.triangles.size()), extent * 1e-6, 1e-300});
  for (std::size_t a = 0; a < 3; ++a) n_[a] = long(std::floor((hi_[a] - lo_[a]) / h_)) + 1;
  for (std::uint32_t i = 0; i < mesh.triangles.size(); ++i) {
    const auto& t = mesh.triangles[i];
    std::array<long, 3> from{}, to{};
    for (std::size_t a = 0; a < 3; ++a) {
      double mn = mesh.points[t[0].idx()][a], mx = mn;
      for (int k = 1; k < 3; ++k) {
        mn = std::min(mn, mesh.points[t[std::size_t(k)].idx()][a]);
        mx = std::max(mx, mesh.points[t[std::size_t(k)].idx()][a]);
      }
      from[a] = cellOf(mn, a);
      to[a] = cellOf(mx, a);
    }
    for (long x = from[0]; x <= to[0]; ++x)
      for (long y = from[1]; y <= to[1]; ++y)
        for (long z = from[2]; z <= to[2]; ++z) cells_[key(x, y, z)].push_back(i);
  }
}

std::pair<double, double> TriangleGrid::nearest(const Vec3& p) const {
  if (cells_.empty()) return nearestTriangleBruteForce(mesh_, p);
  for (std::size_t a = 0; a < 3; ++a)
    if (!(p[a] >= lo_[a] - 2 * h_ && p[a] <= hi_[a] + 2 * h_))
      return nearestTriangleBruteForce(mesh_, p);
  const std::array<long, 3> c{cellOf(p[0], 0), cellOf(p[1], 1), cellOf(p[2], 2)};
  double best = std::numeric_limits<double>::infinity(), edge = 0.0;
  const long rings = std::max({n_[0], n_[1], n_[2]}) + 2;
  for (long r = 0; r <= rings; ++r) {
    for (long x = std::max(0L, c[0] - r); x <= std::min(n_[0] - 1, c[0] + r); ++x) {
      for (long y = std::max(0L, c[1] - r); y <= std::min(n_[1] - 1, c[1] + r); ++y) {
        for (long z = std::max(0L, c[2] - r); z <= std::min(n_[2] - 1, c[2] + r); ++z) {
          if (std::max({std::labs(x - c[0]), std::labs(y - c[1]), std::labs(z - c[2])}) != r)
            continue;
          const auto it = cells_.find(key(x, y, z));
          if (it == cells_.end()) continue;
          for (std::uint32_t i : it->second) {
            const auto& t = mesh_.triangles[i];
            const Vec3 &a = mesh_.points[t[0].idx()], &b = mesh_.points[t[1].idx()],
                       &cc = mesh_.points[t[2].idx()];
            const double d = dist2(p, closestOnTriangle(p, a, b, cc));
            if (d < best || (d == best && geometry::longestEdge(a, b, cc) > edge)) {
              best = d;
              edge = geometry::longestEdge(a, b, cc);
            }
          }
        }
      }
    }
    // Every triangle beyond ring r is more than (r - 2) cells from p (p is within two cells of
    // its clamped cell).
    if (std::sqrt(best) <= double(r - 2) * h_) break;
  }
  return {std::sqrt(best), edge};
}

long TriangleGrid::cellOf(double v, std::size_t axis) const {
  return std::clamp(long(std::floor((v - lo_[axis]) / h_)), 0L, n_[axis] - 1);
}

std::uint64_t TriangleGrid::key(long x, long y, long z) {
  // Each index is below 2^21 (a million cells at most along an axis, plus one).
  return (std::uint64_t(x) << 42) | (std::uint64_t(y) << 21) | std::uint64_t(z);
}

}  // namespace cutsim::topology
