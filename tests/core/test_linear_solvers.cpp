// Each linear solver on its own, without a scene: a system operator over real force fields at a
// deformed state, against a dense brute-force solve; the reports of capped, indefinite and
// reused solves.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "cutsim/core/linear_solver.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/forcefields/stretch_springs.hpp"
#include "support/fixtures.hpp"

namespace cutsim::test {
namespace {

using core::CGSettings;
using core::CholmodSolver;
using core::ConjugateGradient;
using core::SystemOperator;
using Eigen::VectorXd;

/// A 6 x 6 sheet with stretch and bending springs at a random deformation, some points fixed.
struct System {
  topology::Topology topo{grid(6, 1.0)};
  std::unique_ptr<forcefields::StretchSprings> stretch;
  std::unique_ptr<forcefields::FastTriangularBendingSprings> bending;
  std::vector<forcefields::ForceField*> fields;
  std::vector<double> x, mass;
  std::vector<char> constrained;
  std::uint64_t revision = 1;

  explicit System(double massScale = 1.0) {
    forcefields::StretchParameters sp;
    sp.stiffness = 300.0;
    sp.damping = 0.5;
    stretch = std::make_unique<forcefields::StretchSprings>(topo, sp);
    forcefields::BendingParameters bp;
    bp.bendingStiffness = 2.0;
    bending = std::make_unique<forcefields::FastTriangularBendingSprings>(topo, bp);
    fields = {stretch.get(), bending.get()};
    const std::size_t n = topo.pointCapacity();
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-0.03, 0.03);
    for (std::size_t p = 0; p < n; ++p) {
      const auto r = topo.restPosition(topology::PointId(p));
      for (int c = 0; c < 3; ++c) x.push_back(r[c] * (c == 0 ? 1.1 : 1.0) + u(rng));
    }
    mass.assign(n, massScale * 0.02);
    constrained.assign(n, 0);
    constrained[0] = constrained[5] = 1;
  }
  SystemOperator op(double h = 0.01) const {
    return SystemOperator(fields, x, mass, constrained, h * h, h, revision);
  }
};

/// The dense matrix of A (applied to the unit vectors).
Eigen::MatrixXd dense(const SystemOperator& A) {
  const Eigen::Index N = A.size();
  Eigen::MatrixXd M(N, N);
  VectorXd e = VectorXd::Zero(N), col;
  for (Eigen::Index i = 0; i < N; ++i) {
    e[i] = 1.0;
    A.apply(e, col);
    M.col(i) = col;
    e[i] = 0.0;
  }
  return M;
}

/// The brute-force twin: eliminate the prescribed unknowns and solve the free block densely.
VectorXd bruteForce(const SystemOperator& A, const VectorXd& b, const VectorXd& prescribed) {
  const Eigen::MatrixXd M = dense(A);
  std::vector<Eigen::Index> freeDofs;
  for (std::size_t p = 0; p < A.numSlots(); ++p)
    if (!A.isConstrained(p))
      for (int c = 0; c < 3; ++c) freeDofs.push_back(Eigen::Index(3 * p + c));
  const Eigen::Index F = Eigen::Index(freeDofs.size());
  Eigen::MatrixXd Mff(F, F);
  VectorXd rhs(F);
  const VectorXd bc = b - M * prescribed;
  for (Eigen::Index i = 0; i < F; ++i) {
    rhs[i] = bc[freeDofs[std::size_t(i)]];
    for (Eigen::Index j = 0; j < F; ++j) Mff(i, j) = M(freeDofs[std::size_t(i)], freeDofs[std::size_t(j)]);
  }
  const VectorXd xf = Mff.ldlt().solve(rhs);
  VectorXd out = prescribed;
  for (Eigen::Index i = 0; i < F; ++i) out[freeDofs[std::size_t(i)]] = xf[i];
  return out;
}

struct Problem {
  VectorXd b, prescribed;
};
Problem problem(const SystemOperator& A) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g;
  Problem p{VectorXd(A.size()), VectorXd::Zero(A.size())};
  for (Eigen::Index i = 0; i < A.size(); ++i) p.b[i] = g(rng);
  for (std::size_t q = 0; q < A.numSlots(); ++q)
    if (A.isConstrained(q))
      for (int c = 0; c < 3; ++c) p.prescribed[Eigen::Index(3 * q + c)] = 0.1 * g(rng);
  return p;
}

TEST(SystemOperator, DiagonalIsTheDenseMatrixDiagonalAndTheMatrixIsSymmetric) {
  System s;
  const SystemOperator A = s.op();
  const Eigen::MatrixXd M = dense(A);
  EXPECT_LT((M - M.transpose()).norm(), 1e-12 * M.norm());
  EXPECT_LT((A.diagonal() - M.diagonal()).norm(), 1e-12 * M.diagonal().norm());
}

TEST(LinearSolvers, BothMatchTheDenseSolveWithPrescribedPoints) {
  System s;
  const SystemOperator A = s.op();
  const Problem p = problem(A);
  const VectorXd expected = bruteForce(A, p.b, p.prescribed);
  ConjugateGradient cg(CGSettings{2000, 1e-13, false});
  CholmodSolver cholmod;
  for (core::LinearSolver* solver : std::initializer_list<core::LinearSolver*>{&cg, &cholmod}) {
    SCOPED_TRACE(std::string(solver->name()));
    VectorXd dv = p.prescribed;
    const core::SolveReport r = solver->solve(A, p.b, dv);
    EXPECT_TRUE(r.converged);
    EXPECT_FALSE(r.indefinite);
    EXPECT_LT(r.residual, 1e-11);
    EXPECT_LT((dv - expected).norm(), 1e-9 * expected.norm());
    // The prescribed entries are kept exactly.
    for (std::size_t q = 0; q < A.numSlots(); ++q) {
      if (!A.isConstrained(q)) continue;
      for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(dv[Eigen::Index(3 * q + c)], p.prescribed[Eigen::Index(3 * q + c)]);
      }
    }
  }
}

TEST(LinearSolvers, ACappedCGSaysItMissedItsTolerance) {
  System s;
  const SystemOperator A = s.op(0.05);
  const Problem p = problem(A);
  ConjugateGradient cg(CGSettings{3, 1e-10, false});
  VectorXd dv = p.prescribed;
  const core::SolveReport r = cg.solve(A, p.b, dv);
  EXPECT_EQ(r.iterations, 3);
  EXPECT_FALSE(r.converged);
  EXPECT_GT(r.residual, 1e-10);
  // The reported residual is the true one, relative to the free unknowns' right-hand side
  // (b less the prescribed unknowns' columns), computed here from the dense matrix.
  const Eigen::MatrixXd M = dense(A);
  VectorXd res = p.b - M * dv, bf = p.b - M * p.prescribed;
  A.project(res);
  A.project(bf);
  EXPECT_NEAR(r.residual, res.norm() / bf.norm(), 1e-12);
}

TEST(LinearSolvers, AnIndefiniteSystemIsReportedNotSolvedSilently) {
  System s(-1.0);  // negative masses: A is indefinite
  const SystemOperator A = s.op(1e-4);
  const Problem p = problem(A);
  ConjugateGradient cg(CGSettings{100, 1e-10, false});
  VectorXd dv = p.prescribed;
  EXPECT_TRUE(cg.solve(A, p.b, dv).indefinite);
  CholmodSolver cholmod;
  dv = p.prescribed;
  const core::SolveReport r = cholmod.solve(A, p.b, dv);
  EXPECT_TRUE(r.indefinite);
  EXPECT_FALSE(r.converged);
}

TEST(LinearSolvers, CholmodKeepsItsAnalysisUntilTheRevisionChanges) {
  System s;
  CholmodSolver cholmod;
  const Problem p = problem(s.op());
  for (int i = 0; i < 3; ++i) {
    s.x[3 * 7] += 0.01;  // new values, same pattern
    VectorXd dv = p.prescribed;
    const core::SolveReport r = cholmod.solve(s.op(), p.b, dv);
    EXPECT_EQ(r.analysed, i == 0);
    EXPECT_LT(r.residual, 1e-11);
  }
  EXPECT_EQ(cholmod.analyses(), 1);
  s.revision = 2;  // the topology changed
  VectorXd dv = p.prescribed;
  EXPECT_TRUE(cholmod.solve(s.op(), p.b, dv).analysed);
  EXPECT_EQ(cholmod.analyses(), 2);
}

TEST(LinearSolvers, CGWarmStartsFromItsLastSolution) {
  System s;
  const SystemOperator A = s.op();
  const Problem p = problem(A);
  ConjugateGradient cg(CGSettings{2000, 1e-10, true});
  VectorXd dv = p.prescribed;
  const int cold = cg.solve(A, p.b, dv).iterations;
  dv = p.prescribed;
  const int warm = cg.solve(A, p.b, dv).iterations;
  EXPECT_GT(cold, 5);
  EXPECT_LE(warm, 1);
}

// A resting system driven only by its prescribed points (a grasp that starts): b is zero on the
// free points, yet the solve has work to do, and its residual is measured against that work.
TEST(LinearSolvers, ResidualsAreRelativeToTheWorkThePrescribedPointsMake) {
  System s;
  const SystemOperator A = s.op();
  Problem p = problem(A);
  p.b.setZero();
  const VectorXd expected = bruteForce(A, p.b, p.prescribed);
  ConjugateGradient cg(CGSettings{2000, 1e-10, false});
  CholmodSolver cholmod;
  for (core::LinearSolver* solver : std::initializer_list<core::LinearSolver*>{&cg, &cholmod}) {
    SCOPED_TRACE(std::string(solver->name()));
    VectorXd dv = p.prescribed;
    const core::SolveReport r = solver->solve(A, p.b, dv);
    EXPECT_TRUE(r.converged);
    EXPECT_LT(r.residual, 1e-9);
    EXPECT_LT((dv - expected).norm(), 1e-7 * expected.norm());
  }
}

TEST(LinearSolvers, SettingsOutOfRangeAreRejected) {
  EXPECT_THROW(ConjugateGradient(CGSettings{0, 1e-8, true}), InvalidInput);
  EXPECT_THROW(ConjugateGradient(CGSettings{10, 0.0, true}), InvalidInput);
  EXPECT_THROW(CholmodSolver(core::CholmodSettings{10, 0}), InvalidInput);
}

}  // namespace
}  // namespace cutsim::test
