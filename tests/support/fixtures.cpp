#include "support/fixtures.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <random>

namespace cutsim::test {

using topology::MeshData;
using topology::PointId;
using topology::Vec3;

MeshData grid(int n, double size, double jitter, std::uint64_t seed) {
  MeshData m;
  const double h = size / (n - 1);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> dist(-jitter * h, jitter * h);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      Vec3 p{h * i, h * j, 0.0};
      if (jitter > 0.0 && i > 0 && j > 0 && i < n - 1 && j < n - 1) {
        p[0] += dist(rng);
        p[1] += dist(rng);
      }
      m.points.push_back(p);
    }
  }
  const auto id = [n](int i, int j) { return static_cast<PointId>(j * n + i); };
  for (int j = 0; j + 1 < n; ++j) {
    for (int i = 0; i + 1 < n; ++i) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  }
  return m;
}

MeshData oneHinge(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  MeshData m;
  m.points = {a, b, c, d};
  m.triangles = {{PointId(2), PointId(3), PointId(0)}, {PointId(3), PointId(2), PointId(1)}};
  return m;
}

MeshData fan(int sectors, bool closed, double height) {
  MeshData m;
  m.points.push_back({0.0, 0.0, 0.0});
  const double span = closed ? 2.0 * std::numbers::pi : 1.5 * std::numbers::pi;
  const int rim = closed ? sectors : sectors + 1;
  for (int k = 0; k < rim; ++k) {
    const double t = span * k / sectors;
    m.points.push_back({std::cos(t), std::sin(t), height * std::sin(2.0 * t)});
  }
  for (int k = 0; k < sectors; ++k) {
    const auto a = static_cast<PointId>(1 + k);
    const auto b = static_cast<PointId>(1 + (k + 1) % rim);
    m.triangles.push_back({PointId(0), a, b});
  }
  return m;
}

MeshData shuffledVertices(const MeshData& mesh, std::uint64_t seed,
                          std::vector<PointId>* newOfOld) {
  std::vector<PointId> perm(mesh.points.size());
  std::iota(perm.begin(), perm.end(), PointId{0});
  std::mt19937_64 rng(seed);
  std::shuffle(perm.begin(), perm.end(), rng);
  MeshData out;
  out.points.resize(mesh.points.size());
  for (std::size_t i = 0; i < perm.size(); ++i) out.points[perm[i].idx()] = mesh.points[i];
  for (const auto& t : mesh.triangles)
    out.triangles.push_back({perm[t[0].idx()], perm[t[1].idx()], perm[t[2].idx()]});
  if (newOfOld) *newOfOld = perm;
  return out;
}

}  // namespace cutsim::test
