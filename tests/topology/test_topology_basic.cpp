// Topology: construction, queries, observers' registration.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "support/fixtures.hpp"
#include "support/ids.hpp"
#include "support/mirror_observer.hpp"

namespace cutsim::test {
namespace {

using topology::EdgeId;
using topology::kInvalidIndex;
using topology::MeshData;
using topology::PointId;
using topology::Topology;
using topology::TriangleId;

MeshData octahedron() {
  MeshData m;
  m.points = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  m.triangles = {tri(0, 2, 4), tri(2, 1, 4), tri(1, 3, 4), tri(3, 0, 4),
                 tri(2, 0, 5), tri(1, 2, 5), tri(3, 1, 5), tri(0, 3, 5)};
  return m;
}

std::size_t boundaryEdges(const Topology& t) {
  std::size_t n = 0;
  for (auto e : t.edges()) n += t.isBoundaryEdge(e) ? 1 : 0;
  return n;
}

TEST(TopologyBasic, GridCountsAndQueries) {
  Topology t(grid(5));
  EXPECT_EQ(t.numPoints(), 25u);
  EXPECT_EQ(t.numEdges(), 56u);
  EXPECT_EQ(t.numTriangles(), 32u);
  EXPECT_EQ(boundaryEdges(t), 16u);
  EXPECT_TRUE(t.validate().ok()) << t.validate().summary();
  for (auto f : t.triangles()) {
    auto v = t.triangleVertices(f);
    auto e = t.triangleEdges(f);
    for (int i = 0; i < 3; ++i) {
      // edge i is opposite vertex i
      auto ev = t.edgeVertices(e[i]);
      std::set<topology::PointId> a{ev[0], ev[1]}, b{v[(i + 1) % 3], v[(i + 2) % 3]};
      EXPECT_EQ(a, b);
      EXPECT_EQ(t.oppositeVertex(f, e[i]), v[i]);
      auto tt = t.edgeTriangles(e[i]);
      EXPECT_TRUE(tt[0] == f || tt[1] == f);
    }
  }
  for (auto e : t.edges()) {
    auto ev = t.edgeVertices(e);
    auto tt = t.edgeTriangles(e);
    EXPECT_EQ(t.findEdge(ev[0], ev[1]), e);
    EXPECT_EQ(t.findEdge(ev[1], ev[0]), e);
    if (tt[0].idx() != kInvalidIndex) {
      // [0] is the triangle in which the edge runs v0 -> v1 (counter-clockwise)
      auto v = t.triangleVertices(tt[0]);
      bool runs = false;
      for (int i = 0; i < 3; ++i) runs |= v[i] == ev[0] && v[(i + 1) % 3] == ev[1];
      EXPECT_TRUE(runs);
    }
    EXPECT_EQ(t.isBoundaryEdge(e), tt[0].idx() == kInvalidIndex || tt[1].idx() == kInvalidIndex);
  }
  // The centre of the 5x5 grid has 6 triangles and 6 edges around it; the corner (0,0) 2 and 3.
  EXPECT_EQ(t.trianglesAroundPoint(PointId(12)).size(), 6u);
  EXPECT_EQ(t.edgesAroundPoint(PointId(12)).size(), 6u);
  EXPECT_FALSE(t.isBoundaryPoint(PointId(12)));
  EXPECT_EQ(t.trianglesAroundPoint(PointId(0)).size(), 2u);
  EXPECT_EQ(t.edgesAroundPoint(PointId(0)).size(), 3u);
  EXPECT_TRUE(t.isBoundaryPoint(PointId(0)));
  EXPECT_EQ(t.findEdge(topology::PointId(0), topology::PointId(24)).idx(), kInvalidIndex);
}

TEST(TopologyBasic, ClosedSurfaceHasNoBoundary) {
  Topology t(octahedron());
  EXPECT_EQ(t.numPoints(), 6u);
  EXPECT_EQ(t.numEdges(), 12u);
  EXPECT_EQ(t.numTriangles(), 8u);
  EXPECT_EQ(boundaryEdges(t), 0u);
  for (auto p : t.points()) EXPECT_FALSE(t.isBoundaryPoint(p));
  EXPECT_TRUE(t.validate().ok());
}

TEST(TopologyBasic, IsolatedPointsAreKept) {
  MeshData m = grid(2);
  m.points.push_back({5, 5, 5});
  Topology t(m);
  EXPECT_EQ(t.numPoints(), 5u);
  EXPECT_TRUE(t.isIsolatedPoint(PointId(4)));
  EXPECT_TRUE(t.edgesAroundPoint(PointId(4)).empty());
}

TEST(TopologyBasic, RejectsNonManifoldAndBadIndices) {
  MeshData m = grid(2);  // two triangles (0,1,3), (0,3,2)
  m.points.push_back({0.5, 0.5, 1});
  m.triangles.push_back(tri(0, 3, 4));  // a third triangle on edge (0,3)
  EXPECT_THROW(Topology t(m), InvalidInput);
  std::vector<topology::Vec3> pts{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  std::vector<topology::TriangleVertices> bad{tri(0, 1, 7)};
  EXPECT_THROW(Topology(pts, bad), InvalidInput);
  std::vector<topology::TriangleVertices> rep{tri(0, 1, 1)};
  EXPECT_THROW(Topology(pts, rep), InvalidInput);
}

TEST(TopologyBasic, QueriesOnDeadOrMissingElementsThrow) {
  Topology t(grid(3));
  EXPECT_THROW(t.edgeVertices(EdgeId(1000)), TopologyError);
  EXPECT_THROW(t.triangleVertices(TriangleId(1000)), TopologyError);
  EXPECT_THROW(t.restPosition(PointId(1000)), TopologyError);
  auto own = t.triangleEdges(TriangleId(0));
  for (auto e : t.edges())
    if (std::find(own.begin(), own.end(), e) == own.end()) {
      EXPECT_THROW(t.oppositeVertex(TriangleId(0), e), TopologyError);
      break;
    }
}

TEST(TopologyBasic, SubscriptionsEndCleanly) {
  Topology t(grid(3));
  EventLog a, b;
  {
    auto sa = t.subscribe(a);
    auto sb = t.subscribe(b);
    EXPECT_EQ(t.numObservers(), 2u);
    EXPECT_THROW((void)t.subscribe(a), TopologyError);
    t.splitEdge(t.edges()[0], 0.5);
    EXPECT_FALSE(a.log.empty());
    EXPECT_EQ(a.log, b.log);
    sb.reset();
    EXPECT_FALSE(sb.active());
    EXPECT_EQ(t.numObservers(), 1u);
    b.clear();
    t.splitEdge(t.edges()[0], 0.5);
    EXPECT_TRUE(b.log.empty());
  }
  EXPECT_EQ(t.numObservers(), 0u);
  // A subscription may outlive its topology.
  EventLog c;
  topology::Subscription s;
  {
    Topology u(grid(2));
    s = u.subscribe(c);
    EXPECT_TRUE(s.active());
  }
  EXPECT_FALSE(s.active());
  s.reset();
}

}  // namespace
}  // namespace cutsim::test
