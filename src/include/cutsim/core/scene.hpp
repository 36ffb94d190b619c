#pragma once
// Scenes: a JSON file that lists only what a simulation needs (mesh, mass, gravity, force fields,
// constraints, solver, time step and duration, outputs) and a timeline of scripted actions (cuts,
// progressive cuts, carving, tearing, grasps). The format is documented in docs/scenes.md.
//
// loadScene() parses and validates a whole scene before anything runs: every problem is an
// InvalidInput whose what() is "SCENE.json:LINE: /json/pointer: message". Force fields,
// integrators and linear solvers are read and built through their registries
// (cutsim/base/registry.hpp, registries.hpp). SceneRunner builds the core::Simulation from a
// validated scene (nothing the scene does not ask for) and plays it.
#include <any>
#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "cutsim/core/constraints.hpp"
#include "cutsim/core/simulation.hpp"
#include "cutsim/core/timeline.hpp"
#include "cutsim/forcefields/contact.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/topology/mesh_io.hpp"

namespace cutsim::core {

/// Where a value came from in the scene file, for the messages of errors found later (at run time).
struct SceneLocation {
  std::string pointer;  ///< JSON pointer, "/timeline/2"
  std::size_t line = 0;
  /// The text the value came from when it is not the scene's file (an action given while the
  /// simulation runs); "" for the scene's file.
  std::string source;
  /// "FILE:LINE" (or "FILE" when the line is unknown).
  std::string where(const std::string& file) const;
};

/// A generated flat grid of nx x ny VERTICES (nx, ny >= 2) covering size[0] x size[1].
struct GridSpec {
  int nx = 2, ny = 2;
  double width = 1.0, height = 1.0;
  /// Alternating: cell (i, j) is split along (i,j)-(i+1,j+1) when i + j is even, along
  /// (i+1,j)-(i,j+1) when odd (as data/meshes/grid_10x10.obj). One way: always (i,j)-(i+1,j+1).
  bool alternating = true;
  /// "xy": vertex (i, j) at origin + (u, v, 0), triangles facing +z.
  /// "xz": vertex (i, j) at origin + (u, 0, v), triangles facing -y (a curtain in front of +y).
  bool planeXZ = false;
  topology::Vec3 origin{0, 0, 0};
  /// With alternating false: every cell split along (i+1,j)-(i,j+1) ("downward") instead.
  bool downward = false;
};
topology::MeshData makeGrid(const GridSpec& grid);

/// A placement of the mesh as read: each point scaled (per axis), then rotated (Euler angles in
/// degrees: about x, then y, then z, fixed axes: R = Rz Ry Rx, as SOFA's MechanicalObject
/// `rotation`), then translated. The identity by default.
struct MeshTransform {
  Vec3 scale{1, 1, 1};
  Vec3 rotation{0, 0, 0};  ///< degrees
  Vec3 translation{0, 0, 0};
  bool identity() const;
  Vec3 apply(const Vec3& p) const;
};

/// A force field of the scene: its registered type and the parameters its entry read.
struct ForceFieldSpec {
  std::string type;     ///< a name of forcefields::ForceFieldRegistry
  std::string label;    ///< "" = the type name
  std::any parameters;  ///< the entry's parameter struct (e.g. forcefields::BendingParameters)
  SceneLocation location;
};

/// An integrator or a linear solver of the scene: its registered type and parameters.
struct ComponentSpec {
  std::string type;
  std::any parameters;
  SceneLocation location;
};

/// A constraint of the scene: its registered type and the parameters its entry read.
struct ConstraintSpec {
  std::string type;
  std::any parameters;
  SceneLocation location;
};

/// An action of the timeline: its registered type, its parameters and its timing.
struct ActionSpec {
  std::string type;
  std::any parameters;
  ActionTiming timing;
  SceneLocation location;
  double startTime() const { return timing.start(); }
  /// A fresh instance of the action (ActionRegistry).
  std::unique_ptr<TimelineAction> build() const;
};

struct OutputSettings {
  int every = 1;        ///< a frame every N steps (and the last one)
  bool vtk = true;      ///< surface and spring network as .vtp frames with .pvd collections
  bool springs = true;  ///< the spring network frames (with vtk)
  bool obj = false;     ///< OBJ frames of the surface at current positions
  bool csv = true;      ///< one CSV row per step
  /// Energy accounting (docs/energy.md): the simulation counts work, dissipation and removed
  /// energy, and the CSV has their columns.
  bool energy = false;
};

struct Scene {
  std::filesystem::path file;  ///< as given
  std::string name;            ///< "name" key, or the file's stem
  std::string description;
  std::optional<std::filesystem::path> meshFile;  ///< resolved against the scene's folder
  std::optional<GridSpec> grid;
  MeshTransform meshTransform;
  bool massByTotal = false;
  /// "lumping": "uniform": every point carries the same mass (a total spread equally, or
  /// perPointMass): SOFA's UniformMass. Else by area (SOFA's DiagonalMass).
  bool massUniform = false;
  double density = 0.0, totalMass = 0.0, perPointMass = 0.0;
  Vec3 gravity{0, 0, 0};
  std::vector<ForceFieldSpec> forceFields;
  std::vector<ConstraintSpec> constraints;
  /// The step hooks its sections ask for (StepHookRegistry): today "contact", whose parameters
  /// are a forcefields::ContactSetup holding the "obstacles" list too. In the order built.
  std::vector<ComponentSpec> stepHooks;
  ComponentSpec integrator;                   ///< by default implicit-euler
  std::optional<ComponentSpec> linearSolver;  ///< for integrators that use one (default cg)
  double timeStep = 0.0, duration = 0.0;
  /// "threads": the threads parallel loops may use (cutsim::setThreads when the run is built);
  /// 0 when the scene leaves it to the process (CUTSIM_THREADS, the machine's cores).
  int threads = 0;
  OutputSettings output;
  std::vector<ActionSpec> timeline;  ///< sorted by start time (stable: file order at ties)
  /// What the check found that does not stop the run ("FILE:LINE: /pointer: message"): memory
  /// the run, or a fallback to CHOLMOD, would need beyond what is available now. `cutsim run`
  /// and `resume` print them on stderr, Python warns (RuntimeWarning).
  std::vector<std::string> warnings;

  /// The "contact" section and the "obstacles" list, if the scene has contact (else null).
  const forcefields::ContactSetup* contactSetup() const;

  /// Number of steps: duration / timeStep rounded up (within 1e-9 of a whole number: rounded).
  long numSteps() const;
  /// The mesh the scene starts from (read or generated, then placed by meshTransform).
  topology::MeshData mesh() const;
  /// The mass law for the mesh the scene starts from.
  MassLaw massLaw(const topology::Topology& mesh) const;
  /// Labels of the force fields as the simulation gets them (unique: "Type", "Type_2", ...),
  /// the contact field's last ("contact") when the scene has contact.
  std::vector<std::string> forceFieldLabels() const;
  /// Names of every grasp of the timeline, in order of first appearance.
  std::vector<std::string> graspNames() const;
};

/// Parses and validates the scene text (sourceName names it in messages; relative mesh paths are
/// resolved against baseDir), including a dry run of the timeline's cuts and removals on a copy of
/// the mesh. Throws InvalidInput "SOURCE:LINE: /pointer: message".
Scene parseScene(std::string_view text, const std::string& sourceName,
                 const std::filesystem::path& baseDir);
/// The text of a scene file (a folder, a missing or unreadable file: InvalidInput "PATH: ...").
std::string readSceneText(const std::filesystem::path& file);
/// Reads and parses the file: a JSON scene, or a SOFA scene (.scn, read by sofa_scene.hpp's reader
/// and checked as its JSON translation is). A missing or unreadable file: InvalidInput "PATH: ...".
Scene loadScene(const std::filesystem::path& file);

/// One timeline entry given while a simulation runs (the "action" key and the action's keys, with
/// "at", or "from" and "to", not before `now`): read through the action registry with the checks
/// of a scene's timeline, InvalidInput "SOURCE:LINE: /pointer: message". No dry run: the action
/// meets the running surface when it starts, and fails there if it must.
ActionSpec parseActionEntry(std::string_view text, const std::string& sourceName, double now);
/// One entry of a scene's "forceFields" list, given while a simulation runs (a change of its
/// parameters: SceneRunner::replaceForceField).
ForceFieldSpec parseForceFieldEntry(std::string_view text, const std::string& sourceName);
/// One entry of a scene's "constraints" list, given while a simulation runs.
ConstraintSpec parseConstraintEntry(std::string_view text, const std::string& sourceName);

/// Builds the simulation a scene describes and plays its timeline.
class SceneRunner {
 public:
  explicit SceneRunner(const Scene& scene);
  ~SceneRunner();
  SceneRunner(const SceneRunner&) = delete;
  SceneRunner& operator=(const SceneRunner&) = delete;

  Simulation& simulation() { return *sim_; }
  const Simulation& simulation() const { return *sim_; }
  const Scene& scene() const { return scene_; }

  long numSteps() const { return numSteps_; }
  long currentStep() const { return step_; }
  /// Time of the current step: currentStep() * timeStep (not accumulated) while the time step is
  /// the scene's; after setTimeStep, the sum from there.
  double time() const;
  bool finished() const { return step_ >= numSteps_; }

  /// Runs the actions due at time 0. Called once, before the first advance().
  void start();
  /// One step: the simulation step, then the actions that go on (progressive cuts, tearing) in
  /// timeline order, then the actions due at the new time. Nothing once finished().
  StepStats advance();
  /// The same step, also past the scene's duration (scripts that run on). When an action fails
  /// after the step (a running action, or one due), the step stays done, the failed action leaves
  /// the timeline, the other actions still run, and the first failure is thrown.
  StepStats stepOnce();
  /// Adds an action (parseActionEntry) to the timeline: it starts at once if it is due now (as
  /// the scene's actions due now have), else when its time comes. Its failures name its source.
  void schedule(ActionSpec action);
  /// Replaces force field i by the one `spec` (parseForceFieldEntry) describes, of the same type,
  /// built on the current mesh: new parameters (stiffness, prestrain) from the next step on.
  void replaceForceField(std::size_t i, const ForceFieldSpec& spec);
  /// Applies a constraint (parseConstraintEntry) now.
  void applyConstraint(const ConstraintSpec& constraint);
  /// Changes the time step of the following steps (finite, > 0); numSteps() becomes the steps
  /// so far and those of the new time step that reach the scene's duration.
  void setTimeStep(double dt);
  double timeStep() const { return timeStep_; }
  const StepStats& lastStats() const { return lastStats_; }
  /// The instruments the started actions move in the world now (TimelineAction::instruments):
  /// what the output's frames draw.
  std::vector<std::array<Vec3, 2>> instrumentSegments() const;

  /// The first FastTriangularBendingSprings field, or null.
  const forcefields::FastTriangularBendingSprings* bendingField() const;
  /// Plays the scene's timeline without the physics, up to its last action: the surface stays at
  /// rest while the time advances step by step, and the actions run as they will in the run (a
  /// progressive cut piece by piece, among the other actions at their times). Actions that act
  /// on strains (tearing, fracture) are left out: at rest nothing tears. Throws what the run
  /// would (InvalidInput, TopologyError, naming the action and the time). The scene check uses it
  /// when the timeline has a progressive cut, which its per-action check makes whole at once.
  static void rehearseTimeline(const Scene& scene);
  /// Builds the integrator (with its linear solver) a scene names.
  static std::unique_ptr<Integrator> makeIntegrator(const Scene& scene);
  /// Edges torn so far, cuts done so far (pieces of progressive cuts count one each).
  long tornEdges() const { return tornEdges_; }
  long cutsDone() const { return cutsDone_; }
  /// What the cuts and tears among the actions last played made (the actions due at a time: a
  /// schedule() plays them at once), in order; forgets them.
  std::vector<topology::IncisionResult> takeIncisions() { return std::exchange(incisions_, {}); }

  // ---- checkpoints (docs/robustness.md) ----
  /// What of this run cannot be saved: components without checkpoints (by label or name),
  /// actions without them, and changes made while running (schedule, replaceForceField,
  /// applyConstraint: a checkpoint restores the scene's run). Empty: the run can be saved.
  std::vector<std::string> notCheckpointable() const;
  /// Writes the run's whole state between two steps: the sections "topology" (the mesh with its
  /// index history), the simulation's (Simulation::saveState) and "runner" (the clock, the
  /// timeline's progress and each started action's state). Throws cutsim::Error naming what
  /// cannot be saved.
  void save(ArchiveWriter& out) const;
  /// The runner of `scene` as save() left it: the topology read back exactly, every component
  /// built on it as the scene asks, then given its saved state, each validated. The scene must be
  /// the one the checkpoint was written for. A checkpoint that does not fit: InvalidInput naming
  /// the checkpoint and the section.
  SceneRunner(const Scene& scene, ArchiveReader& in);

 private:
  /// The checkpointed clock and counters, declared once for save and load.
  template <class Archive, class Self>
  static void members(Archive& a, Self& s);
  class Context;
  struct Running {
    const ActionSpec* spec;
    std::unique_ptr<TimelineAction> action;
  };
  void runDueActions(double t);
  /// notCheckpointable() without the actions still to come.
  std::vector<std::string> notSavableNow() const;
  struct Rehearsal {};
  SceneRunner(const Scene& scene, Rehearsal);
  void build(bool physics, std::unique_ptr<topology::Topology> topology = nullptr);

  bool rehearsal_ = false;
  Scene scene_;
  std::unique_ptr<Simulation> sim_;
  std::unique_ptr<Context> context_;
  long numSteps_ = 0;
  long step_ = 0;
  std::size_t nextAction_ = 0;
  bool started_ = false;
  StepStats lastStats_;
  std::vector<Running> running_;  // started actions, in timeline order
  // Actions given while running (running_ points at them: each is allocated once), sorted by
  // start time from nextScheduled_ on.
  std::vector<std::unique_ptr<ActionSpec>> scheduled_;
  std::size_t nextScheduled_ = 0;
  double timeStep_ = 0.0;
  long stepBase_ = 0;  // the step and the time at the last change of time step
  double timeBase_ = 0.0;
  double meanEdge_ = 0.0;
  long tornEdges_ = 0, cutsDone_ = 0;
  std::vector<topology::IncisionResult> incisions_;  // of the actions last played
  bool edited_ = false;  // changed while running (schedule, replaceForceField, applyConstraint)
};

}  // namespace cutsim::core
