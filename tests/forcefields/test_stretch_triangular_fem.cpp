// TriangularFEM: the analytic plane-stress energy, finite differences, matrices, invariants,
// degenerate triangles, parameters, and the incremental table against a rebuild after every
// operation of random topology sequences.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <any>
#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <utility>

#include "cutsim/forcefields/registry.hpp"
#include "cutsim/forcefields/stretch_springs.hpp"
#include "cutsim/forcefields/triangular_fem.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/field_helpers.hpp"
#include "support/fixtures.hpp"
#include "support/force_field_harness.hpp"
#include "support/ids.hpp"
#include "support/random_ops.hpp"

namespace cutsim::forcefields {
namespace {

using test::SequenceCase;
using topology::kInvalidIndex;
using topology::MeshData;
using topology::Topology;

using Model = test::FieldModel<TriangularFEM>;

Model makeModel(const MeshData& mesh, const TriangularFEMParameters& p = {}) {
  return test::makeFieldModel<TriangularFEM>(mesh, p);
}

TriangularFEMParameters someParameters(double restScale = 1.0) {
  TriangularFEMParameters p;
  p.youngModulus = 250.0;
  p.poissonRatio = 0.35;
  p.thickness = 0.1;
  p.restScale = restScale;
  return p;
}

/// The rest scales the derivative tests run with: none, and a prestrain (the held sheet stretched
/// by 1/0.9 - 1 = 11%).
constexpr double kRestScales[] = {1.0, 0.9};

std::string scaleName(double restScale) {
  return " restScale " + std::to_string(restScale);
}

/// The rest shape of the elements: x scaled by s (3 doubles per point).
std::vector<double> scaled(std::vector<double> x, double s) {
  for (double& c : x) c *= s;
  return x;
}

// ---------------------------------------------------------------------------------------------

TEST(TriangularFem, BadParametersAreRejectedNamingTheParameter) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    TriangularFEMParameters p;
    std::string where, value;
  };
  std::vector<Case> cases;
  auto with = [](auto set) {
    TriangularFEMParameters p;
    set(p);
    return p;
  };
  cases.push_back({with([&](auto& p) { p.youngModulus = -2.0; }), "youngModulus", "-2"});
  cases.push_back({with([&](auto& p) { p.youngModulus = nan; }), "youngModulus", "nan"});
  cases.push_back({with([&](auto& p) { p.youngModulus = inf; }), "youngModulus", "inf"});
  cases.push_back({with([&](auto& p) { p.poissonRatio = 0.5; }), "poissonRatio", "0.5"});
  cases.push_back({with([&](auto& p) { p.poissonRatio = 0.7; }), "poissonRatio", "0.7"});
  cases.push_back({with([&](auto& p) { p.poissonRatio = -1.0; }), "poissonRatio", "-1"});
  cases.push_back({with([&](auto& p) { p.poissonRatio = nan; }), "poissonRatio", "nan"});
  cases.push_back({with([&](auto& p) { p.thickness = -0.1; }), "thickness", "-0.1"});
  cases.push_back({with([&](auto& p) { p.thickness = -inf; }), "thickness", "-inf"});
  cases.push_back({with([&](auto& p) { p.restScale = 0.0; }), "restScale", "0"});
  cases.push_back({with([&](auto& p) { p.restScale = -0.5; }), "restScale", "-0.5"});
  cases.push_back({with([&](auto& p) { p.restScale = nan; }), "restScale", "nan"});
  cases.push_back({with([&](auto& p) { p.restScale = inf; }), "restScale", "inf"});
  for (const Case& c : cases) {
    SCOPED_TRACE(c.where + " = " + c.value);
    try {
      c.p.validate();
      ADD_FAILURE() << "accepted";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.where(), c.where);
      EXPECT_NE(e.message().find(c.value), std::string::npos) << e.message();
    }
    const MeshData mesh = test::grid(3);
    Topology topo(mesh.points, mesh.triangles);
    EXPECT_THROW(TriangularFEM(topo, c.p), InvalidInput);
  }
  EXPECT_NO_THROW(TriangularFEMParameters{}.validate());
  EXPECT_NO_THROW(with([](auto& p) { p.poissonRatio = -0.9; }).validate());
  EXPECT_NO_THROW(with([](auto& p) { p.restScale = 1e-3; }).validate());
}

TEST(TriangularFem, OneElementPerTriangle) {
  Model m = makeModel(test::grid(5, 4.0, 0.2, 1));
  EXPECT_EQ(m.ff->numElements(), m.topo->numTriangles());
  EXPECT_EQ(m.ff->numDegenerate(), 0u);
  EXPECT_EQ(m.ff->typeName(), "TriangularFEM");
  double area = 0.0;
  for (const FemTriangle& e : m.ff->elements()) area += e.area;
  EXPECT_NEAR(area, 16.0, 1e-12);
  for (TriangleId t : m.topo->triangles()) {
    const FemRecord r = m.ff->element(t);
    EXPECT_EQ(r.triangle, t);
    EXPECT_FALSE(r.degenerate);
  }
  EXPECT_EQ(m.ff->element(TriangleId(m.topo->triangleCapacity())).triangle, TriangleId::invalid());
  std::vector<std::array<PointId, 2>> segments;
  m.ff->draw(segments);
  EXPECT_EQ(segments.size(), 3 * m.topo->numTriangles());
  TripletAccumulator acc;
  m.ff->addBToMatrix(m.rest, acc, 1.0);
  EXPECT_TRUE(acc.triplets().empty());
  EXPECT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
}

TEST(TriangularFem, HomogeneousStretchGivesThePlaneStressEnergy) {
  // A homogeneous deformation diag(1 + ex, 1 + ey) of the plane, then a rigid motion:
  // E = A h [mu (ex^2 + ey^2) + lambda/2 (ex + ey)^2], with mu = E/(2(1+nu)),
  // lambda = E nu/(1 - nu^2); for ey = -nu ex (uniaxial stress) E = A h Y ex^2 / 2.
  const TriangularFEMParameters p = someParameters();
  Model m = makeModel(test::grid(4, 2.0, 0.3, 5), p);
  const double nu = p.poissonRatio, young = p.youngModulus;
  const double mu = young / (2.0 * (1.0 + nu)), lambda = young * nu / (1.0 - nu * nu);
  for (auto [ex, ey] : {std::pair{0.1, 0.0}, std::pair{0.3, -0.35 * 0.3}, std::pair{-0.2, 0.15}}) {
    SCOPED_TRACE("ex " + std::to_string(ex) + " ey " + std::to_string(ey));
    const Eigen::Matrix3d a = Eigen::Vector3d(1.0 + ex, 1.0 + ey, 1.0).asDiagonal();
    const std::vector<double> x =
        test::transformed(test::transformed(m.rest, a, Eigen::Vector3d::Zero()),
                          test::randomRotation(3), Eigen::Vector3d(0.5, 1.0, -2.0));
    const double expected =
        4.0 * p.thickness * (mu * (ex * ex + ey * ey) + 0.5 * lambda * (ex + ey) * (ex + ey));
    EXPECT_NEAR(m.ff->potentialEnergy(x), expected, 1e-12 * expected);
    if (ey == -nu * ex) {
      EXPECT_NEAR(expected, 4.0 * p.thickness * young * ex * ex / 2.0, 1e-12 * expected);
    }
    // A homogeneous stress: the interior points are in equilibrium.
    const std::vector<double> f = test::forceAt(*m.ff, x);
    for (PointId q : m.topo->points()) {
      if (m.topo->isBoundaryPoint(q)) continue;
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(f[3 * q.idx() + k], 0.0, 1e-11 * young);
    }
  }
}

TEST(TriangularFem, RestScaleScalesEveryElementsRestShape) {
  // restScale s: shape gradients g / s, rest areas s^2 A. The mesh scaled by s (and moved
  // rigidly) is force-free; the mesh itself is under the equibiaxial strain e = 1/s - 1 (tension
  // for s < 1, compression for s > 1): E = s^2 A h Y e^2 / (1 - nu), no force on interior points.
  const MeshData mesh = test::grid(5, 4.0, 0.2, 1);
  const Model plain = makeModel(mesh, someParameters());
  for (double s : {0.8, 1.25}) {
    SCOPED_TRACE(scaleName(s));
    const TriangularFEMParameters p = someParameters(s);
    Model m = makeModel(mesh, p);
    EXPECT_EQ(m.ff->parameters().restScale, s);
    for (TriangleId t : m.topo->triangles()) {
      const FemRecord r = m.ff->element(t), r1 = plain.ff->element(t);
      EXPECT_NEAR(r.area, s * s * r1.area, 1e-14 * r1.area);
      for (int k = 0; k < 4; ++k) EXPECT_NEAR(r.g[k], r1.g[k] / s, 1e-14 * std::fabs(r1.g[k] / s));
    }
    const std::vector<double> restShape = scaled(m.rest, s);
    EXPECT_LE(test::maxAbs(test::forceAt(*m.ff, restShape)), 1e-12);
    EXPECT_LE(m.ff->potentialEnergy(restShape), 1e-24);
    EXPECT_LE(test::maxAbs(test::forceAt(*m.ff, test::rigidMotion(restShape, 3))), 1e-11);
    const double e = 1.0 / s - 1.0;
    const double expected =
        s * s * 16.0 * p.thickness * p.youngModulus * e * e / (1.0 - p.poissonRatio);
    EXPECT_NEAR(m.ff->potentialEnergy(m.rest), expected, 1e-12 * expected);
    const std::vector<double> f = test::forceAt(*m.ff, m.rest);
    for (PointId q : m.topo->points()) {
      if (m.topo->isBoundaryPoint(q)) continue;
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(f[3 * q.idx() + k], 0.0, 1e-11 * p.youngModulus);
    }
  }
}

TEST(TriangularFem, RestAndRigidMotionsAreForceFree) {
  for (const auto& [name, mesh] : test::smallMeshes()) {
    SCOPED_TRACE(name);
    Model m = makeModel(mesh, someParameters());
    EXPECT_LE(test::maxAbs(test::forceAt(*m.ff, m.rest)), 1e-12);
    EXPECT_LE(m.ff->potentialEnergy(m.rest), 1e-24);
    for (std::uint64_t seed : {11u, 12u, 13u}) {
      const std::vector<double> x = test::rigidMotion(m.rest, seed);
      EXPECT_LE(test::maxAbs(test::forceAt(*m.ff, x)), 1e-11);
      EXPECT_LE(m.ff->potentialEnergy(x), 1e-22);
      // Deformed: zero net force and torque; the forces turn with the body.
      const std::vector<double> y = test::perturbed(m.rest, 0.2, seed);
      const std::vector<double> f = test::forceAt(*m.ff, y);
      test::expectZeroNetForceAndTorque(y, f);
      const std::vector<double> ry = test::rigidMotion(y, seed + 50);
      const std::vector<double> rf = test::forceAt(*m.ff, ry);
      test::expectZeroNetForceAndTorque(ry, rf);
      EXPECT_LE(test::relativeError(rf, test::transformed(f, test::randomRotation(seed + 50),
                                                          Eigen::Vector3d::Zero())),
                1e-11);
      EXPECT_NEAR(m.ff->potentialEnergy(ry), m.ff->potentialEnergy(y),
                  1e-11 * m.ff->potentialEnergy(y));
    }
  }
}

TEST(TriangularFem, ForceIsMinusEnergyGradient) {
  for (double s : kRestScales) {
    for (const auto& [name, mesh] : test::smallMeshes()) {
      SCOPED_TRACE(name + scaleName(s));
      Model m = makeModel(mesh, someParameters(s));
      for (std::uint64_t seed : {1u, 2u, 3u}) {
        const std::vector<double> x = test::perturbed(m.rest, 0.2, seed);
        EXPECT_GT(m.ff->potentialEnergy(x), 0.0);
        EXPECT_LE(test::forceVsEnergyError(*m.ff, x, 1e-5), 1e-7);
      }
    }
  }
}

TEST(TriangularFem, StiffnessIsExactForRigidMotionsOfTheRestShape) {
  // The elements' rest shape: the mesh scaled by restScale.
  for (double s : kRestScales) {
    for (const auto& [name, mesh] : test::smallMeshes()) {
      SCOPED_TRACE(name + scaleName(s));
      Model m = makeModel(mesh, someParameters(s));
      for (std::uint64_t seed : {21u, 22u}) {
        const std::vector<double> x = test::rigidMotion(scaled(m.rest, s), seed);
        const std::vector<double> dx = test::randomVector(x.size(), 1.0, seed + 100);
        EXPECT_LE(test::dForceVsForceError(*m.ff, x, dx, 1e-5), 1e-7);
        EXPECT_LE(test::matrixVsForceError(*m.ff, x, m.n(), 1e-5), 1e-7);
      }
    }
  }
}

TEST(TriangularFem, StiffnessErrorIsOfTheOrderOfTheStrain) {
  // K holds the rotation constant: away from rest its error shrinks with the strain.
  Model m = makeModel(test::bumpyGrid(4, 2), someParameters());
  const std::vector<double> dir = test::randomVector(m.rest.size(), 1.0, 9);
  double previous = 0.0;
  for (double amplitude : {1e-1, 1e-2, 1e-3}) {
    std::vector<double> x = m.rest;
    for (std::size_t i = 0; i < x.size(); ++i) x[i] += amplitude * dir[i];
    const double err = test::matrixVsForceError(*m.ff, x, m.n(), 1e-6);
    EXPECT_LE(err, 5.0 * amplitude) << "amplitude " << amplitude;
    if (previous > 0.0) {
      EXPECT_LT(err, 0.3 * previous) << "amplitude " << amplitude;
    }
    previous = err;
  }
}

/// The exact K against finite differences of the force at stretched, sheared and compressed
/// sheets (a linear map of the mesh, moved rigidly, plus noise) and random large displacements,
/// on every small mesh; with a prestrain (restScale < 1) the maps act on a material whose rest
/// shape is smaller than the mesh. Returns the worst finite-difference and dForce/matrix errors.
std::pair<double, double> checkExactHessian(double restScale) {
  TriangularFEMParameters p = someParameters(restScale);
  p.exactHessian = true;
  TriangularFEMParameters corotational = someParameters(restScale);
  corotational.tangent = TriangularFEMParameters::Tangent::Corotational;
  Eigen::Matrix3d stretchShear, compress;
  stretchShear << 1.4, 0.35, 0.0, -0.1, 1.2, 0.2, 0.1, 0.0, 1.0;
  compress << 0.7, 0.2, 0.0, 0.0, 0.8, 0.0, 0.0, 0.1, 0.9;
  double worstFd = 0.0, worstPair = 0.0;
  for (const auto& [name, mesh] : test::smallMeshes()) {
    Model m = makeModel(mesh, p), mc = makeModel(mesh, corotational);
    EXPECT_TRUE(m.ff->stiffnessIsExact());
    EXPECT_FALSE(mc.ff->stiffnessIsExact());
    std::uint64_t seed = 50;
    const std::vector<const Eigen::Matrix3d*> maps = {&stretchShear, &compress, nullptr};
    for (const Eigen::Matrix3d* a : maps) {
      ++seed;
      SCOPED_TRACE(name + scaleName(restScale) +
                   (a == &stretchShear ? " stretched"
                    : a == &compress   ? " compressed"
                                       : " random"));
      const std::vector<double> x =
          a ? test::rigidMotion(
                  test::perturbed(test::transformed(m.rest, *a, {0.0, 0.0, 0.0}), 0.03, seed), seed)
            : test::perturbed(m.rest, 0.3, seed);
      const std::vector<double> dx = test::randomVector(x.size(), 1.0, seed + 100);
      const test::StiffnessCheck c = test::expectExactStiffness(*m.ff, x, dx, m.n(), 1e-6, 1e-8);
      worstFd = std::max({worstFd, c.dForceVsForce, c.matrixVsForce});
      worstPair = std::max(worstPair, c.dForceVsMatrix);
      // The corotational K is not d(force)/dx there.
      EXPECT_GT(test::matrixVsForceError(*mc.ff, x, mc.n(), 1e-6), 1e-3);
      EXPECT_GT(test::dForceVsForceError(*mc.ff, x, dx, 1e-6), 1e-3);
    }
  }
  return {worstFd, worstPair};
}

TEST(TriangularFem, ExactHessianMatchesFiniteDifferencesOfTheForce) {
  double worstFd = 0.0, worstPair = 0.0;
  for (double s : kRestScales) {
    const auto [fd, pair] = checkExactHessian(s);
    worstFd = std::max(worstFd, fd);
    worstPair = std::max(worstPair, pair);
  }
  test::recordError("worst_fd_relative_error", worstFd);
  test::recordError("worst_dforce_vs_matrix", worstPair);
}

TEST(TriangularFem, SetExactStiffnessSwitchesTheStiffness) {
  Model m = makeModel(test::bumpyGrid(4, 2), someParameters());
  const std::vector<double> x = test::perturbed(m.rest, 0.3, 5);
  const std::vector<double> dx = test::randomVector(x.size(), 1.0, 6);
  const Eigen::MatrixXd k0 = test::assembledK(*m.ff, x, m.n());
  std::vector<double> df0(x.size(), 0.0);
  m.ff->addDForce(x, dx, df0, 0.7, 0.0);
  EXPECT_FALSE(m.ff->stiffnessIsExact());
  EXPECT_TRUE(m.ff->setExactStiffness(true));
  EXPECT_TRUE(m.ff->stiffnessIsExact());
  EXPECT_TRUE(m.ff->parameters().exactHessian);
  EXPECT_LE(test::matrixVsForceError(*m.ff, x, m.n(), 1e-6), 1e-6);
  // Exact at rest and for rigid motions too, where it equals the corotational K.
  const std::vector<double> r = test::rigidMotion(m.rest, 7);
  EXPECT_LE(test::matrixVsForceError(*m.ff, r, m.n(), 1e-6), 1e-6);
  const Eigen::MatrixXd kr = test::assembledK(*m.ff, r, m.n());
  EXPECT_TRUE(m.ff->setExactStiffness(false));
  EXPECT_FALSE(m.ff->stiffnessIsExact());
  EXPECT_LE(test::maxAbsCoeff(kr - test::assembledK(*m.ff, r, m.n())),
            1e-10 * test::maxAbsCoeff(kr));
  EXPECT_EQ(test::maxAbsCoeff(test::assembledK(*m.ff, x, m.n()) - k0), 0.0);
  std::vector<double> df(x.size(), 0.0);
  m.ff->addDForce(x, dx, df, 0.7, 0.0);
  EXPECT_EQ(df, df0);
}

TEST(TriangularFem, AssembledMatrixEqualsMatrixFreeProduct) {
  for (double s : kRestScales) {
    for (int kind : {0, 1, 2}) {
      const bool exact = kind == 2;
      for (const auto& [name, mesh] : test::smallMeshes()) {
        SCOPED_TRACE(name + scaleName(s) +
                     (kind == 0   ? " projected"
                      : kind == 1 ? " corotational"
                                  : " exact"));
        TriangularFEMParameters p = someParameters(s);
        p.exactHessian = exact;
        if (kind == 1) p.tangent = TriangularFEMParameters::Tangent::Corotational;
        Model m = makeModel(mesh, p);
        const std::vector<double> x = test::perturbed(m.rest, 0.2, 7);
        const std::vector<double> dx = test::randomVector(x.size(), 1.0, 8);
        for (double kf : {1.0, -0.4}) {
          TripletAccumulator acc;
          m.ff->addKToMatrix(x, acc, kf);
          const Eigen::MatrixXd k(acc.toSparse(static_cast<Index>(m.n())));
          std::vector<double> df(x.size(), 0.0);
          m.ff->addDForce(x, dx, df, kf, 3.0);  // bFactor ignored: no damping
          EXPECT_LE(test::relativeError(df, test::times(k, dx)), kind == 1 ? 1e-13 : 1e-12);
          EXPECT_EQ(acc.triplets().size(), 81 * m.ff->numElements());
        }
      }
    }
  }
}

TEST(TriangularFem, StiffnessSymmetricNegativeSemiDefinite) {
  for (const auto& [name, mesh] : test::smallMeshes()) {
    SCOPED_TRACE(name);
    Model m = makeModel(mesh, someParameters());
    for (std::uint64_t seed : {1u, 2u}) {
      const std::vector<double> x = test::perturbed(m.rest, 0.3, seed);
      const Eigen::MatrixXd k = test::assembledK(*m.ff, x, m.n());
      const double scale = test::maxAbsCoeff(k);
      EXPECT_LE(test::maxAsymmetry(k), 1e-13 * scale);
      const std::vector<double> ev = test::symmetricEigenvalues(k);
      EXPECT_NEAR(ev.back(), 0.0, 1e-10 * scale);  // rigid modes
      EXPECT_LT(ev.front(), -1e-3 * scale);
    }
  }
}

// ---- the projected stiffness (the default): the exact Hessian made negative semi-definite ----

/// One element's stiffness against its brute-force twin: the exact K of the same element (9 x 9)
/// pulled back to the 6 coordinates of dF (K = -A D^T H D, dF = sum_l dx_l g_l^T, D of rank 6),
/// H's negative eigenvalues set to zero by a numeric eigendecomposition, pushed forward again.
/// Returns the relative difference with the closed-form projected K, and H's smallest eigenvalue
/// relative to its largest (negative: the projection had something to remove).
std::pair<double, double> projectedVsNumericTwin(const MeshData& mesh, double restScale,
                                                 const std::vector<double>& x) {
  TriangularFEMParameters p = someParameters(restScale), pe = someParameters(restScale);
  pe.exactHessian = true;
  Model m = makeModel(mesh, p), me = makeModel(mesh, pe);
  const FemTriangle& e = m.ff->elements()[0];
  const Eigen::Vector2d gb(e.g[0], e.g[1]), gc(e.g[2], e.g[3]);
  const std::array<Eigen::Vector2d, 3> g = {-gb - gc, gb, gc};
  Eigen::Matrix<double, 6, 9> d = Eigen::Matrix<double, 6, 9>::Zero();
  for (int l = 0; l < 3; ++l) {
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 2; ++j) d(i + 3 * j, 3 * static_cast<int>(e.v[l]) + i) = g[l][j];
    }
  }
  const Eigen::Matrix<double, 9, 6> dPlus = d.transpose() * (d * d.transpose()).inverse();
  const Eigen::MatrixXd kExact = test::assembledK(*me.ff, x, m.n());
  const Eigen::Matrix<double, 6, 6> aH = -(dPlus.transpose() * kExact * dPlus);  // A H
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(0.5 * (aH + aH.transpose()));
  const Eigen::Matrix<double, 6, 1> clamped = eig.eigenvalues().cwiseMax(0.0);
  const Eigen::Matrix<double, 6, 6> aHPlus =
      eig.eigenvectors() * clamped.asDiagonal() * eig.eigenvectors().transpose();
  const Eigen::MatrixXd twin = -(d.transpose() * aHPlus * d);
  const Eigen::MatrixXd k = test::assembledK(*m.ff, x, m.n());
  const double scale = test::maxAbsCoeff(twin);
  return {test::maxAbsCoeff(k - twin) / scale,
          eig.eigenvalues()(0) / eig.eigenvalues().cwiseAbs().maxCoeff()};
}

TEST(TriangularFem, ProjectedStiffnessIsTheExactHessianProjectedInClosedForm) {
  MeshData one;
  one.points = {{0.0, 0.0, 0.0}, {1.1, 0.1, 0.0}, {0.3, 0.9, 0.05}};
  one.triangles = {tri(0, 1, 2)};
  Eigen::Matrix3d stretch, compress, mixed;
  stretch << 1.3, 0.2, 0.0, -0.1, 1.2, 0.1, 0.2, 0.0, 1.0;
  compress << 0.7, 0.1, 0.0, 0.0, 0.8, 0.0, 0.0, 0.1, 0.9;
  mixed << 1.4, 0.0, 0.0, 0.0, 0.75, 0.0, 0.0, 0.3, 1.0;
  double worst = 0.0;
  int clamped = 0;
  for (double s : kRestScales) {
    Model m = makeModel(one, someParameters(s));
    std::uint64_t seed = 300;
    for (const Eigen::Matrix3d* a : {&stretch, &compress, &mixed}) {
      for (int trial = 0; trial < 4; ++trial) {
        ++seed;
        SCOPED_TRACE(scaleName(s) + " seed " + std::to_string(seed));
        const std::vector<double> x = test::rigidMotion(
            test::perturbed(test::transformed(m.rest, *a, {0.0, 0.0, 0.0}), 0.1, seed), seed);
        const auto [err, smallest] = projectedVsNumericTwin(one, s, x);
        EXPECT_LE(err, 1e-10);
        worst = std::max(worst, err);
        clamped += smallest < -1e-6 ? 1 : 0;
      }
    }
  }
  // The states include compressed ones, where the exact Hessian is indefinite: the projection
  // had modes to remove (else the twin would only check the corotational part).
  EXPECT_GE(clamped, 8);
  test::recordError("worst_projected_vs_numeric_twin", worst);
}

TEST(TriangularFem, ProjectedStiffnessIsExactInTensionAndCorotationalInCompression) {
  // A sheet stretched in every direction (bumped out of its plane, moved rigidly) is in tension
  // everywhere: the projected K is the exact one. Compressed in every direction, nothing of the
  // tension's stiffness is left: it is the corotational K.
  TriangularFEMParameters corotational = someParameters(0.9);
  corotational.tangent = TriangularFEMParameters::Tangent::Corotational;
  for (const auto& [name, mesh] : test::smallMeshes()) {
    SCOPED_TRACE(name);
    Model m = makeModel(mesh, someParameters(0.9)), mc = makeModel(mesh, corotational);
    // restScale 0.9: the mesh itself is stretched by 11%; 1.05 more, with a small bump.
    std::vector<double> x =
        test::transformed(m.rest, 1.05 * Eigen::Matrix3d::Identity(), {0.0, 0.0, 0.0});
    for (std::size_t i = 0; i + 2 < x.size(); i += 3) x[i + 2] += 0.01 * std::sin(3.0 * x[i]);
    x = test::rigidMotion(x, 17);
    const std::vector<double> dx = test::randomVector(x.size(), 1.0, 18);
    EXPECT_LE(test::dForceVsForceError(*m.ff, x, dx, 1e-6), 1e-6);
    EXPECT_LE(test::matrixVsForceError(*m.ff, x, m.n(), 1e-6), 1e-6);
    EXPECT_GT(test::matrixVsForceError(*mc.ff, x, mc.n(), 1e-6), 1e-3);  // it was not before
    const std::vector<double> y = test::rigidMotion(
        test::transformed(m.rest, 0.8 * Eigen::Matrix3d::Identity(), {0.0, 0.0, 0.0}), 19);
    const Eigen::MatrixXd kc = test::assembledK(*mc.ff, y, mc.n());
    EXPECT_LE(test::maxAbsCoeff(test::assembledK(*m.ff, y, m.n()) - kc),
              1e-13 * test::maxAbsCoeff(kc));
  }
}

TEST(TriangularFem, ProjectedStiffnessIsNegativeSemiDefiniteWhereTheExactOneIsNot) {
  int indefinite = 0;
  for (double s : kRestScales) {
    TriangularFEMParameters pe = someParameters(s);
    pe.exactHessian = true;
    for (const auto& [name, mesh] : test::smallMeshes()) {
      SCOPED_TRACE(name + scaleName(s));
      Model m = makeModel(mesh, someParameters(s)), me = makeModel(mesh, pe);
      for (std::uint64_t seed : {1u, 2u, 3u}) {
        const std::vector<double> x = test::perturbed(m.rest, 0.3, seed);
        const Eigen::MatrixXd k = test::assembledK(*m.ff, x, m.n());
        const double scale = test::maxAbsCoeff(k);
        EXPECT_LE(test::maxAsymmetry(k), 1e-13 * scale);
        EXPECT_LE(test::symmetricEigenvalues(k).back(), 1e-10 * scale);
        const Eigen::MatrixXd ke = test::assembledK(*me.ff, x, me.n());
        indefinite += test::symmetricEigenvalues(ke).back() > 1e-6 * scale ? 1 : 0;
      }
    }
  }
  EXPECT_GE(indefinite, 3) << "the states should include some where the exact K is indefinite";
}

TEST(TriangularFem, TangentIsReadFromScenesAndChecked) {
  const auto& entry = *ForceFieldRegistry::instance().find("TriangularFEM");
  ScalarParameters none("TriangularFEM");
  EXPECT_EQ(std::any_cast<TriangularFEMParameters>(entry.readValues(none)).tangent,
            TriangularFEMParameters::Tangent::Projected);
  ScalarParameters corot("TriangularFEM", {{"tangent", std::string("corotational")}});
  EXPECT_EQ(std::any_cast<TriangularFEMParameters>(entry.readValues(corot)).tangent,
            TriangularFEMParameters::Tangent::Corotational);
  ScalarParameters bad("TriangularFEM", {{"tangent", std::string("exact")}});
  try {
    entry.readValues(bad);
    ADD_FAILURE() << "tangent \"exact\" accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("tangent"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("corotational"), std::string::npos) << e.what();
  }
}

TEST(TriangularFem, CollapsedTrianglesStayFinite) {
  Model m = makeModel(test::grid(4, 3.0), someParameters());
  const std::vector<double> dx = test::randomVector(m.rest.size(), 1.0, 3);
  // Flattened onto a line (zero area everywhere), then onto one point; both stiffnesses.
  std::vector<double> line = m.rest, point(m.rest.size(), 0.5);
  for (std::size_t i = 0; i < line.size(); i += 3) line[i + 1] = 0.0;
  const std::pair<bool, const std::vector<double>*> cases[] = {
      {false, &line}, {false, &point}, {true, &line}, {true, &point}};
  for (const auto& [exact, x] : cases) {
    m.ff->setExactStiffness(exact);
    const std::vector<double> f = test::forceAt(*m.ff, *x);
    std::vector<double> df(x->size(), 0.0);
    m.ff->addDForce(*x, dx, df, 1.0, 0.0);
    TripletAccumulator acc;
    m.ff->addKToMatrix(*x, acc, 1.0);
    for (double v : f) EXPECT_EQ(v, 0.0);
    for (double v : df) EXPECT_EQ(v, 0.0);
    for (const auto& t : acc.triplets()) EXPECT_EQ(t.value(), 0.0);
    EXPECT_EQ(acc.triplets().size(), 81 * m.ff->numElements());
    const double e = m.ff->potentialEnergy(*x);
    EXPECT_TRUE(std::isfinite(e));
    EXPECT_GT(e, 0.0);
  }
  // Fully collapsed: S = 0, eps = -I, so E = A h (2 mu + 2 lambda) summed = 9 h (2 mu + 2 lambda).
  const TriangularFEMParameters p = someParameters();
  const double mu = p.youngModulus / (2.0 * (1.0 + p.poissonRatio));
  const double lambda = p.youngModulus * p.poissonRatio / (1.0 - p.poissonRatio * p.poissonRatio);
  const double expected = 9.0 * p.thickness * (2.0 * mu + 2.0 * lambda);
  EXPECT_NEAR(m.ff->potentialEnergy(point), expected, 1e-12 * expected);
}

TEST(TriangularFem, DegenerateRestTriangleHasNoElement) {
  // A (0,0), B (2,0), C (1,0) on a line, D (1,1): triangle (A, B, D) and the flat (B, A, C).
  MeshData mesh;
  mesh.points = {{0, 0, 0}, {2, 0, 0}, {1, 0, 0}, {1, 1, 0}};
  mesh.triangles = {tri(0, 1, 3), tri(1, 0, 2)};
  Model m = makeModel(mesh, someParameters());
  EXPECT_EQ(m.ff->numElements(), 1u);
  EXPECT_EQ(m.ff->numDegenerate(), 1u);
  const FemRecord r = m.ff->element(TriangleId(1));
  EXPECT_EQ(r.triangle.idx(), 1u);
  EXPECT_TRUE(r.degenerate);
  EXPECT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
  const std::vector<double> x = test::perturbed(m.rest, 0.2, 4);
  for (double v : test::forceAt(*m.ff, x)) EXPECT_TRUE(std::isfinite(v));
  // Removing it leaves the table consistent.
  m.topo->removeTriangles(std::vector<TriangleId>{TriangleId(1)});
  EXPECT_EQ(m.ff->numDegenerate(), 0u);
  EXPECT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
}

TEST(TriangularFem, FollowsSplitTearCarveAndCompact) {
  Model m = makeModel(test::grid(6, 5.0, 0.2, 4), someParameters());
  m.topo->splitEdge(m.topo->findEdge(topology::PointId(7), topology::PointId(14)), 0.3);
  ASSERT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
  m.topo->tear(m.topo->findEdge(topology::PointId(8), topology::PointId(15)));
  ASSERT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
  m.topo->removeTriangles(std::vector<TriangleId>{TriangleId(0), TriangleId(5)});
  ASSERT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
  EXPECT_EQ(m.ff->numElements(), m.topo->numTriangles());
  // Rest area is conserved by splits and tears; carving removes the triangles' areas.
  m.topo->compact();
  ASSERT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
  EXPECT_EQ(m.ff->numTriangleSlots(), m.topo->triangleCapacity());
  const std::vector<double> rest = test::restOf(*m.topo);
  EXPECT_LE(test::maxAbs(test::forceAt(*m.ff, rest)), 1e-10);
  EXPECT_LE(m.ff->potentialEnergy(rest), 1e-20);
}

// ---------------------------------------------------------------------------------------------
// The incremental table against a rebuild, after every operation of random sequences

class TriangularFemIncremental : public ::testing::TestWithParam<SequenceCase> {};

TEST_P(TriangularFemIncremental, TableEqualsRebuildAfterEveryOperation) {
  const SequenceCase c = GetParam();
  const MeshData mesh = test::sequenceSheet(c);
  Topology topo(mesh.points, mesh.triangles);
  TriangularFEMParameters p;
  p.youngModulus = 300.0;
  p.poissonRatio = 0.25;
  p.thickness = 0.2;
  TriangularFEM ff(topo, p);
  // A prestrained twin: the elements created by the operations get the scaled rest shape too
  // (its validate() compares it with a rebuild at the same restScale after every operation).
  TriangularFEMParameters ps = p;
  ps.restScale = 0.85;
  TriangularFEM prestrained(topo, ps);
  StretchSprings springs(topo, {});  // all follow the same transactions
  ASSERT_TRUE(topo.validate().ok()) << topo.validate().summary();
  const auto oneElementPerTriangle = [&](const test::RandomOp&) {
    ASSERT_EQ(ff.numElements() + ff.numDegenerate(), topo.numTriangles());
    ASSERT_EQ(prestrained.numElements(), ff.numElements());
    ASSERT_EQ(prestrained.numDegenerate(), ff.numDegenerate());
  };
  ASSERT_NO_FATAL_FAILURE(test::runRandomOps(topo, c.seed + 1000, c.steps, oneElementPerTriangle));
  TriangularFEM fresh(topo, p);
  test::expectSameAsFresh(ff, fresh, topo, 0.3, c.seed + 7, 1e-10);
  TriangularFEM freshPrestrained(topo, ps);
  test::expectSameAsFresh(prestrained, freshPrestrained, topo, 0.3, c.seed + 8, 1e-10,
                          ps.restScale);
}

INSTANTIATE_TEST_SUITE_P(TriangularFemSequences, TriangularFemIncremental,
                         ::testing::Values(SequenceCase{1, 8, 150}, SequenceCase{2, 10, 200},
                                           SequenceCase{3, 9, 200}));

}  // namespace
}  // namespace cutsim::forcefields
