// SystemOperator and the Jacobi-preconditioned conjugate gradients (linear_solver.hpp).
#include "cutsim/core/linear_solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/base/parallel.hpp"

namespace cutsim::core {

using Vec = Eigen::VectorXd;

namespace {

// The conjugate gradients' vector work, in blocks of kBlock entries split among the threads
// (cutsim::inParts): an update writes each entry from entries of the same index; a sum adds the
// blocks' partial sums (Eigen's, on each block) in the blocks' order. The same bits for any
// number of threads.
constexpr Eigen::Index kBlock = 4096;
constexpr std::size_t kMinEntriesPerPart = 8192;  // (a part's work: a few microseconds)

/// f(block, begin, length) for every block of [0, n), the blocks in parts on the threads.
template <class F>
void overBlocks(Eigen::Index n, F&& f) {
  const std::size_t blocks = std::size_t((n + kBlock - 1) / kBlock);
  inParts(blocks, partsFor(std::size_t(n), kMinEntriesPerPart),
          [&](int, std::size_t b0, std::size_t b1) {
            for (std::size_t b = b0; b < b1; ++b) {
              const Eigen::Index begin = Eigen::Index(b) * kBlock;
              f(b, begin, std::min(kBlock, n - begin));
            }
          });
}

double sumInOrder(const std::vector<double>& partial) {
  double s = 0.0;
  for (double v : partial) s += v;
  return s;
}

/// a . b by blocks.
double dot(const Vec& a, const Vec& b, std::vector<double>& partial) {
  partial.assign(std::size_t((a.size() + kBlock - 1) / kBlock), 0.0);
  overBlocks(a.size(), [&](std::size_t k, Eigen::Index i, Eigen::Index len) {
    partial[k] = a.segment(i, len).dot(b.segment(i, len));
  });
  return sumInOrder(partial);
}

/// |r| from its squared norm summed by blocks; where that sum may have lost the norm (underflow,
/// overflow) the scaled norm (Eigen's stableNorm), so that no range of doubles breaks it.
double normOf(const Vec& r, double squared) {
  if (squared > 1e-280 && squared < 1e280) return std::sqrt(squared);
  return r.stableNorm();
}

}  // namespace

LinearSolver::~LinearSolver() = default;

SystemOperator::SystemOperator(std::span<forcefields::ForceField* const> fields,
                               std::span<const double> x, std::span<const double> diagonalMass,
                               std::span<const char> constrained, double kFactor, double bFactor,
                               std::uint64_t revision)
    : fields_(fields),
      x_(x),
      mass_(diagonalMass),
      constrained_(constrained),
      kFactor_(kFactor),
      bFactor_(bFactor),
      revision_(revision) {
  if (x.size() != 3 * mass_.size() || constrained.size() != mass_.size())
    throw InvalidInput("linear system",
                       "x, mass and constraint flags must cover the same point slots");
  for (std::size_t k = 0; k < fields_.size(); ++k) {
    try {
      fields_[k]->beginProducts(x_);
    } catch (...) {
      while (k-- > 0) fields_[k]->endProducts(x_);
      throw;
    }
  }
}

SystemOperator::~SystemOperator() {
  for (auto* f : fields_) f->endProducts(x_);
}

void SystemOperator::apply(const Vec& p, Vec& out) const {
  const Eigen::Index N = size();
  out.resize(N);
  if (scratch_.size() != N) scratch_.resize(N);
  Vec& df = scratch_;
  df.setZero();
  std::span<double> dfs(df.data(), std::size_t(N));
  std::span<const double> ps(p.data(), std::size_t(N));
  for (auto* f : fields_) f->addDForce(x_, ps, dfs, kFactor_, bFactor_);
  // out = M p - df, the points in parts on the threads (each entry its own: the same bits).
  inParts(mass_.size(), partsFor(std::size_t(N), kMinEntriesPerPart),
          [&](int, std::size_t begin, std::size_t end) {
            for (std::size_t q = begin; q < end; ++q)
              for (int c = 0; c < 3; ++c) {
                const Eigen::Index i = Eigen::Index(3 * q + c);
                const double mp = mass_[q] * p[i];
                out[i] = mp - df[i];
              }
          });
}

Vec SystemOperator::diagonal() const {
  forcefields::DiagonalAccumulator diagK(size());
  for (auto* f : fields_) {
    f->addKToMatrix(x_, diagK, -kFactor_);
    f->addBToMatrix(x_, diagK, -bFactor_);
  }
  for (std::size_t q = 0; q < mass_.size(); ++q)
    for (int c = 0; c < 3; ++c) diagK.diagonal[Eigen::Index(3 * q + c)] += mass_[q];
  return diagK.diagonal;
}

void SystemOperator::project(Vec& a) const {
  for (std::size_t p = 0; p < constrained_.size(); ++p)
    if (constrained_[p]) a.segment<3>(Eigen::Index(3 * p)).setZero();
}

double SystemOperator::residualKineticEnergy(const Vec& r) const {
  constexpr double inf = std::numeric_limits<double>::infinity();
  if (!r.array().isFinite().all()) return std::numeric_limits<double>::quiet_NaN();
  // Scaled by the largest entry: residuals up to the range of doubles square without overflow
  // (an energy beyond that range is infinite).
  const double scale = r.cwiseAbs().maxCoeff();
  if (scale == 0) return 0.0;
  if (scale > 1e150) return inf;
  double e = 0.0;
  for (std::size_t p = 0; p < constrained_.size(); ++p)
    if (!constrained_[p] && mass_[p] > 0)
      e += (r.segment<3>(Eigen::Index(3 * p)) / scale).squaredNorm() / mass_[p];
  const double s2 = scale * scale;  // (may underflow: then the product is small)
  if (s2 >= 1 && e > std::numeric_limits<double>::max() / s2) return inf;
  return 0.5 * e * s2;
}

Vec SystemOperator::freeRhs(const Vec& b, const Vec& dv) const {
  Vec rhs = b;
  bool prescribed = false;
  for (std::size_t p = 0; p < constrained_.size() && !prescribed; ++p)
    if (constrained_[p]) prescribed = dv.segment<3>(Eigen::Index(3 * p)).squaredNorm() > 0;
  if (prescribed) {
    Vec only = Vec::Zero(size()), Ap;
    for (std::size_t p = 0; p < constrained_.size(); ++p)
      if (constrained_[p])
        only.segment<3>(Eigen::Index(3 * p)) = dv.segment<3>(Eigen::Index(3 * p));
    apply(only, Ap);
    rhs -= Ap;
  }
  project(rhs);
  return rhs;
}

void CGSettings::validate() const {
  if (maxIterations < 1)
    throw InvalidInput("iterations", "must be >= 1 (got " + std::to_string(maxIterations) + ")");
  requireRelativeTolerance("tolerance", tolerance);
}

ConjugateGradient::ConjugateGradient(CGSettings settings) : settings_(settings) {
  settings_.validate();
}

SolveReport ConjugateGradient::solve(const SystemOperator& A, const Vec& b, Vec& dv) {
  const Eigen::Index N = A.size();
  const std::size_t n = A.numSlots();
  if (b.size() != N || dv.size() != N)
    throw InvalidInput("linear system",
                       "the right-hand side and the unknowns must have 3 entries per point slot");
  // Norms scaled (stableNorm): entries up to the range of doubles do not overflow them.
  const double bNorm = A.freeRhs(b, dv).stableNorm();
  if (settings_.warmStart && warm_.size() == N)
    for (std::size_t p = 0; p < n; ++p)
      if (!A.isConstrained(p))
        dv.segment<3>(Eigen::Index(3 * p)) = warm_.segment<3>(Eigen::Index(3 * p));
  // Jacobi preconditioner (zero on the constrained points and where the diagonal is not positive).
  Vec invDiag = A.diagonal();
  for (std::size_t p = 0; p < n; ++p)
    for (int c = 0; c < 3; ++c) {
      double& d = invDiag[Eigen::Index(3 * p + c)];
      d = A.isConstrained(p) || !(d > 0) ? 0.0 : 1.0 / d;
    }
  Vec Ap;
  A.apply(dv, Ap);
  Vec r = b - Ap;
  A.project(r);
  Vec z = invDiag.cwiseProduct(r);
  Vec pdir = z;
  std::vector<double> partial, partialRR;
  double rz = dot(r, z, partial);
  double rNorm = normOf(r, dot(r, r, partial));
  SolveReport report;
  const double stop = settings_.tolerance * std::max(bNorm, 1e-300);
  const Eigen::Index blocks = (N + kBlock - 1) / kBlock;
  while (report.iterations < settings_.maxIterations && rNorm > stop) {
    A.apply(pdir, Ap);
    A.project(Ap);
    const double pAp = dot(pdir, Ap, partial);
    if (!(pAp > 0)) {  // not positive definite along pdir (or a zero direction): stop
      report.indefinite = true;
      break;
    }
    const double alpha = rz / pAp;
    // One pass: dv += alpha p, r -= alpha Ap, z = D^-1 r, and the blocks' r.z and r.r.
    partial.assign(std::size_t(blocks), 0.0);
    partialRR.assign(std::size_t(blocks), 0.0);
    overBlocks(N, [&](std::size_t k, Eigen::Index i, Eigen::Index len) {
      dv.segment(i, len) += alpha * pdir.segment(i, len);
      r.segment(i, len) -= alpha * Ap.segment(i, len);
      z.segment(i, len) = invDiag.segment(i, len).cwiseProduct(r.segment(i, len));
      partial[k] = r.segment(i, len).dot(z.segment(i, len));
      partialRR[k] = r.segment(i, len).squaredNorm();
    });
    const double rzNew = sumInOrder(partial);
    const double beta = rzNew / rz;
    overBlocks(N, [&](std::size_t, Eigen::Index i, Eigen::Index len) {
      pdir.segment(i, len) = z.segment(i, len) + beta * pdir.segment(i, len);
    });
    rz = rzNew;
    rNorm = normOf(r, sumInOrder(partialRR));
    ++report.iterations;
  }
  // Relative to the work the solve had; with none (b = 0 on the free points, nothing prescribed)
  // the absolute residual, which is what any guess left over.
  report.residual = bNorm > 0 ? rNorm / bNorm : rNorm;
  report.converged = std::isfinite(rNorm) && rNorm <= stop;
  if (bNorm == 0 && rNorm == 0) report.converged = true;
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
    {"cg",
     "Jacobi-preconditioned conjugate gradients, matrix-free (SOFA's CGLinearSolver)",
     {{"iterations", KeyType::Integer, "iteration cap, >= 1 (default 100)"},
      {"tolerance", KeyType::Number, "relative residual to stop at, > 0 (default 1e-8)"},
      {"warmStart", KeyType::Boolean, "start from the previous solve's result (default true)"}},
     {},
     [](const ParameterSource& s) -> std::any {
       CGSettings p;
       p.maxIterations = int(s.integer("iterations", 1, 1000000, p.maxIterations));
       p.tolerance = s.positive("tolerance", p.tolerance);
       p.warmStart = s.boolean("warmStart", p.warmStart);
       s.check([&] { p.validate(); });
       return p;
     },
     [](const std::any& p) -> std::unique_ptr<LinearSolver> {
       return std::make_unique<ConjugateGradient>(std::any_cast<const CGSettings&>(p));
     }});
}  // namespace

// (one member: fields() names it for both directions)
void ConjugateGradient::saveState(ArchiveWriter& out) const {
  fields(out, warm_);
}
void ConjugateGradient::loadState(ArchiveReader& in) {
  fields(in, warm_);
}

}  // namespace cutsim::core
