// FastTriangularBendingSprings: the reference cases of the spec (section 8), SOFA's measured
// outputs (section 9), finite differences, invariants, degenerate hinges and parameters.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <set>

#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/field_helpers.hpp"
#include "support/fixtures.hpp"
#include "support/force_field_harness.hpp"
#include "support/ids.hpp"

namespace cutsim::forcefields {
namespace {

using topology::MeshData;
using topology::Topology;
using topology::Vec3;

/// A topology and the field on it (the field points to the topology: neither moves).
struct Model {
  std::unique_ptr<Topology> topo;
  std::unique_ptr<FastTriangularBendingSprings> ff;
  std::vector<double> rest;  ///< 3 * pointCapacity
};

std::vector<double> flatten(const std::vector<Vec3>& pts) {
  std::vector<double> x;
  for (const Vec3& p : pts) x.insert(x.end(), p.begin(), p.end());
  return x;
}

Model makeModel(const MeshData& mesh, const BendingParameters& p = {}) {
  Model m;
  m.topo = std::make_unique<Topology>(mesh.points, mesh.triangles);
  m.ff = std::make_unique<FastTriangularBendingSprings>(*m.topo, p);
  m.rest = flatten(mesh.points);
  return m;
}

Vec3 at(const std::vector<double>& f, std::size_t i) {
  return {f[3 * i], f[3 * i + 1], f[3 * i + 2]};
}

double maxAbs(const std::vector<double>& v) {
  double m = 0.0;
  for (double x : v) m = std::max(m, std::fabs(x));
  return m;
}

std::map<PointId, double> weightMap(const HingeRecord& r) {
  std::map<PointId, double> m;
  for (int i = 0; i < 4; ++i) m[r.vertices[i]] += r.alpha[i];
  return m;
}

void expectVecNear(const Vec3& a, const Vec3& b, double tol) {
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(a[k], b[k], tol) << "component " << k;
}

/// The spec prints 12 significant digits: agree to half a unit of the last one; a component
/// that is exactly 0 in the spec may carry rounding of the other components (1e-14 of them).
void expectVecSpec(const Vec3& a, const Vec3& b) {
  const double scale = std::max({std::fabs(b[0]), std::fabs(b[1]), std::fabs(b[2])});
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(a[k], b[k], 5e-12 * std::fabs(b[k]) + 1e-14 * scale) << "component " << k;
  }
}

// Plain loops over dense matrices: GCC 12 reports false -Wmaybe-uninitialized warnings inside
// Eigen's AVX-512 dense kernels (products, reductions) under -march=native.
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
    for (Eigen::Index i = 0; i < a.rows(); ++i) y[i] += a(i, j) * x[j];
  }
  return y;
}

double dotV(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
  return s;
}

/// The field's own validate (the incremental table against a rebuild).
void expectFieldValid(const Model& m) {
  std::vector<std::string> problems;
  m.ff->validate(*m.topo, problems);
  EXPECT_TRUE(problems.empty()) << (problems.empty() ? "" : problems.front());
}

// Hinge H of the spec: points A, B, C, D are slots 0, 1, 2, 3.
const Vec3 kHA{0.3, -1, 0}, kHB{0.6, 2, 0}, kHC{0, 0, 0}, kHD{1, 0, 0};
// Non-convex hinge NC.
const Vec3 kNA{-2, -1, 0}, kNB{-2, 1, 0}, kNC{0, 0, 0}, kND{1, 0, 0};

// ---------------------------------------------------------------------------------------------
// Spec section 8

TEST(BendingKernel, HingeHWeightsAndStiffness) {
  const HingeWeights w = computeHinge(kHA, kHB, kHC, kHD, 1.0, 1e-6, AreaWeights::Unsigned);
  ASSERT_EQ(w.status, HingeStatus::Active);
  EXPECT_NEAR(w.alpha[0], 2.0 / 3.0, 1e-15);
  EXPECT_NEAR(w.alpha[1], 1.0 / 3.0, 1e-15);
  EXPECT_NEAR(w.alpha[2], -0.6, 1e-15);
  EXPECT_NEAR(w.alpha[3], -0.4, 1e-15);
  EXPECT_NEAR(w.lambda, 0.5, 1e-15);
  EXPECT_FALSE(w.signedFallback);
  // Signed weights equal the unsigned ones on a flat convex hinge.
  const HingeWeights s = computeHinge(kHA, kHB, kHC, kHD, 1.0, 1e-6, AreaWeights::Signed);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(s.alpha[i], w.alpha[i], 1e-15);
  EXPECT_FALSE(s.signedFallback);
}

TEST(BendingSprings, HingeHRestAndRotatedWing) {
  Model m = makeModel(test::oneHinge(kHA, kHB, kHC, kHD));
  ASSERT_EQ(m.ff->numActiveSprings(), 1u);
  const HingeRecord h = m.ff->hinge(m.topo->findEdge(topology::PointId(2), topology::PointId(3)));
  ASSERT_EQ(h.status, HingeStatus::Active);
  const auto w = weightMap(h);
  EXPECT_NEAR(w.at(PointId(0)), 2.0 / 3.0, 1e-15);
  EXPECT_NEAR(w.at(PointId(1)), 1.0 / 3.0, 1e-15);
  EXPECT_NEAR(w.at(PointId(2)), -0.6, 1e-15);
  EXPECT_NEAR(w.at(PointId(3)), -0.4, 1e-15);
  EXPECT_NEAR(h.lambda, 0.5, 1e-15);

  const std::vector<double> f0 = test::forceAt(*m.ff, m.rest);
  EXPECT_LE(maxAbs(f0), 1e-15);
  EXPECT_LE(m.ff->potentialEnergy(m.rest), 1e-30);

  std::vector<double> x = m.rest;
  x[3 * 1 + 1] = 2.0 * std::cos(0.1);
  x[3 * 1 + 2] = 2.0 * std::sin(0.1);
  EXPECT_NEAR(m.ff->potentialEnergy(x), 0.00111018549377, 5e-12 * 0.00111018549377);
  const std::vector<double> f = test::forceAt(*m.ff, x);
  expectVecSpec(at(f, 0), {0, 0.00111018549377, -0.0221852036993});
  expectVecSpec(at(f, 1), {0, 0.000555092746886, -0.0110926018496});
  expectVecSpec(at(f, 2), {0, -0.000999166944395, 0.0199666833294});
  expectVecSpec(at(f, 3), {0, -0.000666111296263, 0.0133111222196});
}

TEST(BendingSprings, FoldEnergyMatchesClosedForm) {
  // Spec section 2: |R| = 2 hA hB |sin(theta/2)| / (hA + hB), E = (4/3) k l sin^2(theta/2)/(hA+hB).
  BendingParameters p;
  p.bendingStiffness = 2.0;
  Model m = makeModel(test::oneHinge(kHA, kHB, kHC, kHD), p);
  for (double theta : {0.01, 0.3, 1.0, 2.5}) {
    std::vector<double> x = m.rest;
    x[3 * 1 + 1] = 2.0 * std::cos(theta);
    x[3 * 1 + 2] = 2.0 * std::sin(theta);
    const double s = std::sin(theta / 2);
    EXPECT_NEAR(m.ff->potentialEnergy(x), (4.0 / 3.0) * 2.0 * 1.0 * s * s / 3.0, 1e-14);
  }
}

TEST(BendingSprings, NonConvexHingeUnsigned) {
  Model m = makeModel(test::oneHinge(kNA, kNB, kNC, kND));
  const HingeRecord h = m.ff->hinge(m.topo->findEdge(topology::PointId(2), topology::PointId(3)));
  ASSERT_EQ(h.status, HingeStatus::Active);
  const auto w = weightMap(h);
  EXPECT_NEAR(w.at(PointId(0)), 0.5, 1e-15);
  EXPECT_NEAR(w.at(PointId(1)), 0.5, 1e-15);
  EXPECT_NEAR(w.at(PointId(2)), -0.6, 1e-15);
  EXPECT_NEAR(w.at(PointId(3)), -0.4, 1e-15);
  EXPECT_NEAR(h.lambda, 4.0 / 3.0, 1e-15);
  EXPECT_NEAR(m.ff->potentialEnergy(m.rest), 3.84, 1e-13);
  const std::vector<double> f = test::forceAt(*m.ff, m.rest);
  expectVecNear(at(f, 0), {1.6, 0, 0}, 1e-14);
  expectVecNear(at(f, 1), {1.6, 0, 0}, 1e-14);
  expectVecNear(at(f, 2), {-1.92, 0, 0}, 1e-14);
  expectVecNear(at(f, 3), {-1.28, 0, 0}, 1e-14);
}

TEST(BendingSprings, NonConvexHingeSigned) {
  BendingParameters p;
  p.areaWeights = AreaWeights::Signed;
  Model m = makeModel(test::oneHinge(kNA, kNB, kNC, kND), p);
  const HingeRecord h = m.ff->hinge(m.topo->findEdge(topology::PointId(2), topology::PointId(3)));
  ASSERT_EQ(h.status, HingeStatus::Active);
  EXPECT_FALSE(h.signedFallback);
  const auto w = weightMap(h);
  EXPECT_NEAR(w.at(PointId(0)), 0.5, 1e-15);
  EXPECT_NEAR(w.at(PointId(1)), 0.5, 1e-15);
  EXPECT_NEAR(w.at(PointId(2)), -3.0, 1e-14);
  EXPECT_NEAR(w.at(PointId(3)), 2.0, 1e-14);
  EXPECT_NEAR(h.lambda, 4.0 / 3.0, 1e-15);
  EXPECT_EQ(m.ff->potentialEnergy(m.rest), 0.0);
  EXPECT_EQ(maxAbs(test::forceAt(*m.ff, m.rest)), 0.0);
  EXPECT_EQ(m.ff->counters().signedFallbacks, 0u);
}

struct GridCase {
  int n;
  std::size_t triangles, edges, active;
  double lambdaAxis, lambdaDiagonal;
};

class BendingGrid : public ::testing::TestWithParam<GridCase> {};

TEST_P(BendingGrid, CountsAndStiffnesses) {
  const GridCase c = GetParam();
  Model m = makeModel(test::grid(c.n));
  EXPECT_EQ(m.topo->numTriangles(), c.triangles);
  EXPECT_EQ(m.topo->numEdges(), c.edges);
  EXPECT_EQ(m.ff->numActiveSprings(), c.active);
  EXPECT_EQ(m.ff->counters().activeSprings, c.active);
  EXPECT_EQ(m.ff->counters().noHinge, c.edges - c.active);
  EXPECT_EQ(m.ff->counters().degenerate(), 0u);
  std::set<long long> lambdas;  // in units of 1e-9
  for (const HingeRecord& s : m.ff->hinges()) {
    if (s.status != HingeStatus::Active) continue;
    const bool axis = std::fabs(s.lambda - c.lambdaAxis) <= 1e-12 * c.lambdaAxis;
    const bool diag = std::fabs(s.lambda - c.lambdaDiagonal) <= 1e-12 * c.lambdaDiagonal;
    EXPECT_TRUE(axis || diag) << "lambda " << s.lambda;
    lambdas.insert(std::llround(s.lambda * 1e9));
  }
  EXPECT_EQ(lambdas.size(), 2u);
  EXPECT_LE(maxAbs(test::forceAt(*m.ff, m.rest)), 1e-12);
  EXPECT_LE(m.ff->bytesPerEdgeSlot(), 64.0);
  expectFieldValid(m);
}

INSTANTIATE_TEST_SUITE_P(Spec, BendingGrid,
                         ::testing::Values(GridCase{5, 32, 56, 40, 0.16 * 4 / 3, 0.64 * 4 / 3},
                                           GridCase{20, 722, 1121, 1045, 3.61 * 4 / 3,
                                                    14.44 * 4 / 3}));

// ---------------------------------------------------------------------------------------------
// Spec section 9: SOFA's measured outputs

std::vector<double> flattenJson(const nlohmann::json& a) {
  std::vector<double> x;
  for (const auto& p : a) {
    for (const auto& c : p) x.push_back(c.get<double>());
  }
  return x;
}

double relativeError(const std::vector<double>& a, const std::vector<double>& b) {
  double err = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    err = std::max(err, std::fabs(a[i] - b[i]));
    scale = std::max(scale, std::fabs(b[i]));
  }
  return scale > 0.0 ? err / scale : err;
}

class BendingSofaReference : public ::testing::TestWithParam<std::pair<const char*, std::size_t>> {
};

TEST_P(BendingSofaReference, ReproducesSofa) {
  const std::string name = GetParam().first;
  const std::string dir = std::string(CUTSIM_TEST_DATA_DIR) + "/sofa-reference/";
  std::ifstream in(dir + name + ".json");
  ASSERT_TRUE(in) << dir + name + ".json";
  const nlohmann::json j = nlohmann::json::parse(in);
  const MeshData mesh = topology::readMesh(dir + name + "_rest.obj");

  BendingParameters p;
  p.bendingStiffness = j.at("bendingStiffness").get<double>();
  p.minDistValidity = j.at("minDistValidity").get<double>();
  Model m = makeModel(mesh, p);
  EXPECT_EQ(m.ff->numActiveSprings(), GetParam().second);

  const std::vector<double> rest = flattenJson(j.at("rest_positions"));
  ASSERT_EQ(rest.size(), m.rest.size());
  EXPECT_LE(relativeError(rest, m.rest), 1e-15);
  const std::vector<double> x = flattenJson(j.at("positions"));
  const std::vector<double> dx = flattenJson(j.at("dx"));

  EXPECT_LE(relativeError(test::forceAt(*m.ff, x), flattenJson(j.at("force"))), 1e-10);
  EXPECT_LE(relativeError(test::forceAt(*m.ff, rest), flattenJson(j.at("force_at_rest"))), 1e-10);
  const double e = j.at("potential_energy").get<double>();
  const double e0 = j.at("potential_energy_at_rest").get<double>();
  EXPECT_NEAR(m.ff->potentialEnergy(x), e, 1e-10 * std::fabs(e));
  EXPECT_NEAR(m.ff->potentialEnergy(rest), e0, 1e-10 * std::fabs(e0));
  std::vector<double> df(x.size(), 0.0);
  m.ff->addDForce(x, dx, df, j.at("kFactor").get<double>(), 0.0);
  EXPECT_LE(relativeError(df, flattenJson(j.at("dforce"))), 1e-10);
  // The assembled K times dx gives the same.
  const Eigen::MatrixXd k = test::assembledK(*m.ff, x, mesh.points.size());
  EXPECT_LE(relativeError(times(k, dx), flattenJson(j.at("dforce"))), 1e-10);
}

INSTANTIATE_TEST_SUITE_P(Sofa, BendingSofaReference,
                         ::testing::Values(std::make_pair("cylinder_patch", std::size_t{62}),
                                           std::make_pair("grid7x6_alt_jitter", std::size_t{79})));

// ---------------------------------------------------------------------------------------------
// Finite differences, symmetry, invariants: over a corpus of meshes

MeshData cylinderPatch() {
  return topology::readMesh(std::string(CUTSIM_TEST_DATA_DIR) +
                            "/sofa-reference/cylinder_patch_rest.obj");
}

std::vector<std::pair<std::string, MeshData>> corpus() {
  return {{"hingeH", test::oneHinge(kHA, kHB, kHC, kHD)},
          {"hingeNC", test::oneHinge(kNA, kNB, kNC, kND)},
          {"grid6_jitter", test::grid(6, 10.0, 0.4, 7)},
          {"fan_closed", test::fan(7, true, 0.3)},
          {"fan_open", test::fan(5, false, 0.2)},
          {"cylinder_patch", cylinderPatch()}};
}

TEST(BendingSprings, FiniteDifferences) {
  for (AreaWeights aw : {AreaWeights::Unsigned, AreaWeights::Signed}) {
    for (const auto& [name, mesh] : corpus()) {
      SCOPED_TRACE(name + (aw == AreaWeights::Signed ? " signed" : " unsigned"));
      BendingParameters p;
      p.bendingStiffness = 1.7;
      p.areaWeights = aw;
      Model m = makeModel(mesh, p);
      for (std::uint64_t seed : {1u, 2u, 3u}) {
        const std::vector<double> x = test::perturbed(m.rest, 0.3, seed);
        const std::vector<double> dx =
            test::perturbed(std::vector<double>(x.size(), 0.0), 1.0, seed + 100);
        EXPECT_LE(test::forceVsEnergyError(*m.ff, x, 1e-3), 1e-7);
        EXPECT_LE(test::dForceVsForceError(*m.ff, x, dx, 1e-3), 1e-9);
        EXPECT_LE(test::matrixVsForceError(*m.ff, x, mesh.points.size(), 1e-3), 1e-9);
      }
    }
  }
}

TEST(BendingSprings, StiffnessSymmetricNegativeSemiDefinite) {
  for (const auto& [name, mesh] : corpus()) {
    SCOPED_TRACE(name);
    Model m = makeModel(mesh);
    const Eigen::MatrixXd k = test::assembledK(*m.ff, m.rest, mesh.points.size());
    const double scale = maxAbsCoeff(k);
    double asym = 0.0;
    for (Eigen::Index i = 0; i < k.rows(); ++i) {
      for (Eigen::Index j = 0; j < k.cols(); ++j)
        asym = std::max(asym, std::fabs(k(i, j) - k(j, i)));
    }
    EXPECT_LE(asym, 1e-15 * scale);
    // Negative semi-definite: x^T K x <= 0 for random x.
    for (std::uint64_t seed = 0; seed < 20; ++seed) {
      const std::vector<double> x =
          test::perturbed(std::vector<double>(static_cast<std::size_t>(k.rows()), 0.0), 1.0, seed);
      EXPECT_LE(dotV(x, times(k, x)), 1e-12 * scale * dotV(x, x));
    }
    // 16 blocks of 3 diagonal entries per spring.
    TripletAccumulator acc;
    m.ff->addKToMatrix(m.rest, acc, 1.0);
    EXPECT_EQ(acc.triplets().size(), 48 * m.ff->numActiveSprings());
  }
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
    y[i] = p[0];
    y[i + 1] = p[1];
    y[i + 2] = p[2];
  }
  return y;
}

TEST(BendingSprings, RigidMotionsOfFlatRestHinges) {
  // Flat convex rest: no force at all under any rigid motion.
  for (const MeshData& mesh : {test::grid(7), test::oneHinge(kHA, kHB, kHC, kHD)}) {
    Model m = makeModel(mesh);
    for (std::uint64_t seed : {11u, 12u, 13u}) {
      const std::vector<double> x = rigidMotion(m.rest, seed);
      const std::vector<double> f = test::forceAt(*m.ff, x);
      EXPECT_LE(maxAbs(f), 1e-12);
      EXPECT_LE(m.ff->potentialEnergy(x), 1e-24);
    }
  }
  // Flat non-convex rest (unsigned): the rest forces turn with the body; net force and torque 0.
  Model m = makeModel(test::oneHinge(kNA, kNB, kNC, kND));
  for (std::uint64_t seed : {21u, 22u}) {
    const std::vector<double> x = rigidMotion(m.rest, seed);
    const std::vector<double> f = test::forceAt(*m.ff, x);
    EXPECT_NEAR(m.ff->potentialEnergy(x), 3.84, 1e-12);
    test::expectZeroNetForceAndTorque(x, f);
  }
}

TEST(BendingSprings, ZeroNetForceAndTorqueAnywhere) {
  for (const auto& [name, mesh] : corpus()) {
    SCOPED_TRACE(name);
    Model m = makeModel(mesh);
    const std::vector<double> x = test::perturbed(m.rest, 0.5, 5);
    test::expectZeroNetForceAndTorque(x, test::forceAt(*m.ff, x));
  }
}

// ---------------------------------------------------------------------------------------------
// Labelling independence

TEST(BendingKernel, LabellingIndependence) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> d(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    const Vec3 c{0, 0, 0}, dd{1 + 0.2 * d(rng), 0.1 * d(rng), 0.1 * d(rng)};
    const Vec3 a{0.5 + d(rng), -1 + 0.3 * d(rng), 0.3 * d(rng)};
    const Vec3 b{0.5 + d(rng), 1 + 0.3 * d(rng), 0.3 * d(rng)};
    for (AreaWeights aw : {AreaWeights::Unsigned, AreaWeights::Signed}) {
      const HingeWeights w = computeHinge(a, b, c, dd, 1.3, 1e-6, aw);
      ASSERT_EQ(w.status, HingeStatus::Active);
      EXPECT_NEAR(w.alpha[0] + w.alpha[1], 1.0, 1e-14);
      EXPECT_NEAR(w.alpha[2] + w.alpha[3], -1.0, 1e-14);
      const HingeWeights s = computeHinge(b, a, dd, c, 1.3, 1e-6, aw);  // A<->B, C<->D
      ASSERT_EQ(s.status, HingeStatus::Active);
      EXPECT_NEAR(s.alpha[0], w.alpha[1], 1e-14);
      EXPECT_NEAR(s.alpha[1], w.alpha[0], 1e-14);
      EXPECT_NEAR(s.alpha[2], w.alpha[3], 1e-14);
      EXPECT_NEAR(s.alpha[3], w.alpha[2], 1e-14);
      EXPECT_NEAR(s.lambda, w.lambda, 1e-14 * w.lambda);
      EXPECT_EQ(s.signedFallback, w.signedFallback);
    }
  }
}

TEST(BendingSprings, VertexNumberingDoesNotMatter) {
  for (AreaWeights aw : {AreaWeights::Unsigned, AreaWeights::Signed}) {
    for (const auto& [name, mesh] : corpus()) {
      SCOPED_TRACE(name);
      BendingParameters p;
      p.areaWeights = aw;
      Model m = makeModel(mesh, p);
      std::vector<PointId> newOfOld;
      MeshData shuffled = test::shuffledVertices(mesh, 99, &newOfOld);
      // Also rotate every triangle's vertex list.
      for (auto& t : shuffled.triangles) std::rotate(t.begin(), t.begin() + 1, t.end());
      Model s = makeModel(shuffled, p);
      EXPECT_EQ(s.ff->numActiveSprings(), m.ff->numActiveSprings());
      const std::vector<double> x = test::perturbed(m.rest, 0.4, 17);
      std::vector<double> xs(x.size());
      for (std::size_t i = 0; i < newOfOld.size(); ++i) {
        for (int k = 0; k < 3; ++k) xs[3 * newOfOld[i].idx() + k] = x[3 * i + k];
      }
      const std::vector<double> f = test::forceAt(*m.ff, x), fs = test::forceAt(*s.ff, xs);
      double err = 0.0;
      for (std::size_t i = 0; i < newOfOld.size(); ++i) {
        for (int k = 0; k < 3; ++k)
          err = std::max(err, std::fabs(f[3 * i + k] - fs[3 * newOfOld[i].idx() + k]));
      }
      EXPECT_LE(err, 1e-12 * std::max(1.0, maxAbs(f)));
      EXPECT_NEAR(m.ff->potentialEnergy(x), s.ff->potentialEnergy(xs),
                  1e-12 * m.ff->potentialEnergy(x));
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Signed weights: flat rest is force-free, convex or not

TEST(BendingSprings, SignedWeightsFlatRestIsForceFree) {
  const std::vector<std::pair<std::string, MeshData>> flat = {
      {"grid9_jitter", test::grid(9, 10.0, 0.45, 4)},
      {"grid7x6_alt_jitter", topology::readMesh(std::string(CUTSIM_TEST_DATA_DIR) +
                                                "/sofa-reference/grid7x6_alt_jitter_rest.obj")},
      {"hingeNC", test::oneHinge(kNA, kNB, kNC, kND)}};
  for (const auto& [name, mesh] : flat) {
    SCOPED_TRACE(name);
    BendingParameters p;
    p.areaWeights = AreaWeights::Signed;
    Model sgn = makeModel(mesh, p);
    Model uns = makeModel(mesh);
    const std::vector<double> fs = test::forceAt(*sgn.ff, sgn.rest);
    const std::vector<double> fu = test::forceAt(*uns.ff, uns.rest);
    double lambdaMax = 0.0;
    for (std::size_t i = 0; i < uns.ff->numActiveSprings(); ++i) {
      lambdaMax = std::max(lambdaMax, uns.ff->springRecord(i).lambda);
    }
    EXPECT_LE(maxAbs(fs), 1e-12 * lambdaMax) << "signed weights leave a rest force";
    EXPECT_GT(maxAbs(fu), 1e-6) << "expected a non-convex hinge in this mesh";
    for (std::size_t i = 2; i < fu.size(); i += 3) EXPECT_EQ(fu[i], 0.0);  // in-plane
    EXPECT_EQ(sgn.ff->counters().signedFallbacks, 0u);
    // The rest force vanishes also after a rigid motion.
    EXPECT_LE(maxAbs(test::forceAt(*sgn.ff, rigidMotion(sgn.rest, 5))), 1e-11 * lambdaMax);
  }
}

TEST(BendingKernel, SignedFallsBackWhenFoldedOrFarAway) {
  // Folded onto itself: NA_vec + NB_vec = 0.
  const Vec3 c{0, 0, 0}, d{1, 0, 0};
  HingeWeights w = computeHinge({0.3, -1, 0}, {0.6, -1, 0}, c, d, 1.0, 1e-6, AreaWeights::Signed);
  ASSERT_EQ(w.status, HingeStatus::Active);
  EXPECT_TRUE(w.signedFallback);
  const HingeWeights u =
      computeHinge({0.3, -1, 0}, {0.6, -1, 0}, c, d, 1.0, 1e-6, AreaWeights::Unsigned);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(w.alpha[i], u.alpha[i]);
  // The diagonal meets the edge's line at x = -20: signed weights -21 and 20.
  w = computeHinge({-20, -1, 0}, {-20, 1, 0}, c, d, 1.0, 1e-6, AreaWeights::Signed);
  EXPECT_TRUE(w.signedFallback);
  // At x = -5: weights -6 and 5, no fallback.
  w = computeHinge({-5, -1, 0}, {-5, 1, 0}, c, d, 1.0, 1e-6, AreaWeights::Signed);
  EXPECT_FALSE(w.signedFallback);
  EXPECT_NEAR(w.alpha[2], -6.0, 1e-13);
  EXPECT_NEAR(w.alpha[3], 5.0, 1e-13);

  BendingParameters p;
  p.areaWeights = AreaWeights::Signed;
  Model m = makeModel(test::oneHinge({-20, -1, 0}, {-20, 1, 0}, c, d), p);
  EXPECT_EQ(m.ff->counters().signedFallbacks, 1u);
  EXPECT_EQ(m.ff->numActiveSprings(), 1u);
  EXPECT_TRUE(
      m.ff->hinge(m.topo->findEdge(topology::PointId(2), topology::PointId(3))).signedFallback);
}

// ---------------------------------------------------------------------------------------------
// Degenerate hinges: deactivated, counted, never NaN

TEST(BendingKernel, DegenerateHingesAreDeactivated) {
  const Vec3 c{0, 0, 0}, d{1, 0, 0}, a{0.3, -1, 0}, b{0.6, 2, 0};
  const auto status = [](const Vec3& pa, const Vec3& pb, const Vec3& pc, const Vec3& pd,
                         double eps) {
    for (AreaWeights aw : {AreaWeights::Unsigned, AreaWeights::Signed}) {
      const HingeWeights w = computeHinge(pa, pb, pc, pd, 1.0, eps, aw);
      if (w.status != HingeStatus::Active) {
        EXPECT_EQ(w.lambda, 0.0);
        for (double al : w.alpha) EXPECT_EQ(al, 0.0);
      }
      for (double al : w.alpha) EXPECT_TRUE(std::isfinite(al));
      EXPECT_TRUE(std::isfinite(w.lambda));
    }
    return computeHinge(pa, pb, pc, pd, 1.0, eps, AreaWeights::Unsigned).status;
  };
  EXPECT_EQ(status(a, a, c, d, 1e-6), HingeStatus::ShortWingDistance);
  EXPECT_EQ(status(a, a, c, d, 0.0), HingeStatus::ShortWingDistance);
  EXPECT_EQ(status({0.5, -1, 0}, {0.5, 1, 0}, c, c, 0.0), HingeStatus::ShortEdge);
  EXPECT_EQ(status({0.5, 0, 0}, b, c, d, 0.0), HingeStatus::SmallHeight);  // A on the line CD
  EXPECT_EQ(status({0.5, 1e-7, 0}, b, c, d, 1e-6), HingeStatus::SmallHeight);
  EXPECT_EQ(status({0.5, 1e-7, 0}, b, c, d, 0.0), HingeStatus::Active);
  EXPECT_EQ(status({2.0, 0, 0}, {-1.0, 0, 0}, c, d, 0.0), HingeStatus::SmallHeight);  // collinear
  // Validity is strict: a wing distance equal to eps deactivates.
  EXPECT_EQ(status({0, -0.5, 0}, {0, 0.5, 0}, c, d, 1.0), HingeStatus::ShortWingDistance);
  // Extreme scales: no overflow, no division by zero.
  const double t = 1e-152;
  EXPECT_EQ(status({0.3 * t, -t, 0}, {0.6 * t, 2 * t, 0}, c, {t, 0, 0}, 0.0),
            HingeStatus::Unrepresentable);
  const double s = 1e-100;
  EXPECT_EQ(status({0.3 * s, -s, 0}, {0.6 * s, 2 * s, 0}, c, {s, 0, 0}, 0.0), HingeStatus::Active);
  const double g = 1e80;
  EXPECT_EQ(status({0.3 * g, -g, 0}, {0.6 * g, 2 * g, 0}, c, {g, 0, 0}, 0.0),
            HingeStatus::Unrepresentable);
  EXPECT_EQ(status(a, b, c, d, 1e300), HingeStatus::ShortWingDistance);
}

TEST(BendingSprings, AHugeStiffnessStaysActiveWhileItsEnergyFitsADouble) {
  // A bending stiffness of 1e300 on a unit hinge: lambda about 1.3e300, an energy that fits a
  // double. The spring stays active and the energy is 1e300 times that at k = 1 (the energy is
  // linear in k); at 1e307 lambda leaves the range and the hinge is counted as unrepresentable.
  MeshData m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {0.3, -1, 0}, {0.6, 1, 0.2}};
  m.triangles = {tri(0, 1, 2), tri(1, 0, 3)};
  topology::Topology t(m);
  std::vector<double> x;
  for (const auto& p : m.points) x.insert(x.end(), p.begin(), p.end());
  x[11] = 0.7;  // the wing D lifted: bent
  auto evaluate = [&](double k, std::size_t* active, std::size_t* unrepresentable) {
    BendingParameters params;
    params.bendingStiffness = k;
    FastTriangularBendingSprings f(t, params);
    *active = f.numActiveSprings();
    *unrepresentable = f.counters().unrepresentable;
    std::vector<double> force(x.size(), 0.0), v(x.size(), 0.0);
    f.addForce(x, v, force);
    for (double fi : force) EXPECT_TRUE(std::isfinite(fi)) << "k = " << k;
    return f.potentialEnergy(x);
  };
  std::size_t active = 0, unrepresentable = 0;
  const double unit = evaluate(1.0, &active, &unrepresentable);
  ASSERT_EQ(active, 1u);
  ASSERT_GT(unit, 0.0);
  const double huge = evaluate(1e300, &active, &unrepresentable);
  EXPECT_EQ(active, 1u);
  EXPECT_EQ(unrepresentable, 0u);
  EXPECT_TRUE(std::isfinite(huge));
  EXPECT_NEAR(huge / unit, 1e300, 1e-12 * 1e300);
  evaluate(1e307, &active, &unrepresentable);
  EXPECT_EQ(active, 0u);
  EXPECT_EQ(unrepresentable, 1u);
}

TEST(BendingSprings, DegenerateHingesAreCounted) {
  // A strip of hinges: one healthy, one with coincident wings, one with a zero-height wing.
  MeshData m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {0.3, -1, 0}, {0.6, 2, 0},   // healthy hinge 0-1
              {3, 0, 0}, {4, 0, 0}, {3.5, 1, 0},  {3.5, 1, 0},   // coincident wings
              {6, 0, 0}, {7, 0, 0}, {6.5, 0, 0},  {6.5, 1, 0}};  // zero height
  m.triangles = {tri(0, 1, 3), tri(1, 0, 2),  tri(4, 5, 6),
                 tri(5, 4, 7), tri(8, 9, 11), tri(9, 8, 10)};
  Model md = makeModel(m);
  const BendingCounters& c = md.ff->counters();
  EXPECT_EQ(c.activeSprings, 1u);
  EXPECT_EQ(c.shortWingDistance, 1u);
  EXPECT_EQ(c.smallHeight, 1u);
  EXPECT_EQ(c.degenerate(), 2u);
  EXPECT_EQ(c.noHinge, 12u);
  EXPECT_EQ(md.ff->hinge(md.topo->findEdge(topology::PointId(4), topology::PointId(5))).status,
            HingeStatus::ShortWingDistance);
  EXPECT_EQ(md.ff->hinge(md.topo->findEdge(topology::PointId(8), topology::PointId(9))).status,
            HingeStatus::SmallHeight);
  const std::vector<double> x = test::perturbed(md.rest, 0.3, 8);
  const std::vector<double> f = test::forceAt(*md.ff, x);
  for (double v : f) EXPECT_TRUE(std::isfinite(v));
  EXPECT_TRUE(std::isfinite(md.ff->potentialEnergy(x)));
  expectFieldValid(md);
}

// ---------------------------------------------------------------------------------------------
// Parameters

TEST(BendingParameters, BadValuesAreRejectedNamingTheParameter) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (const char* name : {"bendingStiffness", "minDistValidity", "rayleighStiffness"}) {
    for (double bad : {-1.0, -1e-300, nan, inf, -inf}) {
      BendingParameters p;
      double& field = std::string(name) == "bendingStiffness"  ? p.bendingStiffness
                      : std::string(name) == "minDistValidity" ? p.minDistValidity
                                                               : p.rayleighStiffness;
      field = bad;
      try {
        p.validate();
        ADD_FAILURE() << name << " accepted a bad value";
      } catch (const InvalidInput& e) {
        EXPECT_EQ(e.where(), name);
        EXPECT_NE(std::string(e.what()).find(name), std::string::npos);
      }
      Topology topo(test::grid(3).points, test::grid(3).triangles);
      EXPECT_THROW(FastTriangularBendingSprings(topo, p), InvalidInput);
      EXPECT_EQ(topo.numObservers(), 0u);
    }
  }
  BendingParameters ok;
  ok.bendingStiffness = 0.0;
  ok.minDistValidity = 0.0;
  EXPECT_NO_THROW(ok.validate());
  try {
    BendingParameters p;
    p.bendingStiffness = nan;
    p.validate();
  } catch (const InvalidInput& e) {
    EXPECT_NE(e.message().find("nan"), std::string::npos) << e.message();
  }
}

TEST(BendingParameters, AreaWeightsByName) {
  EXPECT_EQ(parseAreaWeights("unsigned"), AreaWeights::Unsigned);
  EXPECT_EQ(parseAreaWeights("signed"), AreaWeights::Signed);
  for (const char* bad : {"", "Signed", "area", "unsigned "}) {
    try {
      parseAreaWeights(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.where(), "areaWeights");
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Damping, drawing, sizes

TEST(BendingSprings, RayleighDampingIsConsistent) {
  BendingParameters p;
  p.rayleighStiffness = 0.3;
  const MeshData mesh = test::grid(5, 10.0, 0.3, 2);
  Model m = makeModel(mesh, p);
  const std::size_t n = mesh.points.size();
  const std::vector<double> x = test::perturbed(m.rest, 0.5, 3);
  const Eigen::MatrixXd k = test::assembledK(*m.ff, x, n);
  TripletAccumulator accB;
  m.ff->addBToMatrix(x, accB, 2.0);
  const Eigen::MatrixXd b(accB.toSparse(static_cast<Index>(n)));
  double diffB = 0.0;
  for (Eigen::Index i = 0; i < k.rows(); ++i) {
    for (Eigen::Index j = 0; j < k.cols(); ++j) {
      diffB = std::max(diffB, std::fabs(b(i, j) - 0.6 * k(i, j)));
    }
  }
  EXPECT_LE(diffB, 1e-14 * maxAbsCoeff(k));

  const std::vector<double> dx = test::perturbed(std::vector<double>(x.size(), 0.0), 1.0, 4);
  std::vector<double> df(x.size(), 0.0);
  m.ff->addDForce(x, dx, df, 0.5, 2.0);
  std::vector<double> ref = times(k, dx);
  for (double& r : ref) r *= 1.1;
  double err = 0.0;
  for (std::size_t i = 0; i < df.size(); ++i) err = std::max(err, std::fabs(df[i] - ref[i]));
  EXPECT_LE(err, 1e-12 * maxAbs(ref));

  // Without the component's factor, B is empty and bFactor does not change dForce.
  Model m0 = makeModel(mesh);
  TripletAccumulator acc0;
  m0.ff->addBToMatrix(x, acc0, 2.0);
  EXPECT_TRUE(acc0.triplets().empty());
  std::vector<double> d1(x.size(), 0.0), d2(x.size(), 0.0);
  m0.ff->addDForce(x, dx, d1, 0.5, 0.0);
  m0.ff->addDForce(x, dx, d2, 0.5, 7.0);
  EXPECT_EQ(d1, d2);
  // No velocity-dependent force.
  std::vector<double> f1(x.size(), 0.0), f2(x.size(), 0.0);
  const std::vector<double> v = test::perturbed(std::vector<double>(x.size(), 0.0), 3.0, 5);
  m.ff->addForce(x, std::vector<double>(x.size(), 0.0), f1);
  m.ff->addForce(x, v, f2);
  EXPECT_EQ(f1, f2);
}

TEST(BendingSprings, ZeroStiffnessKeepsTheHingesAndGivesNoForce) {
  BendingParameters p;
  p.bendingStiffness = 0.0;
  Model m = makeModel(test::oneHinge(kHA, kHB, kHC, kHD), p);
  ASSERT_EQ(m.ff->numActiveSprings(), 1u);
  const HingeRecord h = m.ff->hinge(m.topo->findEdge(topology::PointId(2), topology::PointId(3)));
  EXPECT_EQ(h.lambda, 0.0);
  EXPECT_NEAR(weightMap(h).at(PointId(0)), 2.0 / 3.0, 1e-15);
  const std::vector<double> x = test::perturbed(m.rest, 0.5, 1);
  EXPECT_EQ(maxAbs(test::forceAt(*m.ff, x)), 0.0);
  EXPECT_EQ(m.ff->potentialEnergy(x), 0.0);
  expectFieldValid(m);
}

TEST(BendingSprings, StiffnessScalesLinearly) {
  const MeshData mesh = test::grid(6, 10.0, 0.3, 9);
  BendingParameters p1, p2;
  p2.bendingStiffness = 3.5;
  Model m1 = makeModel(mesh, p1), m2 = makeModel(mesh, p2);
  const std::vector<double> x = test::perturbed(m1.rest, 0.5, 2);
  const std::vector<double> f1 = test::forceAt(*m1.ff, x), f2 = test::forceAt(*m2.ff, x);
  for (std::size_t i = 0; i < f1.size(); ++i) EXPECT_NEAR(f2[i], 3.5 * f1[i], 1e-13 * maxAbs(f2));
  for (EdgeId e : m1.topo->edges()) {
    const HingeRecord a = m1.ff->hinge(e), b = m2.ff->hinge(e);
    EXPECT_NEAR(b.lambda, 3.5 * a.lambda, 1e-13 * b.lambda);
  }
}

TEST(BendingSprings, DrawsOneSegmentPerSpringBetweenTheWings) {
  Model m = makeModel(test::grid(4));
  std::vector<std::array<PointId, 2>> seg;
  m.ff->draw(seg);
  ASSERT_EQ(seg.size(), m.ff->numActiveSprings());
  for (std::size_t i = 0; i < seg.size(); ++i) {
    const BendingSpring& s = m.ff->activeSprings()[i];
    EXPECT_EQ(seg[i][0].idx(), s.v[0]);
    EXPECT_EQ(seg[i][1].idx(), s.v[1]);
    EXPECT_TRUE(m.topo->findEdge(seg[i][0], seg[i][1]).idx() == topology::kInvalidIndex);
  }
  EXPECT_EQ(m.ff->typeName(), "FastTriangularBendingSprings");
}

TEST(BendingSprings, WrongVectorSizesAreRefused) {
  Model m = makeModel(test::grid(3));
  std::vector<double> small(3), f(m.rest.size(), 0.0);
  EXPECT_THROW(m.ff->addForce(small, small, f), std::invalid_argument);
  EXPECT_THROW(m.ff->potentialEnergy(small), std::invalid_argument);
}

TEST(BendingSprings, SubscriptionEndsWithTheField) {
  Topology topo(test::grid(3).points, test::grid(3).triangles);
  {
    FastTriangularBendingSprings ff(topo, {});
    EXPECT_EQ(topo.numObservers(), 1u);
    std::vector<std::string> problems;
    ff.validate(topo, problems);
    EXPECT_TRUE(problems.empty());
  }
  EXPECT_EQ(topo.numObservers(), 0u);
}

}  // namespace
}  // namespace cutsim::forcefields
