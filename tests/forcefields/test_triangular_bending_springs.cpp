// TriangularBendingSprings (SOFA's): a spring between the wings of each interior edge, on the
// bending springs' hinge table. Its force against the spring law written out per hinge, its
// derivatives against finite differences, its springs through cuts (the table against a rebuild).
#include <gtest/gtest.h>

#include <cmath>

#include "cutsim/forcefields/triangular_bending_springs.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/field_helpers.hpp"
#include "support/fixtures.hpp"
#include "support/force_field_harness.hpp"

namespace cutsim::forcefields {
namespace {

TriangularBendingSpringsParameters params(double kd = 0.0) {
  TriangularBendingSpringsParameters p;
  p.stiffness = 40.0;
  p.damping = kd;
  return p;
}

TEST(TriangularBendingSprings, ForceIsTheSpringBetweenTheWingsOfEachHinge) {
  topology::Topology topo(test::grid(5, 2.0, 0.15, 4));
  TriangularBendingSprings f(topo, params(0.3));
  const std::vector<double> rest = test::restOf(topo);
  const std::vector<double> x = test::perturbed(rest, 0.2, 3),
                            v = test::randomVector(rest.size(), 1.0, 9);
  std::vector<double> got(x.size(), 0.0), twin(x.size(), 0.0);
  f.addForce(x, v, got);
  std::size_t hinges = 0;
  for (topology::EdgeId e : topo.edges()) {
    const auto tris = topo.edgeTriangles(e);
    if (tris[0].idx() == topology::kInvalidIndex || tris[1].idx() == topology::kInvalidIndex)
      continue;
    ++hinges;
    // The wings: the corner of each triangle that is not on the edge.
    const auto ends = topo.edgeVertices(e);
    std::array<std::size_t, 2> w{};
    for (int s = 0; s < 2; ++s)
      for (auto p : topo.triangleVertices(tris[std::size_t(s)]))
        if (p != ends[0] && p != ends[1]) w[std::size_t(s)] = std::size_t(p.idx());
    double d[3], L0 = 0, l = 0, rel = 0;
    for (int k = 0; k < 3; ++k) {
      d[k] = x[3 * w[1] + std::size_t(k)] - x[3 * w[0] + std::size_t(k)];
      const double r = rest[3 * w[1] + std::size_t(k)] - rest[3 * w[0] + std::size_t(k)];
      L0 += r * r;
      l += d[k] * d[k];
    }
    L0 = std::sqrt(L0);
    l = std::sqrt(l);
    for (int k = 0; k < 3; ++k)
      rel += (v[3 * w[1] + std::size_t(k)] - v[3 * w[0] + std::size_t(k)]) * d[k] / l;
    const double I = 40.0 * (l - L0) + 0.3 * rel;
    for (int k = 0; k < 3; ++k) {
      twin[3 * w[0] + std::size_t(k)] += I * d[k] / l;
      twin[3 * w[1] + std::size_t(k)] -= I * d[k] / l;
    }
  }
  EXPECT_EQ(f.numActiveSprings(), hinges);
  EXPECT_LE(test::relativeError(got, twin), 1e-12);
}

TEST(TriangularBendingSprings, DerivativesMatchFiniteDifferences) {
  topology::Topology topo(test::grid(5, 2.0, 0.15, 4));
  TriangularBendingSprings f(topo, params());
  const std::vector<double> x = test::perturbed(test::restOf(topo), 0.2, 5);
  const std::vector<double> dx = test::randomVector(x.size(), 1.0, 6);
  EXPECT_LE(test::forceVsEnergyError(f, x, 1e-6), 1e-7);
  EXPECT_LE(test::dForceVsForceError(f, x, dx, 1e-6), 1e-7);
  EXPECT_LE(test::matrixVsForceError(f, x, topo.pointCapacity(), 1e-6), 1e-7);
}

TEST(TriangularBendingSprings, ItsHingesFollowACut) {
  topology::Topology topo(test::grid(6, 2.0, 0.0, 1));
  TriangularBendingSprings f(topo, params());
  const std::size_t before = f.numActiveSprings();
  const auto edges = topo.edges();
  for (topology::EdgeId e : edges) {
    const auto tris = topo.edgeTriangles(e);
    if (tris[0].idx() != topology::kInvalidIndex && tris[1].idx() != topology::kInvalidIndex) {
      topo.tear(e);
      break;
    }
  }
  EXPECT_LT(f.numActiveSprings(), before);  // the torn edge is a border now: no hinge
  std::vector<std::string> problems;
  f.validate(topo, problems);
  EXPECT_TRUE(problems.empty()) << problems.front();
}

}  // namespace
}  // namespace cutsim::forcefields
