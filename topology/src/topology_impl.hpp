#pragma once
// Private to topology/: the CGAL-based implementation of Topology. The only place (with the
// topology_*.cpp files that include it) where CGAL's headers are seen.
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>

#include <functional>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "cutsim/topology/topology.hpp"

namespace cutsim::topology {

using Kernel = CGAL::Simple_cartesian<double>;
using Point3 = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point3>;
using VI = Mesh::Vertex_index;
using HI = Mesh::Halfedge_index;
using EI = Mesh::Edge_index;
using FI = Mesh::Face_index;

struct Subscription::Registry {
  std::vector<TopologyObserver*> observers;
  bool delivering = false;
};

/// Uniform hash grid of triangles' rest bounding boxes, for locating a point on the surface in
/// time independent of the mesh size. Built on first use, then kept up to date by the commits.
class TriangleGrid {
 public:
  bool built() const { return built_; }
  void build(const Mesh& mesh);
  void clear() { built_ = false; cells_.clear(); }
  void insert(const Mesh& mesh, FI f);
  void erase(const std::array<Point3, 3>& corners, FI f);
  /// Triangles whose box meets the cube of half-size r around p.
  void query(const Point3& p, double r, std::vector<FI>& out) const;
  double cellSize() const { return cell_; }

 private:
  using Key = std::uint64_t;
  Key key(long i, long j, long k) const;
  void cellRange(const std::array<Point3, 3>& c, long lo[3], long hi[3]) const;
  bool built_ = false;
  double cell_ = 1.0;
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

  Impl() { mesh.set_recycle_garbage(false); }

  // queries on the CGAL structure
  FI faceOf(TriangleId t) const { return FI(t); }
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
  void commit(Topology& self);
  /// Runs `body` in the open transaction, then commits, also when body throws: the mesh is valid
  /// after every primitive, so what was done is announced before the error propagates.
  template <class F>
  auto committed(Topology& self, F&& body) {
    decltype(body()) result{};
    try {
      result = body();
    } catch (...) {
      commit(self);
      throw;
    }
    commit(self);
    return result;
  }
  void abortIfOpen();

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

inline Vec3 toVec(const Point3& p) { return {p.x(), p.y(), p.z()}; }
inline Point3 toPoint(const Vec3& v) { return Point3(v[0], v[1], v[2]); }

}  // namespace cutsim::topology
