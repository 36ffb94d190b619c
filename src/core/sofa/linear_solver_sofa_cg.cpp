// SOFA's CGLinearSolver, step for step (linear_solver.hpp).
#include <cmath>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/core/linear_solver.hpp"

namespace cutsim::core {

using Vec = Eigen::VectorXd;

void SofaCGSettings::validate() const {
  if (maxIterations < 1)
    throw InvalidInput("iterations", "must be >= 1 (got " + std::to_string(maxIterations) + ")");
  requireRelativeTolerance("tolerance", tolerance);
  requireFiniteNonNegative("threshold", threshold);
}

SofaConjugateGradient::SofaConjugateGradient(SofaCGSettings settings) : settings_(settings) {
  settings_.validate();
}

SolveReport SofaConjugateGradient::solve(const SystemOperator& A, const Vec& b, Vec& dv) {
  const Eigen::Index N = A.size();
  const std::size_t n = A.numSlots();
  if (b.size() != N || dv.size() != N)
    throw InvalidInput("linear system",
                       "the right-hand side and the unknowns must have 3 entries per point slot");
  const bool firstSolve = solves_++ == 0;
  // The free points start from zero (SOFA clears x) or from the last solve; the constrained ones
  // keep their prescribed values (zero for SOFA's projective constraints), moved to the right.
  Vec r;
  if (settings_.warmStart && warm_.size() == N) {
    for (std::size_t p = 0; p < n; ++p)
      if (!A.isConstrained(p))
        dv.segment<3>(Eigen::Index(3 * p)) = warm_.segment<3>(Eigen::Index(3 * p));
    Vec Ax;
    A.apply(dv, Ax);
    r = b - Ax;
    A.project(r);
  } else {
    for (std::size_t p = 0; p < n; ++p)
      if (!A.isConstrained(p)) dv.segment<3>(Eigen::Index(3 * p)).setZero();
    r = A.freeRhs(b, dv);
  }
  const double normb = A.freeRhs(b, dv).norm();  // SOFA: |b|, b projected
  SolveReport report;
  lastStop_ = "iterations";
  Vec p, q;
  double rho = r.dot(r), rho1 = 0.0;
  if (normb != 0.0) {
    for (int it = 1; it <= settings_.maxIterations; ++it) {
      rho = r.dot(r);
      if (std::sqrt(rho) / normb <= settings_.tolerance && !(it == 1 && firstSolve)) {
        lastStop_ = "tolerance";
        break;
      }
      if (it == 1)
        p = r;
      else
        p = r + (rho / rho1) * p;
      A.apply(p, q);
      A.project(q);
      const double den = p.dot(q);
      if (den == 0.0) {
        lastStop_ = "zero-denominator";
        break;
      }
      if (std::abs(den) <= settings_.threshold && !(it == 1 && firstSolve)) {
        lastStop_ = "threshold";
        break;
      }
      if (den < 0) report.indefinite = true;
      const double alpha = rho / den;
      dv += alpha * p;
      r -= alpha * q;
      rho1 = rho;
      ++report.iterations;
    }
  } else {
    lastStop_ = "zero-rhs";
  }
  const double rNorm = r.norm();
  report.residual = normb > 0 ? rNorm / normb : rNorm;
  report.converged = std::isfinite(rNorm) && report.residual <= settings_.tolerance;
  report.residualEnergy = A.residualKineticEnergy(r);
  warm_ = dv;
  return report;
}

}  // namespace cutsim::core

// ---- registration ----
#include "cutsim/core/registries.hpp"

namespace cutsim::core {
namespace {
const bool registered = LinearSolverRegistry::instance().add(
    {"sofa-cg",
     "SOFA's CGLinearSolver step for step: no preconditioner, zero initial guess, its tolerance "
     "and threshold tests",
     {{"iterations", KeyType::Integer, "iteration cap, >= 1 (default 25)"},
      {"tolerance", KeyType::Number, "|r| / |b| to stop at, > 0 (default 1e-5)"},
      {"threshold", KeyType::Number, "stop when |p^T A p| <= threshold, >= 0 (default 1e-5)"},
      {"warmStart", KeyType::Boolean, "start from the previous solve's result (default false)"}},
     {},
     [](const ParameterSource& s) -> std::any {
       SofaCGSettings p;
       p.maxIterations = int(s.integer("iterations", 1, 1000000, p.maxIterations));
       p.tolerance = s.positive("tolerance", p.tolerance);
       p.threshold = s.nonNegative("threshold", p.threshold);
       p.warmStart = s.boolean("warmStart", p.warmStart);
       s.check([&] { p.validate(); });
       return p;
     },
     [](const std::any& p) -> std::unique_ptr<LinearSolver> {
       return std::make_unique<SofaConjugateGradient>(std::any_cast<const SofaCGSettings&>(p));
     }});
}  // namespace

// (lastStop() describes the last solve only: not kept.)
void SofaConjugateGradient::saveState(ArchiveWriter& out) const {
  fields(out, warm_);
}
void SofaConjugateGradient::loadState(ArchiveReader& in) {
  fields(in, warm_);
}

}  // namespace cutsim::core
