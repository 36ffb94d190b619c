// TriangularFEMForceFieldOptim (SOFA's membrane, formula for formula) against its cutsim twin
// TriangularFEM: at a rest shape moved rigidly both give no force and the same K (where the
// frame's turn does not count); at small strains their forces agree to second order; its own
// addDForce, assembled K and the finite differences of its force at rest agree; the energy's
// gradient with the frame held is the force; the table follows topology changes.
#include <gtest/gtest.h>

#include <cmath>

#include "cutsim/base/errors.hpp"
#include "cutsim/forcefields/triangular_fem.hpp"
#include "cutsim/forcefields/triangular_fem_optim.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/field_helpers.hpp"
#include "support/fixtures.hpp"
#include "support/force_field_harness.hpp"
#include "support/ids.hpp"

namespace cutsim::forcefields {
namespace {

TriangularFEMParameters parameters() {
  TriangularFEMParameters p;
  p.youngModulus = 600.0;
  p.poissonRatio = 0.3;
  p.thickness = 0.5;
  return p;
}

struct Twins {
  topology::Topology topo{test::grid(5, 2.0, 0.2, 3)};
  TriangularFEMOptim optim{topo, parameters()};
  TriangularFEM twin{topo, parameters()};
  std::vector<double> rest = test::restOf(topo);
  std::size_t n() const { return topo.pointCapacity(); }
};

TEST(TriangularFemOptim, NoForceAndTheTwinsStiffnessAtARestShapeMovedRigidly) {
  Twins t;
  const std::vector<double> x = test::rigidMotion(t.rest, 5);
  const std::vector<double> f = test::forceAt(t.optim, x);
  EXPECT_LT(test::maxAbs(f), 1e-9 * parameters().youngModulus);
  const Eigen::MatrixXd K = test::assembledK(t.optim, x, t.n());
  const Eigen::MatrixXd Ktwin = test::assembledK(t.twin, x, t.n());
  EXPECT_LT(test::maxAbsCoeff(K - Ktwin), 1e-10 * test::maxAbsCoeff(Ktwin));
  // At rest the frame's turn carries no stress: K is the exact derivative of the force.
  EXPECT_LT(test::matrixVsForceError(t.optim, x, t.n(), 1e-6), 1e-6);
}

TEST(TriangularFemOptim, ForcesAgreeWithTheTwinsToSecondOrderInTheStrain) {
  Twins t;
  const std::vector<double> dir = test::randomVector(3 * t.n(), 1.0, 9);
  double previous = 0;
  for (double eps : {1e-3, 5e-4}) {
    std::vector<double> x = t.rest;
    for (std::size_t i = 0; i < x.size(); ++i) x[i] += eps * dir[i];
    const double err = test::maxAbs([&] {
      std::vector<double> d = test::forceAt(t.optim, x), g = test::forceAt(t.twin, x);
      for (std::size_t i = 0; i < d.size(); ++i) d[i] -= g[i];
      return d;
    }());
    const double scale = test::maxAbs(test::forceAt(t.twin, x));
    EXPECT_LT(err, 0.05 * scale) << eps;
    if (previous > 0)
      EXPECT_NEAR(previous / err, 4.0, 1.0) << "the difference is not of second order";
    previous = err;
  }
}

TEST(TriangularFemOptim, ItsDForceIsItsMatrixAndItsEnergyGradientIsItsForceAtSmallStrain) {
  Twins t;
  const std::vector<double> x = test::perturbed(t.rest, 0.05, 4);
  const std::vector<double> dx = test::randomVector(3 * t.n(), 1.0, 8);
  EXPECT_LT(test::dForceVsMatrixError(t.optim, x, dx, t.n()), 1e-12);
  EXPECT_LT(test::maxAsymmetry(test::assembledK(t.optim, x, t.n())),
            1e-9 * test::maxAbsCoeff(test::assembledK(t.optim, x, t.n())));
  // Not a gradient away from rest (the frame turns along ab): only close, to O(strain).
  EXPECT_LT(test::forceVsEnergyError(t.optim, x, 1e-6), 0.1);
  EXPECT_FALSE(t.optim.stiffnessIsExact());
  EXPECT_FALSE(t.optim.setExactStiffness(true));
  TriangularFEMParameters exact = parameters();
  exact.exactHessian = true;
  EXPECT_THROW(TriangularFEMOptim(t.topo, exact), InvalidInput);
}

TEST(TriangularFemOptim, TheFrameFollowsTheFirstEdgeAsSofasDoes) {
  // One triangle, stretched along its first edge ab by 10%: SOFA's strain is exactly 0.1 along
  // x (linear in the displacement in the frame of ab), so f_b = (E / (1 - nu^2)) * 0.1 * h * |ab|
  // ... in closed form for the right triangle a = 0, b = (1, 0), c = (0, 1): f_b.x = -A h s_xx / bx
  // with A = 1/2, s_xx = E / (1 - nu^2) * 0.1.
  topology::MeshData m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.triangles = {tri(0, 1, 2)};
  topology::Topology topo(m);
  TriangularFEMOptim f(topo, parameters());
  std::vector<double> x = {0, 0, 0, 1.1, 0, 0, 0, 1, 0};
  const std::vector<double> force = test::forceAt(f, x);
  const TriangularFEMParameters p = parameters();
  const double sxx = p.youngModulus / (1 - p.poissonRatio * p.poissonRatio) * 0.1;
  EXPECT_NEAR(force[3], -0.5 * p.thickness * sxx, 1e-12 * sxx);
  EXPECT_NEAR(force[4], 0.0, 1e-12 * sxx);
  EXPECT_NEAR(force[0] + force[3] + force[6], 0.0, 1e-12 * sxx);
}

}  // namespace
}  // namespace cutsim::forcefields
