#pragma once
// Energy accounting: where a run's energy goes, step by step (docs/energy.md).
//
// The stored energy is the kinetic energy plus the force fields' potential energy (contact's
// penalty included). What flows in and out is counted per step, by what does it:
//
//   gravity      work done by gravity, sum m g . dx
//   constraints  work done by fixed points and grasps, their reactions . dx (trapezoidal: the
//                reactions at the substep's start and end)
//   contact      work done by the fields that are not conservative (ForceField::conservative():
//                contact, whose obstacles move and whose friction is not linear in v): what
//                their potential jumps by at fixed positions when the field itself changes (its
//                obstacles move, its pairs are found again), their friction's work
//                (ForceField::addFrictionForce . dx), and the work of the step hooks' corrections
//                of a step (contact's displacement bound and moving-obstacle response), the change
//                of kinetic, potential and gravity energy they make
//   damping      dissipated by damping: Rayleigh's, h (rM v1' M v1 - rK v1' K v1), and the
//                conservative fields' own, -h v1' B v1 (v1, x1: the integrator's proposal)
//   removed      stored energy that changed between steps: springs and elements removed by cuts,
//                tears and carving, masses moved by a repair, attachments released, a field
//                given new parameters (negative when energy was added)
//
// with dx = x1 - x0 the step's displacement and v1 the velocity the integrator proposes. The
// balance, stored + damping + removed - work, is constant in exact arithmetic and exact time
// integration; what it drifts by is the integrator's own error (implicit Euler's numerical
// dissipation, ...), documented per integrator in docs/energy.md.
#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

#include "cutsim/base/fwd.hpp"

namespace cutsim::core {

class Model;
class Integrator;

/// Energy that flowed over some time, in joules, by what made it flow.
struct EnergyFlows {
  double gravity = 0.0;      ///< work done by gravity
  double constraints = 0.0;  ///< work done by fixed points and grasps
  double contact = 0.0;      ///< work done by contact, obstacles and the step hooks
  double damping = 0.0;      ///< energy dissipated by damping (>= 0 when it dissipates)
  double removed = 0.0;      ///< stored energy taken out between steps (topology changes, ...)
  double work() const { return gravity + constraints + contact; }
  EnergyFlows& operator+=(const EnergyFlows& o);
};

/// The accounts of one simulation (Simulation::enableEnergyAccounting).
class EnergyLedger {
 public:
  /// Opens the accounts at the model's current state (its stored energy is the balance's start).
  explicit EnergyLedger(const Model& model);

  /// Kinetic energy plus every field's potential energy at (x, v).
  static double stored(const Model& model, std::span<const double> x, std::span<const double> v);
  /// The potential energy of the fields that are not conservative() at x.
  static double nonConservativePotential(const Model& model, std::span<const double> x);
  /// stored() at the model's state.
  static double stored(const Model& model);

  /// Before a step: a new row of step flows; whatever the stored energy changed by since the
  /// accounts last saw it is counted as removed (settle()).
  void beginStep(const Model& model);
  /// The flows of one integrator (sub)step of h from (x0, v0), the model's state, to the
  /// integrator's proposal (xp, vp), with the constraints' `reaction` (3 per slot; empty: none)
  /// at the `constrained` points. Returns them; the caller adds them with commit() once the
  /// step hooks kept the proposal.
  EnergyFlows proposalFlows(const Model& model, const Integrator& integrator, double h,
                            std::span<const double> xp, std::span<const double> vp,
                            const Eigen::VectorXd& reaction,
                            std::span<const char> constrained) const;
  /// Adds a kept (sub)step's flows, with the work of the step hooks that changed its proposal
  /// (xp, vp) into the state the model now holds: the change of kinetic, conservative and gravity
  /// energy they made.
  void commit(const Model& model, EnergyFlows flows, std::span<const double> xp,
              std::span<const double> vp, bool hooksChanged, const Eigen::VectorXd& reaction,
              std::span<const char> constrained);
  /// After the step's last substep: the stored energy is read again (the flows explain its
  /// change; what they do not is the balance's drift).
  void endStep(const Model& model);
  /// Counts as removed what the stored energy changed by since the accounts last saw it (a cut,
  /// a tear, a released attachment between steps). Called before a step and before reading.
  void settle(const Model& model);

  const EnergyFlows& total() const { return total_; }
  /// The flows of the last step (and what was removed after it, when settled since).
  const EnergyFlows& lastStep() const { return step_; }
  /// The stored energy when last read.
  double storedEnergy() const { return stored_; }
  /// stored + damping + removed - work: constant but for the integrator's error.
  double balance() const { return stored_ + total_.damping + total_.removed - total_.work(); }
  /// The balance's change since the accounts were opened, and over the last step.
  double drift() const { return balance() - initial_; }
  double stepDrift() const { return balance() - stepStart_; }

  /// Checkpoints: the accounts, so that a resumed run reports what an uninterrupted one does.
  void saveState(ArchiveWriter& out) const;
  void loadState(ArchiveReader& in);

 private:
  template <class Archive, class Self>
  static void members(Archive& a, Self& s);

  EnergyFlows total_, step_;
  double stored_ = 0.0, initial_ = 0.0, stepStart_ = 0.0;
  double lastPotential_ = 0.0;  // nonConservativePotential when last read
  // The reactions at the end of the last substep (NaN: the point was not held), on the mesh of
  // topology revision lastRevision_.
  std::vector<double> lastReaction_;
  std::uint64_t lastRevision_ = 0;
};

}  // namespace cutsim::core
