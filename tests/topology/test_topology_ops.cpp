// Topology operations on small hand-built meshes: exact counts and event sequences, the side an
// incision opens on, cuts along polylines, compaction, and rejected requests that change nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <set>

#include "cutsim/base/union_find.hpp"
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
using topology::Vec3;
using Strings = std::vector<std::string>;

/// A topology with a mirror (checked by validate) and an event log.
struct Watched {
  explicit Watched(const MeshData& m) : t(m), mirror(t) {
    s1 = t.subscribe(mirror);
    s2 = t.subscribe(log);
  }
  void check() {
    auto r = t.validate();
    ASSERT_TRUE(r.ok()) << r.summary();
  }
  Topology t;
  MirrorObserver mirror;
  EventLog log;
  topology::Subscription s1, s2;
};

std::size_t components(const Topology& t) {
  UnionFind sets(t.triangleCapacity());
  for (auto e : t.edges()) {
    auto tt = t.edgeTriangles(e);
    if (tt[0].idx() != kInvalidIndex && tt[1].idx() != kInvalidIndex)
      sets.unite(tt[0].idx(), tt[1].idx());
  }
  std::size_t n = 0;
  for (auto f : t.triangles()) n += sets.find(f.idx()) == f.idx() ? 1 : 0;
  return n;
}

std::size_t boundaryEdges(const Topology& t) {
  std::size_t n = 0;
  for (auto e : t.edges()) n += t.isBoundaryEdge(e) ? 1 : 0;
  return n;
}

Vec3 centroid(const Topology& t, topology::TriangleId f) {
  Vec3 c{0, 0, 0};
  for (auto p : t.triangleVertices(f)) {
    auto r = t.restPosition(p);
    for (int k = 0; k < 3; ++k) c[k] += r[k] / 3.0;
  }
  return c;
}

PointId gridId(int n, int i, int j) {
  return PointId(j * n + i);
}

TEST(TopologyOps, AddPointsThenTriangles) {
  Watched w(grid(2));
  std::vector<Vec3> pts{{2, 0, 0}, {2, 1, 0}};
  auto ids = w.t.addPoints(pts);
  ASSERT_EQ(ids.size(), 2u);
  EXPECT_EQ(w.log.log, (Strings{"P+:4,5", "end:addPoints"}));
  EXPECT_TRUE(w.t.isIsolatedPoint(ids[0]));
  w.check();
  w.log.clear();
  // grid(2): points 0(0,0) 1(1,0) 2(0,1) 3(1,1); triangles (0,1,3), (0,3,2).
  std::vector<topology::TriangleVertices> tris{tri(1, 4, 5), tri(1, 5, 3)};
  auto added = w.t.addTriangles(tris);
  EXPECT_EQ(added.size(), 2u);
  EXPECT_EQ(w.log.kinds(), (Strings{"E+", "T+", "end"}));
  EXPECT_EQ(w.log.count("E+"), 4u);  // (1,4) (4,5) (5,1) (5,3); (1,3) existed
  EXPECT_EQ(w.t.numTriangles(), 4u);
  EXPECT_FALSE(w.t.isBoundaryEdge(w.t.findEdge(topology::PointId(1), topology::PointId(3))));
  w.check();
}

TEST(TopologyOps, AddTrianglesRejectsBadRequestsWithoutChange) {
  Watched w(grid(2));
  auto before = w.t.numTriangles();
  std::vector<topology::TriangleVertices> wrongSide{
      tri(0, 1, 3)};  // edge 0->1 already used by (0,1,3)
  EXPECT_THROW(w.t.addTriangles(wrongSide), TopologyError);
  auto far = w.t.addPoints(std::vector<Vec3>{{5, 5, 0}, {6, 5, 0}, {5, 6, 0}});
  w.log.clear();
  std::vector<topology::TriangleVertices> bowtie{
      {PointId(3), far[0], far[1]}};  // touches the mesh at 3 only
  EXPECT_THROW(w.t.addTriangles(bowtie), TopologyError);
  std::vector<topology::TriangleVertices> missing{tri(0, 1, 99)};
  EXPECT_THROW(w.t.addTriangles(missing), TopologyError);
  std::vector<topology::TriangleVertices> twice{{far[0], far[1], far[2]}, {far[0], far[1], far[2]}};
  EXPECT_THROW(w.t.addTriangles(twice), TopologyError);
  EXPECT_TRUE(w.log.log.empty());
  EXPECT_EQ(w.t.numTriangles(), before);
  w.check();
}

TEST(TopologyOps, RemoveTrianglesCarvesEdgesAndPoints) {
  Watched w(grid(3));
  // Quad (0,0) of the 3x3 grid: triangles 0 = (0,1,4) and 1 = (0,4,3).
  std::vector<topology::TriangleId> tris{topology::TriangleId(0), topology::TriangleId(1)};
  w.t.removeTriangles(tris);
  EXPECT_EQ(w.log.kinds(), (Strings{"T-", "E-", "P-", "end"}));
  EXPECT_EQ(w.log.log[0], "T-:0,1");
  EXPECT_EQ(w.log.count("E-"), 3u);  // (0,1), (0,3), (0,4)
  EXPECT_EQ(w.log.log[2], "P-:0");
  EXPECT_EQ(w.t.numTriangles(), 6u);
  EXPECT_EQ(w.t.numPoints(), 8u);
  EXPECT_FALSE(w.t.isPointAlive(PointId(0)));
  EXPECT_TRUE(w.t.isBoundaryPoint(PointId(4)));
  w.check();
}

TEST(TopologyOps, RemoveTrianglesSplitsABowtie) {
  Watched w(fan(6, true));  // closed fan: centre 0, triangles 0..5
  std::vector<topology::TriangleId> tris{topology::TriangleId(1), topology::TriangleId(4)};
  w.t.removeTriangles(tris);
  // The centre is left with two fans: one keeps point 0, the other moves to a copy.
  EXPECT_EQ(w.t.numTriangles(), 4u);
  EXPECT_EQ(w.t.numPoints(), 8u);
  EXPECT_EQ(w.log.kinds(), (Strings{"T-", "E-", "P+", "E+", "T+", "end"}));
  EXPECT_EQ(components(w.t), 2u);
  w.check();
}

TEST(TopologyOps, SplitInteriorEdge) {
  Watched w(grid(5));
  EdgeId e = w.t.findEdge(gridId(5, 2, 2), gridId(5, 3, 3));  // an interior diagonal
  ASSERT_NE(e.idx(), kInvalidIndex);
  PointId m = w.t.splitEdge(e, 0.25);
  EXPECT_EQ(w.log.kinds(), (Strings{"T-", "E-", "P+", "E+", "T+", "end"}));
  EXPECT_EQ(w.log.count("T-"), 2u);
  EXPECT_EQ(w.log.count("E-"), 1u);
  EXPECT_EQ(w.log.count("E+"), 4u);
  EXPECT_EQ(w.log.count("T+"), 4u);
  auto ev = w.t.restPosition(m);
  // The parameter runs from the edge's first vertex.
  EXPECT_NEAR(ev[2], 0.0, 1e-15);
  EXPECT_EQ(w.t.numPoints(), 26u);
  EXPECT_EQ(w.t.numEdges(), 59u);
  EXPECT_EQ(w.t.numTriangles(), 34u);
  w.check();
}

TEST(TopologyOps, SplitBoundaryEdgeAndTriangle) {
  Watched w(grid(3));
  EdgeId e = w.t.findEdge(topology::PointId(0), topology::PointId(1));
  w.t.splitEdge(e, 0.5);
  EXPECT_EQ(w.log.count("T-"), 1u);
  EXPECT_EQ(w.log.count("E+"), 3u);
  EXPECT_EQ(w.log.count("T+"), 2u);
  w.check();
  w.log.clear();
  // Triangle 3 = (1, 5, 4) has three interior edges, which all stay.
  PointId c = w.t.splitTriangle(TriangleId(3), {0.2, 0.3, 0.5});
  EXPECT_EQ(w.log.kinds(), (Strings{"T-", "P+", "E+", "T+", "end"}));
  EXPECT_EQ(w.log.count("E+"), 3u);
  EXPECT_EQ(w.log.count("T+"), 3u);
  EXPECT_FALSE(w.t.isBoundaryPoint(c));
  w.check();
  // A triangle with a border edge: that edge is destroyed and created anew (same endpoints, new
  // index), as the triangle is replaced.
  w.log.clear();
  w.t.splitTriangle(TriangleId(2), {0.2, 0.3, 0.5});  // (1, 2, 5), on the border
  EXPECT_EQ(w.log.kinds(), (Strings{"T-", "E-", "P+", "E+", "T+", "end"}));
  EXPECT_EQ(w.log.count("E+"), 3u + w.log.count("E-"));
  w.check();
  EXPECT_THROW(w.t.splitEdge(e, 0.5), TopologyError);  // e is dead now
  EXPECT_THROW(w.t.splitEdge(w.t.edges()[0], 1.0), TopologyError);
  EXPECT_THROW(w.t.splitTriangle(w.t.triangles()[0], {0.5, 0.5, 0.0}), TopologyError);
}

TEST(TopologyOps, IncisionFromTheBorderOpensOnTheLeft) {
  const int n = 5;
  Watched w(grid(n));
  // Along y = 5 from the left border (0,5) to (5,5): walking +x, the right side is y < 5.
  std::vector<PointId> path{gridId(n, 0, 2), gridId(n, 1, 2), gridId(n, 2, 2)};
  auto r = w.t.incise(path);
  EXPECT_EQ(r.copies.size(), 2u);  // the border end and the interior point; the tip stays
  EXPECT_EQ(r.copiedFrom, (std::vector<PointId>{gridId(n, 0, 2), gridId(n, 1, 2)}));
  EXPECT_EQ(w.log.kinds(), (Strings{"T-", "E-", "P+", "E+", "T+", "end"}));
  EXPECT_EQ(boundaryEdges(w.t), 16u + 4u);
  EXPECT_EQ(components(w.t), 1u);
  std::set<PointId> copies(r.copies.begin(), r.copies.end());
  for (auto f : w.t.triangles()) {
    bool usesCopy = false, usesOriginal = false;
    for (auto p : w.t.triangleVertices(f)) {
      usesCopy |= copies.count(p) > 0;
      usesOriginal |= p == path[0] || p == path[1];
    }
    if (usesCopy) {
      EXPECT_GT(centroid(w.t, f)[1], 5.0);
    }
    if (usesOriginal) {
      EXPECT_LT(centroid(w.t, f)[1], 5.0);
    }
  }
  w.check();
}

TEST(TopologyOps, IncisionAcrossSplitsTheMesh) {
  const int n = 4;
  Watched w(grid(n));
  std::vector<PointId> path;
  for (int i = 0; i < n; ++i) path.push_back(gridId(n, i, 1));
  auto r = w.t.incise(path);
  EXPECT_EQ(r.copies.size(), 4u);
  EXPECT_EQ(components(w.t), 2u);
  w.check();
}

TEST(TopologyOps, TearAnInteriorEdgeOpensASlit) {
  Watched w(grid(5));
  EdgeId e = w.t.findEdge(gridId(5, 1, 2), gridId(5, 2, 2));
  auto r = w.t.tear(e);
  // Both ends are interior: the edge is split at its midpoint, which is duplicated.
  EXPECT_EQ(r.insertedPoints.size(), 1u);
  EXPECT_EQ(r.copies.size(), 1u);
  EXPECT_EQ(r.path.size(), 3u);
  EXPECT_EQ(boundaryEdges(w.t), 16u + 4u);
  EXPECT_EQ(w.t.numTriangles(), 34u);
  w.check();
  // Tearing next to the border duplicates the border point.
  Watched b(grid(5));
  auto r2 = b.t.tear(b.t.findEdge(gridId(5, 0, 2), gridId(5, 1, 2)));
  EXPECT_TRUE(r2.insertedPoints.empty());
  EXPECT_EQ(r2.copiedFrom, (std::vector<PointId>{gridId(5, 0, 2)}));
  b.check();
}

TEST(TopologyOps, IncisionRejectsBadPathsWithoutChange) {
  Watched w(grid(5));
  auto cap = w.t.pointCapacity();
  std::vector<PointId> notConnected{gridId(5, 0, 2), gridId(5, 2, 2)};
  EXPECT_THROW(w.t.incise(notConnected), TopologyError);
  std::vector<PointId> border{gridId(5, 0, 0), gridId(5, 1, 0)};
  EXPECT_THROW(w.t.incise(border), TopologyError);
  std::vector<PointId> repeated{gridId(5, 1, 2), gridId(5, 2, 2), gridId(5, 1, 2)};
  EXPECT_THROW(w.t.incise(repeated), TopologyError);
  std::vector<PointId> missing{gridId(5, 1, 2), PointId(999)};
  EXPECT_THROW(w.t.incise(missing), TopologyError);
  std::vector<PointId> one{PointId(3)};
  EXPECT_THROW(w.t.incise(one), TopologyError);
  EXPECT_THROW(w.t.tear(w.t.findEdge(topology::PointId(0), topology::PointId(1))), TopologyError);
  try {
    w.t.incise(notConnected);
  } catch (const TopologyError& e) {
    EXPECT_NE(std::string(e.what()).find("not connected"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(w.log.log.empty());
  EXPECT_EQ(w.t.pointCapacity(), cap);
  w.check();
}

TEST(TopologyOps, CompactRenumbersDensely) {
  Watched w(grid(4));
  std::vector<topology::TriangleId> tris{topology::TriangleId(0), topology::TriangleId(1),
                                         topology::TriangleId(7)};
  w.t.removeTriangles(tris);
  w.t.tear(w.t.findEdge(gridId(4, 1, 1), gridId(4, 2, 2)));
  w.check();
  EXPECT_GT(w.t.garbageFraction(), 0.0);
  w.log.clear();
  w.t.compact();
  EXPECT_EQ(w.log.kinds(), (Strings{"P#", "E#", "T#", "end"}));
  EXPECT_EQ(w.t.pointCapacity(), w.t.numPoints());
  EXPECT_EQ(w.t.edgeCapacity(), w.t.numEdges());
  EXPECT_EQ(w.t.triangleCapacity(), w.t.numTriangles());
  EXPECT_EQ(w.t.garbageFraction(), 0.0);
  w.check();
  w.log.clear();
  w.t.compact();  // nothing to do: no events
  EXPECT_TRUE(w.log.log.empty());
}

std::vector<Vec3> line(std::initializer_list<Vec3> pts) {
  return pts;
}

double distanceToPolyline(const Vec3& p, const std::vector<Vec3>& poly) {
  double best = 1e300;
  for (std::size_t i = 0; i + 1 < poly.size(); ++i) {
    Vec3 a = poly[i], b = poly[i + 1];
    double ab2 = 0, t = 0;
    for (int k = 0; k < 3; ++k) {
      ab2 += (b[k] - a[k]) * (b[k] - a[k]);
      t += (p[k] - a[k]) * (b[k] - a[k]);
    }
    t = std::clamp(t / ab2, 0.0, 1.0);
    double d = 0;
    for (int k = 0; k < 3; ++k) {
      double x = a[k] + t * (b[k] - a[k]) - p[k];
      d += x * x;
    }
    best = std::min(best, std::sqrt(d));
  }
  return best;
}

TEST(TopologyCut, PolylineFromTheBorderIntoTheInterior) {
  Watched w(grid(11));  // spacing 1
  auto poly = line({{0, 4.5, 0}, {5.5, 4.5, 0}});
  auto r = w.t.cutPolyline(poly);
  w.check();
  EXPECT_GE(r.path.size(), 7u);
  for (auto p : r.path) EXPECT_LT(distanceToPolyline(w.t.restPosition(p), poly), 1e-9);
  EXPECT_EQ(components(w.t), 1u);
  EXPECT_GT(boundaryEdges(w.t), 40u);
  EXPECT_FALSE(r.copies.empty());
  // One transaction: one end event.
  EXPECT_EQ(std::count(w.log.log.begin(), w.log.log.end(), "end:cutPolyline"), 1);
}

TEST(TopologyCut, PolylineWithACornerCutsOffAPiece) {
  Watched w(grid(11));
  auto poly = line({{0, 4.5, 0}, {4.5, 4.5, 0}, {4.5, 0, 0}});
  auto r = w.t.cutPolyline(poly);
  w.check();
  EXPECT_EQ(components(w.t), 2u);
  for (auto p : r.path) EXPECT_LT(distanceToPolyline(w.t.restPosition(p), poly), 1e-9);
}

TEST(TopologyCut, SnappingAvoidsSlivers) {
  Watched w(grid(11));
  // Passes 0.01 from the vertices (3,3) and (6,6): snapped onto them.
  auto poly = line({{0, 0.01, 0}, {8.0, 8.01, 0}});
  w.t.cutPolyline(poly);
  w.check();
  double shortest = 1e300;
  for (auto e : w.t.edges()) {
    auto v = w.t.edgeVertices(e);
    auto a = w.t.restPosition(v[0]), b = w.t.restPosition(v[1]);
    shortest = std::min(shortest, std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]));
  }
  EXPECT_GT(shortest, 0.05);
}

TEST(TopologyCut, CurvedSurfaceIsFollowed) {
  // A half cylinder of radius 2 along x; the cut runs along x on the surface.
  MeshData m = grid(9, 8.0);
  for (auto& p : m.points) {
    double a = p[1] / 8.0 * 3.14159265358979;
    p = {p[0], 2 * std::cos(a), 2 * std::sin(a)};
  }
  Watched w(m);
  double a = 0.43 * 3.14159265358979;
  auto poly =
      line({{0, 2 * std::cos(a), 2 * std::sin(a)}, {5.5, 2 * std::cos(a), 2 * std::sin(a)}});
  auto r = w.t.cutPolyline(poly);
  w.check();
  EXPECT_GE(r.path.size(), 6u);
  EXPECT_FALSE(r.copies.empty());
}

TEST(TopologyCut, RejectsPolylinesOffTheSurfaceWithoutChange) {
  Watched w(grid(11));
  auto cap = w.t.pointCapacity();
  EXPECT_THROW(w.t.cutPolyline(line({{5, 5, 3}, {6, 6, 3}})), TopologyError);   // above it
  EXPECT_THROW(w.t.cutPolyline(line({{5, 5, 0}, {15, 5, 0}})), TopologyError);  // leaves it
  EXPECT_THROW(w.t.cutPolyline(line({{5, 5, 0}})), TopologyError);              // one point
  EXPECT_THROW(w.t.cutPolyline(line({{1, 1, 0}, {8, 8, 0}, {8, 1, 0}, {1, 8, 0}})),
               TopologyError);  // crosses itself
  try {
    w.t.cutPolyline(line({{5, 5, 0}, {15, 5, 0}}));
  } catch (const TopologyError& e) {
    EXPECT_NE(std::string(e.what()).find("not on the surface"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(w.log.log.empty());
  EXPECT_EQ(w.t.pointCapacity(), cap);
  // Around a hole: a cut that would cross the removed region is rejected too.
  std::vector<topology::TriangleId> hole;
  for (auto f : w.t.triangles()) {
    auto c = centroid(w.t, f);
    if (std::abs(c[0] - 5) < 1.5 && std::abs(c[1] - 5) < 1.5) hole.push_back(f);
  }
  w.t.removeTriangles(hole);
  w.check();
  w.log.clear();
  cap = w.t.pointCapacity();
  try {
    w.t.cutPolyline(line({{1.5, 5.2, 0}, {8.5, 5.2, 0}}));
    ADD_FAILURE() << "a cut across a hole was accepted";
  } catch (const TopologyError& e) {
    EXPECT_NE(std::string(e.what()).find("leaves the surface"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(w.log.log.empty());
  EXPECT_EQ(w.t.pointCapacity(), cap);
  w.check();
}

TEST(TopologyOps, TearingTheOneHingeSeparatesItsTriangles) {
  Watched w(oneHinge({0.3, -1, 0}, {0.6, 2, 0}, {0, 0, 0}, {1, 0, 0}));
  auto r = w.t.tear(w.t.findEdge(topology::PointId(2), topology::PointId(3)));
  // Both ends of the hinge edge are on the border: both are duplicated.
  EXPECT_EQ(r.copies.size(), 2u);
  EXPECT_TRUE(r.insertedPoints.empty());
  EXPECT_EQ(w.t.numPoints(), 6u);
  EXPECT_EQ(w.t.numEdges(), 6u);
  EXPECT_EQ(components(w.t), 2u);
  EXPECT_EQ(w.log.kinds(), (Strings{"T-", "E-", "P+", "E+", "T+", "end"}));
  w.check();
}

TEST(TopologyOps, IncisionOfAStripFromBorderToBorder) {
  // A strip of 4 squares, 2 x 5 points: point i + 5 j at (i, j); cut across it at x = 2.
  MeshData strip;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 5; ++i) strip.points.push_back({double(i), double(j), 0.0});
  for (int i = 0; i < 4; ++i) {
    PointId a = PointId(i), b = PointId(i + 1), c = PointId(i + 6), d = PointId(i + 5);
    strip.triangles.push_back({a, b, c});
    strip.triangles.push_back({a, c, d});
  }
  Watched w(strip);
  auto r = w.t.incise(std::vector<PointId>{PointId(2), PointId(7)});
  EXPECT_EQ(r.copies.size(), 2u);
  EXPECT_EQ(components(w.t), 2u);
  EXPECT_EQ(boundaryEdges(w.t), 10u + 2u);
  w.check();
}

TEST(TopologyOps, IncisionOfAClosedSurfaceOpensASlit) {
  MeshData oct;
  oct.points = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  oct.triangles = {tri(0, 2, 4), tri(2, 1, 4), tri(1, 3, 4), tri(3, 0, 4),
                   tri(2, 0, 5), tri(1, 2, 5), tri(3, 1, 5), tri(0, 3, 5)};
  Watched w(oct);
  // From the north pole over (1,0,0) to the south pole: the poles are the slit's tips.
  auto r = w.t.incise(std::vector<PointId>{PointId(4), PointId(0), PointId(5)});
  EXPECT_EQ(r.copiedFrom, (std::vector<PointId>{PointId(0)}));
  EXPECT_EQ(w.t.numPoints(), 7u);
  EXPECT_EQ(boundaryEdges(w.t), 4u);
  EXPECT_EQ(components(w.t), 1u);
  w.check();
}

TEST(TopologyCut, PolylineAlongExistingEdgesInsertsNothing) {
  Watched w(grid(11));  // spacing 1: y = 5 is a grid line
  auto r = w.t.cutPolyline(line({{0, 5, 0}, {5, 5, 0}}));
  EXPECT_TRUE(r.insertedPoints.empty());
  EXPECT_EQ(r.path.size(), 6u);
  EXPECT_EQ(r.copies.size(), 5u);  // the border end and four interior points; the tip stays
  w.check();
}

TEST(TopologyCut, PolylineThroughAVertexAndEndingOnTheBorder) {
  Watched w(grid(11));
  // From the bottom border through the vertex (3, 3) to the left border.
  auto r = w.t.cutPolyline(line({{3, 0, 0}, {3, 3, 0}, {0, 6, 0}}));
  EXPECT_NE(std::find(r.path.begin(), r.path.end(), gridId(11, 3, 3)), r.path.end());
  EXPECT_EQ(components(w.t), 2u);
  w.check();
}

TEST(TopologyCut, PolylineThatDoublesBackOnItself) {
  // The second segment runs back along the first: the path visits its own edges again.
  Watched w(grid(9, 10.0, 0.25, 6));
  auto r = w.t.cutPolyline(line({{7.8465674696881358, 7.8877157715082671, 0},
                                 {7.0839251451425538, 6.7600548785742749, 0},
                                 {7.2262576502102638, 6.9674882407819272, 0}}));
  EXPECT_GE(r.path.size(), 3u);
  w.check();
  // And a zig-zag that comes back close to itself.
  Watched z(grid(11));
  z.t.cutPolyline(line({{1.3, 5.05, 0}, {8.7, 5.05, 0}, {1.3, 5.12, 0}}));
  z.check();
}

}  // namespace
}  // namespace cutsim::test
