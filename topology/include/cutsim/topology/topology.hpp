#pragma once
// The triangle topology: a manifold triangle mesh on CGAL::Surface_mesh (kept out of this header),
// the only writer of connectivity, which announces every change to its observers as events.
// See docs/topology-events.md for the event contract and the index policy.
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/base/fwd.hpp"
#include "cutsim/topology/events.hpp"
#include "cutsim/topology/mesh_io.hpp"
#include "cutsim/topology/types.hpp"

namespace cutsim::topology {

class Topology;

/// Keeps an observer registered while it lives; ends the registration when destroyed or reset.
/// Outliving the topology is safe.
class Subscription {
 public:
  Subscription() = default;
  Subscription(Subscription&&) noexcept;
  Subscription& operator=(Subscription&&) noexcept;
  Subscription(const Subscription&) = delete;
  Subscription& operator=(const Subscription&) = delete;
  ~Subscription();
  void reset();
  bool active() const;
  struct Registry;  ///< opaque, owned by the topology

 private:
  friend class Topology;
  Subscription(std::weak_ptr<Registry> registry, TopologyObserver* observer);
  std::weak_ptr<Registry> registry_;
  TopologyObserver* observer_ = nullptr;
};

/// Mesh quality repair after an operation (see "Quality repair" in docs/topology-events.md).
struct RepairOptions {
  /// Target of the smallest angle of the triangles around the operation, in degrees: in [0, 60);
  /// 0 turns the repair off. Greedy flips, collapses, relocations and splits, then Delaunay
  /// refinement, which reaches targets up to 20.7 degrees everywhere the input allows (see
  /// "Quality repair" in docs/topology-events.md).
  double minAngle = 0.0;
  /// Points that must neither move nor disappear (fixed or grasped points).
  std::vector<PointId> locked;
  /// Flips, collapses and relocations only where the rest surface is flat within this angle
  /// (degrees): no corner of the triangles involved farther off their mean plane than
  /// tan(flatness / 4) times their extent along it (two triangles bent by this angle reach it).
  /// 5 lets a curved rest surface meshed at a few degrees of bend from one triangle to the next
  /// (skin over an organ) be repaired, and keeps creases.
  double flatness = 5.0;
};

/// What a repair did, and the quality of the patch before and after (in degrees; the patch is
/// every triangle around the points the operation touched).
struct RepairReport {
  std::size_t flips = 0, collapses = 0, relocations = 0, splits = 0;
  std::size_t insertions = 0;  ///< points inserted at circumcentres (Delaunay refinement)
  bool budgetSpent = false;    ///< refinement stopped at its budget, not when done
  std::size_t triangles = 0;   ///< triangles of the patch after the repair
  double minAngleBefore = 0.0, minAngleAfter = 0.0;  ///< smallest angle of the patch
  double meanMinBefore = 0.0, meanMinAfter = 0.0;    ///< mean of the triangles' smallest angles
  std::size_t belowTargetBefore = 0, belowTargetAfter = 0;  ///< triangles under the target
};

/// Result of an incision (incise, tear, cutPolyline).
struct IncisionResult {
  std::vector<PointId> path;            ///< the vertices of the cut path, in order (originals)
  std::vector<PointId> copies;          ///< new points created by opening the cut
  std::vector<PointId> copiedFrom;      ///< copies[i] is a copy of copiedFrom[i]
  std::vector<PointId> insertedPoints;  ///< points inserted on edges/triangles (cutPolyline, tear)
  /// The repair that followed (all zero without one). A point the repair removed is replaced in
  /// the lists above by the point that took its place (collapsed into, or relocated to).
  RepairReport repair;
};

/// Options of cutPolyline.
struct CutOptions {
  /// A crossing closer than snapTolerance * (local edge length) to a vertex (or, for a corner of
  /// the polyline, to an edge) snaps to it, so that the cut leaves no sliver triangles. The
  /// polyline's ends snap likewise, onto the border too: a cut ending just inside the border
  /// reaches it (so a cut with both ends within the tolerance of the border separates the piece
  /// between them); elsewhere snapping never moves the path onto the border.
  double snapTolerance = 0.1;
  /// Quality repair of the triangles around the cut, in the same transaction (off by default
  /// at this level; scenes turn it on).
  RepairOptions repair;
};

/// Options of sew.
struct SewOptions {
  /// How far apart (world distance, > 0) two lips' points may be and still be joined.
  double tolerance = 0.0;
  /// Only border points it accepts take part (empty: every border point).
  std::function<bool(PointId)> within;
  /// Points that must not disappear (fixed or grasped): a point joined to one merges into it.
  /// Two locked points are joined only where their rest positions agree (a cut's copies of one
  /// held point: one of them stays); elsewhere the pair is left open.
  std::vector<PointId> locked;
  /// Points kept rather than the others they are joined to where the choice is free (the points a
  /// suture's thread ties).
  std::vector<PointId> preferred;
  /// Quality repair around the seam, in the same transaction (off by default at this level).
  RepairOptions repair;
};

/// Result of a sew.
struct SewResult {
  std::size_t edgesJoined = 0;    ///< pairs of border edges made one interior edge
  std::size_t pointsRemoved = 0;  ///< lip points that disappeared into the point they joined
  std::size_t splits = 0;         ///< lip edges split where a point of the other lip faced them
  std::vector<PointId> inserted;  ///< points inserted on a lip facing a point of the other, that
                                  ///< stayed (most are joined into a new point)
  std::vector<PointId> merged;    ///< what each group of joined points became (ascending)
  /// Each group of joined points (ids from before the sew, or inserted by it) and the point it
  /// became (after the repair: the point that took its place).
  struct Group {
    PointId into;
    std::vector<PointId> points;
  };
  std::vector<Group> groups;
  double largestGap = 0.0;  ///< the largest world distance between two points joined
  /// Facing pairs within the tolerance left open: joining them would have joined both ends of an
  /// edge (lips whose edges are shorter than the gap between them there) or left the surface
  /// non-manifold (lips that cross each other).
  std::size_t edgesLeftOpen = 0;
  RepairReport repair;  ///< the repair that followed (all zero without one)
};

struct ValidationReport {
  std::vector<std::string> problems;
  bool ok() const { return problems.empty(); }
  std::string summary() const;
};

class Topology {
 public:
  Topology();
  /// Builds from rest positions and counter-clockwise triangles; checks manifoldness
  /// (throws InvalidInput). Points not used by a triangle are kept as isolated points.
  Topology(std::span<const Vec3> restPoints, std::span<const TriangleVertices> triangles);
  explicit Topology(const MeshData& mesh);
  ~Topology();
  Topology(Topology&&) noexcept;
  Topology& operator=(Topology&&) noexcept;
  Topology(const Topology&) = delete;
  Topology& operator=(const Topology&) = delete;

  // ---- counts and slots ----
  std::size_t numPoints() const;     ///< live points
  std::size_t numEdges() const;      ///< live edges
  std::size_t numTriangles() const;  ///< live triangles
  Index pointCapacity() const;       ///< slots, live or dead: every PointId < pointCapacity()
  Index edgeCapacity() const;
  Index triangleCapacity() const;
  bool isPointAlive(PointId p) const;
  bool isEdgeAlive(EdgeId e) const;
  bool isTriangleAlive(TriangleId t) const;
  /// Fraction of dead slots over all slots (points, edges, triangles together).
  double garbageFraction() const;
  /// Increases with every transaction that changes the mesh and with every compaction (for
  /// caches of what depends on the connectivity, such as a solver's sparsity pattern).
  std::uint64_t revision() const;
  /// A 64-bit hash (FNV-1a) of the whole half-edge structure as stored: every slot, live or dead,
  /// its connectivity, removal flag and rest position bit for bit, the removal counters and free
  /// lists, and the revision. Two topologies with the same digest behave the same under every
  /// operation; a failed operation leaves it unchanged (the undo journal).
  std::uint64_t digest() const;

  // ---- geometry (rest configuration: material coordinates) ----
  Vec3 restPosition(PointId p) const;
  /// The rest position of a point of triangle t given by its barycentric weights (in the order
  /// of triangleVertices(t)): where a located surface point is in the material.
  Vec3 restPositionOn(TriangleId t, const std::array<double, 3>& weights) const;

  // ---- queries ----
  EdgeVertices edgeVertices(EdgeId e) const;
  TriangleVertices triangleVertices(TriangleId t) const;  ///< counter-clockwise
  TriangleEdges triangleEdges(TriangleId t) const;        ///< edge i is opposite vertex i
  /// The triangles on either side of e: [0] lies to the left of edgeVertices(e) (the triangle
  /// where the edge runs v0 -> v1), [1] to the right; kInvalidIndex where there is none.
  std::array<TriangleId, 2> edgeTriangles(EdgeId e) const;
  PointId oppositeVertex(TriangleId t, EdgeId e) const;  ///< throws if e is not an edge of t
  EdgeId findEdge(PointId a, PointId b) const;           ///< kInvalidIndex if none
  bool isBoundaryEdge(EdgeId e) const;                   ///< fewer than two triangles
  bool isBoundaryPoint(PointId p) const;                 ///< on a boundary edge
  bool isIsolatedPoint(PointId p) const;                 ///< in no edge
  std::vector<EdgeId> edgesAroundPoint(PointId p) const;
  std::vector<TriangleId> trianglesAroundPoint(PointId p) const;
  std::vector<PointId> points() const;  ///< live ids, ascending
  std::vector<EdgeId> edges() const;
  std::vector<TriangleId> triangles() const;

  // ---- observers ----
  [[nodiscard]] Subscription subscribe(TopologyObserver& observer);
  std::size_t numObservers() const;

  // ---- operations: each is one transaction (validated first: a rejected request throws
  //      TopologyError and changes nothing) ----
  std::vector<PointId> addPoints(std::span<const Vec3> restPositions);
  std::vector<TriangleId> addTriangles(std::span<const TriangleVertices> triangles);
  /// Removes the triangles, then the edges and points they leave unused (carving).
  void removeTriangles(std::span<const TriangleId> triangles);
  /// As above, then the quality repair of the hole's surroundings, in the same transaction.
  RepairReport removeTriangles(std::span<const TriangleId> triangles, const RepairOptions& repair);
  /// Carving along a boundary: removes the part of the surface where phi (a function of the rest
  /// position, <= 0 inside, > 0 outside) is inside, cutting the triangles its boundary crosses:
  /// every edge with one end inside and one outside is split where phi, followed along the edge,
  /// becomes positive (bisection), which leaves the boundary as a chain of edges (a point within
  /// a quarter of an edge of a crossing first moves onto it, unless it is on the border, locked
  /// by `repair.locked`, its star is not flat, or it is the last inside point around); the
  /// triangles inside go, then the quality repair runs around the hole. One transaction. Returns
  /// the repair's report and the number of triangles removed (0: no point is inside; nothing
  /// changes).
  RepairReport carve(const std::function<double(const Vec3&)>& phi, const RepairOptions& repair,
                     std::size_t* removed = nullptr);
  /// A point of the surface as weights of points that were live when an operation began.
  using PointWeights = std::span<const std::pair<PointId, double>>;
  /// The same carving, phi also given each point it is asked about as weights of the points live
  /// when the carve began (a vertex: itself; a point along an edge: its two ends; a centroid: up to
  /// six): what a region given in the world needs, since the same weights of the points' current
  /// positions give where that point is now (a cautery carving the surface as it is; a function
  /// of the rest position alone cannot tell the two lips of a cut apart). With `moveBorder`,
  /// border points too move onto a crossing within a quarter of an edge (a hole carved again
  /// where it is: its rim lies on the last region's boundary, a hair's breadth from the next
  /// one's, where crossings would leave edges a tiny fraction of the mesh's, which the repair can
  /// only refine around): the outline within a quarter of an edge of the region is drawn onto
  /// its boundary, the outer border's and a cut's lips' too.
  RepairReport carve(const std::function<double(const Vec3&, PointWeights)>& phi,
                     const RepairOptions& repair, std::size_t* removed = nullptr,
                     bool moveBorder = false);
  /// Inserts a point on e at v0 + t (v1 - v0), t in (0, 1); the one or two triangles split too.
  PointId splitEdge(EdgeId e, double t);
  /// Inserts a point inside t with barycentric weights (sum 1, each > 0); t splits into three.
  PointId splitTriangle(TriangleId t, const std::array<double, 3>& barycentric);
  /// Opens the mesh along a path of interior edges (consecutive points joined by edges).
  /// Every path vertex whose triangles the cut separates into several fans is duplicated; the
  /// fan that holds the triangle to the RIGHT of the path (seen from the triangles' front side,
  /// walking along the path) keeps the original vertex, the others move to copies. A path of one
  /// edge between two interior points is first split at its midpoint. No bowtie is left.
  IncisionResult incise(std::span<const PointId> path);
  /// Separates the two triangles across an interior edge, opening the mesh there.
  IncisionResult tear(EdgeId e);
  IncisionResult tear(EdgeId e, const RepairOptions& repair);  ///< then the quality repair
  /// Cuts along a polyline given in rest coordinates, from a surface point to a surface point:
  /// inserts the path (splitting crossed edges and triangles, snapping), then incises it. The
  /// insertion is planned on a copy of the triangles around the cut first: a request that cannot
  /// be carried out throws TopologyError and changes nothing.
  IncisionResult cutPolyline(std::span<const Vec3> polyline, const CutOptions& options = {});
  /// Sews lips back together, the reverse of a cut: every pair of facing border edges whose ends
  /// lie within `options.tolerance` of each other where the surface is now (`positions`: x, y, z
  /// per point slot, world coordinates) becomes one interior edge. Facing: the two edges run in
  /// opposite directions and their triangles lie on either side of the seam. A lip point facing
  /// the middle of the other lip's edge, no point of it within the tolerance, first becomes a
  /// point of that edge too (split there), so lips cut or repaired apart still meet point to
  /// point. Each group of joined points becomes one point: one of them where their rest
  /// positions are the same (a locked one, else a preferred one, else the lowest id: the others
  /// are destroyed), else a new point at their mean (ancestors: the group, equal weights; the
  /// group destroyed). A pair that would join both ends of an edge or leave the surface
  /// non-manifold (lips that cross) is left open (SewResult::edgesLeftOpen). Observers follow
  /// through the usual events. One transaction ("sew"): a request that finds no facing lips within
  /// the tolerance (it says how far apart the closest are), can join none of them, or would leave
  /// a point joining two pieces at a corner only, throws TopologyError
  /// naming what and where, and changes nothing. See "Sewing" in docs/topology-events.md.
  SewResult sew(std::span<const double> positions, const SewOptions& options);
  /// Quality repair (edge flips, edge collapses, vertex relocations, border splits) of the
  /// triangles around the given points, as a transaction of its own ("repair"): see
  /// docs/topology-events.md. Points may be dead (ignored).
  RepairReport repair(std::span<const PointId> around, const RepairOptions& options);
  /// Renumbers every element densely and emits renumbering events (old -> new).
  void compact();

  // ---- checking ----
  /// Half-edge structure, manifoldness, and every observer's validate().
  ValidationReport validate() const;
  void validateOrThrow() const;  ///< throws TopologyError listing the problems

  // ---- checkpoints ----
  /// Writes the whole structure as stored, every slot live or dead with its connectivity,
  /// removal flag and rest position, the counters, free lists and revision, into the section
  /// "topology" (an observer's data goes in sections of its own).
  void save(ArchiveWriter& out) const;
  /// Reads what save() wrote: the same structure bit for bit (digest() is checked against the
  /// saved one), with no observer. Every index is checked before use and the half-edge structure
  /// validated: a damaged or foreign archive is refused (InvalidInput naming the archive).
  static Topology load(ArchiveReader& in);

  /// Current state as a triangle soup (live points densely renumbered in ascending id order).
  MeshData toMeshData(std::vector<PointId>* pointIds = nullptr) const;

  struct Impl;  ///< implementation detail (CGAL-based), opaque outside topology/src

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace cutsim::topology
