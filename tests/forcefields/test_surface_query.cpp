// The deformed surface's queries (surface_query.hpp) against a brute force over every triangle
// built on CGAL's kernel (its exact predicates for crossings, its distances), independent of the
// contact code's geometry: on a wavy, cut sheet, after its positions move (the hierarchy
// refitted) and after another cut (rebuilt).
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/forcefields/surface_query.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/fixtures.hpp"

namespace cutsim::test {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using P3 = K::Point_3;
using forcefields::SurfaceQuery;
using topology::TriangleId;
using topology::Vec3;

/// A sheet of 9 x 9 points cut along a slit, bent into waves (its positions, 3 per slot).
struct WavySheet {
  topology::Topology topo{grid(9, 1.0, 0.2, 7)};
  std::vector<double> x;
  explicit WavySheet(double phase = 0.0) {
    topo.cutPolyline(std::vector<Vec3>{{0.2, 0.45, 0.0}, {0.7, 0.55, 0.0}});
    place(phase);
  }
  void place(double phase) {
    x.assign(3 * topo.pointCapacity(), 0.0);
    for (topology::PointId p : topo.points()) {
      const Vec3 r = topo.restPosition(p);
      x[3 * p.idx()] = r[0];
      x[3 * p.idx() + 1] = r[1];
      x[3 * p.idx() + 2] = 0.15 * std::sin(6.0 * r[0] + phase) * std::cos(4.0 * r[1]);
    }
  }
  P3 at(topology::PointId p) const {
    return {x[3 * p.idx()], x[3 * p.idx() + 1], x[3 * p.idx() + 2]};
  }
  K::Triangle_3 triangle(TriangleId t) const {
    const auto v = topo.triangleVertices(t);
    return {at(v[0]), at(v[1]), at(v[2])};
  }
};

P3 p3(const Vec3& v) {
  return {v[0], v[1], v[2]};
}

/// CGAL's distance between a segment and a triangle: 0 if they meet, else the least of the ends'
/// distances to it and the segment's to its edges.
double segmentTriangle(const K::Segment_3& s, const K::Triangle_3& t) {
  if (CGAL::do_intersect(s, t)) return 0.0;
  double d2 =
      std::min(CGAL::squared_distance(s.source(), t), CGAL::squared_distance(s.target(), t));
  for (int k = 0; k < 3; ++k)
    d2 = std::min(d2, CGAL::squared_distance(s, K::Segment_3(t.vertex(k), t.vertex((k + 1) % 3))));
  return std::sqrt(d2);
}

std::set<TriangleId> asSet(const std::vector<TriangleId>& v) {
  return {v.begin(), v.end()};
}

class SurfaceQueryTest : public ::testing::Test {
 protected:
  std::mt19937 rng{11};
  Vec3 randomPoint(double lo = -0.2, double hi = 1.2) {
    std::uniform_real_distribution<double> u(lo, hi);
    return {u(rng), u(rng), std::uniform_real_distribution<double>(-0.4, 0.4)(rng)};
  }

  /// Every query against the brute force, on the sheet's current positions.
  void checkAll(const WavySheet& s, const SurfaceQuery& q) {
    const std::vector<TriangleId> tris = s.topo.triangles();
    ASSERT_EQ(q.size(), tris.size());
    for (int trial = 0; trial < 40; ++trial) {
      SCOPED_TRACE("trial " + std::to_string(trial));
      // Nearest point.
      const Vec3 c = randomPoint();
      double best = std::numeric_limits<double>::infinity();
      for (TriangleId t : tris)
        best = std::min(best, std::sqrt(CGAL::squared_distance(p3(c), s.triangle(t))));
      const auto near = q.closestPoint(c);
      ASSERT_TRUE(near);
      EXPECT_NEAR(near->distance, best, 1e-12);
      EXPECT_NEAR(std::sqrt(CGAL::squared_distance(p3(near->point), s.triangle(near->triangle))),
                  0.0, 1e-12);
      EXPECT_NEAR(std::sqrt(CGAL::squared_distance(p3(near->point), p3(c))), near->distance, 1e-12);
      EXPECT_FALSE(q.closestPoint(c, 0.5 * best));  // nothing that near
      // Many at once (in the order of a space-filling curve): the same answers.
      if (trial == 0) {
        std::vector<Vec3> many(200);
        for (Vec3& m : many) m = randomPoint();
        const auto all = q.closestPoints(many, 0.3);
        ASSERT_EQ(all.size(), many.size());
        for (std::size_t k = 0; k < many.size(); ++k) {
          const auto one = q.closestPoint(many[k], 0.3);
          ASSERT_EQ(bool(all[k]), bool(one));
          if (one) {
            EXPECT_EQ(all[k]->triangle, one->triangle);
            EXPECT_EQ(all[k]->distance, one->distance);
          }
        }
      }

      // Segment and ray: the triangles it crosses (CGAL's exact predicate), the first one's
      // distance.
      const Vec3 a = randomPoint(), b = randomPoint();
      const K::Segment_3 seg(p3(a), p3(b));
      std::set<TriangleId> crossed;
      for (TriangleId t : tris)
        if (CGAL::do_intersect(seg, s.triangle(t))) crossed.insert(t);
      const auto hits = q.segmentHits(a, b);
      std::set<TriangleId> got;
      for (const auto& h : hits) got.insert(h.triangle);
      EXPECT_EQ(got, crossed);
      EXPECT_TRUE(std::is_sorted(hits.begin(), hits.end(),
                                 [](const auto& u, const auto& v) { return u.t < v.t; }));
      const Vec3 dir{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
      const auto ray = q.rayHit(a, dir);
      const K::Ray_3 r(p3(a), p3(b));
      double first = std::numeric_limits<double>::infinity();
      for (TriangleId t : tris) {
        const auto x = CGAL::intersection(r, s.triangle(t));
        if (!x) continue;
        if (const P3* p = boost::get<P3>(&*x))
          first = std::min(first, std::sqrt(CGAL::squared_distance(*p, p3(a))));
      }
      ASSERT_EQ(bool(ray), std::isfinite(first));
      if (ray) {
        EXPECT_NEAR(ray->t, first, 1e-9);
        EXPECT_NEAR(std::sqrt(CGAL::squared_distance(p3(ray->point), s.triangle(ray->triangle))),
                    0.0, 1e-9);
      }

      // Sphere and capsule.
      const double rad = std::uniform_real_distribution<double>(0.01, 0.3)(rng);
      std::set<TriangleId> inSphere, inCapsule;
      for (TriangleId t : tris) {
        if (std::sqrt(CGAL::squared_distance(p3(c), s.triangle(t))) <= rad) inSphere.insert(t);
        if (segmentTriangle(seg, s.triangle(t)) <= rad) inCapsule.insert(t);
      }
      EXPECT_EQ(asSet(q.sphereOverlap(c, rad)), inSphere);
      EXPECT_EQ(asSet(q.capsuleOverlap(a, b, rad)), inCapsule);
      const auto sorted = q.sphereOverlap(c, rad);
      EXPECT_TRUE(std::is_sorted(sorted.begin(), sorted.end()));

      // A blade a-b moving to a1-b1: the triangles its swept surface (two triangles) meets.
      const Vec3 m = randomPoint(-0.2, 0.2);
      const Vec3 a1{a[0] + m[0], a[1] + m[1], a[2] + m[2]},
          b1{b[0] + m[0], b[1] + m[1], b[2] + m[2]};
      const K::Triangle_3 q1(p3(a), p3(b), p3(b1)), q2(p3(a), p3(b1), p3(a1));
      std::set<TriangleId> swept;
      for (TriangleId t : tris)
        if (CGAL::do_intersect(q1, s.triangle(t)) || CGAL::do_intersect(q2, s.triangle(t)))
          swept.insert(t);
      EXPECT_EQ(asSet(q.sweptSegmentHits(a, b, a1, b1)), swept);
    }
  }
};

TEST_F(SurfaceQueryTest, EveryQueryAgreesWithTheBruteForceAsTheSurfaceMovesAndIsCut) {
  WavySheet s;
  SurfaceQuery q(s.topo, s.x);
  checkAll(s, q);
  s.place(1.3);  // new positions: the hierarchy is refitted
  q.update(s.x);
  checkAll(s, q);
  s.topo.cutPolyline(
      std::vector<Vec3>{{0.1, 0.8, 0.0}, {0.9, 0.75, 0.0}});  // new triangles: rebuilt
  s.place(2.1);
  q.update(s.x);
  checkAll(s, q);
}

// A jaw translated through the sheet sweeps a prism: every triangle the prism's boundary meets,
// and every one wholly inside it (checked against the prism's five planes), is reported.
TEST_F(SurfaceQueryTest, ASweptTriangleFindsWhatItsPrismMeetsOrHolds) {
  WavySheet s;
  SurfaceQuery q(s.topo, s.x);
  const std::vector<TriangleId> tris = s.topo.triangles();
  for (int trial = 0; trial < 20; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const Vec3 o = randomPoint(0.2, 0.8);
    std::array<Vec3, 3> from{Vec3{o[0] - 0.15, o[1] - 0.1, 0.4}, Vec3{o[0] + 0.15, o[1] - 0.1, 0.4},
                             Vec3{o[0], o[1] + 0.2, 0.4}};
    std::array<Vec3, 3> to = from;
    for (auto& p : to) p[2] = -0.4;  // straight down through the sheet
    std::set<TriangleId> expected;
    for (TriangleId t : tris) {
      const auto tri = s.triangle(t);
      // Inside the prism: every corner's (x, y) inside the jaw's triangle (z spans the sheet).
      bool inside = true;
      bool touches = false;
      const K::Triangle_2 jaw({from[0][0], from[0][1]}, {from[1][0], from[1][1]},
                              {from[2][0], from[2][1]});
      const K::Triangle_2 flat({tri.vertex(0).x(), tri.vertex(0).y()},
                               {tri.vertex(1).x(), tri.vertex(1).y()},
                               {tri.vertex(2).x(), tri.vertex(2).y()});
      touches = CGAL::do_intersect(jaw, flat);
      for (int k = 0; k < 3; ++k)
        inside = inside && !jaw.has_on_unbounded_side({tri.vertex(k).x(), tri.vertex(k).y()});
      if (touches || inside) expected.insert(t);
    }
    EXPECT_EQ(asSet(q.sweptTriangleHits(from, to)), expected);
  }
}

// A blade's incision curves (sweptSegmentCurves): every point lies on its triangle and on the
// swept surface; consecutive points lie in one triangle and one swept triangle (their midpoint is
// on both); every crossing CGAL finds between a triangle and the swept surface is covered by a
// curve; the curves run by increasing sweep. Translated blades and a blade that turns (three
// positions), on the wavy cut sheet.
TEST_F(SurfaceQueryTest, ABladesIncisionCurvesAreWhereTheSweptSurfaceMeetsTheSurface) {
  WavySheet s;
  SurfaceQuery q(s.topo, s.x);
  const std::vector<TriangleId> tris = s.topo.triangles();
  int curves = 0, missed = 0;
  for (int trial = 0; trial < 40; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const Vec3 a = randomPoint(0.1, 0.9), m = randomPoint(-0.4, 0.4);
    std::vector<std::array<Vec3, 2>> poses;
    const Vec3 up{0.1 * m[1], -0.1 * m[0], 0.5};
    const Vec3 tip{a[0], a[1], a[2] - 0.25};
    poses.push_back({tip, Vec3{tip[0] + up[0], tip[1] + up[1], tip[2] + up[2]}});
    const Vec3 t1{tip[0] + m[0], tip[1] + m[1], tip[2] + m[2]};
    if (trial % 2 == 0) {
      poses.push_back({t1, Vec3{t1[0] + up[0], t1[1] + up[1], t1[2] + up[2]}});
    } else {  // the blade turns about its tip's path on the way
      const Vec3 mid{tip[0] + 0.5 * m[0], tip[1] + 0.5 * m[1], tip[2] + 0.5 * m[2]};
      poses.push_back({mid, Vec3{mid[0] + 0.2, mid[1] + up[1], mid[2] + 0.45}});
      poses.push_back({t1, Vec3{t1[0] + 0.3, t1[1] - 0.1, t1[2] + 0.4}});
    }
    std::vector<K::Triangle_3> faces;
    for (std::size_t k = 0; k + 1 < poses.size(); ++k) {
      faces.emplace_back(p3(poses[k][0]), p3(poses[k][1]), p3(poses[k + 1][1]));
      faces.emplace_back(p3(poses[k][0]), p3(poses[k + 1][1]), p3(poses[k + 1][0]));
    }
    auto toSwept = [&](const P3& p) {
      double d2 = std::numeric_limits<double>::infinity();
      for (const auto& f : faces) d2 = std::min(d2, CGAL::squared_distance(p, f));
      return std::sqrt(d2);
    };
    auto toSurface = [&](const P3& p) {
      double d2 = std::numeric_limits<double>::infinity();
      for (TriangleId t : tris) d2 = std::min(d2, CGAL::squared_distance(p, s.triangle(t)));
      return std::sqrt(d2);
    };
    const auto found = q.sweptSegmentCurves(poses);
    std::vector<K::Segment_3> pieces;
    for (const auto& curve : found) {
      ++curves;
      ASSERT_GE(curve.size(), 2u);
      EXPECT_LE(curve.front().s, curve.back().s);
      for (std::size_t k = 0; k < curve.size(); ++k) {
        const auto& x = curve[k];
        const auto tri = s.triangle(x.triangle);
        const P3 fromWeights(x.weights[0] * tri.vertex(0).x() + x.weights[1] * tri.vertex(1).x() +
                                 x.weights[2] * tri.vertex(2).x(),
                             x.weights[0] * tri.vertex(0).y() + x.weights[1] * tri.vertex(1).y() +
                                 x.weights[2] * tri.vertex(2).y(),
                             x.weights[0] * tri.vertex(0).z() + x.weights[1] * tri.vertex(1).z() +
                                 x.weights[2] * tri.vertex(2).z());
        EXPECT_NEAR(std::sqrt(CGAL::squared_distance(fromWeights, p3(x.point))), 0.0, 1e-12);
        EXPECT_NEAR(std::sqrt(CGAL::squared_distance(p3(x.point), tri)), 0.0, 1e-12);
        EXPECT_NEAR(toSwept(p3(x.point)), 0.0, 1e-10);
        EXPECT_GE(x.s, -1e-12);
        EXPECT_LE(x.s, double(poses.size() - 1) + 1e-12);
        if (k == 0) continue;
        const P3 mid = CGAL::midpoint(p3(curve[k - 1].point), p3(x.point));
        EXPECT_NEAR(toSurface(mid), 0.0, 1e-10) << "point " << k;
        EXPECT_NEAR(toSwept(mid), 0.0, 1e-10) << "point " << k;
        pieces.emplace_back(p3(curve[k - 1].point), p3(x.point));
      }
    }
    // Every crossing is on a curve (none of these sweeps makes a closed curve, which would not be
    // returned).
    for (TriangleId t : tris)
      for (const auto& f : faces) {
        const auto x = CGAL::intersection(s.triangle(t), f);
        if (!x) continue;
        const K::Segment_3* seg = boost::get<K::Segment_3>(&*x);
        if (!seg || seg->squared_length() < 1e-18) continue;
        const P3 mid = CGAL::midpoint(seg->source(), seg->target());
        double best = std::numeric_limits<double>::infinity();
        for (const auto& p : pieces) best = std::min(best, CGAL::squared_distance(mid, p));
        if (std::sqrt(best) > 1e-9) ++missed;
      }
  }
  EXPECT_GT(curves, 20);
  EXPECT_EQ(missed, 0);
}

TEST(SurfaceQuery, RefusesARayWithoutDirectionAndEmptyQueriesAreEmpty) {
  WavySheet s;
  SurfaceQuery q(s.topo, s.x);
  EXPECT_THROW(q.rayHit({0, 0, 0}, {0, 0, 0}), InvalidInput);
  EXPECT_TRUE(q.segmentHits({0, 0, 0}, {0, 0, 0}).empty());
  EXPECT_TRUE(q.sphereOverlap({5, 5, 5}, 0.1).empty());
  EXPECT_FALSE(q.rayHit({0.5, 0.5, 1.0}, {0, 0, 1}));  // pointing away
  const auto down = q.rayHit({0.5, 0.5, 1.0}, {0, 0, -2});
  ASSERT_TRUE(down);
  EXPECT_NEAR(down->point[0], 0.5, 1e-12);
  EXPECT_NEAR(down->point[1], 0.5, 1e-12);
  EXPECT_NEAR(down->t, 1.0 - down->point[2], 1e-12);  // the distance along the unit direction
}

}  // namespace
}  // namespace cutsim::test
