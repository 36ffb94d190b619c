#pragma once
// Contact: the surface against itself and against obstacles, as a penalty force field with
// Coulomb friction and a per-step displacement bound that keeps the surface free of
// intersections. Notes: docs/contact.md.
//
// Detection. A bounding volume hierarchy over the live triangles (each box inflated by the
// triangle's margin), rebuilt when the topology's revision changes and refitted otherwise; it
// follows the topology's events like every other observer (validate() compares it and its
// tables with a rebuild). The candidate pairs within their margins are collected once each:
// vertex-triangle (VT) and edge-edge (EE) pairs of the surface that share no point (each point and
// edge is owned by one of its triangles, and a pair of triangles is visited once), and each point
// against each analytic obstacle; a triangle-mesh obstacle gives VT pairs (surface point, obstacle
// triangle), TV pairs (obstacle point, surface triangle) and EE pairs; a box is such a mesh of
// twelve triangles; against a sphere or a capsule each triangle's closest feature (interior, edge,
// corner) makes one pair, each feature once; against a plane, each point. At the step's start the
// pairs within 1.5 d (plus four times the points' velocities relative to the mean one, times dt)
// are kept.
//
// Response. For a pair at distance s (unsigned, between closest points; for an analytic obstacle
// the signed distance of the point) with thickness d and stiffness k:
//
//   E(s) = k/3 (d - s)^3 / s for d/100 < s < d, 0 for s >= d    (C2 at d: E = E' = E'' = 0)
//   continued quadratically below d/100 (finite through zero and below; bounded stiffness)
//   f_i = -E'(s) w_i n,   K_ij = -E''(s) w_i w_j n n^T    (Gauss-Newton: the curvature of s is
//                                                         left out, K is NSD)
//
// with k in N/m: -E'(d/2) = 2/3 k d, -E'(d/100) ~ 3300 k d.
//
// A self pair of two edges gets a share 1 - f_a f_b of the law, f an edge's flatness at the
// step's start (1 where its bend lifts a far corner off the neighbouring triangle's plane by at
// most 0.05 d, 0 from 0.25 d on and at borders): two flat edges whose triangles share no point
// add nothing their corners' pairs do not hold (flat-on-flat contact counted once).
//
// with n the unit direction from the second primitive's closest point to the first's and w_i the
// closest points' barycentric weights (+ on the first primitive, - on the second). K is exact only
// along n: stiffnessIsExact() is false. The energy is part of potentialEnergy().
//
// Friction (lagged): at the step's start each pair's normal force lambda = -E'(s) and normal
// n0 are frozen; the friction force on the pair's tangential relative velocity u_T is
// -mu lambda u_T / max(|u_T|, eps_v) (viscous below the stick velocity eps_v, Coulomb above),
// spread with the same weights; its derivative is the damping matrix B (NSD).
//
// Guarantee. After the step's solve, limitDisplacement() takes the proposed displacements and
// finds every pair that could meet (within the sum of its primitives' displacements relative to
// the mean one; every triangle that could reach an analytic obstacle); additive continuous
// collision detection (Li et al. 2021) along the linear motion checks each; the points of a pair
// it cannot prove apart are bounded by gamma times the pair's distance at the step's start,
// gamma < 1/2, so that the pair cannot meet (the offset geometric contact argument), and the
// search runs again for the shortened displacements until nothing changes. A step that clamps
// more than splitAbove of the points is redone as two halves. Pairs excluded below are not
// bounded; pairs at zero distance (made so by a topology operation) are left to the penalty.
//
// Cuts and tears. A self pair within d whose primitives are within d of each other in the rest
// configuration (neighbours in the material: the two lips of a cut, which start at distance zero,
// the small triangles a repair leaves next to a cut) is excluded from the penalty, the friction
// and the bound until its distance first exceeds d; then it gets its normal thickness. (With d
// below the mesh's smallest altitude, only the lips of cuts are such pairs.)
#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "cutsim/forcefields/force_field.hpp"
#include "cutsim/forcefields/obstacle.hpp"
#include "cutsim/topology/events.hpp"
#include "cutsim/topology/types.hpp"

namespace cutsim::topology {
class Topology;
class Subscription;
}  // namespace cutsim::topology

namespace cutsim::forcefields {

using topology::Vec3;

/// The contact settings of a scene.
struct ContactParameters {
  double thickness = 0.0;       ///< d, m: > 0
  double stiffness = 0.0;       ///< k, N/m: > 0 (E = k/3 (d - s)^3 / s)
  double friction = 0.0;        ///< mu of self-contact: >= 0
  double stickVelocity = 1e-3;  ///< eps_v, m/s: > 0
  bool selfContact = true;
  double displacementFraction = 0.4;  ///< gamma: in (0, 0.5)
  /// A step whose bound clamped more than this fraction of the points is redone as two halves
  /// (in [0, 1]), at most maxSplits times in a row (>= 0).
  double splitAbove = 0.01;
  int maxSplits = 4;
  /// The search keeps the pairs of primitives within (1 + searchSlack) d of the widest margin
  /// and reuses them while no point has moved far enough to bring another pair within reach
  /// (a Verlet list): resting contact is not searched anew at every step. 0: search every time.
  double searchSlack = 0.25;
  /// The most threads contact's long loops may share (the classification and the bound's scan
  /// of a large search cache, a round obstacle's or the bound's obstacle triangles over a large
  /// surface: docs/contact.md): 0 takes the process's setting (cutsim::threads(): a scene's
  /// "threads", `cutsim run --threads N`, CUTSIM_THREADS, else the machine's hardware threads).
  /// The pairs, forces and steps are the same, bit for bit, whatever the count. In [0, 256].
  int threads = 0;
  /// Throws InvalidInput (where = the parameter's name) for a value out of range.
  void validate() const;
};

/// What a contact is built from: its settings and its obstacles (a scene's "contact" section and
/// "obstacles" list).
struct ContactSetup {
  ContactParameters parameters;
  std::vector<Obstacle> obstacles;
};

/// Where each obstacle is over a step: its offset from its scene position at the step's start
/// and at its end (one of each per obstacle).
struct ObstaclePoses {
  std::vector<Vec3> start, end;
};

/// What contact did at given positions and velocities (for the CSV).
struct ContactMeasure {
  std::size_t candidates = 0;                   ///< pairs within their margins at the step's start
  std::size_t active = 0;                       ///< pairs within the thickness (penalty on)
  std::size_t excluded = 0;                     ///< pairs excluded after a topology change
  double selfNormal = 0.0, selfFriction = 0.0;  ///< sums of the pairs' force magnitudes (N)
  std::vector<double> obstacleNormal, obstacleFriction;  ///< per obstacle (N)
};

/// Two primitives closer than a distance (the start check of a scene).
struct ContactProximity {
  std::string what;  ///< "point 12 and triangle 40", "point 3 and obstacle \"floor\""
  double distance = 0.0;
};

class Contact final : public ForceField, public topology::TopologyObserver {
 public:
  Contact(topology::Topology& topology, ContactParameters parameters,
          std::vector<Obstacle> obstacles);
  ~Contact() override;

  const ContactParameters& parameters() const { return parameters_; }
  const std::vector<Obstacle>& obstacles() const { return obstacles_; }
  /// Replaces obstacle k's path (its step hook, core::ContactStep, edits paths: a move from a
  /// script). Throws InvalidInput naming the obstacle for a bad path (nothing changes then).
  void setObstaclePath(std::size_t k, std::vector<ObstacleKey> path);

  /// Before each step of dt from positions x and velocities v, with the obstacles at `poses`
  /// (their offsets at the step's start and end: the step hook reads them off the paths; the
  /// field itself knows no time): the obstacles move to their end poses, the candidate pairs are
  /// found at x, the exclusions are updated, the friction's normal forces are frozen.
  void beginStep(std::span<const double> x, std::span<const double> v, const ObstaclePoses& poses,
                 double dt);
  /// The same with every obstacle at its scene position (offset zero) over the step.
  void beginStep(std::span<const double> x, std::span<const double> v, double dt);

  /// After an implicit step's solve, before limitDisplacement: the friction pairs that slid at
  /// the step's start and whose tangential relative velocity at v1 points against that sliding
  /// direction (the Coulomb force, of a fixed direction over the step, carried them past rest:
  /// the next step would carry them back, a period-two oscillation) are held for the rest of
  /// the step: their friction becomes the viscous law at any speed (rest within the stick
  /// velocity; where a load beyond the friction limit moves the pair faster than that, more than
  /// the Coulomb force for this step). Pairs all of whose surface points the step prescribes
  /// (`constrained`, per point slot; empty: none) are left alone: holding them would change no
  /// motion. Returns how many; when some, the step is to be solved again (the pairs, normals and
  /// normal forces stay those of the step's start). docs/contact.md, "Friction".
  std::size_t holdOvershoots(std::span<const double> v1, std::span<const char> constrained = {});

  /// After the step's solve: first the response to moving obstacles
  /// (respondToMovingObstacles), then clamps each unconstrained point's displacement x1 - x0 to
  /// its bound (velocities of clamped points become (x1 - x0) / dt). Returns the number of
  /// clamped points. Part of the step (the bounds, anchors and pairs it finds are the step's
  /// state, bounds()).
  std::size_t limitDisplacement(std::span<const double> x0, std::span<double> x1,
                                std::span<double> v1, double dt, std::span<const char> constrained);

  /// Forces and counts at x, v with the current pairs.
  ContactMeasure measure(std::span<const double> x, std::span<const double> v) const;
  /// measure() at the end of a step (its step hook, core::ContactStep, calls it after the step
  /// is committed; the CSV reports it, also for a step after which a cut changed the mesh).
  void recordStep(std::span<const double> x, std::span<const double> v) { last_ = measure(x, v); }
  /// How many primitive pairs the search's cache holds (0: none).
  std::size_t cachedPairs() const;
  /// How many times the pairs were searched, and how many steps reused the search's cache.
  std::size_t searches() const;
  std::size_t searchesReused() const;
  const ContactMeasure& lastStep() const { return last_; }

  // The two queries below search with the step's tables (margins, boxes, hierarchies): call them
  // between steps; they leave those tables as their search made them (the next step's start
  // makes them again), and closePairs drops the last step's pairs.

  /// Pairs (surface-surface and surface-obstacle) closer than `within` at x, ignoring the
  /// exclusions; at most `limit` of them, closest first.
  std::vector<ContactProximity> closePairs(std::span<const double> x, double within,
                                           std::size_t limit = 5);

  /// Triangles that intersect each other (sharing no point) or an obstacle at x, or have a
  /// corner inside an analytic obstacle; at most `limit` (the start check of a scene).
  std::vector<ContactProximity> intersections(std::span<const double> x, std::size_t limit = 5);

  /// Before the bound: each free point within d of a moving solid obstacle (a sphere, a capsule,
  /// a box, a plane; not a triangle mesh, whose distance is unsigned) that the step would take
  /// closer to it than it starts (or, coming from farther, closer than d) is moved back along
  /// the obstacle's normal at its end: an inelastic impulse from a body of infinite mass, with
  /// Coulomb friction (the obstacle's coefficient) taken off its motion along the surface
  /// relative to the obstacle; one that would end inside or past the obstacle's middle is
  /// carried with the obstacle at its start distance. It corrects
  /// what the linearised solve gets wrong about a moving obstacle (docs/contact.md, "Moving
  /// obstacles"), so that the bound does not have to. Returns how many points it moved.
  std::size_t respondToMovingObstacles(std::span<const double> x0, std::span<double> x1,
                                       std::span<double> v1, double dt,
                                       std::span<const char> constrained);

  /// The bound of each point slot after the last limitDisplacement (infinity: none; for tests).
  const std::vector<double>& bounds() const;

  // ---- ForceField ----
  std::string typeName() const override { return "Contact"; }
  void addForce(std::span<const double> x, std::span<const double> v,
                std::span<double> f) const override;
  void addDForce(std::span<const double> x, std::span<const double> dx, std::span<double> df,
                 double kFactor, double bFactor) const override;
  /// Evaluates the pairs at x once for the solve; its products then skip comparing x.
  void beginProducts(std::span<const double> x) const override;
  void endProducts(std::span<const double> x) const override;
  double potentialEnergy(std::span<const double> x) const override;
  /// Its obstacles move and its friction is not linear in v: its work is counted, not its energy.
  bool conservative() const override { return false; }
  /// The friction forces of addForce alone.
  void addFrictionForce(std::span<const double> x, std::span<const double> v,
                        std::span<double> f) const override;
  void addKToMatrix(std::span<const double> x, MatrixAccumulator& m, double kFactor) const override;
  void addBToMatrix(std::span<const double> x, MatrixAccumulator& m, double bFactor) const override;
  bool stiffnessIsExact() const override { return false; }
  /// Its step hook (core::ContactStep) holds it.
  bool replaceable() const override { return false; }

  // ---- TopologyObserver ----
  void onPointsRenumbered(const topology::Topology&, const topology::Renumbering&) override;
  void onTransactionEnd(const topology::Topology&, const topology::TransactionSummary&) override;
  std::string observerName() const override { return "Contact"; }
  void validate(const topology::Topology& topology,
                std::vector<std::string>& problems) const override;
  /// Checkpoints: the exclusions and released pairs, the hierarchy as built, the pair cache and
  /// its schedule, the step's pairs and bounds, the obstacles' paths and poses (what the next
  /// steps depend on; the per-topology tables are rebuilt, as they are after every change).
  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override;
  void loadState(ArchiveReader& in) override;

  struct Impl;

 private:
  ContactParameters parameters_;
  std::vector<Obstacle> obstacles_;
  ContactMeasure last_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cutsim::forcefields
