#pragma once
// The model: what is simulated, and nothing of how a step is taken. It owns the topology, the
// mechanical state and the lumped mass that follow it, the force fields, gravity and the point
// constraints (fixed points, grasps); it evaluates forces, their derivatives and the potential
// energy at any positions, and says which points a step must move where. Integrators
// (integrator.hpp) step a model; linear solvers (linear_solver.hpp) solve the systems they form.
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "cutsim/core/constraints.hpp"
#include "cutsim/core/mass.hpp"
#include "cutsim/core/state.hpp"
#include "cutsim/forcefields/force_field.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::core {

/// Thrown by the model's and the integrators' checks when a value stops being finite; the
/// simulation turns it into a SolverError that names the step.
struct NonFiniteValue {
  std::string what;       ///< "force", "velocity change", ...
  std::string component;  ///< the force field's label or the integrator's name; may be empty
  std::size_t point = 0;  ///< the point slot
};
/// Throws NonFiniteValue for the first entry of a (3 per point) that is NaN or infinite.
void requireFinite(std::span<const double> a, const char* what, const std::string& component);

/// Where a step must put the constrained points.
struct StepConstraints {
  /// Per point slot: 1 if the step prescribes the point (fixed, grasped, dead, or without mass).
  std::vector<char> constrained;
  /// Per degree of freedom: the position a prescribed point must have at the end of the step
  /// (its current position for fixed, dead and massless points; the path's target for grasps).
  std::vector<double> target;
};

class Model {
 public:
  /// Takes the topology; creates the state (x = rest, v = 0) and, if density > 0, the mass.
  Model(std::unique_ptr<topology::Topology> topology, double density);
  /// The same with the mass by either law (a value <= 0: no mass).
  Model(std::unique_ptr<topology::Topology> topology, MassLaw mass);
  ~Model();
  Model(const Model&) = delete;
  Model& operator=(const Model&) = delete;

  topology::Topology& topology() { return *topology_; }
  const topology::Topology& topology() const { return *topology_; }
  MechanicalState& state() { return *state_; }
  const MechanicalState& state() const { return *state_; }
  bool hasMass() const { return mass_ != nullptr; }
  const LumpedMass& mass() const { return *mass_; }
  std::size_t numSlots() const { return state_->numSlots(); }

  void setGravity(const Vec3& g) { gravity_ = g; }
  const Vec3& gravity() const { return gravity_; }

  /// The model owns its force fields; they were built on topology(). Labels default to the type.
  forcefields::ForceField& addForceField(std::unique_ptr<forcefields::ForceField> field,
                                         std::string label = "");
  /// Replaces force field i (one that is replaceable()) by `field`, built on topology(), under its
  /// label: a change of parameters between steps. The new field builds its tables from the mesh as
  /// it is now (which the old field's incremental tables equal).
  void replaceForceField(std::size_t i, std::unique_ptr<forcefields::ForceField> field);
  std::size_t numForceFields() const { return fields_.size(); }
  forcefields::ForceField& forceField(std::size_t i) { return *fields_[i]; }
  const forcefields::ForceField& forceField(std::size_t i) const { return *fields_[i]; }
  const std::string& forceFieldLabel(std::size_t i) const { return labels_[i]; }
  /// The fields, for SystemOperator.
  std::span<forcefields::ForceField* const> fields() const { return fieldPointers_; }

  PointSet& fixed() { return *fixed_; }
  const PointSet& fixed() const { return *fixed_; }
  /// Starts a grasp of `points` at time `now`, anchored at their current positions.
  Grasp& addGrasp(const std::string& name, std::span<const PointId> points, DisplacementPath path,
                  double now);
  void releaseGrasp(const std::string& name);
  std::size_t numGrasps() const { return grasps_.size(); }
  Grasp& grasp(std::size_t i) { return *grasps_[i]; }
  const Grasp& grasp(std::size_t i) const { return *grasps_[i]; }
  Grasp* findGrasp(const std::string& name);

  // ---- what integrators ask ----
  /// f += F(x, v) of every field (each checked finite: NonFiniteValue names the field) + M g.
  void addForce(std::span<const double> x, std::span<const double> v, std::span<double> f) const;
  /// df += sum over the fields of (kFactor K(x) + bFactor B(x)) dx.
  void addDForce(std::span<const double> x, std::span<const double> dx, std::span<double> df,
                 double kFactor, double bFactor) const;
  /// Potential energy at x: the fields' plus gravity's (-sum m g.x).
  double potentialEnergy(std::span<const double> x) const;
  /// The prescribed points of a step that ends at time tEnd.
  StepConstraints constraints(double tEnd) const;
  /// Asks every field for its exact stiffness (true) or its default one; returns the labels of
  /// the fields that have no exact stiffness to give.
  std::vector<std::string> setExactStiffness(bool exact);

  // ---- energies at the current state ----
  double kineticEnergy() const;
  /// Sum of 1/2 m |v|^2 over the points of the velocities v (3 per slot): the state's, or a
  /// step's before it is taken. With `overflowAt`, the sum stops at the first point where it is
  /// no longer finite and that point is written there (else the slot count).
  double kineticEnergyOf(std::span<const double> v, std::size_t* overflowAt = nullptr) const;
  double gravityEnergy() const;  ///< -sum m g.x
  /// The same at positions x (3 per slot).
  double gravityEnergyOf(std::span<const double> x) const;
  double fieldEnergy(std::size_t i) const;
  /// Total force on each point slot from the force fields and gravity (not the constraints).
  std::vector<double> totalForce() const;

  // ---- checkpoints (docs/robustness.md) ----
  /// The labels of the force fields that cannot be saved (empty: the model can).
  std::vector<std::string> notCheckpointable() const;
  /// Writes the sections "state", "mass", "fixed", "grasps" and "field<i>" per force field.
  void saveState(ArchiveWriter& out) const;
  /// Reads them into a model built as the saved one was, on the checkpoint's topology: the
  /// state, mass, fixed points and fields replaced, the grasps made again; each part validated.
  void loadState(ArchiveReader& in);

 private:
  std::unique_ptr<topology::Topology> topology_;
  std::unique_ptr<MechanicalState> state_;
  std::unique_ptr<LumpedMass> mass_;
  std::unique_ptr<PointSet> fixed_;
  std::vector<std::unique_ptr<Grasp>> grasps_;
  std::vector<std::unique_ptr<forcefields::ForceField>> fields_;
  std::vector<forcefields::ForceField*> fieldPointers_;
  std::vector<std::string> labels_;
  Vec3 gravity_{0, 0, 0};
};

}  // namespace cutsim::core
