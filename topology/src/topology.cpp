// Topology: construction, queries, observers, transactions and event delivery, validation,
// compaction. Operations are in topology_ops.cpp and topology_cut.cpp.
#include <CGAL/boost/graph/Euler_operations.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

#include "cutsim/base/union_find.hpp"
#include "topology_impl.hpp"

namespace cutsim::topology {

// ------------------------------------------------------------------------------------------
// Subscription

Subscription::Subscription(std::weak_ptr<Registry> registry, TopologyObserver* observer)
    : registry_(std::move(registry)), observer_(observer) {}
Subscription::Subscription(Subscription&& o) noexcept
    : registry_(std::move(o.registry_)), observer_(o.observer_) {
  o.observer_ = nullptr;
}
Subscription& Subscription::operator=(Subscription&& o) noexcept {
  if (this != &o) {
    reset();
    registry_ = std::move(o.registry_);
    observer_ = o.observer_;
    o.observer_ = nullptr;
  }
  return *this;
}
Subscription::~Subscription() {
  reset();
}
void Subscription::reset() {
  if (auto r = registry_.lock(); r && observer_) {
    auto& obs = r->observers;
    obs.erase(std::remove(obs.begin(), obs.end(), observer_), obs.end());
  }
  registry_.reset();
  observer_ = nullptr;
}
bool Subscription::active() const {
  return observer_ != nullptr && !registry_.expired();
}

std::string ValidationReport::summary() const {
  std::ostringstream s;
  for (std::size_t i = 0; i < problems.size() && i < 20; ++i) s << "  - " << problems[i] << "\n";
  if (problems.size() > 20) s << "  ... and " << problems.size() - 20 << " more\n";
  return s.str();
}

// ------------------------------------------------------------------------------------------
// Construction

Topology::Topology() : impl_(std::make_unique<Impl>()) {}

Topology::Topology(const MeshData& data) : impl_(std::make_unique<Impl>()) {
  checkManifold(data);
  Mesh& m = impl_->mesh;
  // Room for a quarter more of everything: cuts add elements at the end, and the first growth of
  // an array filled to its capacity would copy the whole mesh in the middle of a cut.
  const std::size_t nv = data.points.size(), nf = data.triangles.size();
  const std::size_t ne = nv + nf + 1;  // Euler: E = V + F - chi, a little over for open meshes
  m.reserve(nv + nv / 4, ne + ne / 4, nf + nf / 4);
  for (const Vec3& p : data.points) m.add_vertex(toPoint(p));
  std::vector<std::array<VI, 3>> faces;
  faces.reserve(data.triangles.size());
  for (const auto& t : data.triangles)
    faces.push_back({VI(t[0].idx()), VI(t[1].idx()), VI(t[2].idx())});
  CGAL::Euler::add_faces(faces, m);
  if (m.number_of_faces() != data.triangles.size()) {
    throw TopologyError("internal error: the half-edge structure took " +
                        std::to_string(m.number_of_faces()) + " of " +
                        std::to_string(data.triangles.size()) + " triangles");
  }
  // Each triangle starts at its first vertex as given (CGAL's add_face starts it at the last):
  // triangleVertices gives back the file's order, which formulations that are not invariant
  // under a rotation of the vertices (SOFA's TriangularFEMForceFieldOptim: a frame along the
  // first edge) need.
  for (const auto& t : data.triangles) {
    const HI h = m.halfedge(VI(t[0].idx()), VI(t[1].idx()));
    if (h != Mesh::null_halfedge() && m.face(h) != Mesh::null_face()) m.set_halfedge(m.face(h), h);
  }
}

namespace {
MeshData soup(std::span<const Vec3> pts, std::span<const TriangleVertices> tris) {
  MeshData d;
  d.points.assign(pts.begin(), pts.end());
  d.triangles.assign(tris.begin(), tris.end());
  d.pointLines.assign(pts.size(), 0);
  d.triangleLines.assign(tris.size(), 0);
  for (std::size_t i = 0; i < pts.size(); ++i)
    for (double c : pts[i])
      if (!std::isfinite(c))
        throw InvalidInput("point " + std::to_string(i), "non-finite rest coordinate");
  for (std::size_t i = 0; i < tris.size(); ++i) {
    for (PointId v : tris[i])
      if (v.idx() >= pts.size())
        throw InvalidInput("triangle " + std::to_string(i),
                           "vertex index " + std::to_string(v.idx()) + " out of range [0, " +
                               std::to_string(pts.size()) + ")");
    if (tris[i][0] == tris[i][1] || tris[i][1] == tris[i][2] || tris[i][0] == tris[i][2])
      throw InvalidInput("triangle " + std::to_string(i), "repeated vertex in a triangle");
  }
  return d;
}
}  // namespace

Topology::Topology(std::span<const Vec3> restPoints, std::span<const TriangleVertices> triangles)
    : Topology(soup(restPoints, triangles)) {}

Topology::~Topology() = default;
Topology::Topology(Topology&&) noexcept = default;
Topology& Topology::operator=(Topology&&) noexcept = default;

// ------------------------------------------------------------------------------------------
// Queries

std::size_t Topology::numPoints() const {
  return impl_->mesh.number_of_vertices();
}
std::size_t Topology::numEdges() const {
  return impl_->mesh.number_of_edges();
}
std::size_t Topology::numTriangles() const {
  return impl_->mesh.number_of_faces();
}
Index Topology::pointCapacity() const {
  return Index(impl_->mesh.num_vertices());
}
Index Topology::edgeCapacity() const {
  return Index(impl_->mesh.num_edges());
}
Index Topology::triangleCapacity() const {
  return Index(impl_->mesh.num_faces());
}
bool Topology::isPointAlive(PointId p) const {
  return impl_->vertexAlive(VI(p.idx()));
}
bool Topology::isEdgeAlive(EdgeId e) const {
  return impl_->edgeAlive(EI(e.idx()));
}
bool Topology::isTriangleAlive(TriangleId t) const {
  return impl_->faceAlive(FI(t.idx()));
}

std::uint64_t Topology::revision() const {
  return impl_->revision;
}

std::uint64_t Topology::digest() const {
  const Mesh& m = impl_->mesh;
  std::uint64_t h = 14695981039346656037ull;
  auto mix = [&](const void* data, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
  };
  auto add = [&](std::uint64_t x) { mix(&x, sizeof x); };
  add(m.num_vertices());
  add(m.num_edges());
  add(m.num_faces());
  const detail::Header header = detail::Header::of(m);
  for (Mesh::size_type x : {header.removedV, header.removedE, header.removedF, header.freeV,
                            header.freeE, header.freeF})
    add(x);
  add(header.garbage ? 1 : 0);
  add(impl_->revision);
  for (Mesh::size_type i = 0; i < m.num_vertices(); ++i) {
    const VI v(i);
    add(m.halfedge(v).idx());
    add(m.is_removed(v) ? 1 : 0);
    const Point3& p = m.point(v);
    const double c[3] = {p.x(), p.y(), p.z()};
    mix(c, sizeof c);
  }
  for (Mesh::size_type i = 0; i < m.num_halfedges(); ++i) {
    const HI e(i);
    add(m.face(e).idx());
    add(m.target(e).idx());
    add(m.next(e).idx());
    add(m.prev(e).idx());
  }
  for (Mesh::size_type i = 0; i < m.num_edges(); ++i) add(m.is_removed(EI(i)) ? 1 : 0);
  for (Mesh::size_type i = 0; i < m.num_faces(); ++i) {
    add(m.halfedge(FI(i)).idx());
    add(m.is_removed(FI(i)) ? 1 : 0);
  }
  return h;
}

double Topology::garbageFraction() const {
  const Mesh& m = impl_->mesh;
  double slots = double(m.num_vertices() + m.num_edges() + m.num_faces());
  if (slots == 0) return 0.0;
  double dead = double(m.number_of_removed_vertices() + m.number_of_removed_edges() +
                       m.number_of_removed_faces());
  return dead / slots;
}

namespace {
[[noreturn]] void badIndex(const char* what, Index i) {
  throw TopologyError(std::string(what) + " " + std::to_string(i) + " does not exist");
}
}  // namespace

Vec3 Topology::restPosition(PointId p) const {
  if (!impl_->vertexAlive(VI(p.idx()))) badIndex("point", p.idx());
  return toVec(impl_->mesh.point(VI(p.idx())));
}

Vec3 Topology::restPositionOn(TriangleId t, const std::array<double, 3>& weights) const {
  const TriangleVertices v = triangleVertices(t);
  Vec3 r{0, 0, 0};
  for (std::size_t k = 0; k < 3; ++k) {
    const Vec3 q = restPosition(v[k]);
    for (std::size_t d = 0; d < 3; ++d) r[d] += weights[k] * q[d];
  }
  return r;
}

EdgeVertices Topology::edgeVertices(EdgeId e) const {
  if (!impl_->edgeAlive(EI(e.idx()))) badIndex("edge", e.idx());
  const Mesh& m = impl_->mesh;
  HI h = m.halfedge(EI(e.idx()));
  return {PointId(m.source(h).idx()), PointId(m.target(h).idx())};
}

TriangleVertices Topology::Impl::verticesOf(FI f) const {
  HI h = mesh.halfedge(f);
  return {PointId(mesh.source(h).idx()), PointId(mesh.target(h).idx()),
          PointId(mesh.target(mesh.next(h)).idx())};
}

TriangleEdges Topology::Impl::edgesOf(FI f) const {
  // vertices (s(h), t(h), t(next h)); edge i is opposite vertex i.
  HI h = mesh.halfedge(f);
  HI n = mesh.next(h);
  HI p = mesh.next(n);
  return {EdgeId(mesh.edge(n).idx()), EdgeId(mesh.edge(p).idx()), EdgeId(mesh.edge(h).idx())};
}

TriangleVertices Topology::triangleVertices(TriangleId t) const {
  if (!impl_->faceAlive(FI(t.idx()))) badIndex("triangle", t.idx());
  return impl_->verticesOf(FI(t.idx()));
}

TriangleEdges Topology::triangleEdges(TriangleId t) const {
  if (!impl_->faceAlive(FI(t.idx()))) badIndex("triangle", t.idx());
  return impl_->edgesOf(FI(t.idx()));
}

std::array<TriangleId, 2> Topology::edgeTriangles(EdgeId e) const {
  if (!impl_->edgeAlive(EI(e.idx()))) badIndex("edge", e.idx());
  const Mesh& m = impl_->mesh;
  HI h = m.halfedge(EI(e.idx()));
  FI a = m.face(h), b = m.face(m.opposite(h));
  return {a.is_valid() ? TriangleId(a.idx()) : TriangleId(kInvalidIndex),
          b.is_valid() ? TriangleId(b.idx()) : TriangleId(kInvalidIndex)};
}

PointId Topology::oppositeVertex(TriangleId t, EdgeId e) const {
  TriangleEdges te = triangleEdges(t);
  TriangleVertices tv = impl_->verticesOf(FI(t.idx()));
  for (int i = 0; i < 3; ++i)
    if (te[i] == e) return tv[i];
  throw TopologyError("edge " + std::to_string(e.idx()) + " is not an edge of triangle " +
                      std::to_string(t.idx()));
}

HI Topology::Impl::findHalfedge(VI a, VI b) const {
  HI h = mesh.halfedge(b);  // incoming to b
  if (!h.is_valid()) return Mesh::null_halfedge();
  HI start = h;
  std::size_t guard = 0;
  do {
    if (mesh.source(h) == a) return h;
    h = mesh.opposite(mesh.next(h));
    if (++guard > mesh.num_halfedges()) break;
  } while (h != start);
  return Mesh::null_halfedge();
}

EdgeId Topology::findEdge(PointId a, PointId b) const {
  if (!impl_->vertexAlive(VI(a.idx())) || !impl_->vertexAlive(VI(b.idx())) || a == b)
    return EdgeId(kInvalidIndex);
  HI h = impl_->findHalfedge(VI(a.idx()), VI(b.idx()));
  return h.is_valid() ? EdgeId(impl_->mesh.edge(h).idx()) : EdgeId(kInvalidIndex);
}

bool Topology::isBoundaryEdge(EdgeId e) const {
  if (!impl_->edgeAlive(EI(e.idx()))) badIndex("edge", e.idx());
  return impl_->mesh.is_border(EI(e.idx()));
}

bool Topology::isBoundaryPoint(PointId p) const {
  if (!impl_->vertexAlive(VI(p.idx()))) badIndex("point", p.idx());
  const Mesh& m = impl_->mesh;
  return !m.is_isolated(VI(p.idx())) && m.is_border(VI(p.idx()), true);
}

bool Topology::isIsolatedPoint(PointId p) const {
  if (!impl_->vertexAlive(VI(p.idx()))) badIndex("point", p.idx());
  return impl_->mesh.is_isolated(VI(p.idx()));
}

void Topology::Impl::incomingHalfedges(VI v, std::vector<HI>& out) const {
  out.clear();
  HI h = mesh.halfedge(v);
  if (!h.is_valid()) return;
  HI start = h;
  do {
    out.push_back(h);
    h = mesh.opposite(mesh.next(h));
    if (out.size() > mesh.num_halfedges()) break;
  } while (h != start);
}

std::vector<EdgeId> Topology::edgesAroundPoint(PointId p) const {
  if (!impl_->vertexAlive(VI(p.idx()))) badIndex("point", p.idx());
  std::vector<HI> hs;
  impl_->incomingHalfedges(VI(p.idx()), hs);
  std::vector<EdgeId> out;
  for (HI h : hs) out.push_back(EdgeId(impl_->mesh.edge(h).idx()));
  return out;
}

std::vector<TriangleId> Topology::trianglesAroundPoint(PointId p) const {
  if (!impl_->vertexAlive(VI(p.idx()))) badIndex("point", p.idx());
  std::vector<HI> hs;
  impl_->incomingHalfedges(VI(p.idx()), hs);
  std::vector<TriangleId> out;
  for (HI h : hs)
    if (FI f = impl_->mesh.face(h); f.is_valid()) out.push_back(TriangleId(f.idx()));
  return out;
}

std::vector<PointId> Topology::points() const {
  std::vector<PointId> out;
  out.reserve(numPoints());
  for (VI v : impl_->mesh.vertices()) out.push_back(PointId(v.idx()));
  return out;
}
std::vector<EdgeId> Topology::edges() const {
  std::vector<EdgeId> out;
  out.reserve(numEdges());
  for (EI e : impl_->mesh.edges()) out.push_back(EdgeId(e.idx()));
  return out;
}
std::vector<TriangleId> Topology::triangles() const {
  std::vector<TriangleId> out;
  out.reserve(numTriangles());
  for (FI f : impl_->mesh.faces()) out.push_back(TriangleId(f.idx()));
  return out;
}

double Topology::Impl::localEdgeLength(VI v) const {
  std::vector<HI> hs;
  incomingHalfedges(v, hs);
  if (hs.empty()) return 0.0;
  double sum = 0;
  for (HI h : hs)
    sum += std::sqrt(CGAL::squared_distance(mesh.point(mesh.source(h)), mesh.point(v)));
  return sum / double(hs.size());
}

MeshData Topology::toMeshData(std::vector<PointId>* pointIds) const {
  MeshData d;
  const Mesh& m = impl_->mesh;
  std::vector<PointId> dense(m.num_vertices(), PointId(kInvalidIndex));
  for (VI v : m.vertices()) {
    dense[v.idx()] = PointId(d.points.size());
    d.points.push_back(toVec(m.point(v)));
    if (pointIds) pointIds->push_back(PointId(v.idx()));
  }
  for (FI f : m.faces()) {
    TriangleVertices t = impl_->verticesOf(f);
    d.triangles.push_back({dense[t[0].idx()], dense[t[1].idx()], dense[t[2].idx()]});
  }
  d.pointLines.assign(d.points.size(), 0);
  d.triangleLines.assign(d.triangles.size(), 0);
  return d;
}

// ------------------------------------------------------------------------------------------
// Observers

Subscription Topology::subscribe(TopologyObserver& observer) {
  auto& obs = impl_->registry->observers;
  if (std::find(obs.begin(), obs.end(), &observer) != obs.end())
    throw TopologyError("observer '" + observer.observerName() + "' is already subscribed");
  obs.push_back(&observer);
  return Subscription(impl_->registry, &observer);
}

std::size_t Topology::numObservers() const {
  return impl_->registry->observers.size();
}

// ------------------------------------------------------------------------------------------
// Failure injection

namespace {
thread_local std::uint64_t gFailureCountdown = 0;  // 0: disarmed
thread_local std::uint64_t gFailurePointsPassed = 0;
}  // namespace

void injectFailureAt(std::uint64_t n) {
  gFailureCountdown = n;
  gFailurePointsPassed = 0;
}

std::uint64_t failurePointsPassed() {
  return gFailurePointsPassed;
}

void failurePoint(const char* where) {
  ++gFailurePointsPassed;
  if (gFailureCountdown != 0 && --gFailureCountdown == 0)
    throw InjectedFailure(std::string("injected failure at ") + where + " (failure point " +
                          std::to_string(gFailurePointsPassed) + ")");
}

// ------------------------------------------------------------------------------------------
// Transactions

void Topology::Impl::begin(std::string op) {
  if (registry->delivering)
    throw TopologyError("'" + op + "' called from an observer while events are delivered: " +
                        "observers must not change the topology");
  if (open)
    throw TopologyError("internal error: nested transaction '" + op + "' in '" + operation + "'");
  open = true;
  operation = std::move(op);
  vBefore = Index(mesh.num_vertices());
  eBefore = Index(mesh.num_edges());
  fBefore = Index(mesh.num_faces());
  journal.begin(mesh);
}

void Topology::Impl::clearTransaction() noexcept {
  open = false;
  trisDestroyed.clear();
  trisDestroyedV.clear();
  trisDestroyedE.clear();
  trisDestroyedP.clear();
  edgesDestroyed.clear();
  edgesDestroyedV.clear();
  pointsDestroyed.clear();
  ancestry.clear();
  touched.clear();
  journal.clear();
}

void Topology::Impl::rollback() noexcept {
  journal.rollback(mesh);
  clearTransaction();
}

VI Topology::Impl::newFreePoint(const Point3& p) {
  failurePoint("a new point");
  return mesh.add_vertex(p);
}

VI Topology::Impl::newPoint(const std::vector<std::pair<PointId, double>>& ancestors) {
  // Compose with the ancestry of points created earlier in this transaction.
  std::vector<std::pair<PointId, double>> flat;
  double x = 0, y = 0, z = 0;
  for (auto [a, w] : ancestors) {
    const Point3& p = mesh.point(VI(a.idx()));
    x += w * p.x();
    y += w * p.y();
    z += w * p.z();
    if (a.idx() >= vBefore) {
      auto it = ancestry.find(a);
      if (it != ancestry.end() && !it->second.empty()) {
        for (auto [aa, ww] : it->second) flat.emplace_back(aa, w * ww);
        continue;
      }
    }
    flat.emplace_back(a, w);
  }
  failurePoint("a new point");
  std::sort(flat.begin(), flat.end());
  std::vector<std::pair<PointId, double>> merged;
  for (auto& [a, w] : flat) {
    if (!merged.empty() && merged.back().first == a)
      merged.back().second += w;
    else
      merged.emplace_back(a, w);
  }
  VI v = mesh.add_vertex(Point3(x, y, z));
  ancestry[PointId(v.idx())] = std::move(merged);
  return v;
}

void Topology::Impl::detachFace(FI f) {
  // As CGAL::Euler::remove_face, but a vertex left without edges stays (isolated) until commit,
  // so that the same transaction may attach new faces to it.
  failurePoint("a triangle detached");
  for (PointId p : verticesOf(f)) journal.recordStar(mesh, VI(p.idx()));
  HI h = mesh.halfedge(f);
  HI end = h;
  if (f.idx() < fBefore) {
    trisDestroyed.push_back(TriangleId(f.idx()));
    trisDestroyedV.push_back(verticesOf(f));
    trisDestroyedE.push_back(edgesOf(f));
    auto v = verticesOf(f);
    trisDestroyedP.push_back(
        {mesh.point(VI(v[0].idx())), mesh.point(VI(v[1].idx())), mesh.point(VI(v[2].idx()))});
  }
  for (PointId p : verticesOf(f)) touched.push_back(VI(p.idx()));
  auto removeEdge = [&](EI e) {
    if (e.idx() < eBefore) {
      edgesDestroyed.push_back(EdgeId(e.idx()));
      HI eh(2 *
            e.idx());  // the edge's first halfedge (an Edge_index built from a halfedge keeps it)
      edgesDestroyedV.push_back({PointId(mesh.source(eh).idx()), PointId(mesh.target(eh).idx())});
    }
    mesh.remove_edge(e);
  };
  do {
    mesh.set_face(h, Mesh::null_face());
    HI nh = mesh.next(h);
    bool hBorder = mesh.is_border(mesh.opposite(h));
    bool nhBorder = mesh.is_border(mesh.opposite(nh));
    if (hBorder && nhBorder && mesh.next(mesh.opposite(nh)) == mesh.opposite(h)) {
      mesh.set_halfedge(mesh.target(h), Mesh::null_halfedge());
      if (h != end) removeEdge(mesh.edge(h));
    } else {
      if (nhBorder) {
        HI x = mesh.opposite(mesh.next(mesh.opposite(nh)));
        mesh.set_halfedge(mesh.target(x), x);
        mesh.set_next(h, mesh.next(mesh.opposite(mesh.next(h))));
      }
      if (hBorder) {
        HI y = mesh.opposite(mesh.next(h));
        mesh.set_halfedge(mesh.target(y), y);
        HI p = mesh.prev(mesh.opposite(h));
        mesh.set_next(p, mesh.next(mesh.opposite(mesh.next(p))));
        if (h != end) removeEdge(mesh.edge(h));
      }
    }
    h = nh;
  } while (h != end);
  mesh.remove_face(f);
  if (mesh.is_border(mesh.opposite(h))) removeEdge(mesh.edge(h));
}

std::vector<FI> Topology::Impl::attachFaces(const std::vector<std::array<VI, 3>>& faces) {
  std::vector<FI> out(faces.size(), Mesh::null_face());
  std::vector<std::size_t> pending(faces.size());
  std::iota(pending.begin(), pending.end(), 0);
  while (!pending.empty()) {
    std::vector<std::size_t> next;
    for (std::size_t i : pending) {
      failurePoint("a triangle attached");
      for (VI v : faces[i]) journal.recordStar(mesh, v);
      FI f = CGAL::Euler::add_face(faces[i], mesh);
      if (f == Mesh::null_face())
        next.push_back(i);
      else
        out[i] = f;
    }
    if (next.size() == pending.size()) {
      const auto& t = faces[next.front()];
      throw TopologyError("internal error in '" + operation + "': cannot attach triangle (" +
                          std::to_string(t[0].idx()) + ", " + std::to_string(t[1].idx()) + ", " +
                          std::to_string(t[2].idx()) + ")");
    }
    pending.swap(next);
  }
  return out;
}

void Topology::Impl::reattach(const std::vector<FI>& faces,
                              const std::unordered_map<std::uint64_t, VI>& subst) {
  std::vector<std::array<VI, 3>> added;
  added.reserve(faces.size());
  for (FI f : faces) {
    TriangleVertices t = verticesOf(f);
    std::array<VI, 3> nt;
    for (int i = 0; i < 3; ++i) {
      auto it = subst.find(faceVertexKey(f, VI(t[i].idx())));
      nt[i] = it == subst.end() ? VI(t[i].idx()) : it->second;
    }
    added.push_back(nt);
  }
  for (FI f : faces) detachFace(f);
  attachFaces(added);
}

std::vector<std::vector<FI>> Topology::Impl::fansAround(
    VI v, const std::function<bool(EI)>& isSeparator) const {
  std::vector<HI> hs;
  incomingHalfedges(v, hs);
  std::vector<FI> faces;
  for (HI h : hs)
    if (FI f = mesh.face(h); f.is_valid()) faces.push_back(f);
  std::sort(faces.begin(), faces.end());
  faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
  UnionFind fans(faces.size());
  auto slot = [&](FI f) {
    return std::size_t(std::lower_bound(faces.begin(), faces.end(), f) - faces.begin());
  };
  for (HI h : hs) {
    FI a = mesh.face(h), b = mesh.face(mesh.opposite(h));
    if (!a.is_valid() || !b.is_valid()) continue;
    if (isSeparator && isSeparator(mesh.edge(h))) continue;
    fans.unite(slot(a), slot(b));
  }
  std::vector<std::vector<FI>> groups;
  std::unordered_map<std::size_t, std::size_t> rootToGroup;
  for (std::size_t i = 0; i < faces.size(); ++i) {
    auto [it, inserted] = rootToGroup.emplace(fans.find(i), groups.size());
    if (inserted) groups.emplace_back();
    groups[it->second].push_back(faces[i]);
  }
  return groups;
}

void Topology::Impl::splitFans(const std::vector<VI>& candidates,
                               const std::function<bool(EI)>& isSeparator,
                               const std::unordered_map<std::uint32_t, FI>& keepFace,
                               std::vector<PointId>* copies, std::vector<PointId>* copiedFrom) {
  std::unordered_map<std::uint64_t, VI> subst;
  std::vector<FI> affected;
  std::vector<VI> seen;
  for (VI v : candidates) {
    if (!vertexAlive(v) || std::find(seen.begin(), seen.end(), v) != seen.end()) continue;
    seen.push_back(v);
    auto groups = fansAround(v, isSeparator);
    if (groups.size() < 2) continue;
    std::size_t keep = 0;  // groups are ordered by their smallest face index
    if (auto it = keepFace.find(v.idx()); it != keepFace.end()) {
      for (std::size_t g = 0; g < groups.size(); ++g)
        if (std::find(groups[g].begin(), groups[g].end(), it->second) != groups[g].end()) keep = g;
    }
    for (std::size_t g = 0; g < groups.size(); ++g) {
      if (g == keep) continue;
      VI c = newPoint({{PointId(v.idx()), 1.0}});
      if (copies) copies->push_back(PointId(c.idx()));
      if (copiedFrom) copiedFrom->push_back(PointId(v.idx()));
      for (FI f : groups[g]) {
        subst[faceVertexKey(f, v)] = c;
        affected.push_back(f);
      }
    }
  }
  if (affected.empty()) return;
  std::sort(affected.begin(), affected.end());
  affected.erase(std::unique(affected.begin(), affected.end()), affected.end());
  reattach(affected, subst);
}

namespace {
template <class Id, class Data>
void sortTogether(std::vector<Id>& ids, std::vector<Data>& data) {
  std::vector<std::size_t> order(ids.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return ids[a] < ids[b]; });
  std::vector<Id> i2;
  std::vector<Data> d2;
  for (std::size_t k : order) {
    i2.push_back(ids[k]);
    d2.push_back(data[k]);
  }
  ids.swap(i2);
  data.swap(d2);
}
}  // namespace

namespace {
/// Delivers one transaction's events, each to every observer in turn (the contract's order). An
/// observer that throws does not stop the delivery: the transaction is done and every other
/// observer must follow it; the first failure is thrown as ObserverError once all is delivered.
class Delivery {
 public:
  /// `observers`: the registry's list, copied before the point of no return (copying allocates).
  Delivery(Subscription::Registry& registry, std::vector<TopologyObserver*> observers)
      : registry_(registry), observers_(std::move(observers)) {
    registry_.delivering = true;
  }
  ~Delivery() { registry_.delivering = false; }
  Delivery(const Delivery&) = delete;
  Delivery& operator=(const Delivery&) = delete;

  template <class F>
  void each(const char* event, F&& f) {
    for (TopologyObserver* o : observers_) {
      // An observer unsubscribed (and perhaps destroyed) by another one's handler is skipped.
      const auto& now = registry_.observers;
      if (std::find(now.begin(), now.end(), o) == now.end()) continue;
      try {
        f(*o);
      } catch (const std::exception& e) {
        failed(*o, event, e.what());
      } catch (...) {
        failed(*o, event, "an exception that is not a std::exception");
      }
    }
  }
  void finish(const std::string& operation) {
    registry_.delivering = false;
    if (failures_ == 0) return;
    throw ObserverError(
        "observer '" + first_ + "' failed on the event '" + event_ + "' of '" + operation +
        "': " + message_ +
        (failures_ > 1 ? " (and " + std::to_string(failures_ - 1) + " more failures)" : "") +
        "; the operation was carried out and every other observer followed it");
  }

 private:
  void failed(const TopologyObserver& o, const char* event, const char* what) noexcept {
    if (failures_++ > 0) return;
    try {
      first_ = o.observerName();
      event_ = event;
      message_ = what;
    } catch (...) {  // (out of memory: the count still says that something failed)
    }
  }
  Subscription::Registry& registry_;
  std::vector<TopologyObserver*> observers_;
  std::size_t failures_ = 0;
  std::string first_, event_, message_;
};
}  // namespace

void Topology::Impl::commit(Topology& self) {
  // Phase 1, which may still fail (then the transaction is rolled back): the points left without
  // any edge are removed (carving), and the events' lists are made.
  std::vector<TriangleId> triC;
  std::vector<TriangleVertices> triCV;
  std::vector<TriangleEdges> triCE;
  std::vector<EdgeId> edgeC;
  std::vector<EdgeVertices> edgeCV;
  std::vector<PointId> pointC;
  std::vector<std::uint32_t> offsets{0};
  std::vector<PointId> anc;
  std::vector<double> w;
  std::string op;
  std::vector<TopologyObserver*> observers;
  try {
    std::sort(touched.begin(), touched.end());
    touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
    for (VI v : touched) {
      if (!vertexAlive(v) || !mesh.is_isolated(v)) continue;
      failurePoint("an isolated point removed");
      journal.recordVertex(mesh, v);
      if (v.idx() < vBefore) pointsDestroyed.push_back(PointId(v.idx()));
      mesh.remove_vertex(v);
    }

    // Net lists. Elements created in this transaction have slots >= the *Before marks.
    for (Index f = fBefore; f < mesh.num_faces(); ++f)
      if (!mesh.is_removed(FI(f))) {
        triC.push_back(TriangleId(f));
        triCV.push_back(verticesOf(FI(f)));
        triCE.push_back(edgesOf(FI(f)));
      }
    for (Index e = eBefore; e < mesh.num_edges(); ++e)
      if (!mesh.is_removed(EI(e))) {
        edgeC.push_back(EdgeId(e));
        HI h = mesh.halfedge(EI(e));
        edgeCV.push_back({PointId(mesh.source(h).idx()), PointId(mesh.target(h).idx())});
      }
    for (Index v = vBefore; v < mesh.num_vertices(); ++v)
      if (!mesh.is_removed(VI(v))) {
        pointC.push_back(PointId(v));
        if (auto it = ancestry.find(PointId(v)); it != ancestry.end())
          for (auto [a, ww] : it->second) {
            anc.push_back(a);
            w.push_back(ww);
          }
        offsets.push_back(std::uint32_t(anc.size()));
      }
    {
      std::vector<std::size_t> order(trisDestroyed.size());
      std::iota(order.begin(), order.end(), 0);
      std::sort(order.begin(), order.end(),
                [&](std::size_t a, std::size_t b) { return trisDestroyed[a] < trisDestroyed[b]; });
      std::vector<TriangleId> t2;
      std::vector<TriangleVertices> v2;
      std::vector<TriangleEdges> e2;
      std::vector<std::array<Point3, 3>> p2;
      for (std::size_t k : order) {
        t2.push_back(trisDestroyed[k]);
        v2.push_back(trisDestroyedV[k]);
        e2.push_back(trisDestroyedE[k]);
        p2.push_back(trisDestroyedP[k]);
      }
      trisDestroyed.swap(t2);
      trisDestroyedV.swap(v2);
      trisDestroyedE.swap(e2);
      trisDestroyedP.swap(p2);
    }
    sortTogether(edgesDestroyed, edgesDestroyedV);
    std::sort(pointsDestroyed.begin(), pointsDestroyed.end());
    op = operation;
    observers = registry->observers;
    failurePoint("the commit");
  } catch (...) {
    rollback();
    throw;
  }

  // Phase 2, the point of no return: nothing below undoes the transaction.
  // Keep the locator up to date (only once it has been built); a locator that cannot be updated
  // is dropped (it is rebuilt when next needed).
  if (grid.built()) {
    try {
      for (std::size_t i = 0; i < trisDestroyed.size(); ++i)
        grid.erase(trisDestroyedP[i], FI(trisDestroyed[i].idx()));
      for (TriangleId t : triC) grid.insert(mesh, FI(t.idx()));
    } catch (...) {
      grid.clear();
    }
  }

  TransactionSummary summary;
  summary.operation = op;
  summary.trianglesDestroyed = trisDestroyed.size();
  summary.edgesDestroyed = edgesDestroyed.size();
  summary.pointsDestroyed = pointsDestroyed.size();
  summary.pointsCreated = pointC.size();
  summary.edgesCreated = edgeC.size();
  summary.trianglesCreated = triC.size();

  // The journal is cleared before delivery: observers see a closed transaction.
  std::vector<TriangleId> tD;
  tD.swap(trisDestroyed);
  std::vector<TriangleVertices> tDV;
  tDV.swap(trisDestroyedV);
  std::vector<TriangleEdges> tDE;
  tDE.swap(trisDestroyedE);
  std::vector<EdgeId> eD;
  eD.swap(edgesDestroyed);
  std::vector<EdgeVertices> eDV;
  eDV.swap(edgesDestroyedV);
  std::vector<PointId> pD;
  pD.swap(pointsDestroyed);
  clearTransaction();
  ++revision;

  Delivery d(*registry, std::move(observers));
  if (!tD.empty())
    d.each("triangles destroyed", [&](auto& o) { o.onTrianglesDestroyed(self, {tD, tDV, tDE}); });
  if (!eD.empty()) d.each("edges destroyed", [&](auto& o) { o.onEdgesDestroyed(self, {eD, eDV}); });
  if (!pD.empty()) d.each("points destroyed", [&](auto& o) { o.onPointsDestroyed(self, {pD}); });
  if (!pointC.empty())
    d.each("points created", [&](auto& o) { o.onPointsCreated(self, {pointC, offsets, anc, w}); });
  if (!edgeC.empty())
    d.each("edges created", [&](auto& o) { o.onEdgesCreated(self, {edgeC, edgeCV}); });
  if (!triC.empty())
    d.each("triangles created", [&](auto& o) { o.onTrianglesCreated(self, {triC, triCV, triCE}); });
  d.each("transaction end", [&](auto& o) { o.onTransactionEnd(self, summary); });
  d.finish(op);
}

// ------------------------------------------------------------------------------------------
// Compaction

void Topology::compact() {
  Impl& I = *impl_;
  if (I.registry->delivering) throw TopologyError("compact() called from an observer");
  if (I.open) throw TopologyError("compact() called inside the transaction '" + I.operation + "'");
  Mesh& m = I.mesh;
  if (!m.has_garbage()) return;
  const std::size_t nV = m.num_vertices(), nE = m.num_edges(), nF = m.num_faces();
  const Index liveV = Index(m.number_of_vertices()), liveE = Index(m.number_of_edges()),
              liveF = Index(m.number_of_faces());
  std::vector<Index> vmap(nV, kInvalidIndex), emap(nE, kInvalidIndex), fmap(nF, kInvalidIndex);
  auto visitor = [&](auto& vm, auto& hm, auto& fm) {
    // CGAL swaps the last live element into the first hole: the maps are involutions, so
    // map[old] is the new index of a live old element; a value beyond the live count means dead.
    for (std::size_t i = 0; i < nV; ++i) {
      Index n = Index(vm[VI(Index(i))].idx());
      vmap[i] = n < liveV ? n : kInvalidIndex;
    }
    for (std::size_t i = 0; i < nE; ++i) {
      Index n = Index(hm[HI(Index(2 * i))].idx()) / 2;
      emap[i] = n < liveE ? n : kInvalidIndex;
    }
    for (std::size_t i = 0; i < nF; ++i) {
      Index n = Index(fm[FI(Index(i))].idx());
      fmap[i] = n < liveF ? n : kInvalidIndex;
    }
  };
  // A removed element that was not moved keeps map[i] == i, which may be < live count only if
  // it was swapped; mark removed ones explicitly before collecting.
  std::vector<bool> vdead(nV), edead(nE), fdead(nF);
  std::vector<TopologyObserver*> observers =
      I.registry->observers;       // (allocates: before the change)
  failurePoint("the compaction");  // the last point at which nothing has changed
  for (std::size_t i = 0; i < nV; ++i) vdead[i] = m.is_removed(VI(Index(i)));
  for (std::size_t i = 0; i < nE; ++i) edead[i] = m.is_removed(EI(Index(i)));
  for (std::size_t i = 0; i < nF; ++i) fdead[i] = m.is_removed(FI(Index(i)));
  m.collect_garbage(visitor);
  ++I.revision;
  for (std::size_t i = 0; i < nV; ++i)
    if (vdead[i]) vmap[i] = kInvalidIndex;
  for (std::size_t i = 0; i < nE; ++i)
    if (edead[i]) emap[i] = kInvalidIndex;
  for (std::size_t i = 0; i < nF; ++i)
    if (fdead[i]) fmap[i] = kInvalidIndex;
  I.grid.clear();
  I.grid.chooseCellSize(0.0);  // chosen again for the compacted mesh, at its next build

  TransactionSummary summary;
  summary.operation = "compact";
  summary.renumbered = true;
  Delivery d(*I.registry, std::move(observers));
  d.each("points renumbered", [&](auto& o) { o.onPointsRenumbered(*this, {vmap, liveV}); });
  d.each("edges renumbered", [&](auto& o) { o.onEdgesRenumbered(*this, {emap, liveE}); });
  d.each("triangles renumbered", [&](auto& o) { o.onTrianglesRenumbered(*this, {fmap, liveF}); });
  d.each("transaction end", [&](auto& o) { o.onTransactionEnd(*this, summary); });
  d.finish("compact");
}

// ------------------------------------------------------------------------------------------
// Validation

ValidationReport Topology::validate() const {
  ValidationReport r;
  const Mesh& m = impl_->mesh;
  auto bad = [&](std::string s) { r.problems.push_back(std::move(s)); };
  if (!m.is_valid(false)) bad("CGAL's Surface_mesh::is_valid() fails");
  for (FI f : m.faces()) {
    HI h = m.halfedge(f);
    if (m.next(m.next(m.next(h))) != h)
      bad("triangle " + std::to_string(f.idx()) + " is not a triangle");
    auto t = impl_->verticesOf(f);
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
      bad("triangle " + std::to_string(f.idx()) + " has a repeated vertex");
  }
  for (EI e : m.edges()) {
    HI h = m.halfedge(e);
    if (m.is_border(h) && m.is_border(m.opposite(h)))
      bad("edge " + std::to_string(e.idx()) + " has no triangle");
    if (m.source(h) == m.target(h)) bad("edge " + std::to_string(e.idx()) + " is a loop");
  }
  // Manifold vertices: one fan each; no two edges with the same endpoints.
  std::vector<HI> hs;
  for (VI v : m.vertices()) {
    if (m.is_isolated(v)) continue;
    impl_->incomingHalfedges(v, hs);
    std::vector<VI> nbrs;
    for (HI h : hs) nbrs.push_back(m.source(h));
    std::sort(nbrs.begin(), nbrs.end());
    if (std::adjacent_find(nbrs.begin(), nbrs.end()) != nbrs.end())
      bad("point " + std::to_string(v.idx()) + " has two edges to the same neighbour");
    std::size_t borders = 0;
    for (HI h : hs) borders += m.is_border(h) ? 1 : 0;
    if (borders > 1)
      bad("point " + std::to_string(v.idx()) + " is a bowtie (" + std::to_string(borders) +
          " boundary fans)");
    if (hs.size() >= 1 && m.target(hs.front()) != v)
      bad("point " + std::to_string(v.idx()) + ": halfedge does not point to it");
  }
  for (auto* o : impl_->registry->observers) {
    std::vector<std::string> problems;
    o->validate(*this, problems);
    for (auto& p : problems) bad(o->observerName() + ": " + p);
  }
  return r;
}

void Topology::validateOrThrow() const {
  ValidationReport r = validate();
  if (!r.ok()) throw TopologyError("topology validation failed:\n" + r.summary());
}

}  // namespace cutsim::topology

// ------------------------------------------------------------------------------------------
// Checkpoints

#include "cutsim/base/archive.hpp"

namespace cutsim::topology {

void Topology::save(ArchiveWriter& out) const {
  const Impl& I = *impl_;
  if (I.open) throw TopologyError("save: a transaction is open");
  const Mesh& m = I.mesh;
  out.begin("topology");
  out.u64(m.num_vertices());
  out.u64(m.num_edges());
  out.u64(m.num_faces());
  out.u64(I.revision);
  const detail::Header header = detail::Header::of(m);
  for (Mesh::size_type x : {header.removedV, header.removedE, header.removedF, header.freeV,
                            header.freeE, header.freeF})
    out.u64(x);
  out.boolean(header.garbage);
  out.f64(I.grid.chosenCellSize());
  std::vector<std::uint32_t> vh, vr, h, er, fh, fr;
  std::vector<double> pts;
  for (Mesh::size_type i = 0; i < m.num_vertices(); ++i) {
    vh.push_back(m.halfedge(VI(i)).idx());
    vr.push_back(m.is_removed(VI(i)) ? 1 : 0);
    const Point3& p = m.point(VI(i));
    pts.insert(pts.end(), {p.x(), p.y(), p.z()});
  }
  for (Mesh::size_type i = 0; i < m.num_halfedges(); ++i) {
    const HI e(i);
    h.insert(h.end(), {m.face(e).idx(), m.target(e).idx(), m.next(e).idx(), m.prev(e).idx()});
  }
  for (Mesh::size_type i = 0; i < m.num_edges(); ++i) er.push_back(m.is_removed(EI(i)) ? 1 : 0);
  for (Mesh::size_type i = 0; i < m.num_faces(); ++i) {
    fh.push_back(m.halfedge(FI(i)).idx());
    fr.push_back(m.is_removed(FI(i)) ? 1 : 0);
  }
  out.u32s(vh);
  out.u32s(vr);
  out.f64s(pts);
  out.u32s(h);
  out.u32s(er);
  out.u32s(fh);
  out.u32s(fr);
  out.u64(digest());
}

Topology Topology::load(ArchiveReader& in) {
  in.open("topology");
  const std::uint64_t nv = in.u64(), ne = in.u64(), nf = in.u64();
  constexpr std::uint64_t kMax = 1ull << 31;
  if (nv >= kMax || ne >= kMax / 2 || nf >= kMax) in.fail("sizes out of range");
  const std::uint64_t revision = in.u64();
  const std::uint64_t removedV = in.u64(), removedE = in.u64(), removedF = in.u64();
  const std::uint64_t freeV = in.u64(), freeE = in.u64(), freeF = in.u64();
  const bool garbage = in.boolean();
  const double cell = in.f64();
  if (!(cell >= 0 && std::isfinite(cell)))
    in.fail("the locator's cell size is " + std::to_string(cell));
  const auto vh = in.u32s(), vr = in.u32s();
  const auto pts = in.f64s();
  const auto h = in.u32s(), er = in.u32s(), fh = in.u32s(), fr = in.u32s();
  const std::uint64_t savedDigest = in.u64();
  const std::uint64_t nh = 2 * ne;
  if (vh.size() != nv || vr.size() != nv || pts.size() != 3 * nv || h.size() != 4 * nh ||
      er.size() != ne || fh.size() != nf || fr.size() != nf)
    in.fail("arrays of the wrong sizes");
  const std::uint32_t null = std::uint32_t(-1);
  auto index = [&](std::uint32_t x, std::uint64_t n, const char* what) {
    if (x != null && x >= n) in.fail(std::string("a ") + what + " index out of range");
  };
  auto flags = [&](const std::vector<std::uint32_t>& f, std::uint64_t removed, const char* what) {
    std::uint64_t count = 0;
    for (std::uint32_t x : f) {
      if (x > 1) in.fail(std::string("a ") + what + " removal flag holds " + std::to_string(x));
      count += x;
    }
    if (count != removed)
      in.fail(std::string("the ") + what + " removal count disagrees with the flags");
  };
  flags(vr, removedV, "point");
  flags(er, removedE, "edge");
  flags(fr, removedF, "triangle");
  for (double c : pts)
    if (!std::isfinite(c)) in.fail("a rest position is not finite");
  Topology t;
  Impl& I = *t.impl_;
  Mesh& m = I.mesh;
  m.resize(Mesh::size_type(nv), Mesh::size_type(ne), Mesh::size_type(nf));
  detail::Arrays a(m);
  auto& vconn = a.vconn;
  auto& hconn = a.hconn;
  auto& fconn = a.fconn;
  // A removed element's link is its free list's next (an index of its own kind, or null).
  for (std::uint64_t i = 0; i < nv; ++i) {
    index(vh[i], vr[i] ? nv : nh, vr[i] ? "free point" : "halfedge");
    vconn[VI(Mesh::size_type(i))].halfedge_ = HI(vh[i]);
    a.vremoved[VI(Mesh::size_type(i))] = vr[i] != 0;
    m.point(VI(Mesh::size_type(i))) = Point3(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
  }
  for (std::uint64_t i = 0; i < nh; ++i) {
    const bool dead = er[i / 2] != 0;
    index(h[4 * i], nf, "triangle");
    index(h[4 * i + 1], nv, "point");
    index(h[4 * i + 2], nh, "halfedge");
    index(h[4 * i + 3], nh, "halfedge");
    auto& c = hconn[HI(Mesh::size_type(i))];
    c.face_ = FI(h[4 * i]);
    c.vertex_ = VI(h[4 * i + 1]);
    c.next_halfedge_ = HI(h[4 * i + 2]);
    c.prev_halfedge_ = HI(h[4 * i + 3]);
    if (!dead && (h[4 * i + 1] == null || h[4 * i + 2] == null || h[4 * i + 3] == null))
      in.fail("a live halfedge without its point or neighbours");
  }
  for (std::uint64_t i = 0; i < ne; ++i) a.eremoved[EI(Mesh::size_type(i))] = er[i] != 0;
  for (std::uint64_t i = 0; i < nf; ++i) {
    index(fh[i], fr[i] ? nf : nh, fr[i] ? "free triangle" : "halfedge");
    if (!fr[i] && fh[i] == null) in.fail("a live triangle without a halfedge");
    fconn[FI(Mesh::size_type(i))].halfedge_ = HI(fh[i]);
    a.fremoved[FI(Mesh::size_type(i))] = fr[i] != 0;
  }
  // The free lists (CGAL's remove_* links every removed element into its kind's list): each
  // must run through removed elements only, exactly as many as the counter says, then end.
  auto freeList = [&](std::uint64_t head, std::uint64_t removed, std::uint64_t n,
                      std::uint64_t step, const auto& isRemoved, const auto& link,
                      const char* what) {
    std::uint64_t x = head, count = 0;
    while (x != null) {
      if (x >= n || x % step != 0 || !isRemoved(x / step) || count >= removed)
        in.fail(std::string("the free list of ") + what + " is broken");
      ++count;
      x = link(x);
    }
    if (count != removed) in.fail(std::string("the free list of ") + what + " misses removed ones");
  };
  freeList(
      freeV, removedV, nv, 1, [&](std::uint64_t i) { return vr[i] != 0; },
      [&](std::uint64_t i) { return vh[i]; }, "points");
  freeList(
      freeE, removedE, nh, 2, [&](std::uint64_t i) { return er[i] != 0; },
      [&](std::uint64_t i) { return h[4 * i + 2]; }, "edges");
  freeList(
      freeF, removedF, nf, 1, [&](std::uint64_t i) { return fr[i] != 0; },
      [&](std::uint64_t i) { return fh[i]; }, "triangles");
  detail::Header{Mesh::size_type(removedV),
                 Mesh::size_type(removedE),
                 Mesh::size_type(removedF),
                 Mesh::size_type(freeV),
                 Mesh::size_type(freeE),
                 Mesh::size_type(freeF),
                 garbage}
      .applyTo(m);
  I.revision = revision;
  I.grid.chooseCellSize(cell);
  // Live elements must point to live ones, and the links must agree, before anything walks them.
  for (std::uint64_t i = 0; i < nh; ++i) {
    if (er[i / 2]) continue;
    const HI e{Mesh::size_type(i)};
    if (m.is_removed(m.target(e)) || m.is_removed(m.edge(m.next(e))) || m.prev(m.next(e)) != e ||
        (m.face(e).is_valid() && m.is_removed(m.face(e))))
      in.fail("the half-edge links do not agree (halfedge " + std::to_string(i) + ")");
  }
  for (std::uint64_t i = 0; i < nv; ++i) {
    const VI v{Mesh::size_type(i)};
    if (!vr[i] && m.halfedge(v).is_valid() &&
        (m.is_removed(m.edge(m.halfedge(v))) || m.target(m.halfedge(v)) != v))
      in.fail("point " + std::to_string(i) + " has a halfedge that does not end at it");
  }
  // Each live triangle is the face of exactly the three halfedges of its cycle.
  std::vector<std::uint32_t> claims(nf, 0), incoming(nv, 0);
  for (std::uint64_t i = 0; i < nh; ++i) {
    if (er[i / 2]) continue;
    const HI e{Mesh::size_type(i)};
    if (m.face(e).is_valid()) {
      if (m.face(m.next(e)) != m.face(e))
        in.fail("halfedge " + std::to_string(i) + " and the next have other triangles");
      ++claims[m.face(e).idx()];
    }
    ++incoming[m.target(e).idx()];
  }
  for (std::uint64_t i = 0; i < nf; ++i) {
    const FI f{Mesh::size_type(i)};
    if (!fr[i] &&
        (claims[i] != 3 || m.is_removed(m.edge(m.halfedge(f))) || m.face(m.halfedge(f)) != f ||
         m.next(m.next(m.next(m.halfedge(f)))) != m.halfedge(f)))
      in.fail("triangle " + std::to_string(i) + " is not a triangle of its halfedges");
  }
  // Each live point's halfedges form one circle (the journal and every walk go round it).
  for (std::uint64_t i = 0; i < nv; ++i) {
    const VI v{Mesh::size_type(i)};
    if (vr[i] || !m.halfedge(v).is_valid()) {
      if (!vr[i] && incoming[i] != 0)
        in.fail("point " + std::to_string(i) + " has edges but no halfedge");
      continue;
    }
    HI e = m.halfedge(v);
    std::uint32_t walked = 0;
    do {
      if (++walked > incoming[i]) break;
      e = m.opposite(m.next(e));
    } while (e != m.halfedge(v));
    if (walked != incoming[i])
      in.fail("point " + std::to_string(i) + "'s halfedges do not form one circle");
  }
  if (t.digest() != savedDigest) in.fail("the structure read back differs from the one saved");
  const ValidationReport r = t.validate();
  if (!r.ok()) in.fail("the saved topology is not valid:\n" + r.summary());
  in.close();
  return t;
}

}  // namespace cutsim::topology
