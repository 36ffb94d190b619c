#pragma once
// Timeline actions and scene constraints as registered components. Each kind (cut, remove,
// tearing, grasp, release; the fixed constraint) registers in its own source file its name, its
// keys, how to read its parameters from a ParameterSource and how to build itself; the scene reads
// them through ActionRegistry and ConstraintRegistry, as it reads force fields and integrators.
//
// An action is built afresh for each run (it may keep state: a progressive cut's progress). Before
// anything runs, dryRun() checks it on a copy of the rest mesh that the timeline's earlier actions
// have already changed; during the run, start() runs it when it is due and afterStep() after each
// later step (the actions that go on: a progressive cut, tearing), in timeline order.
#include <array>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "cutsim/core/constraints.hpp"
#include "cutsim/core/simulation.hpp"
#include "cutsim/forcefields/registry.hpp"
#include "cutsim/topology/mesh_io.hpp"

namespace cutsim::core {

/// A choice of points in rest coordinates: listed ids, a box (inclusive), or for each given
/// position the nearest live point (ties: lowest id).
struct PointSelection {
  enum class Kind { Points, Box, Near };
  Kind kind = Kind::Points;
  std::vector<PointId> points;
  Vec3 boxMin{0, 0, 0}, boxMax{0, 0, 0};
  std::vector<Vec3> near;
  /// A box takes one piece: only the points inside that are connected to the seed (the live point
  /// inside nearest to `seed`, default the box's centre) by edges inside the box, so that a box
  /// straddling a cut or a tear takes one side (a grasp's default; a fixed constraint takes all).
  bool onePiece = false;
  std::optional<Vec3> seed;
  /// The selected live points, ascending, without repeats.
  std::vector<PointId> resolve(const topology::Topology& topology) const;
  /// Reads "points", "box" or "near" (exactly one) from s.
  static PointSelection read(const ParameterSource& s);
  /// The selection's key ("points", "box", "near").
  std::string_view key() const;
};

/// Of `points`, the one whose position (positionOf: rest or current) is nearest `position` (ties:
/// the first); PointId::invalid() if there is none.
PointId nearestPoint(std::span<const PointId> points, const Vec3& position,
                     const std::function<Vec3(PointId)>& positionOf);
/// The points of `inside` connected to `start` by edges whose both ends are in `inside` (one piece
/// of a region: the side of a cut that crosses it), ascending.
std::vector<PointId> connectedWithin(const topology::Topology& topology,
                                     const std::vector<PointId>& inside, PointId start);

/// The point of triangle t with the given barycentric weights (in the order of its vertices) as a
/// point of the mesh: the corner it is (a weight within rounding of 1), a point inserted on the
/// edge it is on (one within rounding of 0), or one inserted inside the triangle; an inserted
/// point is exactly that material point (its rest position and its current position are the
/// weights' of the corners'). One topology transaction when it inserts; throws TopologyError.
PointId pointAt(topology::Topology& topology, topology::TriangleId t,
                std::array<double, 3> weights);

/// Reads a grasp's "name" (required, not empty, without a comma, a quote or a line break: it
/// names CSV columns).
std::string readGraspName(const ParameterSource& s);

class ActionContext;
/// Fails the action (`who`: "grasp \"forceps\"") if one of `points` is fixed or held by a grasp:
/// a point is held by one constraint (the reactions would be meaningless otherwise).
void requireFree(ActionContext& c, std::span<const PointId> points, const std::string& who);

/// A region of rest space: a sphere or a box.
struct Region {
  enum class Kind { Sphere, Box };
  Kind kind = Kind::Sphere;
  Vec3 center{0, 0, 0};
  double radius = 0.0;
  Vec3 boxMin{0, 0, 0}, boxMax{0, 0, 0};
  bool contains(const Vec3& p) const;
  /// Reads key "sphere" ({"center", "radius" > 0}) or "box" ([[min], [max]]) from s.
  static Region read(const ParameterSource& s, std::string_view key);
  /// Negative inside, positive outside, zero on the boundary (a sphere's signed distance; for a
  /// box, the largest of the signed distances to its slabs).
  double levelSet(const Vec3& p) const;
};
/// The live triangles whose rest centroid lies in the region.
std::vector<topology::TriangleId> trianglesInRegion(const topology::Topology& topo,
                                                    const Region& region);

/// The default smallest-angle target of the quality repair after cuts and removals (degrees).
inline constexpr double kDefaultMinAngle = 20.0;
/// Repair options for an operation of the running simulation: the target, and its fixed and
/// grasped points locked (they neither move nor disappear).
topology::RepairOptions repairOptions(const Simulation& simulation, double minAngle);
/// Reads an action's "minAngle" key (degrees, in [0, 60); 0 turns the repair off).
double readMinAngle(const ParameterSource& s);

/// When an action runs: at a time, or over an interval (entries whose keys include "from").
struct ActionTiming {
  double at = 0.0;
  double from = 0.0, to = 0.0;
  bool interval = false;
  double start() const { return interval ? from : at; }
};

/// Whether a cut changed the mesh (one whose path runs along the border or an earlier cut's lips,
/// onto which its ends snapped, opens nothing): what the cut counters count.
bool incisionOpened(const topology::IncisionResult& r);

/// What a running action may use.
class ActionContext {
 public:
  virtual ~ActionContext();
  virtual Simulation& simulation() = 0;
  virtual double time() const = 0;          ///< the current time
  virtual double timeStep() const = 0;      ///< the scene's
  virtual double meanRestEdge() const = 0;  ///< of the mesh the scene starts from
  /// Ends the run with InvalidInput "FILE:LINE: /timeline/i: at t = T " + message (the action
  /// cannot be carried out as the scene gives it).
  [[noreturn]] virtual void fail(const std::string& message) const = 0;
  /// The same as a TopologyError: the topology refused the action's operation (nothing changed).
  [[noreturn]] virtual void failTopology(const std::string& message) const = 0;
  virtual void countCut() = 0;
  virtual void countTorn(long edges) = 0;
  /// What a cut or a tear made (its path, its copies, the repair's figures), for the front end
  /// that scheduled the action (SceneRunner::takeIncisions: Python's sim.cut and sim.tear).
  virtual void recordIncision(const topology::IncisionResult& result) = 0;
};

/// What an action's check before the run may use.
class DryRunContext {
 public:
  virtual ~DryRunContext();
  /// The copy of the rest mesh, as the timeline's earlier actions leave it.
  virtual topology::Topology& topology() = 0;
  /// The mesh the scene starts from.
  virtual const topology::MeshData& restMesh() const = 0;
  /// Names of the grasps active at the action's time.
  virtual std::set<std::string>& activeGrasps() = 0;
  /// The scene's force fields as (type, label, as the run labels them: Scene::forceFieldLabels),
  /// or nullptr where they are not known (an action given while a simulation runs).
  virtual const std::vector<std::pair<std::string, std::string>>* forceFields() const {
    return nullptr;
  }
  /// Fails the scene at a key path of the action ("polyline/2"; "" for the action itself).
  [[noreturn]] virtual void fail(std::string_view key, const std::string& message) const = 0;
};

class TimelineAction {
 public:
  virtual ~TimelineAction();
  virtual void dryRun(DryRunContext& c) const = 0;
  virtual void start(ActionContext& c) = 0;
  virtual void afterStep(ActionContext& /*c*/) {}
  /// The grasp it starts, for the CSV's columns ("" for other actions).
  virtual std::string graspName() const { return ""; }
  /// Whether the scene check's rehearsal of the timeline (SceneRunner::rehearseTimeline, the
  /// surface at rest) plays it: not the actions that act on strains.
  virtual bool rehearsed() const { return true; }
  /// The instrument it moves in the world at `time`, if any, as segments (a scalpel's blade, from
  /// its tip): what the frames draw.
  virtual void instruments(double /*time*/, std::vector<std::array<Vec3, 2>>& /*out*/) const {}
  /// Checkpoints: whether the action saves what it goes on with (a progressive cut's progress,
  /// crack tips); saveState and loadState write and read it in the open section (loadState on the
  /// restored simulation, which it checks what it read against). An action that is done once
  /// started keeps nothing.
  virtual bool checkpointable() const { return false; }
  virtual void saveState(ArchiveWriter& /*out*/) const {}
  virtual void loadState(ArchiveReader& /*in*/, const Simulation& /*simulation*/) {}
};
using ActionRegistry = Registry<TimelineAction, const ActionTiming&>;

/// A constraint of the scene's "constraints" list.
class SceneConstraint {
 public:
  virtual ~SceneConstraint();
  virtual void dryRun(DryRunContext& c) const = 0;
  virtual void apply(Simulation& sim) const = 0;
};
using ConstraintRegistry = Registry<SceneConstraint>;

// ---- the parameters of the project's actions (what their entries read) ----

struct CutParameters {
  std::vector<Vec3> polyline;  ///< rest coordinates
  double snapTolerance = 0.1;
  double minAngle = kDefaultMinAngle;  ///< quality repair target, degrees (0: off)
};
struct RemoveParameters {
  Region region;
  /// Cut the triangles the region's boundary crosses (a clean hole), or remove whole triangles
  /// whose rest centroid is inside (the jagged, cheaper removal).
  bool cutBoundary = true;
  double minAngle = kDefaultMinAngle;  ///< quality repair target, degrees (0: off)
};
struct TearingParameters {
  double threshold = 0.0;              ///< Green strain normal to an edge above which it tears
  int maxPerStep = 4;                  ///< edges torn per step at most
  double minAngle = kDefaultMinAngle;  ///< quality repair target after each tear (degrees, 0: off)
};
struct FractureParameters {
  double criticalStrain = 0.0;         ///< averaged Green strain above which a crack advances
  double length = 0.0;                 ///< radius of the averaging disc around a tip (m)
  double speed = 0.0;                  ///< largest crack speed (m/s), required
  double minAngle = kDefaultMinAngle;  ///< quality repair target along the crack (degrees)
};
struct GraspParameters {
  std::string name;
  PointSelection selection;
  /// Instead of `selection`: the points whose CURRENT position lies in this sphere when the grasp
  /// starts (world coordinates: what forceps of that radius close on), one piece unless
  /// selection.onePiece is false.
  std::optional<Region> worldSphere;
  DisplacementPath path;  ///< times relative to the grasp's start
};
struct ReleaseParameters {
  std::string name;
};

}  // namespace cutsim::core
