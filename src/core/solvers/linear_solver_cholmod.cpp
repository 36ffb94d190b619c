// CholmodSolver: supernodal Cholesky of the system assembled in place (linear_solver.hpp).
#include <dlfcn.h>

#include <Eigen/CholmodSupport>
#include <Eigen/SparseCore>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/core/linear_solver.hpp"
#include "solvers/system_matrix.hpp"

namespace cutsim::core {

using Vec = Eigen::VectorXd;

void pinBlasThreads() {
  static bool done = false;
  if (done) return;
  done = true;
  using SetThreads = void (*)(int);
  if (auto fn = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads")))
    fn(1);
  if (auto fn = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "omp_set_num_threads"))) fn(1);
}

void CholmodSettings::validate() const {
  if (shortLivedPattern < 0)
    throw InvalidInput("shortLivedPattern",
                       "must be >= 0 (got " + std::to_string(shortLivedPattern) + ")");
  if (reorderAfter < 1)
    throw InvalidInput("reorderAfter", "must be >= 1 (got " + std::to_string(reorderAfter) + ")");
}

struct CholmodSolver::Impl {
  Impl() {
    // The system matrix is numbered in a fill-reducing order already (METIS on the point graph):
    // CHOLMOD keeps it (only postordering its elimination tree, which changes no fill).
    cholmod.cholmod().nmethods = 1;
    cholmod.cholmod().method[0].ordering = CHOLMOD_NATURAL;
    // CHOLMOD's own messages stay off stderr ("matrix not positive definite" in the middle of a
    // progress display): the solver's status says it, and a step whose matrix was not positive
    // definite is flagged (`indefinite`), counted and reported by the run.
    cholmod.cholmod().print = 0;
  }
  Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Lower> cholmod;
  SystemMatrix system;
  std::uint64_t revision = 0;   // the revision the pattern was built for
  SystemMatrix::Fields fields;  // the fields it was built for
  int solvesOnPattern = 0;
  bool analysed = false;
  long analyses = 0;
  // Restored from a checkpoint: the pattern the saved solver kept (built again at the next
  // solve, in the same ordering, when the topology is still the one it was built for).
  bool restored = false;
  SystemMatrix::Ordering restoredOrdering = SystemMatrix::Ordering::NestedDissection;
  std::size_t restoredSlots = 0;
};

CholmodSolver::CholmodSolver(CholmodSettings settings)
    : settings_(settings), impl_(std::make_unique<Impl>()) {
  settings_.validate();
}
CholmodSolver::~CholmodSolver() = default;

long CholmodSolver::analyses() const {
  return impl_->analyses;
}

SolveReport CholmodSolver::solve(const SystemOperator& A, const Vec& b, Vec& dv) {
  pinBlasThreads();
  Impl& S = *impl_;
  const std::size_t n = A.numSlots();
  const SystemMatrix::Fields fl(A.fields().begin(), A.fields().end());
  // The pattern follows the topology and the list of fields; a field that adds a block outside
  // it (it should not) gets the pattern rediscovered, once.
  using Ordering = SystemMatrix::Ordering;
  // A restored solver decides as the saved one would have, with the pattern it kept.
  const bool built = S.system.built() || S.restored;
  const Ordering kept = S.restored ? S.restoredOrdering : S.system.ordering();
  bool rebuild = S.restored ? (S.revision != A.revision() || S.restoredSlots != n)
                            : (!S.system.built() || S.revision != A.revision() || S.fields != fl ||
                               S.system.numSlots() != n);
  // Nested dissection costs more to compute but factorises faster: worth it for a pattern that
  // lasts. A pattern that lasted only a few solves (a progressive cut) is followed by
  // minimum-degree ones, until one of those has lasted long enough to be worth reordering.
  Ordering ordering = Ordering::NestedDissection;
  if (rebuild && built && S.solvesOnPattern < settings_.shortLivedPattern)
    ordering = Ordering::MinimumDegree;
  if (!rebuild && kept == Ordering::MinimumDegree && S.solvesOnPattern >= settings_.reorderAfter)
    rebuild = true;
  if (rebuild) S.solvesOnPattern = 0;
  ++S.solvesOnPattern;
  if (S.restored && !rebuild) {
    // The kept pattern, built again in its ordering (its age goes on).
    S.system.build(fl, A.x(), n, kept);
    S.fields = fl;
    S.analysed = false;
  }
  S.restored = false;
  for (int attempt = 0;; ++attempt) {
    if (rebuild) {
      S.system.build(fl, A.x(), n, ordering);
      S.revision = A.revision();
      S.fields = fl;
      S.analysed = false;
    }
    if (S.system.fill(fl, A.x(), A.kFactor(), A.bFactor(), A.diagonalMass())) break;
    if (attempt > 0)
      throw SolverError("internal error: a force field's matrix blocks left the pattern it gave");
    rebuild = true;
  }
  const std::vector<char> constrained(A.constrained().begin(), A.constrained().end());
  const Vec rhs = S.system.eliminate(constrained, b, dv);
  auto& M = S.system.matrix();
  SolveReport report;
  report.iterations = 1;
  if (!S.analysed) {
    S.cholmod.analyzePattern(M);
    S.analysed = true;
    report.analysed = true;
    ++S.analyses;
  }
  S.cholmod.factorize(M);
  const double bNorm = A.freeRhs(b, dv).stableNorm();
  if (S.cholmod.info() != Eigen::Success) {
    report.indefinite = true;
    report.converged = false;
    report.residual = bNorm > 0 ? 1.0 : 0.0;  // dv unchanged: the residual of the guess is unknown
    return report;
  }
  dv = S.system.toOriginal(S.cholmod.solve(rhs));
  Vec check;
  A.apply(dv, check);
  Vec res = b - check;
  A.project(res);
  report.residual = bNorm > 0 ? res.stableNorm() / bNorm : 0.0;
  if (S.system.approximate() && bNorm > 0) {
    // Contact pairs outside the kept pattern were lumped onto the diagonal (a matrix above the
    // system's): conjugate gradients on the true system, preconditioned by the factorisation,
    // bring the solve to rounding in a few iterations, and the symbolic analysis is kept.
    auto precondition = [&](const Vec& r) {
      Vec rp(r.size());
      const auto& idx = S.system.newIndex();
      for (std::size_t p = 0; p < n; ++p)
        rp.segment<3>(3 * Eigen::Index(idx[p])) = r.segment<3>(3 * Eigen::Index(p));
      Vec z = S.system.toOriginal(S.cholmod.solve(rp));
      A.project(z);
      return z;
    };
    Vec z = precondition(res), p = z, Ap;
    double rz = res.dot(z);
    for (int it = 0; it < 100 && report.residual > 1e-12; ++it) {
      A.apply(p, Ap);
      A.project(Ap);
      const double pAp = p.dot(Ap);
      if (!(pAp > 0)) break;
      const double alpha = rz / pAp;
      dv += alpha * p;
      res -= alpha * Ap;
      report.residual = res.stableNorm() / bNorm;
      ++report.iterations;
      z = precondition(res);
      const double rzNew = res.dot(z);
      p = z + (rzNew / rz) * p;
      rz = rzNew;
    }
  }
  // A direct solve is converged unless rounding went wrong (a nearly singular matrix).
  report.converged = std::isfinite(report.residual) && report.residual <= 1e-6;
  return report;
}

}  // namespace cutsim::core

// ---- registration ----
#include "cutsim/core/registries.hpp"

namespace cutsim::core {
namespace {
const bool registered = LinearSolverRegistry::instance().add(
    {"cholmod",
     "supernodal Cholesky (CHOLMOD) in a kept pattern, ordered by METIS: exact solves",
     {{"shortLivedPattern", KeyType::Integer,
       "solves under which a replaced pattern counts as short-lived (default 10)"},
      {"reorderAfter", KeyType::Integer,
       "solves on a minimum-degree pattern before reordering by METIS (default 20)"}},
     {},
     [](const ParameterSource& s) -> std::any {
       CholmodSettings p;
       p.shortLivedPattern = int(s.integer("shortLivedPattern", 0, 1000000, p.shortLivedPattern));
       p.reorderAfter = int(s.integer("reorderAfter", 1, 1000000, p.reorderAfter));
       s.check([&] { p.validate(); });
       return p;
     },
     [](const std::any& p) -> std::unique_ptr<LinearSolver> {
       return std::make_unique<CholmodSolver>(std::any_cast<const CholmodSettings&>(p));
     }});
}  // namespace
void CholmodSolver::saveState(ArchiveWriter& out) const {
  const Impl& S = *impl_;
  const bool built = S.system.built() || S.restored;
  out.boolean(built);
  out.u64(S.restored ? std::uint64_t(S.restoredOrdering) : std::uint64_t(S.system.ordering()));
  out.u64(S.revision);
  out.u64(S.restored ? S.restoredSlots : (S.system.built() ? S.system.numSlots() : 0));
  out.i64(S.solvesOnPattern);
}

void CholmodSolver::loadState(ArchiveReader& in) {
  Impl& S = *impl_;
  S.restored = in.boolean();
  const std::uint64_t ordering = in.u64();
  if (ordering > 1) in.fail("cholmod: an ordering of " + std::to_string(ordering));
  S.restoredOrdering = SystemMatrix::Ordering(ordering);
  S.revision = in.u64();
  S.restoredSlots = std::size_t(in.u64());
  S.solvesOnPattern = int(in.i64());
}

}  // namespace cutsim::core
