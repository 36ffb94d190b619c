// The nearest-triangle grid against its brute-force twin, on jittered, folded and sparse meshes,
// for points on, near and far from them.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "cutsim/topology/triangle_grid.hpp"
#include "support/ids.hpp"

namespace cutsim::topology {
namespace {

MeshData grid(int nx, int ny, std::mt19937& rng, double jitter, double fold) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  MeshData m;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const double x = double(i) / (nx - 1), y = double(j) / (ny - 1);
      m.points.push_back(
          {x + jitter * u(rng) / nx, y + jitter * u(rng) / ny, fold * std::sin(6 * x) * y});
    }
  for (int j = 0; j + 1 < ny; ++j)
    for (int i = 0; i + 1 < nx; ++i) {
      const Index a = Index(j * nx + i), b = a + 1, c = a + Index(nx), d = c + 1;
      m.triangles.push_back(tri(a, b, d));
      m.triangles.push_back(tri(a, d, c));
    }
  return m;
}

TEST(TriangleGrid, NearestEqualsTheBruteForce) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.3, 1.3), small(-0.05, 0.05);
  for (const auto& [nx, ny, jitter, fold] :
       {std::tuple{9, 9, 0.0, 0.0}, std::tuple{31, 17, 0.4, 0.0}, std::tuple{25, 25, 0.3, 0.3},
        std::tuple{3, 40, 0.2, 1.0}}) {
    const MeshData m = grid(nx, ny, rng, jitter, fold);
    const TriangleGrid g(m);
    for (int q = 0; q < 400; ++q) {
      Vec3 p;
      if (q % 4 == 0) {  // on the surface: a mesh point, moved a little
        p = m.points[std::size_t(rng() % m.points.size())];
        p = {p[0] + small(rng), p[1] + small(rng), p[2] + small(rng)};
      } else if (q % 4 == 3) {  // far: outside the box (the brute force's path)
        p = {u(rng) * 10, u(rng) * 10, u(rng) * 10};
      } else {
        p = {u(rng), u(rng), 0.5 * u(rng)};
      }
      const auto fast = g.nearest(p), slow = nearestTriangleBruteForce(m, p);
      ASSERT_EQ(fast.first, slow.first) << nx << "x" << ny << " query " << q;
      ASSERT_EQ(fast.second, slow.second) << nx << "x" << ny << " query " << q;
    }
  }
}

TEST(TriangleGrid, EmptyAndSingleTriangleMeshes) {
  MeshData empty;
  const TriangleGrid e(empty);
  EXPECT_TRUE(std::isinf(e.nearest({0, 0, 0}).first));
  MeshData one;
  one.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  one.triangles = {tri(0, 1, 2)};
  const TriangleGrid g(one);
  EXPECT_EQ(g.nearest({0.2, 0.2, 0.5}).first, 0.5);
  EXPECT_EQ(g.nearest({0.2, 0.2, 0.5}).second, std::sqrt(2.0));
}

}  // namespace
}  // namespace cutsim::topology
