// DihedralBending: finite differences, the Gauss-Newton stiffness, agreement with the linear
// springs for small folds, exact large folds, rigid motions, curved rest shapes, degenerate
// hinges, parameters, and the incremental table against a rebuild after every operation of random
// topology sequences.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>

#include "cutsim/core/simulation.hpp"
#include "cutsim/forcefields/dihedral_bending.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/forcefields/stretch_springs.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/field_helpers.hpp"
#include "support/fixtures.hpp"
#include "support/force_field_harness.hpp"
#include "support/random_ops.hpp"

namespace cutsim::forcefields {
namespace {

using test::SequenceCase;
using topology::MeshData;
using topology::Topology;
using topology::Vec3;

constexpr double kPi = std::numbers::pi;

using Model = test::FieldModel<DihedralBending>;

Model makeModel(const MeshData& mesh, const DihedralBendingParameters& p = {}) {
  return test::makeFieldModel<DihedralBending>(mesh, p);
}

/// A grid on [0, size]^2 wrapped onto a cylinder of radius r about an axis parallel to y.
MeshData cylinderPatch(int n, double size, double r) {
  MeshData mesh = test::grid(n, size);
  for (Vec3& p : mesh.points) {
    const double u = p[0];
    p = {r * std::sin(u / r), p[1], r * (1.0 - std::cos(u / r))};
  }
  return mesh;
}

/// The flat positions of `mesh` rolled onto the cylinder of radius r (axis parallel to y).
std::vector<double> rolled(const MeshData& mesh, double r) {
  std::vector<double> x;
  for (const Vec3& p : mesh.points) {
    x.push_back(r * std::sin(p[0] / r));
    x.push_back(p[1]);
    x.push_back(r * (1.0 - std::cos(p[0] / r)));
  }
  return x;
}

std::vector<std::pair<std::string, MeshData>> corpus() {
  return {{"bumpy5", test::bumpyGrid(5, 3)},
          {"cylinder", cylinderPatch(5, 3.0, 2.0)},
          {"fan_closed", test::fan(7, true, 0.3)},
          {"fan_open", test::fan(5, false, 0.2)}};
}

/// x -> scale R x + t.
std::vector<double> similarity(const std::vector<double>& x, std::uint64_t seed, double scale) {
  const Eigen::Matrix3d r = test::randomRotation(seed);
  const Eigen::Vector3d t(1.5, -2.0, 0.7);
  std::vector<double> y(x.size());
  for (std::size_t i = 0; i < x.size(); i += 3) {
    const Eigen::Vector3d p = scale * (r * Eigen::Vector3d(x[i], x[i + 1], x[i + 2])) + t;
    for (int k = 0; k < 3; ++k) y[i + k] = p[k];
  }
  return y;
}

/// The flat hinge H of the spec, with wing B rotated about CD by theta.
MeshData foldedHinge(double theta) {
  return test::oneHinge({0.3, -1.0, 0.0}, {0.6, 2.0 * std::cos(theta), 2.0 * std::sin(theta)},
                        {0.0, 0.0, 0.0}, {1.0, 0.0, 0.0});
}

// ---------------------------------------------------------------------------------------------
// Parameters and set-up

TEST(DihedralBending, BadParametersAreRejectedNamingTheParameter) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double bad : {-1.0, nan, inf, -inf}) {
    for (const char* name : {"bendingStiffness", "minDist", "rayleighStiffness"}) {
      SCOPED_TRACE(std::string(name) + " = " + std::to_string(bad));
      DihedralBendingParameters p;
      if (std::string(name) == "bendingStiffness") p.bendingStiffness = bad;
      if (std::string(name) == "minDist") p.minDist = bad;
      if (std::string(name) == "rayleighStiffness") p.rayleighStiffness = bad;
      try {
        p.validate();
        ADD_FAILURE() << "accepted";
      } catch (const InvalidInput& e) {
        EXPECT_EQ(e.where(), name);
      }
      const MeshData mesh = test::grid(3);
      Topology topo(mesh.points, mesh.triangles);
      EXPECT_THROW(DihedralBending(topo, p), InvalidInput);
      EXPECT_EQ(topo.numObservers(), 0u);
    }
  }
  EXPECT_NO_THROW(DihedralBendingParameters{}.validate());
}

TEST(DihedralBending, OneHingePerInteriorEdgeWithTheSpringsCalibration) {
  // The flat hinge H of bending-springs.md: l = 1, hA = 1, hB = 2, so c = k / 9.
  DihedralBendingParameters p;
  p.bendingStiffness = 2.5;
  Model m = makeModel(foldedHinge(0.0), p);
  ASSERT_EQ(m.ff->numActiveHinges(), 1u);
  EXPECT_EQ(m.ff->counters().active, 1u);
  EXPECT_EQ(m.ff->counters().noHinge, 4u);
  const DihedralHinge h = m.ff->activeHinges()[0];
  EXPECT_NEAR(h.coefficient, 2.5 / 9.0, 1e-15);
  EXPECT_EQ(h.restAngle, 0.0);
  std::vector<std::array<PointId, 2>> seg;
  m.ff->draw(seg);
  ASSERT_EQ(seg.size(), 1u);
  EXPECT_EQ(std::minmax(seg[0][0], seg[0][1]), std::minmax(PointId{0}, PointId{1}));
  EXPECT_EQ(m.ff->typeName(), "DihedralBending");
  // Grid N=5 of the spec: 40 interior edges.
  Model g = makeModel(test::grid(5));
  EXPECT_EQ(g.ff->numActiveHinges(), 40u);
  EXPECT_TRUE(g.topo->validate().ok()) << g.topo->validate().summary();
}

TEST(DihedralBending, SignedAngleIsRobustUpToPi) {
  for (double theta : {-3.1, -2.0, -0.5, -1e-3, 0.0, 1e-3, 0.5, 2.0, 3.1}) {
    const MeshData h = foldedHinge(theta);
    const double got = dihedralAngle(h.points[0], h.points[1], h.points[2], h.points[3]);
    // Folding B about CD changes the angle by -theta or +theta depending on the convention; the
    // magnitude and the consistency of the sign are what matter.
    EXPECT_NEAR(std::fabs(got), std::fabs(theta), 1e-12) << theta;
    const MeshData h2 = foldedHinge(0.5);
    const double ref = dihedralAngle(h2.points[0], h2.points[1], h2.points[2], h2.points[3]);
    if (theta != 0.0) {
      EXPECT_EQ(got > 0.0, (theta > 0.0) == (ref > 0.0)) << theta;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Forces and stiffness

TEST(DihedralBending, ForceIsMinusEnergyGradient) {
  for (const auto& [name, mesh] : corpus()) {
    SCOPED_TRACE(name);
    DihedralBendingParameters p;
    p.bendingStiffness = 3.7;
    Model m = makeModel(mesh, p);
    for (std::uint64_t seed : {1u, 2u, 3u}) {
      const std::vector<double> x = test::perturbed(m.rest, 0.2, seed);
      EXPECT_GT(m.ff->potentialEnergy(x), 0.0);
      EXPECT_EQ(m.ff->numDegenerateAt(x), 0u);
      EXPECT_LE(test::forceVsEnergyError(*m.ff, x, 1e-6), 1e-6);
    }
  }
}

TEST(DihedralBending, GaussNewtonStiffnessIsSymmetricNegativeSemiDefinite) {
  for (const auto& [name, mesh] : corpus()) {
    SCOPED_TRACE(name);
    Model m = makeModel(mesh);
    for (std::uint64_t seed : {1u, 2u}) {
      const std::vector<double> x = test::perturbed(m.rest, 0.3, seed);
      const Eigen::MatrixXd k = test::assembledK(*m.ff, x, m.n());
      const double scale = test::maxAbsCoeff(k);
      ASSERT_GT(scale, 0.0);
      EXPECT_LE(test::maxAsymmetry(k), 1e-14 * scale);
      EXPECT_LE(test::symmetricEigenvalues(k).back(), 1e-10 * scale);
      // Matrix-free products equal the assembled matrix, with Rayleigh damping folded in.
      DihedralBendingParameters pr;
      pr.rayleighStiffness = 0.3;
      Model mr = makeModel(mesh, pr);
      const std::vector<double> dx = test::perturbed(std::vector<double>(x.size(), 0.0), 1.0, 9);
      for (const auto& [kf, bf] : {std::pair{1.0, 0.0}, {0.0, 1.0}, {-0.4, 2.0}}) {
        TripletAccumulator acc;
        mr.ff->addKToMatrix(x, acc, kf);
        mr.ff->addBToMatrix(x, acc, bf);
        const Eigen::MatrixXd a(acc.toSparse(static_cast<Index>(mr.n())));
        std::vector<double> df(x.size(), 0.0);
        mr.ff->addDForce(x, dx, df, kf, bf);
        EXPECT_LE(test::relativeError(df, test::times(a, dx)), 1e-12) << kf << " " << bf;
      }
    }
  }
}

TEST(DihedralBending, StiffnessIsTheExactJacobianAtTheRestAngles) {
  // Similar images of the rest shape (rotated, moved, scaled by 1.3) have every theta = theta0:
  // the dropped second-order term vanishes, so K is d(force)/dx there.
  for (const auto& [name, mesh] : corpus()) {
    SCOPED_TRACE(name);
    Model m = makeModel(mesh);
    const std::vector<double> x = similarity(m.rest, 4, 1.3);
    EXPECT_LE(test::maxAbs(test::forceAt(*m.ff, x)), 1e-12);
    EXPECT_LE(test::matrixVsForceError(*m.ff, x, m.n(), 1e-6), 1e-7);
    const std::vector<double> dx = test::perturbed(std::vector<double>(x.size(), 0.0), 1.0, 3);
    EXPECT_LE(test::dForceVsForceError(*m.ff, x, dx, 1e-6), 1e-7);
    // Away from the rest angles it is not (the documented Gauss-Newton approximation).
    const std::vector<double> y = test::perturbed(m.rest, 0.3, 5);
    EXPECT_GT(test::matrixVsForceError(*m.ff, y, m.n(), 1e-6), 1e-4);
  }
}

// ---------------------------------------------------------------------------------------------
// The exact Hessian (exactHessian, setExactStiffness)

/// The configurations of the exact-Hessian tests, each with its model: single hinges (flat or
/// curved at rest) folded 60 to 150 degrees, and sheets bent far from their rest shapes, all
/// moved rigidly and jittered so that nothing is axis-aligned.
struct FoldedCase {
  std::string name;
  Model model;
  std::vector<double> x;
};

std::vector<FoldedCase> foldedCases(const DihedralBendingParameters& p) {
  std::vector<FoldedCase> cases;
  const auto flatten = [](const MeshData& mesh) {
    std::vector<double> x;
    for (const Vec3& q : mesh.points) x.insert(x.end(), q.begin(), q.end());
    return x;
  };
  std::uint64_t seed = 20;
  for (double restDeg : {0.0, 25.0}) {
    for (double deg : {60.0, 90.0, 120.0, 150.0}) {
      Model m = makeModel(foldedHinge(restDeg * kPi / 180.0), p);
      const std::vector<double> y = flatten(foldedHinge(-deg * kPi / 180.0));
      cases.push_back({"hinge " + std::to_string(int(restDeg)) + " -> " + std::to_string(int(deg)),
                       std::move(m), test::perturbed(similarity(y, ++seed, 1.0), 0.02, seed)});
    }
  }
  // A grid rolled onto a cylinder of radius 0.2: the hinges across the roll fold by about 70
  // degrees (and the diagonal ones by about 40).
  {
    const MeshData grid = test::grid(5, 1.0);
    Model m = makeModel(grid, p);
    const std::vector<double> y = rolled(grid, 0.2);
    cases.push_back(
        {"rolled grid", std::move(m), test::perturbed(similarity(y, 30, 1.0), 0.02, 31)});
  }
  {
    Model m = makeModel(cylinderPatch(5, 3.0, 2.0), p);
    std::vector<double> y = test::perturbed(m.rest, 0.4, 32);
    cases.push_back({"cylinder jittered", std::move(m), similarity(y, 33, 1.0)});
  }
  return cases;
}

/// The largest |theta - theta0| over the active hinges at x.
double largestFold(const DihedralBending& ff, const std::vector<double>& x) {
  double largest = 0.0;
  for (const DihedralHinge& h : ff.activeHinges()) {
    const auto at = [&](std::uint32_t v) { return Vec3{x[3 * v], x[3 * v + 1], x[3 * v + 2]}; };
    const double theta = dihedralAngle(at(h.v[0]), at(h.v[1]), at(h.v[2]), at(h.v[3]));
    double d = std::fabs(theta - h.restAngle);
    if (d > kPi) d = 2.0 * kPi - d;
    largest = std::max(largest, d);
  }
  return largest;
}

TEST(DihedralBending, ExactHessianMatchesFiniteDifferencesOfTheForce) {
  DihedralBendingParameters p;
  p.bendingStiffness = 2.3;
  p.exactHessian = true;
  double worstFd = 0.0, worstPair = 0.0;
  for (FoldedCase& c : foldedCases(p)) {
    SCOPED_TRACE(c.name);
    const DihedralBending& ff = *c.model.ff;
    EXPECT_TRUE(ff.stiffnessIsExact());
    ASSERT_EQ(ff.numDegenerateAt(c.x), 0u);
    EXPECT_GT(largestFold(ff, c.x), 0.9);  // well away from the rest angles
    const std::vector<double> dx = test::randomVector(c.x.size(), 1.0, 40);
    // h = 1e-6 on coordinates and curvatures of order 1: the differences' truncation error is
    // O(h^2) = 1e-12 and their rounding error O(1e-16 / h) = 1e-10 (measured: below 1e-9), so
    // 1e-8 relative is a safe bound that a wrong second-order term would still exceed.
    const test::StiffnessCheck check =
        test::expectExactStiffness(ff, c.x, dx, c.model.n(), 1e-6, 1e-8);
    worstFd = std::max({worstFd, check.dForceVsForce, check.matrixVsForce});
    worstPair = std::max(worstPair, check.dForceVsMatrix);
    // The exact K is indefinite there (the Gauss-Newton K is not).
    const std::vector<double> ev =
        test::symmetricEigenvalues(test::assembledK(ff, c.x, c.model.n()));
    EXPECT_GT(ev.back(), 1e-8 * std::fabs(ev.front())) << "no positive eigenvalue";
    // The default K is the Gauss-Newton one: not d(force)/dx at such a configuration.
    DihedralBendingParameters gn = p;
    gn.exactHessian = false;
    DihedralBending approximate(*c.model.topo, gn);
    EXPECT_FALSE(approximate.stiffnessIsExact());
    EXPECT_GT(test::matrixVsForceError(approximate, c.x, c.model.n(), 1e-6), 1e-3);
    EXPECT_GT(test::dForceVsForceError(approximate, c.x, dx, 1e-6), 1e-3);
  }
  test::recordError("worst_fd_relative_error", worstFd);
  test::recordError("worst_dforce_vs_matrix", worstPair);
}

TEST(DihedralBending, SetExactStiffnessSwitchesTheHessianAndKeepsTheGaussNewtonDamping) {
  const MeshData mesh = test::bumpyGrid(5, 3);
  DihedralBendingParameters p;
  p.rayleighStiffness = 0.3;
  Model m = makeModel(mesh, p);
  const std::vector<double> x = test::perturbed(m.rest, 0.4, 3);
  const std::vector<double> dx = test::randomVector(x.size(), 1.0, 4);
  const auto matrix = [&](double kf, double bf) {
    TripletAccumulator acc;
    m.ff->addKToMatrix(x, acc, kf);
    m.ff->addBToMatrix(x, acc, bf);
    return Eigen::MatrixXd(acc.toSparse(static_cast<Index>(m.n())));
  };
  const auto dForce = [&](double kf, double bf) {
    std::vector<double> df(x.size(), 0.0);
    m.ff->addDForce(x, dx, df, kf, bf);
    return df;
  };
  EXPECT_FALSE(m.ff->stiffnessIsExact());
  const Eigen::MatrixXd kGN = matrix(1.0, 0.0), bGN = matrix(0.0, 1.0);
  const std::vector<double> dfGN = dForce(-0.4, 2.0);

  EXPECT_TRUE(m.ff->setExactStiffness(true));
  EXPECT_TRUE(m.ff->stiffnessIsExact());
  EXPECT_TRUE(m.ff->parameters().exactHessian);
  const Eigen::MatrixXd kExact = matrix(1.0, 0.0);
  EXPECT_GT(test::maxAbsCoeff(kExact - kGN), 1e-3 * test::maxAbsCoeff(kGN));
  // B is rayleighStiffness times the Gauss-Newton K in both modes, bit for bit.
  EXPECT_EQ(test::maxAbsCoeff(matrix(0.0, 1.0) - bGN), 0.0);
  EXPECT_LE(test::maxAbsCoeff(bGN - 0.3 * kGN), 1e-15 * test::maxAbsCoeff(kGN));
  // Matrix-free products equal the assembled matrices, factors folded in (k = 0 with b != 0,
  // and kFactor + bFactor rayleighStiffness = 0 with kFactor != 0, included).
  for (const auto& [kf, bf] :
       {std::pair{1.0, 0.0}, {0.0, 1.0}, {-0.4, 2.0}, {0.6, -2.0}, {0.0, 0.0}}) {
    EXPECT_LE(test::relativeError(dForce(kf, bf), test::times(matrix(kf, bf), dx)), 1e-12)
        << kf << " " << bf;
  }
  // Back to the default: bit for bit what it was.
  EXPECT_TRUE(m.ff->setExactStiffness(false));
  EXPECT_FALSE(m.ff->stiffnessIsExact());
  EXPECT_EQ(test::maxAbsCoeff(matrix(1.0, 0.0) - kGN), 0.0);
  EXPECT_EQ(dForce(-0.4, 2.0), dfGN);
}

TEST(DihedralBending, ExactHessianOfDegenerateHingesIsZeroAndFinite) {
  DihedralBendingParameters p;
  p.exactHessian = true;
  Model m = makeModel(foldedHinge(0.0), p);
  for (int which = 0; which < 3; ++which) {
    std::vector<double> x = m.rest;
    if (which == 0) x[1] = 0.0;  // A = (0.3, 0, 0)
    if (which == 1) std::fill(x.begin(), x.end(), 0.25);
    if (which == 2) x[9] = 0.0;  // D = C
    EXPECT_EQ(m.ff->numDegenerateAt(x), 1u) << which;
    const Eigen::MatrixXd k = test::assembledK(*m.ff, x, m.n());
    EXPECT_EQ(test::maxAbsCoeff(k), 0.0);
    std::vector<double> df(x.size(), 0.0);
    m.ff->addDForce(x, x, df, 1.0, 0.5);
    EXPECT_EQ(test::maxAbs(df), 0.0);
  }
  // Any scale: the hinge folded by 100 degrees and scaled by 1e-45 or 1e45 has K / scale^2.
  {
    const MeshData folded = foldedHinge(-100.0 * kPi / 180.0);
    std::vector<double> y;
    for (const Vec3& q : folded.points) y.insert(y.end(), q.begin(), q.end());
    const Eigen::MatrixXd k1 = test::assembledK(*m.ff, y, m.n());
    const std::vector<double> dx = test::randomVector(y.size(), 1.0, 6);
    std::vector<double> df1(y.size(), 0.0);
    m.ff->addDForce(y, dx, df1, 1.0, 0.0);
    for (double scale : {1e-45, 1e45}) {
      std::vector<double> ys = y;
      for (double& v : ys) v *= scale;
      const Eigen::MatrixXd ks = test::assembledK(*m.ff, ys, m.n()) * (scale * scale);
      EXPECT_LE(test::maxAbsCoeff(ks - k1), 1e-12 * test::maxAbsCoeff(k1)) << scale;
      std::vector<double> df(y.size(), 0.0);
      m.ff->addDForce(ys, dx, df, scale * scale, 0.0);
      EXPECT_LE(test::relativeError(df, df1), 1e-12) << scale;
    }
  }
  // Nearly degenerate (a wing 1e-9 off the edge line, folded): large but finite.
  std::vector<double> x = m.rest;
  x[1] = 1e-9;
  x[2] = 1e-9;
  const Eigen::MatrixXd k = test::assembledK(*m.ff, x, m.n());
  EXPECT_TRUE(k.allFinite());
  std::vector<double> df(x.size(), 0.0);
  m.ff->addDForce(x, test::randomVector(x.size(), 1.0, 5), df, 1.0, 0.0);
  for (double v : df) EXPECT_TRUE(std::isfinite(v));
}

TEST(DihedralBending, RigidMotionsAndSimilaritiesAreForceFree) {
  for (const auto& [name, mesh] : corpus()) {
    SCOPED_TRACE(name);
    Model m = makeModel(mesh);
    const std::vector<double> x0 = test::perturbed(m.rest, 0.2, 7);
    const double e0 = m.ff->potentialEnergy(x0);
    const std::vector<double> f0 = test::forceAt(*m.ff, x0);
    for (std::uint64_t seed : {11u, 12u}) {
      EXPECT_LE(test::maxAbs(test::forceAt(*m.ff, similarity(m.rest, seed, 1.0))), 1e-12);
      EXPECT_LE(m.ff->potentialEnergy(similarity(m.rest, seed, 0.5)), 1e-24);
      // A deformed shape moved rigidly keeps its energy; the net force and torque are zero.
      const std::vector<double> y = similarity(x0, seed, 1.0);
      EXPECT_NEAR(m.ff->potentialEnergy(y), e0, 1e-12 * e0);
      const std::vector<double> f = test::forceAt(*m.ff, y);
      Eigen::Vector3d net = Eigen::Vector3d::Zero(), torque = Eigen::Vector3d::Zero();
      for (std::size_t i = 0; i < y.size(); i += 3) {
        const Eigen::Vector3d fi(f[i], f[i + 1], f[i + 2]), yi(y[i], y[i + 1], y[i + 2]);
        net += fi;
        torque += yi.cross(fi);
      }
      EXPECT_LE(net.norm(), 1e-12 * std::max(1.0, test::maxAbs(f0)));
      EXPECT_LE(torque.norm(), 1e-11 * std::max(1.0, test::maxAbs(f0)));
    }
  }
}

TEST(DihedralBending, CurvedRestShapeIsForceFreeUnlikeTheLinearSprings) {
  const MeshData mesh = cylinderPatch(7, 3.0, 1.5);
  Model m = makeModel(mesh);
  EXPECT_LE(test::maxAbs(test::forceAt(*m.ff, m.rest)), 1e-13);
  EXPECT_EQ(m.ff->potentialEnergy(m.rest), 0.0);
  Topology topo(mesh.points, mesh.triangles);
  FastTriangularBendingSprings springs(topo, {});
  EXPECT_GT(test::maxAbs(test::forceAt(springs, m.rest)), 1e-3);
}

TEST(DihedralBending, LargeFoldsHaveTheExactEnergy) {
  // Hinge H (l = 1, hA = 1, hB = 2) folded by theta: E = k l theta^2 / (3 (hA + hB)) = k theta^2/9.
  for (double theta : {-3.0, -2.0, -1.0, -0.1, 0.1, 1.0, 2.0, 3.0, 3.14}) {
    DihedralBendingParameters p;
    p.bendingStiffness = 1.7;
    Model flat = makeModel(foldedHinge(0.0), p);
    const MeshData folded = foldedHinge(theta);
    std::vector<double> y;
    for (const Vec3& q : folded.points) y.insert(y.end(), q.begin(), q.end());
    EXPECT_NEAR(flat.ff->potentialEnergy(y), 1.7 * theta * theta / 9.0,
                1e-12 * std::max(1.0, theta * theta))
        << theta;
    // The other way round: a hinge built folded, unfolded to flat, has the same energy.
    Model fm = makeModel(folded, p);
    std::vector<double> z;
    for (const Vec3& q : foldedHinge(0.0).points) z.insert(z.end(), q.begin(), q.end());
    EXPECT_NEAR(fm.ff->potentialEnergy(z), 1.7 * theta * theta / 9.0,
                1e-12 * std::max(1.0, theta * theta))
        << theta;
    EXPECT_LE(test::forceVsEnergyError(*flat.ff, y, 1e-7), 1e-6) << theta;
  }
}

TEST(DihedralBending, SmallFoldsAgreeWithTheLinearSprings) {
  // One flat hinge: the springs' energy is (4/3) k l sin^2(theta/2) / (hA + hB).
  double previous = 1.0;
  for (double theta : {0.3, 0.1, 0.03, 0.01}) {
    Model m = makeModel(foldedHinge(0.0));
    Topology topo(m.topo->toMeshData().points, m.topo->toMeshData().triangles);
    FastTriangularBendingSprings springs(topo, {});
    std::vector<double> y;
    for (const Vec3& q : foldedHinge(theta).points) y.insert(y.end(), q.begin(), q.end());
    const double ed = m.ff->potentialEnergy(y), es = springs.potentialEnergy(y);
    const double rel = std::fabs(ed - es) / es;
    EXPECT_LT(rel, previous);
    EXPECT_NEAR(rel, theta * theta / 12.0, 0.1 * theta * theta / 12.0);
    // Forces too: the springs' force has an in-plane part of relative size ~ theta / 2.
    EXPECT_LE(test::relativeError(test::forceAt(*m.ff, y), test::forceAt(springs, y)), 0.6 * theta);
    previous = rel;
  }
  // A flat grid rolled onto a cylinder of growing radius: the relative difference -> 0.
  const MeshData grid = test::grid(9, 2.0);
  Model m = makeModel(grid);
  Topology topo(grid.points, grid.triangles);
  FastTriangularBendingSprings springs(topo, {});
  previous = 1.0;
  for (double r : {2.0, 8.0, 32.0, 128.0}) {
    const std::vector<double> x = rolled(grid, r);
    const double ed = m.ff->potentialEnergy(x), es = springs.potentialEnergy(x);
    ASSERT_GT(es, 0.0);
    const double rel = std::fabs(ed - es) / es;
    EXPECT_LT(rel, previous) << r;
    previous = rel;
  }
  EXPECT_LT(previous, 1e-5);
}

TEST(DihedralBending, DegenerateHingesAreCountedAndNeverNaN) {
  // Rest degeneracies: a wing on the edge line (zero height), an edge of zero length.
  {
    Model m = makeModel(
        test::oneHinge({0.5, 0.0, 0.0}, {0.6, 2.0, 0.0}, {0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}));
    EXPECT_EQ(m.ff->numActiveHinges(), 0u);
    EXPECT_EQ(m.ff->counters().smallHeight, 1u);
    EXPECT_EQ(m.ff->counters().degenerate(), 1u);
    EXPECT_EQ(test::maxAbs(test::forceAt(*m.ff, m.rest)), 0.0);
  }
  {
    const DihedralRecord r =
        dihedralHinge({0.3, -1.0, 0.0}, {0.6, 2.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {});
    EXPECT_EQ(r.status, DihedralStatus::ShortEdge);
    const DihedralRecord big =
        dihedralHinge({0.3, -1.0, 0.0}, {0.6, 2e70, 0.0}, {0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {});
    EXPECT_EQ(big.status, DihedralStatus::Unrepresentable);
    DihedralBendingParameters p;
    p.minDist = 1.5;  // hA = 1 <= minDist
    EXPECT_EQ(dihedralHinge({0.3, -1.0, 0.0}, {0.6, 2.0, 0.0}, {0, 0, 0}, {3, 0, 0}, p).status,
              DihedralStatus::SmallHeight);
  }
  // Current degeneracies: wing A on the line CD, all points on one spot, C on D.
  Model m = makeModel(foldedHinge(0.0));
  for (int which = 0; which < 3; ++which) {
    std::vector<double> x = m.rest;
    if (which == 0) x[1] = 0.0;  // A = (0.3, 0, 0)
    if (which == 1) std::fill(x.begin(), x.end(), 0.25);
    if (which == 2) x[9] = 0.0;  // D = C
    EXPECT_EQ(m.ff->numDegenerateAt(x), 1u) << which;
    const std::vector<double> f = test::forceAt(*m.ff, x);
    EXPECT_EQ(test::maxAbs(f), 0.0);
    const Eigen::MatrixXd k = test::assembledK(*m.ff, x, m.n());
    EXPECT_EQ(test::maxAbsCoeff(k), 0.0);
    std::vector<double> df(x.size(), 0.0);
    m.ff->addDForce(x, x, df, 1.0, 0.0);
    EXPECT_EQ(test::maxAbs(df), 0.0);
    EXPECT_TRUE(std::isfinite(m.ff->potentialEnergy(x)));
  }
  // Too short vectors are rejected.
  std::vector<double> shortV(3, 0.0), f(m.rest.size(), 0.0);
  EXPECT_THROW(m.ff->addForce(shortV, shortV, f), std::invalid_argument);
  EXPECT_THROW((void)m.ff->potentialEnergy(shortV), std::invalid_argument);
}

TEST(DihedralBending, ImplicitSolversRelaxARolledSheet) {
  // A flat sheet rolled to a half-cylinder unrolls under the implicit solvers with the
  // Gauss-Newton stiffness: no NaN, the bending energy falls, and CG and CHOLMOD agree.
  std::vector<double> finalX[2];
  int run = 0;
  for (auto kind :
       {core::SolverSettings::Kind::ImplicitCholmod, core::SolverSettings::Kind::ImplicitCG}) {
    const MeshData mesh = test::grid(7, 1.0);
    core::Simulation sim(std::make_unique<Topology>(mesh.points, mesh.triangles), 1.0);
    StretchParameters sp;
    sp.stiffness = 200.0;
    sim.addForceField(std::make_unique<StretchSprings>(sim.topology(), sp), "stretch");
    DihedralBendingParameters dp;
    dp.bendingStiffness = 0.05;
    sim.addForceField(std::make_unique<DihedralBending>(sim.topology(), dp), "bending");
    const std::vector<double> x0 = rolled(mesh, 1.0 / kPi);
    std::copy(x0.begin(), x0.end(), sim.state().x().begin());
    core::SolverSettings s;
    s.kind = kind;
    s.cgMaxIterations = 200;
    s.cgTolerance = 1e-10;
    s.rayleighMass = 2.0;
    sim.setSolver(s);
    const double e0 = sim.potentialEnergy(1);
    ASSERT_GT(e0, 0.0);
    for (int i = 0; i < 100; ++i) sim.step(0.02);
    EXPECT_LT(sim.potentialEnergy(1), 0.2 * e0);
    finalX[run++].assign(sim.state().x().begin(), sim.state().x().end());
  }
  EXPECT_LE(test::relativeError(finalX[0], finalX[1]), 1e-4);
}

// ---------------------------------------------------------------------------------------------
// The incremental table against a rebuild, after every operation of random sequences

class DihedralIncremental : public ::testing::TestWithParam<SequenceCase> {};

TEST_P(DihedralIncremental, TableEqualsRebuildAfterEveryOperation) {
  const SequenceCase c = GetParam();
  // A gently curved jittered sheet: rest angles are not zero, so they are compared too.
  MeshData mesh = test::sequenceSheet(c);
  for (Vec3& p : mesh.points) p[2] = 0.2 * std::sin(0.6 * p[0]) * std::cos(0.4 * p[1]);
  Topology topo(mesh.points, mesh.triangles);
  DihedralBendingParameters p;
  p.bendingStiffness = 3.0;
  DihedralBending ff(topo, p);
  ASSERT_TRUE(topo.validate().ok()) << topo.validate().summary();
  const auto everyEdgeCounted = [&](const test::RandomOp&) {
    ASSERT_EQ(ff.counters().active + ff.counters().noHinge + ff.counters().degenerate(),
              topo.numEdges());
  };
  ASSERT_NO_FATAL_FAILURE(test::runRandomOps(topo, c.seed, c.steps, everyEdgeCounted));
  // The rest shape of the cut mesh is force-free, and a fresh field agrees everywhere.
  DihedralBending fresh(topo, p);
  test::expectSameAsFresh(ff, fresh, topo, 0.2, c.seed + 7, 1e-12);
}

INSTANTIATE_TEST_SUITE_P(DihedralSequences, DihedralIncremental,
                         ::testing::Values(SequenceCase{1, 8, 150}, SequenceCase{2, 10, 200},
                                           SequenceCase{3, 12, 200}, SequenceCase{4, 6, 120},
                                           SequenceCase{5, 9, 200}));

TEST(DihedralIncrementalOps, CompactionKeepsTheTable) {
  Model m = makeModel(test::bumpyGrid(7, 3));
  m.topo->removeTriangles(
      std::vector<TriangleId>{TriangleId(0), TriangleId(1), TriangleId(17), TriangleId(40)});
  for (EdgeId e : m.topo->edges()) {
    if (!m.topo->isBoundaryEdge(e)) {
      m.topo->tear(e);
      break;
    }
  }
  ASSERT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
  EXPECT_GT(m.ff->numEdgeSlots(), m.topo->numEdges());
  m.topo->compact();
  EXPECT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
  EXPECT_EQ(m.ff->numEdgeSlots(), m.topo->edgeCapacity());
  EXPECT_LE(test::maxAbs(test::forceAt(*m.ff, test::restOf(*m.topo))), 1e-12);
}

}  // namespace
}  // namespace cutsim::forcefields
