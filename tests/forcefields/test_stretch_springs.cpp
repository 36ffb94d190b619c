// StretchSprings: finite differences, matrices, invariants, degenerate springs, parameters, and the
// incremental table against a rebuild after every operation of random topology sequences.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <set>
#include <utility>

#include "cutsim/forcefields/stretch_springs.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/field_helpers.hpp"
#include "support/fixtures.hpp"
#include "support/force_field_harness.hpp"
#include "support/random_ops.hpp"

namespace cutsim::forcefields {
namespace {

using test::SequenceCase;
using topology::kInvalidIndex;
using topology::MeshData;
using topology::Topology;
using topology::Vec3;

using Model = test::FieldModel<StretchSprings>;

Model makeModel(const MeshData& mesh, const StretchParameters& p = {}) {
  return test::makeFieldModel<StretchSprings>(mesh, p);
}

/// The rest scales the derivative tests run with: none, and a prestrain (every spring of the
/// mesh stretched by 1/0.9 - 1 = 11% at rest positions).
constexpr double kRestScales[] = {1.0, 0.9};

std::string scaleName(double restScale) {
  return " restScale " + std::to_string(restScale);
}

Eigen::MatrixXd assembledB(const ForceField& ff, const std::vector<double>& x, std::size_t n) {
  TripletAccumulator acc;
  ff.addBToMatrix(x, acc, 1.0);
  return Eigen::MatrixXd(acc.toSparse(static_cast<Index>(n)));
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
  for (double bad : {0.0, -0.5, nan, inf}) {
    StretchParameters r;
    r.restScale = bad;
    cases.push_back({r, "restScale",
                     std::isnan(bad) ? "nan"
                     : bad == inf    ? "inf"
                     : bad == 0.0    ? "0"
                                     : "-0.5"});
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
  const MeshData mesh = test::bumpyGrid(5, 2);
  Model m = makeModel(mesh);
  EXPECT_EQ(m.ff->numSprings(), m.topo->numEdges());
  EXPECT_EQ(m.ff->typeName(), "StretchSprings");
  EXPECT_EQ(m.ff->observerName(), "StretchSprings");
  for (EdgeId e : m.topo->edges()) {
    const StretchRecord r = m.ff->spring(e);
    ASSERT_EQ(r.edge, e);
    const auto ev = m.topo->edgeVertices(e);
    EXPECT_EQ(std::minmax(r.vertices[0], r.vertices[1]), std::minmax(ev[0], ev[1]));
    const Vec3 a = mesh.points[ev[0].idx()], b = mesh.points[ev[1].idx()];
    const double l = std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                               (a[2] - b[2]) * (a[2] - b[2]));
    EXPECT_NEAR(r.restLength, l, 1e-14 * l);
  }
  EXPECT_EQ(m.ff->spring(EdgeId(m.topo->edgeCapacity() + 5)).edge, EdgeId::invalid());
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

TEST(StretchSprings, RestScaleMultipliesEveryRestLength) {
  // restScale s: rest lengths s L. The mesh scaled by s is force-free; the mesh itself has every
  // spring stretched (s < 1) or compressed (s > 1) by (1 - s) L.
  const MeshData mesh = test::bumpyGrid(5, 2);
  const Model plain = makeModel(mesh);
  for (double s : {0.8, 1.25}) {
    SCOPED_TRACE(scaleName(s));
    StretchParameters p;
    p.stiffness = 13.0;
    p.restScale = s;
    Model m = makeModel(mesh, p);
    EXPECT_EQ(m.ff->parameters().restScale, s);
    double expected = 0.0;
    for (EdgeId e : m.topo->edges()) {
      const double l = plain.ff->spring(e).restLength;
      EXPECT_NEAR(m.ff->spring(e).restLength, s * l, 1e-14 * l);
      expected += 0.5 * p.stiffness * (1.0 - s) * (1.0 - s) * l * l;
    }
    std::vector<double> restShape = m.rest;
    for (double& c : restShape) c *= s;
    EXPECT_LE(test::maxAbs(test::forceAt(*m.ff, restShape)), 1e-12);
    EXPECT_LE(m.ff->potentialEnergy(restShape), 1e-24);
    EXPECT_NEAR(m.ff->potentialEnergy(m.rest), expected, 1e-12 * expected);
    // Stretched (s < 1) the sheet pulls its border inwards: a negative virial sum x . f.
    const std::vector<double> f = test::forceAt(*m.ff, m.rest);
    double virial = 0.0;
    for (std::size_t i = 0; i < f.size(); ++i) virial += m.rest[i] * f[i];
    EXPECT_EQ(virial < 0.0, s < 1.0);
  }
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
  for (const auto& [name, mesh] : test::smallMeshes()) {
    SCOPED_TRACE(name);
    StretchParameters p;
    p.damping = 2.0;
    Model m = makeModel(mesh, p);
    std::vector<double> f(m.rest.size(), 0.0), v(m.rest.size(), 0.0);
    m.ff->addForce(m.rest, v, f);
    EXPECT_LE(test::maxAbs(f), 1e-12);
    EXPECT_LE(m.ff->potentialEnergy(m.rest), 1e-24);
  }
}

TEST(StretchSprings, ForceIsMinusEnergyGradient) {
  for (double s : kRestScales) {
    for (bool stable : {true, false}) {
      for (const auto& [name, mesh] : test::smallMeshes()) {
        SCOPED_TRACE(name + (stable ? " stable" : " exact") + scaleName(s));
        StretchParameters p;
        p.stiffness = 37.0;
        p.stableJacobian = stable;
        p.restScale = s;
        Model m = makeModel(mesh, p);
        for (std::uint64_t seed : {1u, 2u, 3u}) {
          const std::vector<double> x = test::perturbed(m.rest, 0.3, seed);
          EXPECT_GT(m.ff->potentialEnergy(x), 0.0);
          EXPECT_LE(test::forceVsEnergyError(*m.ff, x, 1e-5), 1e-7);
        }
      }
    }
  }
}

TEST(StretchSprings, PerRestLengthIsSofasMeshSpringForceField) {
  // perRestLength: each spring ks / L0 and kd / L0, L0 its mesh rest length (SOFA's
  // MeshSpringForceField), against the spring law written out per spring; the derivatives as for
  // the uniform springs.
  for (const auto& [name, mesh] : test::smallMeshes()) {
    SCOPED_TRACE(name);
    StretchParameters p;
    p.stiffness = 23.0;
    p.damping = 0.7;
    p.stableJacobian = false;
    p.perRestLength = true;
    Model m = makeModel(mesh, p);
    const std::vector<double> x = test::perturbed(m.rest, 0.3, 5);
    const std::vector<double> v = test::randomVector(x.size(), 1.0, 6);
    std::vector<double> f(x.size(), 0.0), twin(x.size(), 0.0);
    m.ff->addForce(x, v, f);
    for (topology::EdgeId e : m.topo->edges()) {
      const auto ends = m.topo->edgeVertices(e);
      const std::size_t a = 3 * std::size_t(ends[0].idx()), b = 3 * std::size_t(ends[1].idx());
      double d[3], dv[3], L0 = 0, l = 0;
      for (int k = 0; k < 3; ++k) {
        d[k] = x[b + std::size_t(k)] - x[a + std::size_t(k)];
        dv[k] = v[b + std::size_t(k)] - v[a + std::size_t(k)];
        const double r = m.rest[b + std::size_t(k)] - m.rest[a + std::size_t(k)];
        L0 += r * r;
        l += d[k] * d[k];
      }
      L0 = std::sqrt(L0);
      l = std::sqrt(l);
      double uv = 0;
      for (int k = 0; k < 3; ++k) uv += dv[k] * d[k] / l;
      const double intensity = -(p.stiffness / L0) * (l - L0) - (p.damping / L0) * uv;
      for (int k = 0; k < 3; ++k) {
        twin[b + std::size_t(k)] += intensity * d[k] / l;
        twin[a + std::size_t(k)] -= intensity * d[k] / l;
      }
    }
    EXPECT_LE(test::relativeError(f, twin), 1e-12);
    EXPECT_LE(test::forceVsEnergyError(*m.ff, x, 1e-5), 1e-7);
    const std::vector<double> dx = test::randomVector(x.size(), 1.0, 7);
    EXPECT_LE(test::dForceVsForceError(*m.ff, x, dx, 1e-5), 1e-7);
    EXPECT_LE(test::matrixVsForceError(*m.ff, x, m.n(), 1e-5), 1e-7);
  }
}

TEST(StretchSprings, ExactJacobianMatchesFiniteDifferences) {
  // stableJacobian = false: dForce and the assembled K are d(force)/dx everywhere, stretched and
  // compressed springs alike, with and without a prestrain.
  for (double s : kRestScales) {
    for (const auto& [name, mesh] : test::smallMeshes()) {
      SCOPED_TRACE(name + scaleName(s));
      StretchParameters p;
      p.stiffness = 23.0;
      p.stableJacobian = false;
      p.restScale = s;
      Model m = makeModel(mesh, p);
      for (std::uint64_t seed : {1u, 2u, 3u}) {
        const std::vector<double> x = test::perturbed(m.rest, 0.3, seed);
        const std::vector<double> dx = test::randomVector(x.size(), 1.0, seed + 100);
        EXPECT_LE(test::dForceVsForceError(*m.ff, x, dx, 1e-5), 1e-7);
        EXPECT_LE(test::matrixVsForceError(*m.ff, x, m.n(), 1e-5), 1e-7);
      }
    }
  }
}

TEST(StretchSprings, StableJacobianIsExactForStretchedSprings) {
  // Every spring stretched (a uniform scaling by 1.3 plus small noise): the clamp is inactive.
  for (const auto& [name, mesh] : test::smallMeshes()) {
    SCOPED_TRACE(name);
    Model m = makeModel(mesh);
    std::vector<double> x = test::perturbed(m.rest, 0.01, 5);
    for (double& xi : x) xi *= 1.3;
    const std::vector<double> dx = test::randomVector(x.size(), 1.0, 105);
    EXPECT_LE(test::dForceVsForceError(*m.ff, x, dx, 1e-5), 1e-7);
    EXPECT_LE(test::matrixVsForceError(*m.ff, x, m.n(), 1e-5), 1e-7);
  }
  // Compressed (scaled by 0.7): the stable K drops the negative transverse stiffness, so it is
  // no longer the derivative; the exact one is.
  const MeshData mesh = test::bumpyGrid(4, 9);
  StretchParameters exact;
  exact.stableJacobian = false;
  Model ms = makeModel(mesh), me = makeModel(mesh, exact);
  std::vector<double> x = test::perturbed(ms.rest, 0.01, 6);
  for (double& xi : x) xi *= 0.7;
  EXPECT_GT(test::matrixVsForceError(*ms.ff, x, ms.n(), 1e-5), 1e-2);
  EXPECT_LE(test::matrixVsForceError(*me.ff, x, me.n(), 1e-5), 1e-7);
  // A prestrained sheet (restScale 0.9) held near its mesh positions: every spring is stretched
  // by about 11%, so the stable K is exact there.
  StretchParameters prestrained;
  prestrained.restScale = 0.9;
  Model mp = makeModel(mesh, prestrained);
  const std::vector<double> held = test::perturbed(mp.rest, 0.01, 7);
  const std::vector<double> dx = test::randomVector(held.size(), 1.0, 107);
  EXPECT_LE(test::dForceVsForceError(*mp.ff, held, dx, 1e-5), 1e-7);
  EXPECT_LE(test::matrixVsForceError(*mp.ff, held, mp.n(), 1e-5), 1e-7);
}

TEST(StretchSprings, SetExactStiffnessDropsTheClampAndRestoresTheParameter) {
  // A sheet sheared and stretched along x, compressed along y, plus noise: springs stretched and
  // compressed alike.
  const MeshData mesh = test::bumpyGrid(4, 9);
  StretchParameters p;
  p.stiffness = 23.0;
  p.damping = 0.5;
  Model m = makeModel(mesh, p);  // stableJacobian = true
  Eigen::Matrix3d a;
  a << 1.35, 0.3, 0.0, 0.0, 0.7, 0.1, 0.05, 0.0, 1.0;
  const std::vector<double> x =
      test::perturbed(test::transformed(m.rest, a, {0.2, -0.1, 0.3}), 0.05, 3);
  int stretched = 0, compressed = 0;
  for (const StretchSpring& sp : m.ff->springs()) {
    const double l = std::hypot(x[3 * sp.b] - x[3 * sp.a], x[3 * sp.b + 1] - x[3 * sp.a + 1],
                                x[3 * sp.b + 2] - x[3 * sp.a + 2]);
    (l > sp.restLength ? stretched : compressed) += 1;
  }
  EXPECT_GT(stretched, 5);
  EXPECT_GT(compressed, 5);
  const std::vector<double> dx = test::randomVector(x.size(), 1.0, 4);
  const auto dForce = [&] {
    std::vector<double> df(x.size(), 0.0);
    m.ff->addDForce(x, dx, df, 1.0, 0.0);
    return df;
  };
  // The default K: clamped, not d(force)/dx. addDForce at x caches its linearisation.
  EXPECT_FALSE(m.ff->stiffnessIsExact());
  const std::vector<double> dfStable = dForce();
  EXPECT_GT(test::dForceVsForceError(*m.ff, x, dx, 1e-6), 1e-3);
  EXPECT_GT(test::matrixVsForceError(*m.ff, x, m.n(), 1e-6), 1e-3);
  // Exact: at bitwise the same x, addDForce must not reuse the clamped linearisation.
  EXPECT_TRUE(m.ff->setExactStiffness(true));
  EXPECT_TRUE(m.ff->stiffnessIsExact());
  EXPECT_FALSE(m.ff->parameters().stableJacobian);
  const std::vector<double> dfExact = dForce();
  EXPECT_GT(test::relativeError(dfExact, dfStable), 1e-3);
  const test::StiffnessCheck c = test::expectExactStiffness(*m.ff, x, dx, m.n(), 1e-6, 1e-8);
  test::recordError("worst_fd_relative_error", std::max(c.dForceVsForce, c.matrixVsForce));
  test::recordError("worst_dforce_vs_matrix", c.dForceVsMatrix);
  // Back to the parameter given at construction, and to the clamped K bit for bit.
  EXPECT_TRUE(m.ff->setExactStiffness(false));
  EXPECT_FALSE(m.ff->stiffnessIsExact());
  EXPECT_TRUE(m.ff->parameters().stableJacobian);
  EXPECT_EQ(dForce(), dfStable);
  // A field built with stableJacobian = false is exact either way.
  StretchParameters exact = p;
  exact.stableJacobian = false;
  Model me = makeModel(mesh, exact);
  EXPECT_TRUE(me.ff->stiffnessIsExact());
  EXPECT_TRUE(me.ff->setExactStiffness(false));
  EXPECT_TRUE(me.ff->stiffnessIsExact());
  test::expectExactStiffness(*me.ff, x, dx, me.n(), 1e-6, 1e-8);
}

TEST(StretchSprings, AssembledMatricesEqualMatrixFreeProducts) {
  for (bool stable : {true, false}) {
    for (const auto& [name, mesh] : test::smallMeshes()) {
      SCOPED_TRACE(name + (stable ? " stable" : " exact"));
      StretchParameters p;
      p.stiffness = 11.0;
      p.damping = 0.7;
      p.stableJacobian = stable;
      Model m = makeModel(mesh, p);
      const std::vector<double> x = test::perturbed(m.rest, 0.3, 7);
      const std::vector<double> dx = test::randomVector(x.size(), 1.0, 8);
      const std::initializer_list<std::pair<double, double>> factors = {
          {1.0, 0.0}, {0.0, 1.0}, {-0.3, 2.5}, {0.0, 0.0}};
      for (const auto& [kf, bf] : factors) {
        TripletAccumulator acc;
        m.ff->addKToMatrix(x, acc, kf);
        m.ff->addBToMatrix(x, acc, bf);
        const Eigen::MatrixXd a(acc.toSparse(static_cast<Index>(m.n())));
        std::vector<double> df(x.size(), 0.0);
        m.ff->addDForce(x, dx, df, kf, bf);
        const std::vector<double> ref = test::times(a, dx);
        EXPECT_LE(test::relativeError(df, ref), 1e-13) << "kFactor " << kf << " bFactor " << bf;
      }
      // The pattern depends on the topology only: 4 blocks of 9 entries per spring.
      TripletAccumulator acc;
      m.ff->addKToMatrix(x, acc, 1.0);
      EXPECT_EQ(acc.triplets().size(), 36 * m.ff->numSprings());
    }
  }
}

// addDForce keeps u and a of every spring while it is called at the same positions (the CG
// iterations of one step): positions changed in place, a tear and a compaction must each be
// seen, the result always equal to the assembled matrix at the current positions.
TEST(StretchSprings, DForceFollowsPositionsChangedInPlaceAndTopologyChanges) {
  StretchParameters p;
  p.stiffness = 7.0;
  p.damping = 0.3;
  Model m = makeModel(test::grid(6, 1.0), p);
  auto expectMatchesAssembly = [&](const std::vector<double>& x, const char* when) {
    SCOPED_TRACE(when);
    const std::vector<double> dx = test::randomVector(x.size(), 1.0, 21);
    TripletAccumulator acc;
    m.ff->addKToMatrix(x, acc, 0.8);
    m.ff->addBToMatrix(x, acc, 0.2);
    const std::vector<double> ref =
        test::times(Eigen::MatrixXd(acc.toSparse(static_cast<Index>(m.n()))), dx);
    for (int repeat = 0; repeat < 2; ++repeat) {  // the second call uses the kept terms
      std::vector<double> df(x.size(), 0.0);
      m.ff->addDForce(x, dx, df, 0.8, 0.2);
      EXPECT_LE(test::relativeError(df, ref), 1e-13) << "call " << repeat;
    }
  };
  std::vector<double> x = test::perturbed(m.rest, 0.2, 3);
  expectMatchesAssembly(x, "first positions");
  for (std::size_t i = 0; i < x.size(); i += 7) x[i] += 0.05;  // same buffer, other values
  expectMatchesAssembly(x, "positions changed in place");
  m.topo->tear(m.topo->findEdge(topology::PointId(14), topology::PointId(15)));
  x.resize(3 * m.n(), 0.0);
  expectMatchesAssembly(x, "after a tear");
  m.topo->removeTriangles(std::vector<topology::TriangleId>{m.topo->triangles().front()});
  m.topo->compact();
  x = test::perturbed(test::restOf(*m.topo), 0.2, 4);
  expectMatchesAssembly(x, "after a compaction");
}

TEST(StretchSprings, StiffnessSymmetricAndStableOneNegativeSemiDefinite) {
  for (const auto& [name, mesh] : test::smallMeshes()) {
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
      const double scale = test::maxAbsCoeff(ks);
      EXPECT_LE(test::maxAsymmetry(ks), 1e-14 * scale);
      EXPECT_LE(test::maxAsymmetry(ke), 1e-14 * test::maxAbsCoeff(ke));
      const std::vector<double> es = test::symmetricEigenvalues(ks);
      // The largest is zero (rigid translations are in the null space), none is positive.
      EXPECT_NEAR(es.back(), 0.0, 1e-10 * scale);
      const std::vector<double> ee = test::symmetricEigenvalues(ke);
      if (ee.back() > 1e-6 * scale) exactIndefiniteSomewhere = true;
    }
    // The exact Jacobian of compressed springs is indefinite: the clamp is what makes K stable.
    EXPECT_TRUE(exactIndefiniteSomewhere);
  }
}

TEST(StretchSprings, DampingMatrixIsTheVelocityDerivative) {
  for (const auto& [name, mesh] : test::smallMeshes()) {
    SCOPED_TRACE(name);
    StretchParameters p;
    p.stiffness = 5.0;
    p.damping = 3.0;
    Model m = makeModel(mesh, p);
    const std::vector<double> x = test::perturbed(m.rest, 0.3, 3);
    const std::vector<double> v = test::randomVector(x.size(), 2.0, 4);
    const std::vector<double> dv = test::randomVector(x.size(), 1.0, 5);
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
    EXPECT_LE(test::relativeError(df, fd), 1e-11);
    const Eigen::MatrixXd b = assembledB(*m.ff, x, m.n());
    EXPECT_LE(test::relativeError(test::times(b, dv), fd), 1e-11);
    EXPECT_LE(test::maxAsymmetry(b), 1e-15 * test::maxAbsCoeff(b));
    const std::vector<double> es = test::symmetricEigenvalues(b);
    EXPECT_LE(es.back(), 1e-12 * test::maxAbsCoeff(b));
    EXPECT_LT(es.front(), 0.0);
  }
  // No damping: no B at all.
  Model m = makeModel(test::grid(3));
  TripletAccumulator acc;
  m.ff->addBToMatrix(m.rest, acc, 1.0);
  EXPECT_TRUE(acc.triplets().empty());
}

TEST(StretchSprings, RigidMotions) {
  for (const auto& [name, mesh] : test::smallMeshes()) {
    SCOPED_TRACE(name);
    StretchParameters p;
    p.damping = 1.5;
    Model m = makeModel(mesh, p);
    std::vector<double> zero(m.rest.size(), 0.0);
    for (std::uint64_t seed : {11u, 12u, 13u}) {
      // A rigid motion of the rest shape: no force, no energy.
      const std::vector<double> x = test::rigidMotion(m.rest, seed);
      EXPECT_LE(test::maxAbs(test::forceAt(*m.ff, x)), 1e-11);
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
      EXPECT_LE(test::relativeError(fv, f0), 1e-12);
      // Deformed, anywhere: zero net force and torque, and the forces turn with the body.
      test::expectZeroNetForceAndTorque(y, f0);
      const std::vector<double> ry = test::rigidMotion(y, seed + 50);
      const std::vector<double> rf = test::forceAt(*m.ff, ry);
      test::expectZeroNetForceAndTorque(ry, rf);
      const std::vector<double> turned =
          test::transformed(f0, test::randomRotation(seed + 50), Eigen::Vector3d::Zero());
      EXPECT_LE(test::relativeError(rf, turned), 1e-12);
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
    const EdgeId e = m.topo->findEdge(topology::PointId(4), topology::PointId(5));
    ASSERT_NE(e.idx(), kInvalidIndex);
    std::vector<double> x = m.rest;
    for (int k = 0; k < 3; ++k) x[3 * 5 + k] = x[3 * 4 + k];
    const std::vector<double> v = test::randomVector(x.size(), 1.0, 9);
    const std::vector<double> dx = test::randomVector(x.size(), 1.0, 10);
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
  EXPECT_EQ(test::maxAbs(f), 0.0);
  EXPECT_GT(m.ff->potentialEnergy(x), 0.0);
}

// ---------------------------------------------------------------------------------------------
// The incremental table against a rebuild, after every operation of random sequences

class StretchIncremental : public ::testing::TestWithParam<SequenceCase> {};

TEST_P(StretchIncremental, TableEqualsRebuildAfterEveryOperation) {
  const SequenceCase c = GetParam();
  const MeshData mesh = test::sequenceSheet(c);
  Topology topo(mesh.points, mesh.triangles);
  StretchParameters p;
  p.stiffness = 7.0;
  p.damping = 0.5;
  StretchSprings ff(topo, p);
  // A prestrained twin: the springs created by the operations get scaled rest lengths too (its
  // validate() compares it with a rebuild at the same restScale after every operation).
  StretchParameters ps = p;
  ps.restScale = 0.85;
  StretchSprings prestrained(topo, ps);
  ASSERT_TRUE(topo.validate().ok()) << topo.validate().summary();

  const auto oneSpringPerEdge = [&](const test::RandomOp&) {
    ASSERT_EQ(ff.numSprings(), topo.numEdges());
    ASSERT_EQ(prestrained.numSprings(), topo.numEdges());
  };
  ASSERT_NO_FATAL_FAILURE(test::runRandomOps(topo, c.seed, c.steps, oneSpringPerEdge));
  // The rest shape of the cut mesh is still force-free, and a field built afresh on the final mesh
  // gives the same forces (with damping too), energy and matrices.
  StretchSprings fresh(topo, p);
  const std::vector<double> x = test::expectSameAsFresh(ff, fresh, topo, 0.3, c.seed + 7, 1e-12);
  const std::vector<double> v = test::randomVector(x.size(), 1.0, c.seed + 8);
  std::vector<double> f1(x.size(), 0.0), f2(x.size(), 0.0);
  ff.addForce(x, v, f1);
  fresh.addForce(x, v, f2);
  EXPECT_LE(test::relativeError(f1, f2), 1e-12);
  TripletAccumulator a1, a2;
  ff.addKToMatrix(x, a1, 1.0);
  ff.addBToMatrix(x, a1, 0.5);
  fresh.addKToMatrix(x, a2, 1.0);
  fresh.addBToMatrix(x, a2, 0.5);
  const Eigen::SparseMatrix<double> m1 = a1.toSparse(topo.pointCapacity());
  const Eigen::SparseMatrix<double> m2 = a2.toSparse(topo.pointCapacity());
  EXPECT_LE((m1 - m2).norm(), 1e-12 * m2.norm());
  StretchSprings freshPrestrained(topo, ps);
  test::expectSameAsFresh(prestrained, freshPrestrained, topo, 0.3, c.seed + 9, 1e-12,
                          ps.restScale);
}

INSTANTIATE_TEST_SUITE_P(StretchSequences, StretchIncremental,
                         ::testing::Values(SequenceCase{1, 8, 150}, SequenceCase{2, 10, 200},
                                           SequenceCase{3, 12, 200}, SequenceCase{4, 6, 120},
                                           SequenceCase{5, 10, 200}, SequenceCase{6, 9, 200}));

TEST(StretchIncrementalOps, SplitEdgeGivesHalvesTheirRestLengths) {
  Model m = makeModel(test::grid(5, 4.0));
  const std::size_t before = m.ff->numSprings();
  const EdgeId e = m.topo->findEdge(
      topology::PointId(6), topology::PointId(12));  // an interior diagonal, rest length sqrt(2)
  ASSERT_NE(e.idx(), kInvalidIndex);
  const auto ev = m.topo->edgeVertices(e);
  const PointId p = m.topo->splitEdge(e, 0.25);
  // The edge becomes two halves, and two edges join the new point to the wings.
  EXPECT_EQ(m.ff->numSprings(), before + 3);
  EXPECT_EQ(m.ff->spring(e).edge, EdgeId::invalid());
  const double l = std::sqrt(2.0);
  const EdgeId h0 = m.topo->findEdge(ev[0], p), h1 = m.topo->findEdge(p, ev[1]);
  ASSERT_NE(h0.idx(), kInvalidIndex);
  ASSERT_NE(h1.idx(), kInvalidIndex);
  EXPECT_NEAR(m.ff->spring(h0).restLength, 0.25 * l, 1e-14);
  EXPECT_NEAR(m.ff->spring(h1).restLength, 0.75 * l, 1e-14);
  EXPECT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
}

TEST(StretchIncrementalOps, SpringsCreatedByACutGetScaledRestLengths) {
  // The rest lengths of the springs an incision creates (its copies' edges, the halves of split
  // edges) are scaled as those built at the start.
  StretchParameters p;
  p.restScale = 0.7;
  Model m = makeModel(test::grid(7, 6.0), p);
  const std::vector<Vec3> polyline = {{1.5, 2.5, 0.0}, {4.2, 3.4, 0.0}};
  const topology::IncisionResult r = m.topo->cutPolyline(polyline);
  ASSERT_FALSE(r.copies.empty());
  ASSERT_FALSE(r.insertedPoints.empty());
  for (PointId q : r.copies) {
    for (EdgeId e : m.topo->edgesAroundPoint(q)) {
      const auto ev = m.topo->edgeVertices(e);
      const Vec3 a = m.topo->restPosition(ev[0]), b = m.topo->restPosition(ev[1]);
      const double l = std::hypot(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
      EXPECT_NEAR(m.ff->spring(e).restLength, 0.7 * l, 1e-14 * l);
    }
  }
  EXPECT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
  // The cut mesh scaled by 0.7 is still force-free.
  std::vector<double> restShape = test::restOf(*m.topo);
  for (double& c : restShape) c *= 0.7;
  EXPECT_LE(test::maxAbs(test::forceAt(*m.ff, restShape)), 1e-12);
}

TEST(StretchIncrementalOps, TearGivesTheCopiesTheirOwnSprings) {
  Model m = makeModel(test::grid(5));
  const EdgeId e = m.topo->findEdge(topology::PointId(6), topology::PointId(12));
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
  m.topo->removeTriangles(
      std::vector<TriangleId>{TriangleId(0), TriangleId(1), TriangleId(17), TriangleId(40)});
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
  for (EdgeId e{0}; e.idx() < m.topo->edgeCapacity(); ++e) {
    const auto ev = m.topo->edgeVertices(e);
    EXPECT_EQ(std::minmax(springs[e.idx()].a, springs[e.idx()].b),
              std::minmax(ev[0].idx(), ev[1].idx()));
  }
  const std::vector<double> rest = test::restOf(*m.topo);
  EXPECT_LE(test::maxAbs(test::forceAt(*m.ff, rest)), 1e-12);
}

}  // namespace
}  // namespace cutsim::forcefields
