// Sutures: stitches tied between points of the surface. Finite differences of the force, the
// stiffness and the damping of taut threads, nothing from slack ones, and the stitches following
// the topology (a destroyed point takes its stitch; a cut that copies a stitched point leaves it).
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <vector>

#include "cutsim/forcefields/sutures.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/field_helpers.hpp"
#include "support/fixtures.hpp"
#include "support/force_field_harness.hpp"

namespace cutsim::forcefields {
namespace {

using Model = test::FieldModel<Sutures>;

SuturesParameters someParameters() {
  SuturesParameters p;
  p.stiffness = 40.0;
  p.damping = 1.5;
  return p;
}

TEST(Sutures, ForceStiffnessAndDampingMatchFiniteDifferences) {
  Model m = test::makeFieldModel<Sutures>(test::grid(5, 2.0, 0.2, 3), someParameters());
  const std::vector<double> x = test::perturbed(m.rest, 0.3, 5);
  const auto pts = m.topo->points();
  // Taut threads of several lengths (zero, a fraction of the distance), sharing points.
  const auto dist = [&](PointId a, PointId b) {
    return std::hypot(x[3 * a.idx()] - x[3 * b.idx()], x[3 * a.idx() + 1] - x[3 * b.idx() + 1],
                      x[3 * a.idx() + 2] - x[3 * b.idx() + 2]);
  };
  m.ff->addStitch(pts[0], pts[12], 0.0);
  m.ff->addStitch(pts[3], pts[20], 0.4 * dist(pts[3], pts[20]));
  m.ff->addStitch(pts[12], pts[7], 0.9 * dist(pts[12], pts[7]));
  EXPECT_GT(m.ff->potentialEnergy(x), 0.0);
  EXPECT_LE(test::forceVsEnergyError(*m.ff, x, 1e-6), 1e-7);
  const std::vector<double> dx = test::randomVector(x.size(), 1.0, 6);
  test::expectExactStiffness(*m.ff, x, dx, m.n(), 1e-6, 1e-8);
  const std::vector<double> v = test::randomVector(x.size(), 0.5, 7);
  std::vector<double> f0(x.size(), 0.0), f1(x.size(), 0.0), bv(x.size(), 0.0);
  m.ff->addForce(x, std::vector<double>(x.size(), 0.0), f0);
  m.ff->addForce(x, v, f1);
  m.ff->addDForce(x, v, bv, 0.0, 1.0);
  for (std::size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(f1[i] - f0[i], bv[i], 1e-12);
  TripletAccumulator acc;
  m.ff->addBToMatrix(x, acc, 1.0);
  const Eigen::MatrixXd b(acc.toSparse(static_cast<Index>(m.n())));
  EXPECT_LE(test::relativeError(bv, test::times(b, v)), 1e-14);
  // The stiffness of a taut thread is positive semi-definite (-K has no negative eigenvalue).
  TripletAccumulator k;
  m.ff->addKToMatrix(x, k, 1.0);
  const Eigen::MatrixXd K(k.toSparse(static_cast<Index>(m.n())));
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(-K).eigenvalues().minCoeff(), -1e-9);
}

TEST(Sutures, ASlackThreadDoesNothing) {
  Model m = test::makeFieldModel<Sutures>(test::grid(4, 1.0), someParameters());
  const auto pts = m.topo->points();
  m.ff->addStitch(pts[0], pts[5], 10.0);  // longer than the points are apart
  const std::vector<double> v = test::randomVector(m.rest.size(), 0.5, 3);
  std::vector<double> f(m.rest.size(), 0.0);
  m.ff->addForce(m.rest, v, f);
  EXPECT_EQ(test::maxAbs(f), 0.0);
  EXPECT_EQ(m.ff->potentialEnergy(m.rest), 0.0);
}

TEST(Sutures, ADestroyedPointTakesItsStitchACopyLeavesIt) {
  Model m = test::makeFieldModel<Sutures>(test::grid(5, 1.0), someParameters());
  topology::Topology& t = *m.topo;
  const auto pts = t.points();
  m.ff->addStitch(pts[6], pts[18], 0.0);
  m.ff->addStitch(pts[12], pts[8], 0.0);
  // A cut through point 12 (the middle row) copies it: the stitch stays on the original.
  const std::vector<Vec3> line{{0.0, 0.5, 0.0}, {0.62, 0.5, 0.0}};
  t.cutPolyline(line);
  ASSERT_TRUE(t.validate().ok());
  EXPECT_EQ(m.ff->numLive(), 2u);
  // The copy (the new point at point 12's rest position) is tied by no stitch.
  std::size_t copies = 0;
  for (PointId p : t.points()) {
    if (p == pts[12] || t.restPosition(p) != t.restPosition(pts[12])) continue;
    ++copies;
    for (const auto& s : m.ff->stitches()) EXPECT_TRUE(s.a != p && s.b != p);
  }
  EXPECT_EQ(copies, 1u);
  // Removing the triangles around point 6 destroys it: its stitch goes.
  t.removeTriangles(t.trianglesAroundPoint(pts[6]));
  ASSERT_TRUE(t.validate().ok());
  EXPECT_FALSE(m.ff->stitches()[0].alive);
  EXPECT_EQ(m.ff->numLive(), 1u);
}

}  // namespace
}  // namespace cutsim::forcefields
