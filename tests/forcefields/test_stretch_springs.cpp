// StretchSprings: finite differences, matrices, invariants, degenerate springs, parameters, and the
// incremental table against a rebuild after every operation of random topology sequences.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <initializer_list>
#include <iostream>
#include <limits>
#include <memory>
#include <random>
#include <set>
#include <sstream>
#include <utility>

#include "cutsim/forcefields/stretch_springs.hpp"
#include "cutsim/forcefields/triangular_fem.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/fixtures.hpp"
#include "support/force_field_harness.hpp"

namespace cutsim::forcefields {
namespace {

using topology::kInvalidIndex;
using topology::MeshData;
using topology::Topology;
using topology::Vec3;

/// A topology and the field on it (the field points to the topology: neither moves).
struct Model {
  std::unique_ptr<Topology> topo;
  std::unique_ptr<StretchSprings> ff;
  std::vector<double> rest;  ///< 3 * pointCapacity
  std::size_t n() const { return topo->pointCapacity(); }
};

std::vector<double> restOf(const Topology& t) {
  std::vector<double> x(3 * static_cast<std::size_t>(t.pointCapacity()), 0.0);
  for (PointId p : t.points()) {
    const Vec3 r = t.restPosition(p);
    for (int k = 0; k < 3; ++k) x[3 * p + k] = r[k];
  }
  return x;
}

Model makeModel(const MeshData& mesh, const StretchParameters& p = {}) {
  Model m;
  m.topo = std::make_unique<Topology>(mesh.points, mesh.triangles);
  m.ff = std::make_unique<StretchSprings>(*m.topo, p);
  m.rest = restOf(*m.topo);
  return m;
}

/// A small bumpy, jittered sheet: springs in every direction, not all in one plane.
MeshData bumpyGrid(int n, std::uint64_t seed) {
  MeshData mesh = test::grid(n, 4.0, 0.3, seed);
  for (Vec3& p : mesh.points) p[2] = 0.3 * std::sin(p[0]) * std::cos(0.7 * p[1]);
  return mesh;
}

std::vector<std::pair<std::string, MeshData>> corpus() {
  return {{"grid4", test::grid(4, 3.0)},
          {"bumpy5", bumpyGrid(5, 3)},
          {"fan_closed", test::fan(7, true, 0.3)},
          {"fan_open", test::fan(5, false, 0.2)}};
}

double maxAbs(const std::vector<double>& v) {
  double m = 0.0;
  for (double x : v) m = std::max(m, std::fabs(x));
  return m;
}

// Plain loops over dense matrices: GCC reports false -Wmaybe-uninitialized warnings inside Eigen's
// vectorised dense kernels under -march=native.
double maxAbsCoeff(const Eigen::MatrixXd& a) {
  double m = 0.0;
  for (Eigen::Index j = 0; j < a.cols(); ++j) {
    for (Eigen::Index i = 0; i < a.rows(); ++i) m = std::max(m, std::fabs(a(i, j)));
  }
  return m;
}

std::vector<double> times(const Eigen::MatrixXd& a, const std::vector<double>& x) {
  std::vector<double> y(static_cast<std::size_t>(a.rows()), 0.0);
  for (Eigen::Index j = 0; j < a.cols(); ++j) {
    for (Eigen::Index i = 0; i < a.rows(); ++i) {
      y[static_cast<std::size_t>(i)] += a(i, j) * x[static_cast<std::size_t>(j)];
    }
  }
  return y;
}

double maxAsymmetry(const Eigen::MatrixXd& k) {
  double asym = 0.0;
  for (Eigen::Index i = 0; i < k.rows(); ++i) {
    for (Eigen::Index j = 0; j < k.cols(); ++j) {
      asym = std::max(asym, std::fabs(k(i, j) - k(j, i)));
    }
  }
  return asym;
}

/// max |a - b| / max(|a|, |b|).
double relativeError(const std::vector<double>& a, const std::vector<double>& b) {
  double err = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    err = std::max(err, std::fabs(a[i] - b[i]));
    scale = std::max({scale, std::fabs(a[i]), std::fabs(b[i])});
  }
  return scale > 0.0 ? err / scale : err;
}

/// The eigenvalues of a symmetric matrix, ascending, by Eigen's SelfAdjointEigenSolver in long
/// double: Eigen does not vectorise long double, and its AVX-512 kernels for double (reductions,
/// GEMM) draw false -Wmaybe-uninitialized warnings from GCC 12 under -march=native.
std::vector<double> symmetricEigenvalues(const Eigen::MatrixXd& a) {
  using MatrixXld = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
  MatrixXld al(a.rows(), a.cols());
  for (Eigen::Index j = 0; j < a.cols(); ++j) {
    for (Eigen::Index i = 0; i < a.rows(); ++i) al(i, j) = a(i, j);
  }
  const Eigen::SelfAdjointEigenSolver<MatrixXld> es(al, Eigen::EigenvaluesOnly);
  EXPECT_EQ(es.info(), Eigen::Success);
  std::vector<double> values(static_cast<std::size_t>(a.rows()));
  for (std::size_t i = 0; i < values.size(); ++i) {
    values[i] = static_cast<double>(es.eigenvalues()[static_cast<Eigen::Index>(i)]);
  }
  return values;
}

Eigen::MatrixXd assembledB(const ForceField& ff, const std::vector<double>& x, std::size_t n) {
  TripletAccumulator acc;
  ff.addBToMatrix(x, acc, 1.0);
  return Eigen::MatrixXd(acc.toSparse(static_cast<Index>(n)));
}

Eigen::Matrix3d randomRotation(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> d;
  Eigen::Quaterniond q(d(rng), d(rng), d(rng), d(rng));
  return q.normalized().toRotationMatrix();
}

std::vector<double> rigidMotion(const std::vector<double>& x, std::uint64_t seed) {
  const Eigen::Matrix3d r = randomRotation(seed);
  const Eigen::Vector3d t(1.5, -2.0, 0.7);
  std::vector<double> y(x.size());
  for (std::size_t i = 0; i < x.size(); i += 3) {
    const Eigen::Vector3d p = r * Eigen::Vector3d(x[i], x[i + 1], x[i + 2]) + t;
    for (int k = 0; k < 3; ++k) y[i + k] = p[k];
  }
  return y;
}

void expectZeroNetForceAndTorque(const std::vector<double>& x, const std::vector<double>& f) {
  Eigen::Vector3d net = Eigen::Vector3d::Zero(), torque = Eigen::Vector3d::Zero();
  double scale = 0.0;
  for (std::size_t i = 0; i < x.size(); i += 3) {
    const Eigen::Vector3d xi(x[i], x[i + 1], x[i + 2]), fi(f[i], f[i + 1], f[i + 2]);
    net += fi;
    torque += xi.cross(fi);
    scale = std::max(scale, fi.norm() * std::max(1.0, xi.norm()));
  }
  EXPECT_LE(net.norm(), 1e-12 * std::max(scale, 1.0));
  EXPECT_LE(torque.norm(), 1e-12 * std::max(scale, 1.0));
}

std::vector<double> randomVector(std::size_t n, double amplitude, std::uint64_t seed) {
  return test::perturbed(std::vector<double>(n, 0.0), amplitude, seed);
}

// ---------------------------------------------------------------------------------------------
// Parameters

TEST(StretchSprings, BadParametersAreRejectedNamingTheParameter) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    StretchParameters p;
    std::string where, value;
  };
  std::vector<Case> cases;
  for (double bad : {-1.0, nan, inf, -inf}) {
    StretchParameters s;
    s.stiffness = bad;
    StretchParameters d;
    d.damping = bad;
    const std::string value = std::isnan(bad) ? "nan"
                              : bad == inf    ? "inf"
                              : bad == -inf   ? "-inf"
                                              : "-1";
    cases.push_back({s, "stiffness", value});
    cases.push_back({d, "damping", value});
  }
  for (const Case& c : cases) {
    SCOPED_TRACE(c.where + " = " + c.value);
    try {
      c.p.validate();
      ADD_FAILURE() << "accepted";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.where(), c.where);
      EXPECT_NE(e.message().find(c.value), std::string::npos) << e.message();
    }
    // The constructor validates too.
    const MeshData mesh = test::grid(3);
    Topology topo(mesh.points, mesh.triangles);
    EXPECT_THROW(StretchSprings(topo, c.p), InvalidInput);
    EXPECT_EQ(topo.numObservers(), 0u);
  }
  StretchParameters ok;
  ok.stiffness = 0.0;
  ok.damping = 0.0;
  EXPECT_NO_THROW(ok.validate());
  EXPECT_NO_THROW(StretchParameters{}.validate());
}

// ---------------------------------------------------------------------------------------------
// The table

TEST(StretchSprings, OneSpringPerLiveEdgeWithItsRestLength) {
  const MeshData mesh = bumpyGrid(5, 2);
  Model m = makeModel(mesh);
  EXPECT_EQ(m.ff->numSprings(), m.topo->numEdges());
  EXPECT_EQ(m.ff->typeName(), "StretchSprings");
  EXPECT_EQ(m.ff->observerName(), "StretchSprings");
  for (EdgeId e : m.topo->edges()) {
    const StretchRecord r = m.ff->spring(e);
    ASSERT_EQ(r.edge, e);
    const auto ev = m.topo->edgeVertices(e);
    EXPECT_EQ(std::minmax(r.vertices[0], r.vertices[1]), std::minmax(ev[0], ev[1]));
    const Vec3 a = mesh.points[ev[0]], b = mesh.points[ev[1]];
    const double l = std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                               (a[2] - b[2]) * (a[2] - b[2]));
    EXPECT_NEAR(r.restLength, l, 1e-14 * l);
  }
  EXPECT_EQ(m.ff->spring(m.topo->edgeCapacity() + 5).edge, kInvalidIndex);
  EXPECT_EQ(m.ff->records().size(), m.topo->numEdges());
  // 16 bytes per spring, 4 + 4 bytes of maps.
  EXPECT_NEAR(m.ff->bytesPerEdgeSlot(), 24.0, 1e-12);
  // draw: one segment per spring, the edges' endpoints.
  std::vector<std::array<PointId, 2>> segments;
  m.ff->draw(segments);
  ASSERT_EQ(segments.size(), m.topo->numEdges());
  std::set<std::pair<PointId, PointId>> drawn, edges;
  for (const auto& s : segments) drawn.insert(std::minmax(s[0], s[1]));
  for (EdgeId e : m.topo->edges()) {
    const auto ev = m.topo->edgeVertices(e);
    edges.insert(std::minmax(ev[0], ev[1]));
  }
  EXPECT_EQ(drawn, edges);
  EXPECT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
}

TEST(StretchSprings, VectorsTooShortAreRejected) {
  Model m = makeModel(test::grid(3));
  std::vector<double> x = m.rest, f(x.size(), 0.0), shortV(3, 0.0);
  EXPECT_THROW(m.ff->addForce(shortV, x, f), std::invalid_argument);
  EXPECT_THROW(m.ff->addForce(x, x, shortV), std::invalid_argument);
  EXPECT_THROW(m.ff->addDForce(x, shortV, f, 1.0, 0.0), std::invalid_argument);
  EXPECT_THROW((void)m.ff->potentialEnergy(shortV), std::invalid_argument);
  // Without damping, v is not read.
  EXPECT_NO_THROW(m.ff->addForce(x, shortV, f));
  StretchParameters damped;
  damped.damping = 1.0;
  Model md = makeModel(test::grid(3), damped);
  EXPECT_THROW(md.ff->addForce(x, shortV, f), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// Forces and matrices

TEST(StretchSprings, RestConfigurationIsForceFree) {
  for (const auto& [name, mesh] : corpus()) {
    SCOPED_TRACE(name);
    StretchParameters p;
    p.damping = 2.0;
    Model m = makeModel(mesh, p);
    std::vector<double> f(m.rest.size(), 0.0), v(m.rest.size(), 0.0);
    m.ff->addForce(m.rest, v, f);
    EXPECT_LE(maxAbs(f), 1e-12);
    EXPECT_LE(m.ff->potentialEnergy(m.rest), 1e-24);
  }
}

TEST(StretchSprings, ForceIsMinusEnergyGradient) {
  for (bool stable : {true, false}) {
    for (const auto& [name, mesh] : corpus()) {
      SCOPED_TRACE(name + (stable ? " stable" : " exact"));
      StretchParameters p;
      p.stiffness = 37.0;
      p.stableJacobian = stable;
      Model m = makeModel(mesh, p);
      for (std::uint64_t seed : {1u, 2u, 3u}) {
        const std::vector<double> x = test::perturbed(m.rest, 0.3, seed);
        EXPECT_GT(m.ff->potentialEnergy(x), 0.0);
        EXPECT_LE(test::forceVsEnergyError(*m.ff, x, 1e-5), 1e-7);
      }
    }
  }
}

TEST(StretchSprings, ExactJacobianMatchesFiniteDifferences) {
  // stableJacobian = false: dForce and the assembled K are d(force)/dx everywhere, stretched and
  // compressed springs alike.
  for (const auto& [name, mesh] : corpus()) {
    SCOPED_TRACE(name);
    StretchParameters p;
    p.stiffness = 23.0;
    p.stableJacobian = false;
    Model m = makeModel(mesh, p);
    for (std::uint64_t seed : {1u, 2u, 3u}) {
      const std::vector<double> x = test::perturbed(m.rest, 0.3, seed);
      const std::vector<double> dx = randomVector(x.size(), 1.0, seed + 100);
      EXPECT_LE(test::dForceVsForceError(*m.ff, x, dx, 1e-5), 1e-7);
      EXPECT_LE(test::matrixVsForceError(*m.ff, x, m.n(), 1e-5), 1e-7);
    }
  }
}

TEST(StretchSprings, StableJacobianIsExactForStretchedSprings) {
  // Every spring stretched (a uniform scaling by 1.3 plus small noise): the clamp is inactive.
  for (const auto& [name, mesh] : corpus()) {
    SCOPED_TRACE(name);
    Model m = makeModel(mesh);
    std::vector<double> x = test::perturbed(m.rest, 0.01, 5);
    for (double& xi : x) xi *= 1.3;
    const std::vector<double> dx = randomVector(x.size(), 1.0, 105);
    EXPECT_LE(test::dForceVsForceError(*m.ff, x, dx, 1e-5), 1e-7);
    EXPECT_LE(test::matrixVsForceError(*m.ff, x, m.n(), 1e-5), 1e-7);
  }
  // Compressed (scaled by 0.7): the stable K drops the negative transverse stiffness, so it is
  // no longer the derivative; the exact one is.
  const MeshData mesh = bumpyGrid(4, 9);
  StretchParameters exact;
  exact.stableJacobian = false;
  Model ms = makeModel(mesh), me = makeModel(mesh, exact);
  std::vector<double> x = test::perturbed(ms.rest, 0.01, 6);
  for (double& xi : x) xi *= 0.7;
  EXPECT_GT(test::matrixVsForceError(*ms.ff, x, ms.n(), 1e-5), 1e-2);
  EXPECT_LE(test::matrixVsForceError(*me.ff, x, me.n(), 1e-5), 1e-7);
}

TEST(StretchSprings, AssembledMatricesEqualMatrixFreeProducts) {
  for (bool stable : {true, false}) {
    for (const auto& [name, mesh] : corpus()) {
      SCOPED_TRACE(name + (stable ? " stable" : " exact"));
      StretchParameters p;
      p.stiffness = 11.0;
      p.damping = 0.7;
      p.stableJacobian = stable;
      Model m = makeModel(mesh, p);
      const std::vector<double> x = test::perturbed(m.rest, 0.3, 7);
      const std::vector<double> dx = randomVector(x.size(), 1.0, 8);
      const std::initializer_list<std::pair<double, double>> factors = {
          {1.0, 0.0}, {0.0, 1.0}, {-0.3, 2.5}, {0.0, 0.0}};
      for (const auto& [kf, bf] : factors) {
        TripletAccumulator acc;
        m.ff->addKToMatrix(x, acc, kf);
        m.ff->addBToMatrix(x, acc, bf);
        const Eigen::MatrixXd a(acc.toSparse(static_cast<Index>(m.n())));
        std::vector<double> df(x.size(), 0.0);
        m.ff->addDForce(x, dx, df, kf, bf);
        const std::vector<double> ref = times(a, dx);
        EXPECT_LE(relativeError(df, ref), 1e-13) << "kFactor " << kf << " bFactor " << bf;
      }
      // The pattern depends on the topology only: 4 blocks of 9 entries per spring.
      TripletAccumulator acc;
      m.ff->addKToMatrix(x, acc, 1.0);
      EXPECT_EQ(acc.triplets().size(), 36 * m.ff->numSprings());
    }
  }
}

TEST(StretchSprings, StiffnessSymmetricAndStableOneNegativeSemiDefinite) {
  for (const auto& [name, mesh] : corpus()) {
    SCOPED_TRACE(name);
    StretchParameters exact;
    exact.stableJacobian = false;
    Model ms = makeModel(mesh), me = makeModel(mesh, exact);
    bool exactIndefiniteSomewhere = false;
    for (std::uint64_t seed : {1u, 2u, 3u, 4u}) {
      // Large noise: many springs compressed.
      const std::vector<double> x = test::perturbed(ms.rest, 0.4, seed);
      const Eigen::MatrixXd ks = test::assembledK(*ms.ff, x, ms.n());
      const Eigen::MatrixXd ke = test::assembledK(*me.ff, x, me.n());
      const double scale = maxAbsCoeff(ks);
      EXPECT_LE(maxAsymmetry(ks), 1e-14 * scale);
      EXPECT_LE(maxAsymmetry(ke), 1e-14 * maxAbsCoeff(ke));
      const std::vector<double> es = symmetricEigenvalues(ks);
      // The largest is zero (rigid translations are in the null space), none is positive.
      EXPECT_NEAR(es.back(), 0.0, 1e-10 * scale);
      const std::vector<double> ee = symmetricEigenvalues(ke);
      if (ee.back() > 1e-6 * scale) exactIndefiniteSomewhere = true;
    }
    // The exact Jacobian of compressed springs is indefinite: the clamp is what makes K stable.
    EXPECT_TRUE(exactIndefiniteSomewhere);
  }
}

TEST(StretchSprings, DampingMatrixIsTheVelocityDerivative) {
  for (const auto& [name, mesh] : corpus()) {
    SCOPED_TRACE(name);
    StretchParameters p;
    p.stiffness = 5.0;
    p.damping = 3.0;
    Model m = makeModel(mesh, p);
    const std::vector<double> x = test::perturbed(m.rest, 0.3, 3);
    const std::vector<double> v = randomVector(x.size(), 2.0, 4);
    const std::vector<double> dv = randomVector(x.size(), 1.0, 5);
    // The force is affine in v: a central difference is exact up to rounding.
    std::vector<double> vp = v, vm = v;
    for (std::size_t i = 0; i < v.size(); ++i) {
      vp[i] += dv[i];
      vm[i] -= dv[i];
    }
    std::vector<double> fp(x.size(), 0.0), fm(x.size(), 0.0);
    m.ff->addForce(x, vp, fp);
    m.ff->addForce(x, vm, fm);
    std::vector<double> fd(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) fd[i] = 0.5 * (fp[i] - fm[i]);
    std::vector<double> df(x.size(), 0.0);
    m.ff->addDForce(x, dv, df, 0.0, 1.0);
    EXPECT_LE(relativeError(df, fd), 1e-11);
    const Eigen::MatrixXd b = assembledB(*m.ff, x, m.n());
    EXPECT_LE(relativeError(times(b, dv), fd), 1e-11);
    EXPECT_LE(maxAsymmetry(b), 1e-15 * maxAbsCoeff(b));
    const std::vector<double> es = symmetricEigenvalues(b);
    EXPECT_LE(es.back(), 1e-12 * maxAbsCoeff(b));
    EXPECT_LT(es.front(), 0.0);
  }
  // No damping: no B at all.
  Model m = makeModel(test::grid(3));
  TripletAccumulator acc;
  m.ff->addBToMatrix(m.rest, acc, 1.0);
  EXPECT_TRUE(acc.triplets().empty());
}

TEST(StretchSprings, RigidMotions) {
  for (const auto& [name, mesh] : corpus()) {
    SCOPED_TRACE(name);
    StretchParameters p;
    p.damping = 1.5;
    Model m = makeModel(mesh, p);
    std::vector<double> zero(m.rest.size(), 0.0);
    for (std::uint64_t seed : {11u, 12u, 13u}) {
      // A rigid motion of the rest shape: no force, no energy.
      const std::vector<double> x = rigidMotion(m.rest, seed);
      EXPECT_LE(maxAbs(test::forceAt(*m.ff, x)), 1e-11);
      EXPECT_LE(m.ff->potentialEnergy(x), 1e-22);
      // A rigid velocity (translation + rotation) of a deformed shape: no damping force.
      const std::vector<double> y = test::perturbed(m.rest, 0.3, seed);
      const Eigen::Vector3d w(0.3, -1.1, 0.6), t(2.0, 0.5, -1.0);
      std::vector<double> v(y.size());
      for (std::size_t i = 0; i < y.size(); i += 3) {
        const Eigen::Vector3d vi = t + w.cross(Eigen::Vector3d(y[i], y[i + 1], y[i + 2]));
        for (int k = 0; k < 3; ++k) v[i + k] = vi[k];
      }
      std::vector<double> f0(y.size(), 0.0), fv(y.size(), 0.0);
      m.ff->addForce(y, zero, f0);
      m.ff->addForce(y, v, fv);
      EXPECT_LE(relativeError(fv, f0), 1e-12);
      // Deformed, anywhere: zero net force and torque, and the forces turn with the body.
      expectZeroNetForceAndTorque(y, f0);
      const std::vector<double> ry = rigidMotion(y, seed + 50);
      const std::vector<double> rf = test::forceAt(*m.ff, ry);
      expectZeroNetForceAndTorque(ry, rf);
      const Eigen::Matrix3d r = randomRotation(seed + 50);
      std::vector<double> turned(f0.size());
      for (std::size_t i = 0; i < f0.size(); i += 3) {
        const Eigen::Vector3d fi = r * Eigen::Vector3d(f0[i], f0[i + 1], f0[i + 2]);
        for (int k = 0; k < 3; ++k) turned[i + k] = fi[k];
      }
      EXPECT_LE(relativeError(rf, turned), 1e-12);
      EXPECT_NEAR(m.ff->potentialEnergy(ry), m.ff->potentialEnergy(y),
                  1e-12 * m.ff->potentialEnergy(y));
    }
  }
}

TEST(StretchSprings, ZeroLengthSpringIsFinite) {
  for (bool stable : {true, false}) {
    SCOPED_TRACE(stable ? "stable" : "exact");
    StretchParameters p;
    p.stiffness = 10.0;
    p.damping = 2.0;
    p.stableJacobian = stable;
    Model m = makeModel(test::grid(3, 2.0), p);
    // Collapse the edge 4-5 (rest length 1): point 5 onto point 4, with different velocities.
    const EdgeId e = m.topo->findEdge(4, 5);
    ASSERT_NE(e, kInvalidIndex);
    std::vector<double> x = m.rest;
    for (int k = 0; k < 3; ++k) x[3 * 5 + k] = x[3 * 4 + k];
    const std::vector<double> v = randomVector(x.size(), 1.0, 9);
    const std::vector<double> dx = randomVector(x.size(), 1.0, 10);
    std::vector<double> f(x.size(), 0.0), df(x.size(), 0.0);
    m.ff->addForce(x, v, f);
    m.ff->addDForce(x, dx, df, 1.0, 1.0);
    const double energy = m.ff->potentialEnergy(x);
    TripletAccumulator acc;
    m.ff->addKToMatrix(x, acc, 1.0);
    m.ff->addBToMatrix(x, acc, 1.0);
    for (double vi : f) EXPECT_TRUE(std::isfinite(vi));
    for (double vi : df) EXPECT_TRUE(std::isfinite(vi));
    for (const auto& t : acc.triplets()) EXPECT_TRUE(std::isfinite(t.value()));
    EXPECT_TRUE(std::isfinite(energy));
    // The collapsed spring (rest length 1) still stores its energy 1/2 ks L0^2.
    EXPECT_GE(energy, 0.5 * p.stiffness * 1.0 - 1e-12);
    // The pattern is unchanged: zero blocks for the collapsed spring (K and B).
    EXPECT_EQ(acc.triplets().size(), 2 * 36 * m.ff->numSprings());
    // The other springs still balance.
    double net[3] = {0, 0, 0};
    for (std::size_t i = 0; i < f.size(); i += 3) {
      for (int k = 0; k < 3; ++k) net[k] += f[i + k];
    }
    for (double c : net) EXPECT_NEAR(c, 0.0, 1e-12);
  }
  // All points on one spot: nothing but finite zeros.
  Model m = makeModel(test::grid(3, 2.0));
  std::vector<double> x(m.rest.size(), 0.25);
  const std::vector<double> f = test::forceAt(*m.ff, x);
  EXPECT_EQ(maxAbs(f), 0.0);
  EXPECT_GT(m.ff->potentialEnergy(x), 0.0);
}

// ---------------------------------------------------------------------------------------------
// The incremental table against a rebuild, after every operation of random sequences

class RandomEdits {
 public:
  RandomEdits(Topology& t, std::uint64_t seed) : t_(t), rng_(seed) {}

  /// One random operation; returns its description ("... rejected: ..." when the topology
  /// refused it, which changes nothing).
  std::string step() {
    std::ostringstream what;
    what.precision(17);
    const int op = pick(0, 11);
    try {
      if (op <= 2) {
        const EdgeId e = randomEdge(false);
        const double s = std::uniform_real_distribution<double>(0.2, 0.8)(rng_);
        what << "splitEdge(" << e << ", " << s << ")";
        trace(what);
        t_.splitEdge(e, s);
      } else if (op <= 4) {
        const EdgeId e = randomEdge(true);
        if (e == kInvalidIndex) return "no interior edge";
        what << "tear(" << e << ")";
        trace(what);
        t_.tear(e);
      } else if (op <= 6) {
        const std::vector<PointId> path = randomPath();
        what << "incise(";
        for (PointId p : path) what << p << " ";
        what << ")";
        if (path.size() < 2) return what.str() + " skipped";
        trace(what);
        t_.incise(path);
      } else if (op == 7) {
        std::vector<TriangleId> tris = t_.triangles();
        std::shuffle(tris.begin(), tris.end(), rng_);
        tris.resize(std::min<std::size_t>(tris.size(), static_cast<std::size_t>(pick(1, 3))));
        std::sort(tris.begin(), tris.end());
        what << "removeTriangles(";
        for (TriangleId tr : tris) what << tr << " ";
        what << ")";
        trace(what);
        t_.removeTriangles(tris);
      } else if (op <= 9) {
        std::uniform_real_distribution<double> u(0.3, 9.7), len(0.5, 2.5), turn(-1.0, 1.0);
        std::vector<Vec3> poly;
        Vec3 p{u(rng_), u(rng_), 0.0};
        double angle = std::uniform_real_distribution<double>(0.0, 6.283185307179586)(rng_);
        poly.push_back(p);
        const int n = pick(2, 3);
        for (int i = 1; i < n; ++i) {
          const double l = len(rng_);
          p = {p[0] + l * std::cos(angle), p[1] + l * std::sin(angle), 0.0};
          if (p[0] < 0.3 || p[0] > 9.7 || p[1] < 0.3 || p[1] > 9.7) break;
          poly.push_back(p);
          angle += turn(rng_);
        }
        if (poly.size() < 2) return "cutPolyline skipped";
        what << "cutPolyline(";
        for (const Vec3& q : poly) what << "(" << q[0] << "," << q[1] << ") ";
        what << ")";
        trace(what);
        t_.cutPolyline(poly);
      } else if (op == 10) {
        what << "compact()";
        trace(what);
        t_.compact();
      } else {
        const EdgeId e = randomEdge(false);
        what << "splitEdge(" << e << ", 0.5)";
        trace(what);
        t_.splitEdge(e, 0.5);
      }
    } catch (const TopologyError& err) {
      what << " rejected: " << err.what();
    }
    return what.str();
  }

 private:
  void trace(const std::ostringstream& what) const {
    if (trace_) std::cerr << "  op: " << what.str() << std::endl;
  }
  int pick(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }
  EdgeId randomEdge(bool interior) {
    std::vector<EdgeId> edges = t_.edges();
    if (interior) std::erase_if(edges, [this](EdgeId e) { return t_.isBoundaryEdge(e); });
    if (edges.empty()) return kInvalidIndex;
    return edges[static_cast<std::size_t>(pick(0, static_cast<int>(edges.size()) - 1))];
  }
  std::vector<PointId> randomPath() {
    const EdgeId e0 = randomEdge(true);
    if (e0 == kInvalidIndex) return {};
    const auto ev = t_.edgeVertices(e0);
    std::vector<PointId> path{ev[0], ev[1]};
    const int len = pick(1, 4);
    while (static_cast<int>(path.size()) <= len) {
      std::vector<PointId> next;
      for (EdgeId e : t_.edgesAroundPoint(path.back())) {
        if (t_.isBoundaryEdge(e)) continue;
        const auto v = t_.edgeVertices(e);
        const PointId other = v[0] == path.back() ? v[1] : v[0];
        if (std::find(path.begin(), path.end(), other) == path.end()) next.push_back(other);
      }
      if (next.empty()) break;
      path.push_back(next[static_cast<std::size_t>(pick(0, static_cast<int>(next.size()) - 1))]);
    }
    return path;
  }

  Topology& t_;
  std::mt19937_64 rng_;
  bool trace_ = std::getenv("CUTSIM_TEST_TRACE") != nullptr;
};

struct SequenceCase {
  std::uint64_t seed;
  int gridSide;
  int steps;
};

class StretchIncremental : public ::testing::TestWithParam<SequenceCase> {};

TEST_P(StretchIncremental, TableEqualsRebuildAfterEveryOperation) {
  const SequenceCase c = GetParam();
  const MeshData mesh = test::grid(c.gridSide, 10.0, 0.25, c.seed);
  Topology topo(mesh.points, mesh.triangles);
  StretchParameters p;
  p.stiffness = 7.0;
  p.damping = 0.5;
  StretchSprings ff(topo, p);
  ASSERT_TRUE(topo.validate().ok()) << topo.validate().summary();

  RandomEdits edits(topo, c.seed);
  int accepted = 0;
  for (int i = 0; i < c.steps && topo.numTriangles() > 12; ++i) {
    const std::string what = edits.step();
    if (what.find("rejected") == std::string::npos) ++accepted;
    const topology::ValidationReport r = topo.validate();
    ASSERT_TRUE(r.ok()) << "after step " << i << ": " << what << "\n" << r.summary();
    ASSERT_EQ(ff.numSprings(), topo.numEdges()) << "after step " << i << ": " << what;
  }
  EXPECT_GT(accepted, c.steps / 4) << "too few operations were accepted";
  // The rest shape of the cut mesh is still force-free (new points interpolate their ancestors).
  const std::vector<double> rest = restOf(topo);
  EXPECT_LE(maxAbs(test::forceAt(ff, rest)), 1e-9);
  // A field built afresh on the final mesh gives the same forces, energy and matrices.
  StretchSprings fresh(topo, p);
  const std::vector<double> x = test::perturbed(rest, 0.3, c.seed + 7);
  const std::vector<double> v = randomVector(x.size(), 1.0, c.seed + 8);
  std::vector<double> f1(x.size(), 0.0), f2(x.size(), 0.0);
  ff.addForce(x, v, f1);
  fresh.addForce(x, v, f2);
  EXPECT_LE(relativeError(f1, f2), 1e-12);
  EXPECT_NEAR(ff.potentialEnergy(x), fresh.potentialEnergy(x), 1e-12 * fresh.potentialEnergy(x));
  TripletAccumulator a1, a2;
  ff.addKToMatrix(x, a1, 1.0);
  ff.addBToMatrix(x, a1, 0.5);
  fresh.addKToMatrix(x, a2, 1.0);
  fresh.addBToMatrix(x, a2, 0.5);
  const Eigen::SparseMatrix<double> m1 = a1.toSparse(topo.pointCapacity());
  const Eigen::SparseMatrix<double> m2 = a2.toSparse(topo.pointCapacity());
  EXPECT_LE((m1 - m2).norm(), 1e-12 * m2.norm());
}

INSTANTIATE_TEST_SUITE_P(StretchSequences, StretchIncremental,
                         ::testing::Values(SequenceCase{1, 8, 150}, SequenceCase{2, 10, 200},
                                           SequenceCase{3, 12, 200}, SequenceCase{4, 6, 120},
                                           SequenceCase{5, 10, 200}, SequenceCase{6, 9, 200}));

// TriangularFEM follows triangle events: the same random sequences (its other tests are in
// test_stretch_triangular_fem.cpp).
class TriangularFemIncremental : public ::testing::TestWithParam<SequenceCase> {};

TEST_P(TriangularFemIncremental, TableEqualsRebuildAfterEveryOperation) {
  const SequenceCase c = GetParam();
  const MeshData mesh = test::grid(c.gridSide, 10.0, 0.25, c.seed);
  Topology topo(mesh.points, mesh.triangles);
  TriangularFEMParameters p;
  p.youngModulus = 300.0;
  p.poissonRatio = 0.25;
  p.thickness = 0.2;
  TriangularFEM ff(topo, p);
  StretchSprings springs(topo, {});  // both follow the same transactions
  ASSERT_TRUE(topo.validate().ok()) << topo.validate().summary();
  RandomEdits edits(topo, c.seed + 1000);
  int accepted = 0;
  for (int i = 0; i < c.steps && topo.numTriangles() > 12; ++i) {
    const std::string what = edits.step();
    if (what.find("rejected") == std::string::npos) ++accepted;
    const topology::ValidationReport r = topo.validate();
    ASSERT_TRUE(r.ok()) << "after step " << i << ": " << what << "\n" << r.summary();
    ASSERT_EQ(ff.numElements() + ff.numDegenerate(), topo.numTriangles()) << what;
  }
  EXPECT_GT(accepted, c.steps / 4) << "too few operations were accepted";
  const std::vector<double> rest = restOf(topo);
  EXPECT_LE(maxAbs(test::forceAt(ff, rest)), 1e-9);
  TriangularFEM fresh(topo, p);
  const std::vector<double> x = test::perturbed(rest, 0.3, c.seed + 7);
  EXPECT_LE(relativeError(test::forceAt(ff, x), test::forceAt(fresh, x)), 1e-10);
  EXPECT_NEAR(ff.potentialEnergy(x), fresh.potentialEnergy(x), 1e-10 * fresh.potentialEnergy(x));
}

INSTANTIATE_TEST_SUITE_P(TriangularFemSequences, TriangularFemIncremental,
                         ::testing::Values(SequenceCase{1, 8, 150}, SequenceCase{2, 10, 200},
                                           SequenceCase{3, 9, 200}));

TEST(StretchIncrementalOps, SplitEdgeGivesHalvesTheirRestLengths) {
  Model m = makeModel(test::grid(5, 4.0));
  const std::size_t before = m.ff->numSprings();
  const EdgeId e = m.topo->findEdge(6, 12);  // an interior diagonal, rest length sqrt(2)
  ASSERT_NE(e, kInvalidIndex);
  const auto ev = m.topo->edgeVertices(e);
  const PointId p = m.topo->splitEdge(e, 0.25);
  // The edge becomes two halves, and two edges join the new point to the wings.
  EXPECT_EQ(m.ff->numSprings(), before + 3);
  EXPECT_EQ(m.ff->spring(e).edge, kInvalidIndex);
  const double l = std::sqrt(2.0);
  const EdgeId h0 = m.topo->findEdge(ev[0], p), h1 = m.topo->findEdge(p, ev[1]);
  ASSERT_NE(h0, kInvalidIndex);
  ASSERT_NE(h1, kInvalidIndex);
  EXPECT_NEAR(m.ff->spring(h0).restLength, 0.25 * l, 1e-14);
  EXPECT_NEAR(m.ff->spring(h1).restLength, 0.75 * l, 1e-14);
  EXPECT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
}

TEST(StretchIncrementalOps, TearGivesTheCopiesTheirOwnSprings) {
  Model m = makeModel(test::grid(5));
  const EdgeId e = m.topo->findEdge(6, 12);
  const topology::IncisionResult r = m.topo->tear(e);
  EXPECT_FALSE(r.copies.empty());
  EXPECT_EQ(m.ff->numSprings(), m.topo->numEdges());
  for (PointId c : r.copies) {
    for (EdgeId ce : m.topo->edgesAroundPoint(c)) EXPECT_EQ(m.ff->spring(ce).edge, ce);
  }
  EXPECT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
}

TEST(StretchIncrementalOps, CarvingAndCompactionRenumberTheTable) {
  Model m = makeModel(test::grid(7, 10.0, 0.2, 3));
  m.topo->removeTriangles(std::vector<TriangleId>{0, 1, 17, 40});
  m.topo->splitEdge(m.topo->edges()[10], 0.3);
  ASSERT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
  EXPECT_GT(m.ff->numEdgeSlots(), m.ff->numSprings());
  m.topo->compact();
  EXPECT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
  EXPECT_EQ(m.ff->numEdgeSlots(), m.topo->edgeCapacity());
  EXPECT_EQ(m.ff->numSprings(), m.topo->numEdges());
  EXPECT_EQ(m.topo->edgeCapacity(), m.topo->numEdges());
  // Compaction lays the springs out in edge order.
  const auto springs = m.ff->springs();
  for (EdgeId e = 0; e < m.topo->edgeCapacity(); ++e) {
    const auto ev = m.topo->edgeVertices(e);
    EXPECT_EQ(std::minmax(springs[e].a, springs[e].b), std::minmax(ev[0], ev[1]));
  }
  const std::vector<double> rest = restOf(*m.topo);
  EXPECT_LE(maxAbs(test::forceAt(*m.ff, rest)), 1e-12);
}

}  // namespace
}  // namespace cutsim::forcefields
