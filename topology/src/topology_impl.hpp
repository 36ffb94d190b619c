#pragma once
// Private to topology/: the CGAL-based implementation of Topology. The only place (with the
// topology_*.cpp files that include it) where CGAL's headers are seen.
#include <functional>
#include <optional>
#include <string>
#include <type_traits>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "cutsim/topology/failure_injection.hpp"
#include "cutsim/topology/topology.hpp"
#include "mesh_journal.hpp"

namespace cutsim::topology {

/// A point this close to a line, relative to the line's length, lies on it up to a rounding (or a
/// curved surface's sagitta): cutPolyline snaps crossings as close as that even with the quality
/// repair, and the repair takes a point that close to a chord as on it.
inline constexpr double kSamePoint = 1e-3;

struct Subscription::Registry {
  std::vector<TopologyObserver*> observers;
  bool delivering = false;
};

/// Uniform hash grid of triangles' rest bounding boxes, for locating a point on the surface in
/// time independent of the mesh size. Built on first use, then kept up to date by the commits.
class TriangleGrid {
 public:
  bool built() const { return built_; }
  /// Builds the grid; its cell size is chosen at the first build (twice the mean edge length)
  /// and kept from then on, so that a saved and loaded topology locates points alike.
  void build(const Mesh& mesh);
  void clear() {
    built_ = false;
    cells_.clear();
  }
  void insert(const Mesh& mesh, FI f);
  void erase(const std::array<Point3, 3>& corners, FI f);
  /// Triangles whose box meets the cube of half-size r around p.
  void query(const Point3& p, double r, std::vector<FI>& out) const;
  double cellSize() const { return cell_; }
  /// The cell size chosen (0: none yet), as saved and loaded with the topology.
  double chosenCellSize() const { return chosen_; }
  void chooseCellSize(double cell) { chosen_ = cell; }

 private:
  using Key = std::uint64_t;
  Key key(long i, long j, long k) const;
  void cellRange(const std::array<Point3, 3>& c, long lo[3], long hi[3]) const;
  bool built_ = false;
  double cell_ = 1.0;
  double chosen_ = 0.0;
  std::unordered_map<Key, std::vector<FI>> cells_;
};

struct Topology::Impl {
  Mesh mesh;
  std::shared_ptr<Subscription::Registry> registry = std::make_shared<Subscription::Registry>();
  TriangleGrid grid;
  std::uint64_t revision = 0;  // see Topology::revision()

  // ---- the open transaction (journal) ----
  bool open = false;
  std::string operation;
  Index vBefore = 0, eBefore = 0, fBefore = 0;  // slots below these existed before
  std::vector<TriangleId> trisDestroyed;
  std::vector<TriangleVertices> trisDestroyedV;
  std::vector<TriangleEdges> trisDestroyedE;
  std::vector<std::array<Point3, 3>> trisDestroyedP;
  std::vector<EdgeId> edgesDestroyed;
  std::vector<EdgeVertices> edgesDestroyedV;
  std::vector<PointId> pointsDestroyed;
  std::unordered_map<PointId, std::vector<std::pair<PointId, double>>> ancestry;
  std::vector<VI> touched;
  MeshJournal journal;  // what the open transaction changed, to put it back on failure

  Impl() { mesh.set_recycle_garbage(false); }

  // queries on the CGAL structure
  FI faceOf(TriangleId t) const { return FI(t.idx()); }
  TriangleVertices verticesOf(FI f) const;
  TriangleEdges edgesOf(FI f) const;
  bool faceAlive(FI f) const { return f.idx() < mesh.num_faces() && !mesh.is_removed(f); }
  bool vertexAlive(VI v) const { return v.idx() < mesh.num_vertices() && !mesh.is_removed(v); }
  bool edgeAlive(EI e) const { return e.idx() < mesh.num_edges() && !mesh.is_removed(e); }
  HI findHalfedge(VI a, VI b) const;  // a -> b, or null
  void incomingHalfedges(VI v, std::vector<HI>& out) const;
  double localEdgeLength(VI v) const;

  // transaction primitives
  void begin(std::string op);
  VI newPoint(const std::vector<std::pair<PointId, double>>& ancestors);
  VI newFreePoint(const Point3& p);
  void detachFace(FI f);
  /// Adds the faces (any order; retried until all fit). Throws TopologyError if impossible.
  std::vector<FI> attachFaces(const std::vector<std::array<VI, 3>>& faces);
  /// Replaces (face, vertex) incidences: detaches every listed face and attaches it again with
  /// the substituted vertices.
  void reattach(const std::vector<FI>& faces, const std::unordered_map<std::uint64_t, VI>& subst);
  /// Faces around v grouped into fans; fans are separated by border edges and by edges for which
  /// isSeparator returns true.
  std::vector<std::vector<FI>> fansAround(VI v, const std::function<bool(EI)>& isSeparator) const;
  /// Splits every candidate vertex that has two or more fans: the fan holding keepFace (or, if
  /// none given, the smallest face index) keeps the vertex. Returns the copies made.
  void splitFans(const std::vector<VI>& candidates, const std::function<bool(EI)>& isSeparator,
                 const std::unordered_map<std::uint32_t, FI>& keepFace,
                 std::vector<PointId>* copies, std::vector<PointId>* copiedFrom);
  /// Ends the open transaction: removes the points it left isolated, then delivers the events.
  /// A failure before the first event rolls the transaction back (and propagates); an observer
  /// that throws does not stop the delivery (Delivery in topology.cpp).
  void commit(Topology& self);
  /// Runs `body` in the open transaction begun as `op`, then commits; when body throws, the
  /// transaction is rolled back (the mesh as it was, no event) and the error propagates.
  template <class F>
  auto committed(Topology& self, std::string op, F&& body) {
    begin(std::move(op));
    using R = decltype(body());
    if constexpr (std::is_void_v<R>) {
      try {
        body();
      } catch (...) {
        rollback();
        throw;
      }
      commit(self);
    } else {
      std::optional<R> result;
      try {
        result.emplace(body());
      } catch (...) {
        rollback();
        throw;
      }
      commit(self);
      return std::move(*result);
    }
  }
  /// Puts the mesh back as it was when the open transaction began and closes it (no event).
  void rollback() noexcept;
  /// Closes the transaction's lists (after commit or rollback).
  void clearTransaction() noexcept;

  // operations used by several public ones
  VI splitEdgeNoTxn(EI e, VI from, double t);
  VI splitFaceNoTxn(FI f, const std::array<double, 3>& bary);
  /// As above, the new point weighting f's corners listed in `corners` (any order) by `weights`,
  /// summed in that order.
  VI splitFaceNoTxn(FI f, const std::array<VI, 3>& corners, const std::array<double, 3>& weights);
  void inciseNoTxn(std::vector<VI> path, IncisionResult& result);
  /// Quality repair around `seeds` and the points created so far in this transaction
  /// (topology_repair.cpp). replacedBy: a point the repair removed -> the point that took its place
  /// (follow chains).
  RepairReport repairNoTxn(const std::vector<VI>& seeds, const RepairOptions& options,
                           std::unordered_map<Index, Index>& replacedBy);
  /// The repair, then the points of `result` mapped through its replacements.
  void repairIncision(const RepairOptions& options, IncisionResult& result);

  static std::uint64_t faceVertexKey(FI f, VI v) {
    return (std::uint64_t(f.idx()) << 32) | std::uint64_t(v.idx());
  }
};

/// Throws TopologyError naming `operation` when the options are out of range.
void checkRepairOptions(const RepairOptions& options, const char* operation);

inline Vec3 toVec(const Point3& p) {
  return {p.x(), p.y(), p.z()};
}
inline Point3 toPoint(const Vec3& v) {
  return Point3(v[0], v[1], v[2]);
}

}  // namespace cutsim::topology
