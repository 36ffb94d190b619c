#pragma once
// A simulation: a topology, the mechanical state and mass that follow it, force fields, gravity,
// constraints (fixed points, grasps) and a time integrator. It instantiates only what it is given.
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

struct SolverSettings {
  enum class Kind { Explicit, ImplicitCG, ImplicitCholmod };
  Kind kind = Kind::ImplicitCG;
  int cgMaxIterations = 100;   ///< CG iteration cap (>= 1)
  double cgTolerance = 1e-8;   ///< relative residual |r| / |b| to stop at (> 0)
  bool cgWarmStart = true;     ///< start CG from the previous step's velocity change
  double rayleighMass = 0.0;       ///< mass-proportional damping factor (>= 0)
  double rayleighStiffness = 0.0;  ///< stiffness-proportional damping factor (>= 0)
  /// Throws InvalidInput (where = the setting's name) for values out of range.
  void validate() const;
};

std::string_view toString(SolverSettings::Kind kind);
/// "explicit", "implicit-cg", "implicit-cholmod"; else InvalidInput(where = "solver.type").
SolverSettings::Kind parseSolverKind(std::string_view name);

/// What one step did.
struct StepStats {
  int iterations = 0;        ///< CG iterations (0 for explicit; 1 for CHOLMOD)
  double residual = 0.0;     ///< relative residual of the linear solve
  bool analysed = false;     ///< CHOLMOD redid its symbolic analysis this step
};

class Simulation {
 public:
  /// Takes the topology; creates the state (x = rest, v = 0) and, if density > 0, the mass.
  Simulation(std::unique_ptr<topology::Topology> topology, double density);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  topology::Topology& topology() { return *topology_; }
  const topology::Topology& topology() const { return *topology_; }
  MechanicalState& state() { return *state_; }
  const MechanicalState& state() const { return *state_; }
  const LumpedMass& mass() const { return *mass_; }

  void setGravity(const Vec3& g) { gravity_ = g; }
  const Vec3& gravity() const { return gravity_; }

  /// The simulation owns its force fields; they were built on topology().
  forcefields::ForceField& addForceField(std::unique_ptr<forcefields::ForceField> field,
                                         std::string label = "");
  std::size_t numForceFields() const { return fields_.size(); }
  forcefields::ForceField& forceField(std::size_t i) { return *fields_[i].field; }
  const forcefields::ForceField& forceField(std::size_t i) const { return *fields_[i].field; }
  const std::string& forceFieldLabel(std::size_t i) const { return fields_[i].label; }

  PointSet& fixed() { return *fixed_; }
  const PointSet& fixed() const { return *fixed_; }
  /// Starts a grasp of `points` now, anchored at their current positions. Names are unique.
  Grasp& addGrasp(const std::string& name, std::span<const PointId> points, DisplacementPath path);
  void releaseGrasp(const std::string& name);
  std::size_t numGrasps() const { return grasps_.size(); }
  Grasp& grasp(std::size_t i) { return *grasps_[i]; }
  const Grasp& grasp(std::size_t i) const { return *grasps_[i]; }
  Grasp* findGrasp(const std::string& name);

  void setSolver(const SolverSettings& s);
  const SolverSettings& solver() const { return solver_; }

  /// Advances by dt (> 0). Throws SolverError naming the step, the component and the point if a
  /// force, velocity or position becomes non-finite (the state is then left as before the step).
  StepStats step(double dt);
  double time() const { return time_; }
  long steps() const { return steps_; }

  // ---- energies (at the current state) ----
  double kineticEnergy() const;
  double gravityEnergy() const;  ///< -sum m g.x
  /// Potential energy of force field i.
  double potentialEnergy(std::size_t i) const;

  /// Total force on each point slot from the force fields and gravity (not the constraints).
  std::vector<double> totalForce() const;

 private:
  struct Field {
    std::unique_ptr<forcefields::ForceField> field;
    std::string label;
  };
  struct Solver;
  void checkFinite(std::span<const double> a, const char* what, const std::string& component) const;

  std::unique_ptr<topology::Topology> topology_;
  std::unique_ptr<MechanicalState> state_;
  std::unique_ptr<LumpedMass> mass_;
  std::unique_ptr<PointSet> fixed_;
  std::vector<std::unique_ptr<Grasp>> grasps_;
  std::vector<Field> fields_;
  Vec3 gravity_{0, 0, 0};
  SolverSettings solver_;
  std::unique_ptr<Solver> solverImpl_;
  double time_ = 0.0;
  long steps_ = 0;
};

}  // namespace cutsim::core
