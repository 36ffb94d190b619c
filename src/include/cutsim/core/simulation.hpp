#pragma once
// A simulation: a Model (what is simulated: topology, state, mass, force fields, gravity,
// constraints) stepped by an Integrator (how: explicit, implicit Euler, BDF2, Newton, each with
// its linear solver) and its step hooks (what knows time: step_hook.hpp), with the clock, the
// non-finite guard and the step statistics. It instantiates only what it is given.
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "cutsim/core/energy.hpp"
#include "cutsim/core/integrator.hpp"
#include "cutsim/core/model.hpp"
#include "cutsim/core/step_hook.hpp"

namespace cutsim::core {

/// Counts over the steps so far of the solves that did not meet their tolerance.
struct SolveSummary {
  long flaggedSteps = 0;  ///< steps with any flag
  long missedTolerance = 0, indefinite = 0, fellBack = 0, newtonNotConverged = 0;
  long residualEnergy = 0;     ///< steps with a solve whose residual carried too much energy
  double worstResidual = 0.0;  ///< largest relative residual of a flagged step's solves
  long worstStep = 0;          ///< the step (1-based) it happened at
};

class Simulation {
 public:
  /// Takes the topology; creates the state (x = rest, v = 0) and, if density > 0, the mass.
  /// The integrator is implicit Euler with CG until one is set.
  Simulation(std::unique_ptr<topology::Topology> topology, double density);
  /// The same with the mass by either law (mass.hpp).
  Simulation(std::unique_ptr<topology::Topology> topology, MassLaw mass);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  Model& model() { return *model_; }
  const Model& model() const { return *model_; }

  // ---- the model's parts (shorthands of model().…) ----
  topology::Topology& topology() { return model_->topology(); }
  const topology::Topology& topology() const { return model_->topology(); }
  MechanicalState& state() { return model_->state(); }
  const MechanicalState& state() const { return model_->state(); }
  const LumpedMass& mass() const { return model_->mass(); }
  void setGravity(const Vec3& g) { model_->setGravity(g); }
  const Vec3& gravity() const { return model_->gravity(); }
  forcefields::ForceField& addForceField(std::unique_ptr<forcefields::ForceField> field,
                                         std::string label = "") {
    return model_->addForceField(std::move(field), std::move(label));
  }
  std::size_t numForceFields() const { return model_->numForceFields(); }
  forcefields::ForceField& forceField(std::size_t i) { return model_->forceField(i); }
  const forcefields::ForceField& forceField(std::size_t i) const { return model_->forceField(i); }
  const std::string& forceFieldLabel(std::size_t i) const { return model_->forceFieldLabel(i); }
  PointSet& fixed() { return model_->fixed(); }
  const PointSet& fixed() const { return model_->fixed(); }
  /// Starts a grasp of `points` now, anchored at their current positions. Names are unique.
  Grasp& addGrasp(const std::string& name, std::span<const PointId> points, DisplacementPath path) {
    return model_->addGrasp(name, points, std::move(path), time_);
  }
  void releaseGrasp(const std::string& name) { model_->releaseGrasp(name); }
  std::size_t numGrasps() const { return model_->numGrasps(); }
  Grasp& grasp(std::size_t i) { return model_->grasp(i); }
  const Grasp& grasp(std::size_t i) const { return model_->grasp(i); }
  Grasp* findGrasp(const std::string& name) { return model_->findGrasp(name); }

  // ---- how it steps ----
  void setIntegrator(std::unique_ptr<Integrator> integrator);
  Integrator& integrator() { return *integrator_; }
  const Integrator& integrator() const { return *integrator_; }
  /// The shorthand of the first scenes: setIntegrator(makeIntegrator(s)).
  void setSolver(const SolverSettings& s);
  /// Adds a step hook, called after those added before it (step_hook.hpp).
  StepHook& addStepHook(std::unique_ptr<StepHook> hook);
  std::size_t numStepHooks() const { return hooks_.size(); }
  StepHook& stepHook(std::size_t i) { return *hooks_[i]; }
  const StepHook& stepHook(std::size_t i) const { return *hooks_[i]; }

  /// Advances by dt (> 0). Throws SolverError naming the step, the component and the point if a
  /// force, velocity or position becomes non-finite, or if a solve fails under the integrator's
  /// failure policy (the state is then left as before the step). The step hooks may limit the
  /// step's displacements and have it redone as two half steps (step_hook.hpp).
  StepStats step(double dt);
  double time() const { return time_; }
  /// Advances the time by dt without moving anything (the scene check's rehearsal of a timeline).
  void skipStep(double dt) {
    time_ += dt;
    ++steps_;
  }
  long steps() const { return steps_; }
  const SolveSummary& solveSummary() const { return summary_; }

  // ---- checkpoints (docs/robustness.md) ----
  /// What cannot be saved: force fields, the integrator or its solver, by name (empty: all can).
  std::vector<std::string> notCheckpointable() const;
  /// Writes the sections "sim" (clock, counters), "integr" (the integrator's history) and the
  /// model's (Model::saveState).
  void saveState(ArchiveWriter& out) const;
  /// Reads them into a simulation built as the saved one was, on the checkpoint's topology.
  void loadState(ArchiveReader& in);

  // ---- energies (at the current state) ----
  double kineticEnergy() const { return model_->kineticEnergy(); }
  double gravityEnergy() const { return model_->gravityEnergy(); }  ///< -sum m g.x
  /// Potential energy of force field i.
  double potentialEnergy(std::size_t i) const { return model_->fieldEnergy(i); }
  /// Total force on each point slot from the force fields and gravity (not the constraints).
  std::vector<double> totalForce() const { return model_->totalForce(); }

  // ---- energy accounting (energy.hpp, docs/energy.md) ----
  /// Opens the energy accounts at the current state (again: a new start); off by default (it
  /// costs a few force evaluations a step).
  void enableEnergyAccounting();
  bool energyAccounting() const { return ledger_ != nullptr; }
  /// The accounts, settled (what changed since the last step counted as removed); nullptr when
  /// accounting is off.
  const EnergyLedger* energy();

 private:
  /// One integrator step of h (its proposal limited by the step hooks), or two of h / 2 when a
  /// hook asks for a split.
  void advance(double h, int depth, StepStats& stats);
  /// The checkpointed members, declared once for saveState and loadState.
  template <class Archive, class Self>
  static void members(Archive& a, Self& s);

  std::unique_ptr<Model> model_;
  std::unique_ptr<Integrator> integrator_;
  std::vector<std::unique_ptr<StepHook>> hooks_;
  std::unique_ptr<EnergyLedger> ledger_;
  SolveSummary summary_;
  double time_ = 0.0;
  long steps_ = 0;
};

}  // namespace cutsim::core
