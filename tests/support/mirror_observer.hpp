#pragma once
// Test observers of the topology.
//
// MirrorObserver keeps its own copy of the mesh (alive flags, rest positions, edge endpoints,
// triangle vertices and edges) built ONLY from the events, and its validate() compares that copy
// with the topology: the brute-force twin of every incremental observer. It also checks the event
// contract as events arrive (order within a transaction, sorted lists, ancestry of new points,
// destroyed elements being gone and created ones present when the events are delivered).
//
// EventLog records the sequence of events as short strings, for exact expectations.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "cutsim/topology/topology.hpp"

namespace cutsim::test {

class MirrorObserver : public topology::TopologyObserver {
 public:
  using Topology = topology::Topology;
  explicit MirrorObserver(const Topology& t) { restAll(t); }

  std::string observerName() const override { return "mirror"; }

  void onTrianglesDestroyed(const Topology& t, const topology::TrianglesDestroyed& e) override {
    stage(1, e.triangles);
    for (std::size_t i = 0; i < e.triangles.size(); ++i) {
      auto id = e.triangles[i];
      expect(id.idx() < tri.size() && triAlive[id.idx()],
             "destroyed triangle " + s(id.idx()) + " was not alive");
      expect(!t.isTriangleAlive(id),
             "destroyed triangle " + s(id.idx()) + " still alive in the mesh");
      expect(id.idx() < tri.size() && tri[id.idx()] == e.vertices[i],
             "destroyed triangle " + s(id.idx()) + " vertices differ");
      if (id.idx() < triAlive.size()) triAlive[id.idx()] = false;
    }
  }
  void onEdgesDestroyed(const Topology& t, const topology::EdgesDestroyed& e) override {
    stage(2, e.edges);
    for (std::size_t i = 0; i < e.edges.size(); ++i) {
      auto id = e.edges[i];
      expect(id.idx() < edge.size() && edgeAlive[id.idx()],
             "destroyed edge " + s(id.idx()) + " was not alive");
      expect(!t.isEdgeAlive(id), "destroyed edge " + s(id.idx()) + " still alive in the mesh");
      expect(id.idx() < edge.size() && edge[id.idx()] == e.vertices[i],
             "destroyed edge " + s(id.idx()) + " endpoints differ");
      if (id.idx() < edgeAlive.size()) edgeAlive[id.idx()] = false;
    }
  }
  void onPointsDestroyed(const Topology& t, const topology::PointsDestroyed& e) override {
    stage(3, e.points);
    for (auto id : e.points) {
      expect(id.idx() < pointAlive.size() && pointAlive[id.idx()],
             "destroyed point " + s(id.idx()) + " was not alive");
      expect(!t.isPointAlive(id), "destroyed point " + s(id.idx()) + " still alive in the mesh");
      if (id.idx() < pointAlive.size()) pointAlive[id.idx()] = false;
    }
  }
  void onPointsCreated(const Topology& t, const topology::PointsCreated& e) override {
    stage(4, e.points);
    expect(e.offsets.size() == e.points.size() + 1, "offsets size");
    for (std::size_t i = 0; i < e.points.size(); ++i) {
      auto id = e.points[i];
      expect(id.idx() >= pointAlive.size() || !pointAlive[id.idx()],
             "created point " + s(id.idx()) + " reuses a live slot");
      grow(id.idx() + 1, pointAlive, rest);
      pointAlive[id.idx()] = true;
      if (e.offsets[i] == e.offsets[i + 1]) {
        rest[id.idx()] = t.restPosition(id);  // a free point: its position is the topology's
        continue;
      }
      topology::Vec3 p{0, 0, 0};
      double wsum = 0;
      for (auto k = e.offsets[i]; k < e.offsets[i + 1]; ++k) {
        auto a = e.ancestors[k];
        expect(a.idx() < transactionStartPoints, "ancestor " + s(a.idx()) + " of point " +
                                                     s(id.idx()) + " is new in this transaction");
        expect(a.idx() < rest.size(), "ancestor out of range");
        if (a.idx() >= rest.size()) continue;
        for (int c = 0; c < 3; ++c) p[c] += e.weights[k] * rest[a.idx()][c];
        wsum += e.weights[k];
      }
      expect(std::abs(wsum - 1.0) < 1e-12,
             "weights of point " + s(id.idx()) + " sum to " + std::to_string(wsum));
      rest[id.idx()] = p;
    }
  }
  void onEdgesCreated(const Topology& t, const topology::EdgesCreated& e) override {
    stage(5, e.edges);
    for (std::size_t i = 0; i < e.edges.size(); ++i) {
      auto id = e.edges[i];
      expect(t.isEdgeAlive(id), "created edge " + s(id.idx()) + " not alive in the mesh");
      grow(id.idx() + 1, edgeAlive, edge);
      expect(!edgeAlive[id.idx()], "created edge " + s(id.idx()) + " reuses a live slot");
      edgeAlive[id.idx()] = true;
      edge[id.idx()] = e.vertices[i];
    }
  }
  void onTrianglesCreated(const Topology& t, const topology::TrianglesCreated& e) override {
    stage(6, e.triangles);
    for (std::size_t i = 0; i < e.triangles.size(); ++i) {
      auto id = e.triangles[i];
      expect(t.isTriangleAlive(id), "created triangle " + s(id.idx()) + " not alive in the mesh");
      grow(id.idx() + 1, triAlive, tri, triEdges);
      expect(!triAlive[id.idx()], "created triangle " + s(id.idx()) + " reuses a live slot");
      triAlive[id.idx()] = true;
      tri[id.idx()] = e.vertices[i];
      triEdges[id.idx()] = e.edges[i];
    }
  }
  template <class... V>
  static void renumber(std::span<const topology::Index> map, topology::Index n,
                       std::vector<bool>& alive, V&... data) {
    std::vector<bool> a2(n, false);
    auto move = [&](auto& d) {
      std::remove_reference_t<decltype(d)> d2(n);
      for (std::size_t o = 0; o < map.size() && o < d.size(); ++o)
        if (map[o] != topology::kInvalidIndex) d2[map[o]] = d[o];
      d.swap(d2);
    };
    for (std::size_t o = 0; o < map.size() && o < alive.size(); ++o)
      if (map[o] != topology::kInvalidIndex) a2[map[o]] = alive[o];
    (move(data), ...);
    alive.swap(a2);
  }
  void onPointsRenumbered(const Topology&, const topology::Renumbering& r) override {
    stageRenumber(1);
    renumber(r.oldToNew, r.newSize, pointAlive, rest);
    auto mapPoint = [&](topology::PointId& p) { p = topology::PointId(r.oldToNew[p.idx()]); };
    for (std::size_t e = 0; e < edge.size(); ++e)
      if (edgeAlive[e]) {
        mapPoint(edge[e][0]);
        mapPoint(edge[e][1]);
      }
    for (std::size_t t = 0; t < tri.size(); ++t)
      if (triAlive[t])
        for (auto& p : tri[t]) mapPoint(p);
  }
  void onEdgesRenumbered(const Topology&, const topology::Renumbering& r) override {
    stageRenumber(2);
    renumber(r.oldToNew, r.newSize, edgeAlive, edge);
    for (std::size_t t = 0; t < tri.size(); ++t)
      if (triAlive[t])
        for (auto& e : triEdges[t]) e = topology::EdgeId(r.oldToNew[e.idx()]);
  }
  void onTrianglesRenumbered(const Topology&, const topology::Renumbering& r) override {
    stageRenumber(3);
    renumber(r.oldToNew, r.newSize, triAlive, tri, triEdges);
  }
  void onTransactionEnd(const Topology& t, const topology::TransactionSummary&) override {
    stage_ = 0;
    renumberStage_ = 0;
    transactionStartPoints = t.pointCapacity();
    ++transactions;
  }

  void validate(const Topology& t, std::vector<std::string>& problems) const override {
    for (auto& e : errors) problems.push_back("event contract: " + e);
    if (pointAlive.size() > t.pointCapacity())
      problems.push_back("more point slots than the topology");
    for (topology::Index p = 0; p < t.pointCapacity(); ++p) {
      bool a = p < pointAlive.size() && pointAlive[p];
      if (a != t.isPointAlive(topology::PointId(p))) {
        problems.push_back("point " + s(p) + " alive mismatch");
        continue;
      }
      if (!a) continue;
      auto r = t.restPosition(topology::PointId(p));
      for (int c = 0; c < 3; ++c)
        if (std::abs(r[c] - rest[p][c]) > 1e-9 * (1 + std::abs(r[c])))
          problems.push_back("point " + s(p) + " rest position differs from its interpolation");
    }
    for (topology::Index e = 0; e < t.edgeCapacity(); ++e) {
      bool a = e < edgeAlive.size() && edgeAlive[e];
      if (a != t.isEdgeAlive(topology::EdgeId(e))) {
        problems.push_back("edge " + s(e) + " alive mismatch");
        continue;
      }
      if (a && edge[e] != t.edgeVertices(topology::EdgeId(e)))
        problems.push_back("edge " + s(e) + " endpoints differ");
    }
    for (topology::Index f = 0; f < t.triangleCapacity(); ++f) {
      bool a = f < triAlive.size() && triAlive[f];
      if (a != t.isTriangleAlive(topology::TriangleId(f))) {
        problems.push_back("triangle " + s(f) + " alive mismatch");
        continue;
      }
      if (a && tri[f] != t.triangleVertices(topology::TriangleId(f)))
        problems.push_back("triangle " + s(f) + " vertices differ");
      if (a && triEdges[f] != t.triangleEdges(topology::TriangleId(f)))
        problems.push_back("triangle " + s(f) + " edges differ");
    }
  }

  std::vector<std::string> errors;
  std::size_t transactions = 0;

 private:
  static std::string s(std::size_t i) { return std::to_string(i); }
  void expect(bool ok, const std::string& what) {
    if (!ok) errors.push_back(what);
  }
  template <class Ids>
  void stage(int k, const Ids& ids) {
    expect(k > stage_,
           "event kind " + s(k) + " delivered after kind " + s(stage_) + " in one transaction");
    expect(renumberStage_ == 0, "creation/destruction mixed with renumbering");
    expect(!ids.empty(), "empty event list delivered");
    expect(std::is_sorted(ids.begin(), ids.end()), "event list not sorted");
    stage_ = k;
  }
  void stageRenumber(int k) {
    expect(stage_ == 0, "renumbering mixed with creation/destruction");
    expect(k > renumberStage_, "renumbering out of order");
    renumberStage_ = k;
  }
  template <class... V>
  static void grow(std::size_t n, std::vector<bool>& alive, V&... data) {
    if (alive.size() < n) alive.resize(n, false);
    ((data.size() < n ? data.resize(n) : void()), ...);
  }
  void restAll(const Topology& t) {
    pointAlive.assign(t.pointCapacity(), false);
    rest.assign(t.pointCapacity(), {0, 0, 0});
    for (auto p : t.points()) {
      pointAlive[p.idx()] = true;
      rest[p.idx()] = t.restPosition(p);
    }
    edgeAlive.assign(t.edgeCapacity(), false);
    edge.assign(t.edgeCapacity(), {});
    for (auto e : t.edges()) {
      edgeAlive[e.idx()] = true;
      edge[e.idx()] = t.edgeVertices(e);
    }
    triAlive.assign(t.triangleCapacity(), false);
    tri.assign(t.triangleCapacity(), {});
    triEdges.assign(t.triangleCapacity(), {});
    for (auto f : t.triangles()) {
      triAlive[f.idx()] = true;
      tri[f.idx()] = t.triangleVertices(f);
      triEdges[f.idx()] = t.triangleEdges(f);
    }
    transactionStartPoints = t.pointCapacity();
  }

  int stage_ = 0, renumberStage_ = 0;
  topology::Index transactionStartPoints = 0;
  std::vector<bool> pointAlive, edgeAlive, triAlive;
  std::vector<topology::Vec3> rest;
  std::vector<topology::EdgeVertices> edge;
  std::vector<topology::TriangleVertices> tri;
  std::vector<topology::TriangleEdges> triEdges;
};

/// Records events as strings: "T-:3,4" (triangles destroyed), "E-", "P-", "P+", "E+", "T+",
/// "P#", "E#", "T#" (renumbered, with the new size), "end:<operation>".
class EventLog : public topology::TopologyObserver {
 public:
  using Topology = topology::Topology;
  std::vector<std::string> log;
  std::vector<std::string> kinds() const {
    std::vector<std::string> k;
    for (auto& l : log) k.push_back(l.substr(0, l.find(':')));
    return k;
  }
  void clear() { log.clear(); }
  void onTrianglesDestroyed(const Topology&, const topology::TrianglesDestroyed& e) override {
    add("T-", e.triangles);
  }
  void onEdgesDestroyed(const Topology&, const topology::EdgesDestroyed& e) override {
    add("E-", e.edges);
  }
  void onPointsDestroyed(const Topology&, const topology::PointsDestroyed& e) override {
    add("P-", e.points);
  }
  void onPointsCreated(const Topology&, const topology::PointsCreated& e) override {
    add("P+", e.points);
  }
  void onEdgesCreated(const Topology&, const topology::EdgesCreated& e) override {
    add("E+", e.edges);
  }
  void onTrianglesCreated(const Topology&, const topology::TrianglesCreated& e) override {
    add("T+", e.triangles);
  }
  void onPointsRenumbered(const Topology&, const topology::Renumbering& r) override {
    log.push_back("P#:" + std::to_string(r.newSize));
  }
  void onEdgesRenumbered(const Topology&, const topology::Renumbering& r) override {
    log.push_back("E#:" + std::to_string(r.newSize));
  }
  void onTrianglesRenumbered(const Topology&, const topology::Renumbering& r) override {
    log.push_back("T#:" + std::to_string(r.newSize));
  }
  void onTransactionEnd(const Topology&, const topology::TransactionSummary& s) override {
    log.push_back("end:" + std::string(s.operation));
  }

  /// Number of ids in the last event of that kind ("T+", ...), 0 if none.
  std::size_t count(const std::string& kind) const {
    for (auto it = log.rbegin(); it != log.rend(); ++it)
      if (it->rfind(kind + ":", 0) == 0)
        return std::size_t(std::count(it->begin(), it->end(), ',') + 1);
    return 0;
  }

 private:
  template <class Ids>
  void add(const char* k, const Ids& ids) {
    std::ostringstream o;
    o << k << ":";
    for (std::size_t i = 0; i < ids.size(); ++i) o << (i ? "," : "") << ids[i];
    log.push_back(o.str());
  }
};

}  // namespace cutsim::test
