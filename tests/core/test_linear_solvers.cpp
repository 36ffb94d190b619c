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
    for (Eigen::Index j = 0; j < F; ++j)
      Mff(i, j) = M(freeDofs[std::size_t(i)], freeDofs[std::size_t(j)]);
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

namespace cutsim::test {
namespace {

using core::SofaCGSettings;
using core::SofaConjugateGradient;
using core::SolveReport;

/// The textbook CG, SOFA's loop written out plainly on the dense free block (zero initial guess,
/// no preconditioner, at most `cap` updates): the brute-force twin of SofaConjugateGradient.
Eigen::VectorXd textbookCG(const SystemOperator& A, const Eigen::VectorXd& b, int cap) {
  const Eigen::MatrixXd M = dense(A);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(A.size()), r = b;
  A.project(r);
  Eigen::VectorXd p = r;
  double rho = r.dot(r);
  for (int k = 0; k < cap; ++k) {
    Eigen::VectorXd q = M * p;
    A.project(q);
    const double alpha = rho / p.dot(q);
    x += alpha * p;
    r -= alpha * q;
    const double next = r.dot(r);
    p = r + (next / rho) * p;
    rho = next;
  }
  return x;
}

TEST(SofaCG, TakesSofasStepsAndStopsAtItsCap) {
  System s;
  const SystemOperator A = s.op(0.05);
  const Problem p = problem(A);
  for (int cap : {1, 3, 12}) {
    SofaConjugateGradient cg(SofaCGSettings{cap, 1e-14, 0.0, false});
    VectorXd dv = VectorXd::Zero(A.size());
    const SolveReport r = cg.solve(A, p.b, dv);
    EXPECT_EQ(r.iterations, cap);
    EXPECT_FALSE(r.converged);  // capped above its tolerance: reported
    EXPECT_EQ(cg.lastStop(), "iterations");
    const VectorXd twin = textbookCG(A, p.b, cap);
    EXPECT_LT((dv - twin).norm(), 1e-10 * twin.norm()) << cap;
  }
}

TEST(SofaCG, ConvergesToTheDenseSolveAndStopsOnItsTolerance) {
  System s;
  const SystemOperator A = s.op();
  const Problem p = problem(A);
  const VectorXd prescribedZero = VectorXd::Zero(A.size());
  const VectorXd expected = bruteForce(A, p.b, prescribedZero);
  SofaConjugateGradient cg(SofaCGSettings{5000, 1e-12, 0.0, false});
  VectorXd warmup = VectorXd::Zero(A.size());
  cg.solve(A, p.b, warmup);  // the first solve of all never stops on its first iteration
  VectorXd dv = VectorXd::Zero(A.size());
  const SolveReport r = cg.solve(A, p.b, dv);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(cg.lastStop(), "tolerance");
  EXPECT_LE(r.residual, 1e-12);
  EXPECT_LT((dv - expected).norm(), 1e-9 * expected.norm());
  // SOFA's threshold: an absolute bound on p^T A p, tested before the update.
  SofaConjugateGradient th(SofaCGSettings{5000, 1e-14, 1e300, false});
  VectorXd a = VectorXd::Zero(A.size()), b2 = VectorXd::Zero(A.size());
  th.solve(A, p.b, a);  // first solve: the first iteration is exempt
  EXPECT_EQ(th.solve(A, p.b, b2).iterations, 0);
  EXPECT_EQ(th.lastStop(), "threshold");
  EXPECT_THROW(SofaConjugateGradient(SofaCGSettings{0, 1e-5, 1e-5, false}), InvalidInput);
  EXPECT_THROW(SofaConjugateGradient(SofaCGSettings{10, 1e-5, -1, false}), InvalidInput);
}

}  // namespace
}  // namespace cutsim::test
