#pragma once
// Private to topology/: the undo journal of a transaction. Before a primitive changes the
// half-edge structure, it records the old connectivity of every element it may write (the star of
// each vertex it works around); a failure anywhere before the events are delivered puts every
// recorded element back, cuts the arrays back to their sizes at the start (new elements are only
// ever appended: garbage is not recycled) and restores the mesh's counters, so that the mesh is
// the same bit for bit as before the transaction (Topology::digest() is unchanged).
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>

#include <cstdint>
#include <unordered_set>
#include <utility>
#include <vector>

namespace cutsim::topology {

using Kernel = CGAL::Simple_cartesian<double>;
using Point3 = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point3>;
using VI = Mesh::Vertex_index;
using HI = Mesh::Halfedge_index;
using EI = Mesh::Edge_index;
using FI = Mesh::Face_index;

namespace detail {
// Surface_mesh keeps its connectivity arrays, removal flags, removal counters and free lists
// private, and offers no way to un-remove an element or to lower a counter. The journal reaches
// them through the one place where C++ does not check access: the arguments of an explicit
// instantiation ([temp.spec.general]: "the usual access checking rules do not apply to names used
// to specify explicit instantiations"). Each tag's friend function returns a pointer to one
// member; nothing else of CGAL's internals is used.
template <class Tag, auto Member>
struct Reach {
  friend constexpr auto member(Tag) { return Member; }
};
#define CUTSIM_MESH_MEMBER(TAG, NAME)  \
  struct TAG {                         \
    friend constexpr auto member(TAG); \
  };                                   \
  template struct Reach<TAG, &Mesh::NAME>;
CUTSIM_MESH_MEMBER(VConn, vconn_)
CUTSIM_MESH_MEMBER(HConn, hconn_)
CUTSIM_MESH_MEMBER(FConn, fconn_)
CUTSIM_MESH_MEMBER(VRemoved, vremoved_)
CUTSIM_MESH_MEMBER(ERemoved, eremoved_)
CUTSIM_MESH_MEMBER(FRemoved, fremoved_)
CUTSIM_MESH_MEMBER(RemovedVertices, removed_vertices_)
CUTSIM_MESH_MEMBER(RemovedEdges, removed_edges_)
CUTSIM_MESH_MEMBER(RemovedFaces, removed_faces_)
CUTSIM_MESH_MEMBER(VerticesFreelist, vertices_freelist_)
CUTSIM_MESH_MEMBER(EdgesFreelist, edges_freelist_)
CUTSIM_MESH_MEMBER(FacesFreelist, faces_freelist_)
CUTSIM_MESH_MEMBER(Garbage, garbage_)
#undef CUTSIM_MESH_MEMBER

template <class Tag>
decltype(auto) field(Mesh& m) {
  return m.*member(Tag{});
}
template <class Tag>
decltype(auto) field(const Mesh& m) {
  return m.*member(Tag{});
}

/// The connectivity arrays and removal flags of a mesh, as stored.
struct Arrays {
  decltype(field<VConn>(std::declval<Mesh&>())) vconn;
  decltype(field<HConn>(std::declval<Mesh&>())) hconn;
  decltype(field<FConn>(std::declval<Mesh&>())) fconn;
  decltype(field<VRemoved>(std::declval<Mesh&>())) vremoved;
  decltype(field<ERemoved>(std::declval<Mesh&>())) eremoved;
  decltype(field<FRemoved>(std::declval<Mesh&>())) fremoved;
  explicit Arrays(Mesh& m)
      : vconn(field<VConn>(m)),
        hconn(field<HConn>(m)),
        fconn(field<FConn>(m)),
        vremoved(field<VRemoved>(m)),
        eremoved(field<ERemoved>(m)),
        fremoved(field<FRemoved>(m)) {}
};

/// The mesh's removal counters, free lists' heads and garbage flag.
struct Header {
  Mesh::size_type removedV = 0, removedE = 0, removedF = 0;
  Mesh::size_type freeV = 0, freeE = 0, freeF = 0;
  bool garbage = false;
  static Header of(const Mesh& m) {
    return {field<RemovedVertices>(m),  field<RemovedEdges>(m),  field<RemovedFaces>(m),
            field<VerticesFreelist>(m), field<EdgesFreelist>(m), field<FacesFreelist>(m),
            field<Garbage>(m)};
  }
  void applyTo(Mesh& m) const noexcept {
    field<RemovedVertices>(m) = removedV;
    field<RemovedEdges>(m) = removedE;
    field<RemovedFaces>(m) = removedF;
    field<VerticesFreelist>(m) = freeV;
    field<EdgesFreelist>(m) = freeE;
    field<FacesFreelist>(m) = freeF;
    field<Garbage>(m) = garbage;
  }
};
}  // namespace detail

class MeshJournal {
 public:
  /// Starts recording: the sizes and counters of the mesh as they are now.
  void begin(const Mesh& m) {
    clear();
    active_ = true;
    nv_ = m.num_vertices();
    ne_ = m.num_edges();
    nf_ = m.num_faces();
    header_ = detail::Header::of(m);
  }
  bool active() const { return active_; }

  /// Records v, every edge (both halfedges) incident to it and every face around it (each is the
  /// face of an incoming halfedge), before a primitive changes anything there (the first record
  /// of an element wins: it holds the value at the start of the transaction).
  void recordStar(const Mesh& m, VI v) {
    if (!active_) return;
    recordVertex(m, v);
    if (v.idx() >= nv_ || m.is_removed(v)) return;
    HI h = m.halfedge(v);
    if (!h.is_valid()) return;
    const HI start = h;
    std::size_t guard = 0;
    do {
      recordEdge(m, m.edge(h));
      recordFace(m, m.face(h));
      h = m.opposite(m.next(h));
      if (++guard > m.num_halfedges()) break;
    } while (h != start);
  }
  void recordVertex(const Mesh& m, VI v) {
    if (!active_ || v.idx() >= nv_ || !seenV_.insert(v.idx()).second) return;
    vertices_.push_back({v.idx(), detail::field<detail::VConn>(m)[v], m.is_removed(v)});
  }
  void recordEdge(const Mesh& m, EI e) {
    if (!active_ || e.idx() >= ne_ || !seenE_.insert(e.idx()).second) return;
    const auto& hconn = detail::field<detail::HConn>(m);
    const HI h0(2 * e.idx()), h1(2 * e.idx() + 1);
    edges_.push_back({e.idx(), hconn[h0], hconn[h1], m.is_removed(e)});
  }
  void recordFace(const Mesh& m, FI f) {
    if (!active_ || !f.is_valid() || f.idx() >= nf_ || !seenF_.insert(f.idx()).second) return;
    faces_.push_back({f.idx(), detail::field<detail::FConn>(m)[f], m.is_removed(f)});
  }

  /// Puts the mesh back as it was at begin(). Allocates nothing (cannot fail).
  void rollback(Mesh& m) noexcept {
    if (!active_) return;
    detail::Arrays a(m);
    for (const auto& r : vertices_) {
      a.vconn[VI(r.index)] = r.conn;
      a.vremoved[VI(r.index)] = r.removed;
    }
    for (const auto& r : edges_) {
      a.hconn[HI(2 * r.index)] = r.conn0;
      a.hconn[HI(2 * r.index + 1)] = r.conn1;
      a.eremoved[EI(r.index)] = r.removed;
    }
    for (const auto& r : faces_) {
      a.fconn[FI(r.index)] = r.conn;
      a.fremoved[FI(r.index)] = r.removed;
    }
    m.resize(nv_, ne_, nf_);  // shrinking: no allocation
    header_.applyTo(m);
    active_ = false;
  }

  void clear() noexcept {
    active_ = false;
    vertices_.clear();
    edges_.clear();
    faces_.clear();
    seenV_.clear();
    seenE_.clear();
    seenF_.clear();
  }

  /// Elements recorded so far (for the tests and the benchmarks).
  std::size_t size() const { return vertices_.size() + edges_.size() + faces_.size(); }

 private:
  using VConnT = std::remove_cvref_t<decltype(detail::field<detail::VConn>(std::declval<Mesh&>()))>;
  using HConnT = std::remove_cvref_t<decltype(detail::field<detail::HConn>(std::declval<Mesh&>()))>;
  using FConnT = std::remove_cvref_t<decltype(detail::field<detail::FConn>(std::declval<Mesh&>()))>;
  using VRec = std::remove_cvref_t<decltype(std::declval<VConnT&>()[VI()])>;
  using HRec = std::remove_cvref_t<decltype(std::declval<HConnT&>()[HI()])>;
  using FRec = std::remove_cvref_t<decltype(std::declval<FConnT&>()[FI()])>;
  struct VertexRecord {
    Mesh::size_type index;
    VRec conn;
    bool removed;
  };
  struct EdgeRecord {
    Mesh::size_type index;
    HRec conn0, conn1;
    bool removed;
  };
  struct FaceRecord {
    Mesh::size_type index;
    FRec conn;
    bool removed;
  };

  bool active_ = false;
  Mesh::size_type nv_ = 0, ne_ = 0, nf_ = 0;
  detail::Header header_;
  std::vector<VertexRecord> vertices_;
  std::vector<EdgeRecord> edges_;
  std::vector<FaceRecord> faces_;
  std::unordered_set<Mesh::size_type> seenV_, seenE_, seenF_;
};

}  // namespace cutsim::topology
