// Sewing lips back into one surface (Topology::sew), the reverse of a cut: a sewn cut is the uncut
// sheet again (up to renumbering), every observer follows (validate(): each table equals its
// rebuild), lips cut apart point by point still meet, and a sew that cannot be done says why and
// changes nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "cutsim/core/state.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/topology/geometry.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/fixtures.hpp"

namespace cutsim::test {
namespace {

using topology::PointId;
using topology::Topology;
using topology::Vec3;

/// x, y, z per point slot: where each point is, given a map of the rest position (dead slots 0).
std::vector<double> placed(const Topology& t, const std::function<Vec3(const Vec3&)>& map) {
  std::vector<double> x(3 * t.pointCapacity(), 0.0);
  for (PointId p : t.points()) {
    const Vec3 q = map(t.restPosition(p));
    for (int c = 0; c < 3; ++c) x[3 * p.idx() + c] = q[c];
  }
  return x;
}
std::vector<double> atRest(const Topology& t) {
  return placed(t, [](const Vec3& r) { return r; });
}

/// The triangles as sets of rest positions (rounded to 1e-9): a description that does not
/// depend on the numbering.
std::multiset<std::array<std::array<long long, 3>, 3>> shape(const Topology& t) {
  std::multiset<std::array<std::array<long long, 3>, 3>> out;
  for (auto tr : t.triangles()) {
    std::array<std::array<long long, 3>, 3> c{};
    const auto v = t.triangleVertices(tr);
    for (int k = 0; k < 3; ++k) {
      const Vec3 r = t.restPosition(v[k]);
      for (int d = 0; d < 3; ++d) c[k][d] = std::llround(r[d] * 1e9);
    }
    std::sort(c.begin(), c.end());
    out.insert(c);
  }
  return out;
}

/// Border edges whose rest midpoint is not on the square [0, size]^2's outline (a lip).
std::size_t innerBorderEdges(const Topology& t, double size) {
  std::size_t n = 0;
  for (auto e : t.edges()) {
    if (!t.isBoundaryEdge(e)) continue;
    const auto v = t.edgeVertices(e);
    const Vec3 a = t.restPosition(v[0]), b = t.restPosition(v[1]);
    const double mx = (a[0] + b[0]) / 2, my = (a[1] + b[1]) / 2, eps = 1e-9;
    const bool outline = mx < eps || my < eps || mx > size - eps || my > size - eps;
    n += outline ? 0 : 1;
  }
  return n;
}

/// A sheet with the observers whose tables must follow every operation.
struct Sheet {
  explicit Sheet(int side, double jitter = 0.2)
      : mesh(grid(side, 10.0, jitter, 7)), t(mesh), springs(t, {}), state(t) {}
  topology::MeshData mesh;
  Topology t;
  forcefields::FastTriangularBendingSprings springs;
  core::MechanicalState state;
  void expectValid(const char* when) {
    const topology::ValidationReport r = t.validate();
    EXPECT_TRUE(r.ok()) << when << ":\n" << r.summary();
  }
};

TEST(Sew, ASewnCutIsTheUncutSheet) {
  for (const std::vector<Vec3>& poly :
       {std::vector<Vec3>{{2.1, 3.3, 0}, {5.2, 6.1, 0}, {8.3, 4.4, 0}},       // inside
        std::vector<Vec3>{{0.05, 4.1, 0}, {4.7, 5.3, 0}},                     // from the border
        std::vector<Vec3>{{0.05, 4.1, 0}, {5.0, 6.2, 0}, {9.95, 3.7, 0}}}) {  // across: two pieces
    Sheet s(9);
    const topology::IncisionResult cut = s.t.cutPolyline(poly);
    const auto before = shape(s.t);
    const std::size_t points = s.t.numPoints(), edges = s.t.numEdges(),
                      triangles = s.t.numTriangles();
    const std::size_t open = innerBorderEdges(s.t, 10.0);
    ASSERT_GT(open, 0u);
    topology::SewOptions o;
    o.tolerance = 1e-6;
    const topology::SewResult r = s.t.sew(atRest(s.t), o);
    s.expectValid("after the sew");
    EXPECT_EQ(innerBorderEdges(s.t, 10.0), 0u);
    EXPECT_EQ(r.pointsRemoved, cut.copies.size());
    EXPECT_EQ(s.t.numPoints(), points - cut.copies.size());
    EXPECT_EQ(s.t.numTriangles(), triangles);
    EXPECT_EQ(s.t.numEdges(), edges - r.edgesJoined)
        << "border edges before " << open << ", points " << points << " copies "
        << cut.copies.size() << " inserted " << cut.insertedPoints.size() << " joined "
        << r.edgesJoined << " removed " << r.pointsRemoved;
    EXPECT_TRUE(r.inserted.empty());
    EXPECT_EQ(r.largestGap, 0.0);
    // Same triangles over the same rest positions as the sheet with the cut's points inserted.
    EXPECT_EQ(shape(s.t), before);
    // And the same connectivity: every rest position one point (no copy left).
    std::set<std::array<long long, 3>> positions;
    for (PointId p : s.t.points()) {
      const Vec3 q = s.t.restPosition(p);
      positions.insert({std::llround(q[0] * 1e9), std::llround(q[1] * 1e9), 0});
    }
    EXPECT_EQ(positions.size(), s.t.numPoints());
    EXPECT_EQ(s.t.numEdges(), s.t.numPoints() + s.t.numTriangles() - 1) << "Euler: one disc again";
  }
}

TEST(Sew, TheUncutSheetUpToRenumbering) {
  // An incision along existing edges, sewn: the topology of the sheet before it, up to ids.
  Sheet s(7, 0.0);
  topology::MeshData original = s.t.toMeshData();
  const auto before = shape(s.t);
  std::vector<PointId> path;
  for (PointId p : s.t.points()) {
    const Vec3 r = s.t.restPosition(p);
    if (std::abs(r[1] - 5.0) < 1e-9 && r[0] > 1 && r[0] < 9) path.push_back(p);
  }
  std::sort(path.begin(), path.end(),
            [&](PointId a, PointId b) { return s.t.restPosition(a)[0] < s.t.restPosition(b)[0]; });
  ASSERT_GE(path.size(), 3u);
  s.t.incise(path);
  ASSERT_GT(innerBorderEdges(s.t, 10.0), 0u);
  topology::SewOptions o;
  o.tolerance = 1e-6;
  s.t.sew(atRest(s.t), o);
  s.expectValid("after the sew");
  EXPECT_EQ(shape(s.t), before);
  EXPECT_EQ(s.t.numPoints(), original.points.size());
  EXPECT_EQ(s.t.numTriangles(), original.triangles.size());
  s.t.compact();
  s.expectValid("after compaction");
  EXPECT_EQ(shape(Topology(s.t.toMeshData())), before);
}

TEST(Sew, WorksWhereTheSurfaceIsNowNotAtRest) {
  // The sheet rolled onto a cylinder: the lips meet in the world as at rest, and the sew finds
  // them there; with the lips pulled 0.5 apart in the world it refuses, saying how far.
  Sheet s(9);
  s.t.cutPolyline(std::vector<Vec3>{{1.3, 5.1, 0}, {8.6, 4.9, 0}});
  const auto roll = [](const Vec3& r) {
    const double a = r[0] / 4.0;
    return Vec3{4.0 * std::sin(a), r[1], 4.0 * (1 - std::cos(a))};
  };
  const std::uint64_t digest = s.t.digest();
  // Pull the side above the cut 0.5 along y in the world: the points all of whose triangles lie
  // above the cut's line (the tips, with triangles on both sides, stay).
  const auto above = [](const Vec3& c) { return c[1] > 5.1 - 0.2 * (c[0] - 1.3) / 7.3; };
  std::vector<double> apart = placed(s.t, roll);
  for (PointId p : s.t.points()) {
    bool all = true;
    for (auto tr : s.t.trianglesAroundPoint(p)) {
      Vec3 c{0, 0, 0};
      for (PointId q : s.t.triangleVertices(tr))
        for (int k = 0; k < 3; ++k) c[k] += s.t.restPosition(q)[k] / 3;
      all = all && above(c);
    }
    if (all) apart[3 * p.idx() + 1] += 0.5;
  }
  topology::SewOptions o;
  o.tolerance = 0.1;
  try {
    s.t.sew(apart, o);
    ADD_FAILURE() << "lips 0.5 apart sewn with a tolerance of 0.1";
  } catch (const TopologyError& e) {
    EXPECT_NE(std::string(e.what()).find("are 0.5 apart"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("tolerance 0.1"), std::string::npos) << e.what();
  }
  EXPECT_EQ(s.t.digest(), digest) << "a refused sew changed the mesh";
  const topology::SewResult r = s.t.sew(placed(s.t, roll), o);
  s.expectValid("after the sew");
  EXPECT_EQ(innerBorderEdges(s.t, 10.0), 0u);
  EXPECT_GT(r.edgesJoined, 5u);
}

/// The lip edges of the cut from (1.3, 5.1) to (8.6, 4.9) of a 9 x 9 sheet, away from its ends.
std::vector<topology::EdgeId> cutLips(const topology::Topology& t) {
  std::vector<topology::EdgeId> lips;
  for (auto e : t.edges())
    if (t.isBoundaryEdge(e)) {
      const auto v = t.edgeVertices(e);
      const double y = (t.restPosition(v[0])[1] + t.restPosition(v[1])[1]) / 2;
      const double x = (t.restPosition(v[0])[0] + t.restPosition(v[1])[0]) / 2;
      if (y > 3 && y < 7 && x > 1.5 && x < 8.5) lips.push_back(e);
    }
  return lips;
}

TEST(Sew, LipsWithPointsApartStillMeetPointToPoint) {
  // One lip gets points the other has not (border splits, as a repair makes): the sew inserts
  // their partners on the other lip, and the lips close completely.
  Sheet s(9);
  s.t.cutPolyline(std::vector<Vec3>{{1.3, 5.1, 0}, {8.6, 4.9, 0}});
  const std::vector<topology::EdgeId> lips = cutLips(s.t);
  ASSERT_GE(lips.size(), 6u);
  // Split every other lip edge (of one side or the other) at 0.3 and 0.6 of its length.
  std::size_t splits = 0;
  for (std::size_t i = 0; i < lips.size(); i += 2) {
    s.t.splitEdge(lips[i], i % 4 == 0 ? 0.3 : 0.6);
    ++splits;
  }
  const std::size_t points = s.t.numPoints();
  topology::SewOptions o;
  o.tolerance = 1e-6;
  const topology::SewResult r = s.t.sew(atRest(s.t), o);
  s.expectValid("after the sew");
  EXPECT_EQ(innerBorderEdges(s.t, 10.0), 0u);
  EXPECT_EQ(r.splits, splits);
  for (PointId p : r.inserted) EXPECT_TRUE(s.t.isPointAlive(p));
  EXPECT_LE(r.largestGap, 1e-9);
  // Each inserted point met the split point facing it: both became one (a new point at their
  // mean, since their rest positions differ by rounding, or one of them).
  EXPECT_EQ(s.t.numEdges(), s.t.numPoints() + s.t.numTriangles() - 1);
  EXPECT_LT(s.t.numPoints(), points + splits);
}

TEST(Sew, APointFacingNearAnEndOfTheOtherLipsEdgeIsNotPutThere) {
  // Lip edges split at a tenth of their length: the point made faces the other lip a tenth of an
  // edge from its end. Put there, it would make an edge a tenth long on the other lip (a sliver
  // no repair mends); the sew splits no edge nearer than a fifth of it to an end, and leaves those
  // lips open (the point and the end are further apart than the tolerance).
  Sheet s(9);
  s.t.cutPolyline(std::vector<Vec3>{{1.3, 5.1, 0}, {8.6, 4.9, 0}});
  const std::vector<topology::EdgeId> lips = cutLips(s.t);
  ASSERT_GE(lips.size(), 6u);
  for (std::size_t i = 0; i < lips.size(); i += 4) s.t.splitEdge(lips[i], 0.1);
  // The edges shorter than 0.18, a seventh of the grid's 1.25 (the splits made a tenth long; a sew
  // that put the facing points on the other lip would make as many more).
  const auto shortEdges = [&] {
    std::size_t n = 0;
    for (auto e : s.t.edges()) {
      const auto v = s.t.edgeVertices(e);
      n += topology::geometry::dist2(s.t.restPosition(v[0]), s.t.restPosition(v[1])) < 0.18 * 0.18
               ? 1
               : 0;
    }
    return n;
  };
  const std::size_t before = shortEdges();
  ASSERT_GT(before, 0u);
  topology::SewOptions o;
  o.tolerance = 1e-6;
  const topology::SewResult r = s.t.sew(atRest(s.t), o);
  s.expectValid("after the sew");
  EXPECT_EQ(r.splits, 0u);
  EXPECT_LE(shortEdges(), before) << "the sew made more short edges";
  EXPECT_GT(innerBorderEdges(s.t, 10.0), 0u);  // left open beside each such point
  EXPECT_GT(r.edgesJoined, 0u);                // and joined elsewhere
}

TEST(Sew, OnlyWhereItIsToldTo) {
  Sheet s(9);
  s.t.cutPolyline(std::vector<Vec3>{{1.3, 5.1, 0}, {8.6, 4.9, 0}});
  const std::size_t open = innerBorderEdges(s.t, 10.0);
  topology::SewOptions o;
  o.tolerance = 1e-6;
  o.within = [&](PointId p) { return s.t.restPosition(p)[0] < 5.0; };
  const topology::SewResult r = s.t.sew(atRest(s.t), o);
  s.expectValid("after a partial sew");
  const std::size_t left = innerBorderEdges(s.t, 10.0);
  EXPECT_GT(left, 0u);
  EXPECT_LT(left, open);
  EXPECT_EQ(left + 2 * r.edgesJoined, open);
  for (auto e : s.t.edges())
    if (s.t.isBoundaryEdge(e))
      for (PointId p : s.t.edgeVertices(e)) {
        const Vec3 q = s.t.restPosition(p);
        const bool outline = q[0] < 1e-9 || q[1] < 1e-9 || q[0] > 10 - 1e-9 || q[1] > 10 - 1e-9;
        if (!outline) EXPECT_GT(q[0], 4.0) << "an open lip left where the sew was to close it";
      }
  // The rest closes on a second sew.
  s.t.sew(atRest(s.t), topology::SewOptions{1e-6, {}, {}, {}, {}});
  s.expectValid("after the second sew");
  EXPECT_EQ(innerBorderEdges(s.t, 10.0), 0u);
}

TEST(Sew, KeepsHeldAndPreferredPoints) {
  const std::vector<Vec3> poly{{1.3, 5.1, 0}, {8.6, 4.9, 0}};
  {
    // A cut's two copies of one held point (a cut through a held region holds both sides): one
    // of them stays, held.
    Sheet s(9);
    const topology::IncisionResult cut = s.t.cutPolyline(poly);
    topology::SewOptions both;
    both.tolerance = 1e-6;
    both.locked = {cut.copies[0], cut.copiedFrom[0]};
    s.t.sew(atRest(s.t), both);
    s.expectValid("after the sew");
    EXPECT_EQ(int(s.t.isPointAlive(cut.copies[0])) + int(s.t.isPointAlive(cut.copiedFrom[0])), 1);
    EXPECT_EQ(innerBorderEdges(s.t, 10.0), 0u);
  }
  Sheet s(9);
  const topology::IncisionResult cut = s.t.cutPolyline(poly);
  ASSERT_GE(cut.copies.size(), 2u);
  // A copy held: it survives, its original disappears into it; a preferred one likewise.
  topology::SewOptions o;
  o.tolerance = 1e-6;
  o.locked = {cut.copies[0]};
  o.preferred = {cut.copies[1]};
  const topology::SewResult r = s.t.sew(atRest(s.t), o);
  s.expectValid("after the sew");
  EXPECT_TRUE(s.t.isPointAlive(cut.copies[0]));
  EXPECT_FALSE(s.t.isPointAlive(cut.copiedFrom[0]));
  EXPECT_TRUE(s.t.isPointAlive(cut.copies[1]));
  EXPECT_FALSE(s.t.isPointAlive(cut.copiedFrom[1]));
  EXPECT_TRUE(std::binary_search(r.merged.begin(), r.merged.end(), cut.copies[0]));
}

TEST(Sew, ClosesAGapBetweenLipsAtTheirMeanAndRepairsTheSeam) {
  // Two strips 0.5 apart at rest (y in [0, 5] and [5.5, 10.5]), laid edge to edge in the world:
  // lips whose rest positions differ. Each pair becomes a new point at the mean of their rest
  // positions, its state the mean of theirs; one piece results.
  topology::MeshData m;
  const int nx = 11, ny = 6;
  for (double y0 : {0.0, 5.5}) {
    const auto base = static_cast<topology::Index>(m.points.size());
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) m.points.push_back({double(i), y0 + j, 0});
    for (int j = 0; j + 1 < ny; ++j)
      for (int i = 0; i + 1 < nx; ++i) {
        const auto v = [&](int a, int b) { return PointId(base + topology::Index(b * nx + a)); };
        m.triangles.push_back(topology::TriangleVertices{v(i, j), v(i + 1, j), v(i + 1, j + 1)});
        m.triangles.push_back(topology::TriangleVertices{v(i, j), v(i + 1, j + 1), v(i, j + 1)});
      }
  }
  Topology t(m);
  forcefields::FastTriangularBendingSprings springs(t, {});
  core::MechanicalState state(t);
  for (PointId p : t.points()) {
    const Vec3 r = t.restPosition(p);
    state.x()[3 * p.idx() + 1] = r[1] > 5.2 ? r[1] - 0.5 + 0.01 : r[1];  // 0.01 apart in the world
  }
  const std::vector<double> x(state.x().begin(), state.x().end());
  topology::SewOptions o;
  o.tolerance = 0.05;
  o.repair.minAngle = 20;
  const topology::SewResult r = t.sew(x, o);
  const topology::ValidationReport v = t.validate();
  EXPECT_TRUE(v.ok()) << v.summary();
  EXPECT_EQ(r.edgesJoined, std::size_t(nx - 1));
  EXPECT_EQ(r.merged.size(), std::size_t(nx));
  EXPECT_NEAR(r.largestGap, 0.01, 1e-12);
  EXPECT_EQ(t.numEdges(), t.numPoints() + t.numTriangles() - 1) << "one disc";
  for (PointId p : r.merged) {
    EXPECT_NEAR(t.restPosition(p)[1], 5.25, 1e-12) << "a seam point not at the lips' mean";
    EXPECT_NEAR(state.x()[3 * p.idx() + 1], 5.005, 1e-12) << "its position not the mean";
  }
}

TEST(Sew, RefusesBadRequestsAndLipsThatDoNotFace) {
  Sheet s(7);
  const std::uint64_t digest = s.t.digest();
  topology::SewOptions o;
  o.tolerance = 0.0;
  EXPECT_THROW(s.t.sew(atRest(s.t), o), TopologyError);
  o.tolerance = 1e-6;
  EXPECT_THROW(s.t.sew(std::vector<double>(3), o), TopologyError);
  // An uncut sheet: its outline is a border, but no two edges of it face each other.
  try {
    s.t.sew(atRest(s.t), o);
    ADD_FAILURE() << "an outline sewn to itself";
  } catch (const TopologyError& e) {
    EXPECT_NE(std::string(e.what()).find("no lips lie within the tolerance"), std::string::npos)
        << e.what();
  }
  // Folded onto itself in the world (x -> |x - 5|): the outline's halves meet, but their
  // triangles lie on the same side: no facing lips within the tolerance.
  try {
    s.t.sew(placed(s.t, [](const Vec3& r) { return Vec3{std::abs(r[0] - 5), r[1], 0}; }), o);
    ADD_FAILURE() << "a folded outline sewn to itself";
  } catch (const TopologyError& e) {
    EXPECT_NE(std::string(e.what()).find("no lips lie within the tolerance"), std::string::npos)
        << e.what();
  }
  std::vector<double> nan = atRest(s.t);
  nan[0] = std::nan("");
  EXPECT_THROW(s.t.sew(nan, o), TopologyError);
  EXPECT_EQ(s.t.digest(), digest);
}

}  // namespace
}  // namespace cutsim::test
