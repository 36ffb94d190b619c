// The CHOLMOD system matrix assembled in place (src/core/solvers/system_matrix.hpp) against its
// brute-force twin: the fields' triplets summed into a dense matrix, the mass added, the
// constrained points eliminated row by row. And the solver's reuse of pattern and analysis.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "../../src/core/solvers/system_matrix.hpp"
#include "cutsim/core/simulation.hpp"
#include "cutsim/core/state.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/forcefields/stretch_springs.hpp"
#include "cutsim/forcefields/triangular_fem.hpp"
#include "support/fixtures.hpp"

namespace cutsim::test {
namespace {

using core::SystemMatrix;
using topology::Topology;
using topology::Vec3;

struct Fixture {
  Topology topo{grid(6, 1.0)};
  core::MechanicalState state{topo};
  std::vector<std::unique_ptr<forcefields::ForceField>> owned;
  SystemMatrix::Fields fields;
  std::mt19937_64 rng{5};

  Fixture() {
    forcefields::BendingParameters b;
    b.bendingStiffness = 0.3;
    b.rayleighStiffness = 0.02;
    owned.push_back(std::make_unique<forcefields::FastTriangularBendingSprings>(topo, b));
    forcefields::StretchParameters s;
    s.stiffness = 50.0;
    s.damping = 0.4;
    owned.push_back(std::make_unique<forcefields::StretchSprings>(topo, s));
    owned.push_back(
        std::make_unique<forcefields::TriangularFEM>(topo, forcefields::TriangularFEMParameters{}));
    for (auto& f : owned) fields.push_back(f.get());
    jiggle();
  }

  /// Random displacements, so that stretch and membrane stiffness are not trivial.
  void jiggle() {
    std::uniform_real_distribution<double> u(-0.03, 0.03);
    auto x = state.x();
    for (double& c : x) c += u(rng);
  }

  /// The brute-force twin: dense A and rhs after eliminating the constrained points.
  std::pair<Eigen::MatrixXd, Eigen::VectorXd> bruteForce(double kFactor, double bFactor,
                                                         const std::vector<double>& mass,
                                                         const std::vector<char>& constrained,
                                                         const Eigen::VectorXd& rhs,
                                                         const Eigen::VectorXd& dv) {
    const std::size_t n = state.numSlots();
    forcefields::TripletAccumulator acc;
    for (auto* f : fields) {
      f->addKToMatrix(state.x(), acc, -kFactor);
      f->addBToMatrix(state.x(), acc, -bFactor);
    }
    Eigen::MatrixXd A = Eigen::MatrixXd(acc.toSparse(topology::Index(n)));
    for (std::size_t p = 0; p < n; ++p)
      for (int c = 0; c < 3; ++c) A(Eigen::Index(3 * p + c), Eigen::Index(3 * p + c)) += mass[p];
    Eigen::VectorXd b = rhs;
    const Eigen::Index N = A.rows();
    for (Eigen::Index i = 0; i < N; ++i)
      for (Eigen::Index j = 0; j < N; ++j)
        if (!constrained[std::size_t(i / 3)] && constrained[std::size_t(j / 3)])
          b[i] -= A(i, j) * dv[j];
    for (Eigen::Index i = 0; i < N; ++i)
      if (constrained[std::size_t(i / 3)]) {
        A.row(i).setZero();
        A.col(i).setZero();
        A(i, i) = 1.0;
        b[i] = dv[i];
      }
    return {A, b};
  }
};

/// The in-place matrix (lower triangle, permuted numbering), as a dense symmetric matrix in the
/// original numbering.
Eigen::MatrixXd unpermuted(SystemMatrix& S) {
  const Eigen::MatrixXd L = Eigen::MatrixXd(S.matrix());
  const Eigen::MatrixXd P = L + L.transpose() - Eigen::MatrixXd(L.diagonal().asDiagonal());
  const auto& idx = S.newIndex();
  Eigen::MatrixXd out(P.rows(), P.cols());
  for (std::size_t p = 0; p < idx.size(); ++p)
    for (std::size_t q = 0; q < idx.size(); ++q)
      out.block<3, 3>(Eigen::Index(3 * p), Eigen::Index(3 * q)) =
          P.block<3, 3>(3 * Eigen::Index(idx[p]), 3 * Eigen::Index(idx[q]));
  return out;
}

void expectSameAsBruteForce(Fixture& f, SystemMatrix::Ordering ordering,
                            const std::vector<char>& constrained) {
  const std::size_t n = f.state.numSlots();
  const Eigen::Index N = Eigen::Index(3 * n);
  std::uniform_real_distribution<double> u(0.5, 2.0);
  std::vector<double> mass(n);
  for (double& m : mass) m = u(f.rng);
  const Eigen::VectorXd rhs = Eigen::VectorXd::Random(N), dv = Eigen::VectorXd::Random(N);
  const double kFactor = 0.013, bFactor = 0.1;

  SystemMatrix S;
  S.build(f.fields, f.state.x(), n, ordering);
  ASSERT_TRUE(S.fill(f.fields, f.state.x(), kFactor, bFactor, mass));
  Eigen::VectorXd b = S.eliminate(constrained, rhs, dv);
  auto [A, bRef] = f.bruteForce(kFactor, bFactor, mass, constrained, rhs, dv);

  const Eigen::MatrixXd mine = unpermuted(S);
  EXPECT_LE((mine - A).cwiseAbs().maxCoeff(), 1e-12 * A.cwiseAbs().maxCoeff());
  const Eigen::VectorXd bMine = S.toOriginal(b);
  EXPECT_LE((bMine - bRef).cwiseAbs().maxCoeff(), 1e-12 * (1 + bRef.cwiseAbs().maxCoeff()));
  // The numbering is a permutation of the point slots.
  std::vector<int> seen(n, 0);
  for (auto i : S.newIndex()) ++seen[std::size_t(i)];
  for (int s : seen) EXPECT_EQ(s, 1);
}

TEST(SystemMatrix, EqualsTheBruteForceAssemblyWithBothOrderings) {
  for (auto ordering :
       {SystemMatrix::Ordering::NestedDissection, SystemMatrix::Ordering::MinimumDegree}) {
    Fixture f;
    std::vector<char> constrained(f.state.numSlots(), 0);
    expectSameAsBruteForce(f, ordering, constrained);
    constrained[0] = constrained[5] = constrained[17] = 1;  // fixed and grasped points
    for (std::size_t p = 0; p < constrained.size(); ++p)
      if (!f.topo.isPointAlive(topology::PointId(p))) constrained[p] = 1;  // headroom slots
    expectSameAsBruteForce(f, ordering, constrained);
  }
}

TEST(SystemMatrix, FollowsACutAndNoticesAStalePattern) {
  Fixture f;
  const std::size_t n = f.state.numSlots();
  SystemMatrix S;
  S.build(f.fields, f.state.x(), n, SystemMatrix::Ordering::NestedDissection);
  std::vector<double> mass(n, 1.0);
  ASSERT_TRUE(S.fill(f.fields, f.state.x(), 0.01, 0.1, mass));
  // A cut inserts points and couples new pairs: the old pattern cannot hold them.
  f.topo.cutPolyline(std::vector<Vec3>{{0.05, 0.43, 0}, {0.71, 0.57, 0}});
  std::vector<double> mass2(f.state.numSlots(), 1.0);
  EXPECT_FALSE(S.fill(f.fields, f.state.x(), 0.01, 0.1, mass2));
  std::vector<char> constrained(f.state.numSlots(), 0);
  for (std::size_t p = 0; p < constrained.size(); ++p)
    if (!f.topo.isPointAlive(topology::PointId(p))) constrained[p] = 1;
  expectSameAsBruteForce(f, SystemMatrix::Ordering::MinimumDegree, constrained);
  expectSameAsBruteForce(f, SystemMatrix::Ordering::NestedDissection, constrained);
}

TEST(SystemMatrix, SolverReusesTheAnalysisAcrossConstraintsAndReordersAfterProgressiveCuts) {
  auto sim = std::make_unique<core::Simulation>(std::make_unique<Topology>(grid(12, 1.0)), 1.0);
  core::SolverSettings s;
  s.kind = core::SolverSettings::Kind::ImplicitCholmod;
  sim->setSolver(s);
  forcefields::StretchParameters sp;
  sp.stiffness = 100.0;
  sim->addForceField(std::make_unique<forcefields::StretchSprings>(sim->topology(), sp));
  sim->addForceField(std::make_unique<forcefields::FastTriangularBendingSprings>(
      sim->topology(), forcefields::BendingParameters{}));
  sim->setGravity({0, 0, -9.81});
  sim->fixed().add(topology::PointId(0));
  EXPECT_TRUE(sim->step(0.01).analysed);  // the first step analyses
  EXPECT_FALSE(sim->step(0.01).analysed);
  // Constraints change values, not the pattern: no new analysis.
  sim->fixed().add(topology::PointId(11));
  core::DisplacementPath path;
  path.times = {0.0, 1.0};
  path.displacements = {{0, 0, 0}, {0, 0, 0.1}};
  std::vector<topology::PointId> grasped{topology::PointId(143)};
  sim->addGrasp("pull", grasped, path);
  EXPECT_FALSE(sim->step(0.01).analysed);
  sim->releaseGrasp("pull");
  EXPECT_FALSE(sim->step(0.01).analysed);
  // A progressive cut: a short piece every step, each a new pattern.
  for (int k = 0; k < 5; ++k) {
    const double x0 = 0.05 + 0.15 * k;
    sim->topology().cutPolyline(std::vector<Vec3>{{x0, 0.52, 0}, {x0 + 0.15, 0.52, 0}});
    const auto stats = sim->step(0.01);
    EXPECT_TRUE(stats.analysed) << "cut " << k;
    EXPECT_LT(stats.residual, 1e-9) << "cut " << k;  // the factorisation solves the system
  }
  // Once the topology rests, the quick (minimum-degree) pattern is reordered once, then kept.
  int analyses = 0;
  for (int i = 0; i < 40; ++i) {
    const auto stats = sim->step(0.01);
    analyses += stats.analysed ? 1 : 0;
    EXPECT_LT(stats.residual, 1e-9) << "step " << i;
  }
  EXPECT_EQ(analyses, 1);
  for (double c : sim->state().x()) ASSERT_TRUE(std::isfinite(c));
}

}  // namespace
}  // namespace cutsim::test
