#pragma once
// Linear solvers of the implicit integrators, behind one interface.
//
// Every implicit step of cutsim solves one system of the same shape,
//
//   A dv = b,   A = diag(m') - kFactor K(x) - bFactor B(x),
//
// over the free degrees of freedom of the model (m' is the lumped mass scaled by the integrator,
// K = dF/dx and B = dF/dv summed over the force fields, NSD as SOFA's). A constrained point's
// three unknowns are prescribed: dv there is given and never changed, its rows are dropped and its
// columns move to the right-hand side. SystemOperator describes A without assembling it; a
// LinearSolver solves with it, matrix-free (ConjugateGradient) or assembled (CholmodSolver).
// Residuals are relative to the norm of the free unknowns' right-hand side, b - A dv_prescribed
// over the free degrees of freedom (SystemOperator::freeRhs).
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "cutsim/forcefields/force_field.hpp"

namespace cutsim::core {

/// The system matrix A of one solve, matrix-free.
class SystemOperator {
 public:
  /// fields: the model's force fields; x: positions at which K and B are taken (3 doubles per
  /// point slot); diagonalMass: m' per point slot; constrained: per point slot, 1 if its dv is
  /// prescribed (also every point with m' <= 0); revision: a number that changes whenever the
  /// pattern of K may change (the topology's revision), for solvers that keep a factorisation.
  SystemOperator(std::span<forcefields::ForceField* const> fields, std::span<const double> x,
                 std::span<const double> diagonalMass, std::span<const char> constrained,
                 double kFactor, double bFactor, std::uint64_t revision);
  /// x must not change while the operator lives: the fields are told so
  /// (ForceField::beginProducts) and may skip checking it at every product.
  ~SystemOperator();
  SystemOperator(const SystemOperator&) = delete;
  SystemOperator& operator=(const SystemOperator&) = delete;

  std::size_t numSlots() const { return mass_.size(); }
  Eigen::Index size() const { return Eigen::Index(3 * mass_.size()); }
  /// out = A p (every entry, constrained rows included). Not for concurrent calls on one
  /// operator (it keeps its scratch vector).
  void apply(const Eigen::VectorXd& p, Eigen::VectorXd& out) const;
  /// The diagonal of A, gathered from the fields' blocks without assembling the matrix.
  Eigen::VectorXd diagonal() const;
  /// Zeroes the entries of the constrained points.
  void project(Eigen::VectorXd& a) const;
  /// The right-hand side of the free unknowns once the prescribed ones (dv's entries on the
  /// constrained points) are moved over: b - A dv_prescribed on the free points, zero elsewhere.
  /// Residuals are relative to its norm (a grasp that drives a resting sheet has b = 0 there).
  Eigen::VectorXd freeRhs(const Eigen::VectorXd& b, const Eigen::VectorXd& dv) const;
  bool isConstrained(std::size_t point) const { return constrained_[point] != 0; }
  /// The kinetic energy a residual r of A dv = b (a momentum per point) would carry:
  /// 1/2 sum over the free points of |r_p|^2 / m'_p. When A >= M' (stiffness and damping that
  /// add to the mass), it bounds the kinetic energy of the solve's error, 1/2 |A^-1 r|^2_M'.
  double residualKineticEnergy(const Eigen::VectorXd& r) const;

  std::span<forcefields::ForceField* const> fields() const { return fields_; }
  std::span<const double> x() const { return x_; }
  std::span<const double> diagonalMass() const { return mass_; }
  std::span<const char> constrained() const { return constrained_; }
  double kFactor() const { return kFactor_; }
  double bFactor() const { return bFactor_; }
  std::uint64_t revision() const { return revision_; }

 private:
  std::span<forcefields::ForceField* const> fields_;
  std::span<const double> x_, mass_;
  std::span<const char> constrained_;
  double kFactor_, bFactor_;
  std::uint64_t revision_;
  mutable Eigen::VectorXd scratch_;  // apply()'s df (one apply at a time on an operator)
};

/// What one solve did.
struct SolveReport {
  int iterations = 0;  ///< CG iterations; 1 for a direct solve
  double residual =
      0.0;  ///< |b - A dv| / |freeRhs| over the free degrees of freedom (0 if that is 0)
  bool converged = true;  ///< the residual met the solver's tolerance
  bool indefinite =
      false;  ///< CG met p^T A p <= 0, or the factorisation found A not positive definite
  bool analysed = false;  ///< a direct solver redid its symbolic analysis
  /// An iterative solver's SystemOperator::residualKineticEnergy of its final residual (J): what
  /// the error of dv may carry (ImplicitIntegrator::solve's check); 0 from a direct solver.
  double residualEnergy = 0.0;
};

class LinearSolver {
 public:
  virtual ~LinearSolver();
  /// The registered name ("cg", "cholmod").
  virtual std::string_view name() const = 0;
  /// Whether it solves to rounding (a factorisation) rather than iterating to a tolerance.
  virtual bool direct() const = 0;
  /// Solves A dv = b on the free degrees of freedom. On entry dv holds the prescribed values on
  /// the constrained points (kept) and a starting guess elsewhere (an iterative solver may use
  /// it); b has size A.size(). Never throws for a system it cannot solve: it says so in the
  /// report (the integrator's failure policy decides).
  virtual SolveReport solve(const SystemOperator& A, const Eigen::VectorXd& b,
                            Eigen::VectorXd& dv) = 0;
  /// Checkpoints: whether the solver saves what its next solves depend on (a warm start, the
  /// ordering of a kept pattern); saveState and loadState write and read it in the open section.
  virtual bool checkpointable() const { return false; }
  virtual void saveState(ArchiveWriter& /*out*/) const {}
  virtual void loadState(ArchiveReader& /*in*/) {}
};

/// Jacobi-preconditioned conjugate gradients, matrix-free (SOFA's CGLinearSolver, with a
/// preconditioner). Stops when |r| <= tolerance |b| or after maxIterations, or when it meets a
/// direction of non-positive curvature (reported as indefinite).
struct CGSettings {
  int maxIterations = 100;  ///< >= 1
  double tolerance = 1e-8;  ///< relative residual to stop at, > 0
  bool warmStart = true;    ///< start from the previous solve's dv on the free points
  /// Throws InvalidInput (where = the setting's name) for values out of range.
  void validate() const;
};

class ConjugateGradient final : public LinearSolver {
 public:
  explicit ConjugateGradient(CGSettings settings = {});
  std::string_view name() const override { return "cg"; }
  bool direct() const override { return false; }
  SolveReport solve(const SystemOperator& A, const Eigen::VectorXd& b,
                    Eigen::VectorXd& dv) override;
  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override;
  void loadState(ArchiveReader& in) override;
  const CGSettings& settings() const { return settings_; }

 private:
  CGSettings settings_;
  Eigen::VectorXd warm_;
};

/// SOFA's CGLinearSolver, step for step, for scenes that must give what SOFA gives: no
/// preconditioner, a zero initial guess on the free points (warmStart: the previous solve's),
/// at most `iterations` products A p; it stops when |r| <= tolerance |b| (tested before each
/// product, from the second iteration on) or when |p^T A p| <= threshold (an absolute test, before
/// the update) or p^T A p = 0. As in SOFA the very first solve tests neither on its first
/// iteration. A stop above the tolerance (the cap, the threshold) is reported (converged false),
/// never failed here; a negative p^T A p is followed as SOFA follows it, and reported (indefinite).
struct SofaCGSettings {
  int maxIterations = 25;   ///< SOFA's `iterations`, >= 1
  double tolerance = 1e-5;  ///< SOFA's `tolerance`, > 0
  double threshold = 1e-5;  ///< SOFA's `threshold`, >= 0
  bool warmStart = false;   ///< SOFA's `warmStart`
  void validate() const;
};

class SofaConjugateGradient final : public LinearSolver {
 public:
  explicit SofaConjugateGradient(SofaCGSettings settings = {});
  std::string_view name() const override { return "sofa-cg"; }
  bool direct() const override { return false; }
  SolveReport solve(const SystemOperator& A, const Eigen::VectorXd& b,
                    Eigen::VectorXd& dv) override;
  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override;
  void loadState(ArchiveReader& in) override;
  const SofaCGSettings& settings() const { return settings_; }
  /// How the last solve ended: "tolerance", "threshold", "iterations" (the cap),
  /// "zero-denominator", "zero-rhs".
  std::string_view lastStop() const { return lastStop_; }

 private:
  SofaCGSettings settings_;
  Eigen::VectorXd warm_;
  long solves_ = 0;
  std::string_view lastStop_ = "";
};

/// Supernodal Cholesky (CHOLMOD) of A assembled in place in a kept pattern: the pattern and its
/// symbolic analysis are redone only when A.revision() or the fields change. Points are numbered
/// by METIS nested dissection of the point graph; while the pattern changes every few steps (a
/// progressive cut) a cheaper minimum-degree numbering is used, and a pattern that then rests
/// reorderAfter solves is numbered again by nested dissection.
struct CholmodSettings {
  int shortLivedPattern = 10;  ///< a pattern replaced within this many solves counts as short-lived
  int reorderAfter = 20;       ///< solves on a minimum-degree pattern before reordering it
  void validate() const;
};

class CholmodSolver final : public LinearSolver {
 public:
  explicit CholmodSolver(CholmodSettings settings = {});
  ~CholmodSolver() override;
  std::string_view name() const override { return "cholmod"; }
  bool direct() const override { return true; }
  SolveReport solve(const SystemOperator& A, const Eigen::VectorXd& b,
                    Eigen::VectorXd& dv) override;
  /// Saves the kept pattern's ordering, revision and age: restored, the pattern is built again
  /// in that ordering at the next solve (the factorisation, and so the rounding, are the same).
  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override;
  void loadState(ArchiveReader& in) override;
  /// Symbolic analyses done so far, for tests of the reuse policy.
  long analyses() const;

 private:
  struct Impl;
  CholmodSettings settings_;
  std::unique_ptr<Impl> impl_;
};

/// OpenBLAS and OpenMP (which CHOLMOD uses) would pick their thread counts from the machine; one
/// thread keeps results identical from run to run. Called once, by the first direct solve.
void pinBlasThreads();

}  // namespace cutsim::core
