#pragma once
// Integrators: how a step of a model is taken (the interface and what the implicit ones share;
// each method's class in its own header, cutsim/core/integrators/: explicit_euler.hpp,
// implicit_euler.hpp, bdf2.hpp, newton.hpp; each registered by name in its source file). Each one
// reads the model (forces, their derivatives, the potential energy, the masses) and the step's
// constraints, and returns the new positions and velocities; the Simulation commits them after its
// finiteness checks.
//
//   explicit-euler   symplectic Euler: v += h M^-1 f(x, v), x += h v. Conditionally stable.
//   implicit-euler   backward Euler linearised once per step (Baraff and Witkin 1998):
//                      (M (1 + h rM) - h B - (h^2 + h rK) K) dv = h (f0 + h K v),
//                    f0 = F(x, v) + M g - rM M v + rK K v. First order in h.
//   bdf2             second-order backward differentiation, linearised once per step (Choi and
//                    Ko 2002), with beta = 2h/3:
//                      (M (1 + beta rM) - beta B - (beta^2 + beta rK) K) dv =
//                        M (v_n - v_n-1) / 3 + beta (f0 + K ((x_n - x_n-1) / 3 + beta v_n)),
//                      x_n+1 = (4 x_n - x_n-1) / 3 + beta v_n+1.
//                    It starts (and restarts after a topology change, a change of h, or an edit
//                    of the state between steps) with one implicit Euler step.
//   newton           backward Euler solved to convergence: Newton's method on the incremental
//                    potential (in velocities, with the damping lagged at the step's start),
//                      Phi(v) = 1/2 |v - v_n|^2_M + h rM / 2 |v|^2_M + U(x_n + h v) - h / 2 v.D v,
//                    D = B(x_n) + rK K(x_n), with a backtracking (Armijo) line search on Phi. It
//                    asks the force fields for their exact stiffness (when they have one) and
//                    falls back to their default, positive semi-definite one for an iteration
//                    whose system is not positive definite.
//
// Every implicit integrator solves its systems with a LinearSolver and applies one failure policy
// to each solve that misses its tolerance or meets a non-positive curvature: "warn" (flag the
// step), "fail" (throw, naming the step and the residual) or "fallback" (solve that system again
// with the fallbackSolver, CHOLMOD by default, when the relative residual is above fallbackAbove;
// a capped solve that got closer is only flagged).
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "cutsim/core/linear_solver.hpp"
#include "cutsim/core/model.hpp"

namespace cutsim::core {

/// What one step did.
struct StepStats {
  /// Flags of the step's solves (bits).
  enum Flag : std::uint8_t {
    MissedTolerance = 1,     ///< a linear solve ended above its tolerance (a capped CG)
    Indefinite = 2,          ///< CG met p^T A p <= 0, or a factorisation found A indefinite
    FellBack = 4,            ///< a solve was redone with the fallback solver
    NewtonNotConverged = 8,  ///< Newton's iterations ended above their tolerance
    /// An iterative solve's residual could carry more kinetic energy than a hundredth of the
    /// step's motion, whether or not it met its relative tolerance (ImplicitIntegrator::solve)
    ResidualEnergy = 16,
  };
  int iterations = 0;           ///< linear iterations over the step's solves (1 per direct solve)
  double residual = 0.0;        ///< relative residual of the step's last linear solve
  double worstResidual = 0.0;   ///< the largest relative residual of the step's linear solves
  int solves = 0;               ///< linear solves in the step
  int newtonIterations = 0;     ///< Newton iterations (newton only)
  double newtonResidual = 0.0;  ///< |residual| / |first residual| at Newton's end (newton only)
  bool analysed = false;        ///< a direct solver redid its symbolic analysis this step
  int clamped = 0;   ///< points the step hooks limited (contact's bound; all substeps; a point
                     ///< two hooks limit counts twice)
  int splits = 0;    ///< times the step (or a part of it) was redone as two halves
  int substeps = 1;  ///< integrator steps taken for this step
  std::uint8_t flags = 0;
  bool flagged() const { return flags != 0; }
  /// "ok", or the flags joined by '+': "missed-tolerance", "indefinite", "fallback", "newton",
  /// "residual-energy".
  std::string flagText() const;
};

/// What happens when a linear solve misses its tolerance or meets non-positive curvature.
enum class SolveFailurePolicy { Warn, Fail, Fallback };
std::string_view toString(SolveFailurePolicy p);
/// "warn", "fail", "fallback"; else InvalidInput(where = "onSolveFailure").
SolveFailurePolicy parseSolveFailurePolicy(std::string_view name);

/// Settings shared by the implicit integrators.
struct ImplicitSettings {
  double rayleighMass = 0.0;       ///< mass-proportional damping factor (>= 0)
  double rayleighStiffness = 0.0;  ///< stiffness-proportional damping factor (>= 0)
  SolveFailurePolicy onSolveFailure = SolveFailurePolicy::Fallback;
  double fallbackAbove = 1e-3;  ///< relative residual above which "fallback" re-solves (> 0)
  /// The linear solver that re-solves, by its registered name, with its default settings.
  std::string fallbackSolver = "cholmod";
  void validate() const;
};

/// The step's data an integrator is given.
struct StepInput {
  double dt = 0.0;
  const StepConstraints* constraints = nullptr;
  std::uint64_t revision = 0;  ///< the topology's revision (changes when the mesh does)
};

/// The step's result.
struct StepOutput {
  Eigen::VectorXd x, v;
  /// The force the constraints exert on each degree of freedom during the step (read at the
  /// grasped points).
  Eigen::VectorXd reaction;
};

/// Thrown by an integrator for a solve that failed under the "fail" policy (or could not be
/// solved at all); the simulation turns it into a SolverError naming the step.
struct StepFailure {
  std::string message;
  bool indefinite =
      false;  ///< the system was not positive definite (Newton then drops the exact K)
};

class Integrator {
 public:
  virtual ~Integrator();
  /// The registered name ("explicit-euler", "implicit-euler", "bdf2", "newton").
  virtual std::string_view name() const = 0;
  /// Whether the method is explicit (its instability shows as non-finite values).
  virtual bool isExplicit() const { return false; }
  /// One step of in.dt from the model's current state.
  virtual void step(Model& model, const StepInput& in, StepOutput& out, StepStats& stats) = 0;
  /// The step just taken is to be taken again from the same state (a step hook asked for it:
  /// StepVerdict::again): forget what step() kept of it for the next step (a multistep method's
  /// history). Default: nothing kept.
  virtual void rewind() {}
  /// The linear solver, if the method uses one.
  virtual LinearSolver* linearSolver() const { return nullptr; }
  /// Its Rayleigh damping factors (mass, stiffness): the damping force -rM M v + rK K v, which
  /// energy accounting counts as dissipated. Default: none.
  virtual std::array<double, 2> rayleigh() const { return {0.0, 0.0}; }
  /// Checkpoints: whether the method (with its solvers) saves what its next steps depend on (a
  /// previous step, a warm start); saveState and loadState write and read it in the open section.
  virtual bool checkpointable() const { return false; }
  virtual void saveState(ArchiveWriter& /*out*/) const {}
  virtual void loadState(ArchiveReader& /*in*/) {}
};

/// What the implicit integrators share: the settings, the linear solver, the failure policy.
class ImplicitIntegrator : public Integrator {
 public:
  ImplicitIntegrator(ImplicitSettings settings, std::unique_ptr<LinearSolver> solver);
  ~ImplicitIntegrator() override;
  LinearSolver* linearSolver() const override { return solver_.get(); }
  std::array<double, 2> rayleigh() const override {
    return {settings_.rayleighMass, settings_.rayleighStiffness};
  }
  const ImplicitSettings& settings() const { return settings_; }
  /// Whether its solver and its fallback solver save their state.
  bool checkpointable() const override;
  /// The solver's state, and the fallback solver's (its name unless CHOLMOD) if it was made.
  void saveState(ArchiveWriter& out) const override;
  void loadState(ArchiveReader& in) override;

 protected:
  /// Solves A dv = b with the linear solver and applies the failure policy; records the solve in
  /// stats. Throws StepFailure under "fail", or when no solver can solve the system.
  /// `velocity` is what dv is a change of (3 per slot): an iterative solve's answer is kept only
  /// if its residual (the solver's own, as its tolerance test uses) could carry no more kinetic
  /// energy than a hundredth of the larger of velocity's and velocity + dv's plus that of a
  /// 1 um/s velocity over the free points; else the solve is treated as one far from its
  /// tolerance, flagged ResidualEnergy. A right-hand side dominated by forces that nearly cancel (a
  /// damping or a stiffness huge against the masses) meets a relative tolerance with the answer
  /// still wrong.
  void solve(const SystemOperator& A, const Eigen::VectorXd& b, Eigen::VectorXd& dv,
             StepStats& stats, std::span<const double> velocity);
  /// f0 = F(x, v) + M g - rM M v + rK K v at the model's state (checked finite).
  Eigen::VectorXd dampedForce(const Model& model) const;
  /// The linear Rayleigh-damped implicit step shared by implicit Euler and BDF2:
  /// solves (M (1 + c rM) - c B - (c^2 + c rK) K) dv = b for dv, with the prescribed dv given.
  SystemOperator systemOperator(const Model& model, std::span<const double> x, double c,
                                const StepConstraints& constraints);

  ImplicitSettings settings_;
  std::unique_ptr<LinearSolver> solver_;
  std::unique_ptr<LinearSolver> fallback_;  // settings_.fallbackSolver, made on first use
  std::vector<double> diagonalMass_;        // scratch for systemOperator()
};

/// The three configurations of cutsim's first scenes as one shorthand (C++ API and the scenes'
/// "solver" key): explicit, implicit Euler with CG, implicit Euler with CHOLMOD.
struct SolverSettings {
  enum class Kind { Explicit, ImplicitCG, ImplicitCholmod };
  Kind kind = Kind::ImplicitCG;
  int cgMaxIterations = 100;       ///< CG iteration cap (>= 1)
  double cgTolerance = 1e-8;       ///< relative residual |r| / |b| to stop at (> 0)
  bool cgWarmStart = true;         ///< start CG from the previous step's velocity change
  double rayleighMass = 0.0;       ///< mass-proportional damping factor (>= 0)
  double rayleighStiffness = 0.0;  ///< stiffness-proportional damping factor (>= 0)
  SolveFailurePolicy onSolveFailure = SolveFailurePolicy::Fallback;
  double fallbackAbove = 1e-3;
  /// Throws InvalidInput (where = the setting's name) for values out of range.
  void validate() const;
};
std::string_view toString(SolverSettings::Kind kind);
/// "explicit", "implicit-cg", "implicit-cholmod"; else InvalidInput(where = "solver.type").
SolverSettings::Kind parseSolverKind(std::string_view name);
/// The integrator (and its linear solver) a SolverSettings describes.
std::unique_ptr<Integrator> makeIntegrator(const SolverSettings& settings);

}  // namespace cutsim::core
