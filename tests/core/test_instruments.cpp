// Instruments that act in world space: the scalpel cuts the surface where it is, not where its rest
// mesh is. On a flat sheet at rest it cuts as the polyline cut along the same path; on a sheet
// rolled onto a cylinder a blade moving along the axis cuts a straight line of the rest sheet; on a
// folded sheet a deep blade cuts both layers and a shallow one the one it reaches; a blade above
// the surface cuts nothing. The cautery carves the surface where it is: held still on a sheet at
// rest it carves the removal of its sphere; on a moved sheet the hole is the region it swept, in
// the world; on a fold it carves the layer it reaches; dissecting, it releases exactly the points
// it passed over. Every step keeps the topology and every observer valid.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "cutsim/core/scene.hpp"
#include "cutsim/core/simulation.hpp"
#include "cutsim/forcefields/attachment.hpp"
#include "cutsim/forcefields/sutures.hpp"
#include "cutsim/topology/geometry.hpp"
#include "support/scene_text.hpp"

namespace cutsim::core {
namespace {

using test::parseError;
using ::testing::HasSubstr;

constexpr double kPi = 3.14159265358979323846;

/// A 1 m sheet of 21 x 21 points that hardly moves in a step (no gravity, soft springs), so that
/// the positions a test gives it are where the blade finds it.
std::string sheet(const std::string& timeline, double duration = 0.01,
                  const std::string& gravity = "[0, 0, 0]", const std::string& moreFields = "") {
  return R"({
  "mesh": {"grid": {"nx": 21, "ny": 21, "size": [1, 1], "plane": "xy"}},
  "mass": {"total": 0.2},
  "gravity": )" +
         gravity + R"(,
  "forceFields": [{"type": "StretchSprings", "stiffness": 1e-9})" +
         moreFields + R"(],
  "integrator": {"type": "implicit-euler"},
  "linearSolver": {"type": "cg", "iterations": 100, "tolerance": 1e-8},
  "timeStep": 0.01, "duration": )" +
         std::to_string(duration) + R"(,
  "timeline": [)" +
         timeline + R"(]
})";
}

/// A number as JSON, exactly.
std::string text(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", x);
  return buffer;
}

/// A scalpel entry: the blade's tip moves from `a` to `b` over [from, to], its axis `axis`.
std::string scalpel(const Vec3& a, const Vec3& b, const Vec3& axis, double depth, double to,
                    const std::string& extra = "") {
  auto v = [](const Vec3& p) { return text(p[0]) + ", " + text(p[1]) + ", " + text(p[2]); };
  return R"({"action": "scalpel", "from": 0, "to": )" + text(to) + R"(, "depth": )" + text(depth) +
         R"(, "path": [[0, )" + v(a) + ", " + v(axis) + "], [" + text(to) + ", " + v(b) + ", " +
         v(axis) + "]]" + extra + "}";
}

/// The sheet with a scalpel following `path` (rows of [t, x, y, z, ax, ay, az]) over [0, to], no
/// quality repair, the run lasting `to`.
Scene scalpelScene(const std::string& path, double to, double depth,
                   const std::string& gravity = "[0, 0, 0]") {
  return parseScene(
      sheet(R"({"action": "scalpel", "from": 0, "to": )" + text(to) + R"(, "depth": )" +
                text(depth) + R"(, "minAngle": 0, "path": )" + path + "}",
            to, gravity),
      "a.json", test::kSceneDir);
}

/// Runs the scene, the surface first put where `place` says (a function of the rest position),
/// checking the topology and its observers after every step.
void run(SceneRunner& runner, const std::function<Vec3(const Vec3&)>& place = nullptr) {
  runner.start();
  Simulation& sim = runner.simulation();
  if (place)
    for (PointId p : sim.topology().points()) {
      const Vec3 w = place(sim.topology().restPosition(p));
      for (int d = 0; d < 3; ++d) sim.state().x()[3 * p.idx() + std::size_t(d)] = w[d];
    }
  while (!runner.finished()) {
    runner.advance();
    const auto report = sim.topology().validate();
    ASSERT_TRUE(report.ok()) << "step " << runner.currentStep();
  }
}

/// The rest positions of the points a run added (those beyond the grid's 441).
std::vector<Vec3> newPoints(const Simulation& sim) {
  std::vector<Vec3> out;
  for (PointId p : sim.topology().points())
    if (p.idx() >= 441) out.push_back(sim.topology().restPosition(p));
  return out;
}

/// How many closed loops the border edges make (connected pieces of the graph of border edges):
/// an incision from the border adds none, one with two ends inside adds one, a cut across a sheet
/// that parts it adds one.
std::size_t borderLoops(const topology::Topology& t) {
  std::vector<topology::Index> parent(t.pointCapacity());
  for (topology::Index i = 0; i < parent.size(); ++i) parent[i] = i;
  const std::function<topology::Index(topology::Index)> find = [&](topology::Index i) {
    return parent[i] == i ? i : parent[i] = find(parent[i]);
  };
  std::set<topology::Index> on;
  for (topology::EdgeId e : t.edges()) {
    if (!t.isBoundaryEdge(e)) continue;
    const auto v = t.edgeVertices(e);
    on.insert(v[0].idx());
    on.insert(v[1].idx());
    parent[find(v[0].idx())] = find(v[1].idx());
  }
  std::set<topology::Index> roots;
  for (topology::Index i : on) roots.insert(find(i));
  return roots.size();
}

/// The mesh as sorted rest positions and triangles given by their corners' rest positions.
struct Shape {
  std::vector<Vec3> points;
  std::multiset<std::vector<double>> triangles;
};
Shape shapeOf(const topology::Topology& t) {
  Shape s;
  for (PointId p : t.points()) s.points.push_back(t.restPosition(p));
  std::sort(s.points.begin(), s.points.end());
  auto rounded = [](double x) { return std::round(x * 1e9) / 1e9; };
  for (topology::TriangleId tri : t.triangles()) {
    std::vector<Vec3> c;
    for (PointId p : t.triangleVertices(tri)) c.push_back(t.restPosition(p));
    std::sort(c.begin(), c.end());
    std::vector<double> key;
    for (const Vec3& q : c)
      for (double x : q) key.push_back(rounded(x));
    s.triangles.insert(key);
  }
  return s;
}

TEST(Scalpel, OnAFlatSheetAtRestCutsAsThePolylineCutAlongItsPath) {
  // The blade enters through the left border and stops inside; in one step, and in 25.
  const Vec3 a{-0.2, 0.33, -0.01}, b{0.7, 0.61, -0.01};
  const double y0 = a[1] + (b[1] - a[1]) * (0 - a[0]) / (b[0] - a[0]);  // where it enters
  for (const char* minAngle : {"0", "20"}) {
    const std::string extra = std::string(", \"minAngle\": ") + minAngle;
    SceneRunner cut(parseScene(sheet(R"({"action": "cut", "at": 0.01, "polyline": [[0, )" +
                                     text(y0) + R"(, 0], [0.7, 0.61, 0]])" + extra + "}"),
                               "a.json", test::kSceneDir));
    SceneRunner blade(
        parseScene(sheet(scalpel(a, b, {0, 0, 1}, 0.02, 0.01, extra)), "b.json", test::kSceneDir));
    run(cut);
    run(blade);
    EXPECT_EQ(cut.cutsDone(), 1);
    EXPECT_EQ(blade.cutsDone(), 1);
    const Shape x = shapeOf(cut.simulation().topology()),
                y = shapeOf(blade.simulation().topology());
    ASSERT_EQ(x.points.size(), y.points.size()) << "minAngle " << minAngle;
    for (std::size_t i = 0; i < x.points.size(); ++i)
      for (int d = 0; d < 3; ++d)
        EXPECT_NEAR(x.points[i][d], y.points[i][d], 1e-12) << "point " << i;
    EXPECT_EQ(x.triangles, y.triangles) << "minAngle " << minAngle;
  }
  // Over 25 steps: pieces that join into one incision along the same line.
  SceneRunner slow(parseScene(sheet(scalpel(a, b, {0, 0, 1}, 0.02, 0.25, ", \"minAngle\": 0"), 0.3),
                              "c.json", test::kSceneDir));
  run(slow);
  EXPECT_GT(slow.cutsDone(), 2);
  // One incision, from the border to its tip: the border is still one loop (pieces that did not
  // join would leave a strip uncut and a second loop).
  EXPECT_EQ(borderLoops(slow.simulation().topology()), 1u);
  const auto added = newPoints(slow.simulation());
  ASSERT_FALSE(added.empty());
  // Every new point is on the path (snapping moves a piece's end by at most a tenth of an edge).
  const double dx = b[0] - a[0], dy = b[1] - a[1], len = std::hypot(dx, dy);
  for (const Vec3& p : added) {
    const double off = std::abs((p[0] - a[0]) * dy - (p[1] - a[1]) * dx) / len;
    EXPECT_LT(off, 0.1 * 0.05 * 1.5) << p[0] << ", " << p[1];
    EXPECT_LE(p[0], 0.7 + 1e-9);
  }
}

TEST(Scalpel, ABladeThatEntersAndLeavesMakesAnIncisionWithTwoEnds) {
  // From above the sheet down through it at x = 0.3, along to x = 0.7, and up out of it: one
  // incision from about 0.3 to 0.7 (where the tip crossed the sheet), both ends inside.
  const std::string path =
      R"([[0, 0.25, 0.43, 0.02, 0, 0, 1], [0.05, 0.35, 0.43, -0.02, 0, 0, 1],
          [0.15, 0.65, 0.47, -0.02, 0, 0, 1], [0.2, 0.75, 0.47, 0.02, 0, 0, 1]])";
  SceneRunner runner(scalpelScene(path, 0.2, 0.03));
  run(runner);
  const auto added = newPoints(runner.simulation());
  ASSERT_GT(added.size(), 8u);
  double lo = 1, hi = 0;
  for (const Vec3& p : added) {
    lo = std::min(lo, p[0]);
    hi = std::max(hi, p[0]);
    EXPECT_GT(p[1], 0.42);
    EXPECT_LT(p[1], 0.48);
  }
  // The tip crosses z = 0 half way down and half way up: at x = 0.3 and x = 0.7 (snapping moves
  // an end by at most a tenth of an edge, 0.005).
  EXPECT_NEAR(lo, 0.3, 0.006);
  EXPECT_NEAR(hi, 0.7, 0.006);
  // Two ends inside: the sheet's border is its own 80 edges plus the incision's two lips, which
  // meet at its ends (each lip has as many edges as the other).
  const auto& topo = runner.simulation().topology();
  std::size_t border = 0;
  for (topology::EdgeId e : topo.edges()) border += topo.isBoundaryEdge(e);
  EXPECT_GT(border, 80u);
  EXPECT_EQ((border - 80) % 2, 0u);
  EXPECT_EQ(borderLoops(topo), 2u);  // the sheet's and the incision's
  for (PointId p : topo.points()) {
    const Vec3 r = topo.restPosition(p);
    const bool onOuterBorder = r[0] < 1e-12 || r[0] > 1 - 1e-12 || r[1] < 1e-12 || r[1] > 1 - 1e-12;
    if (p.idx() >= 441) EXPECT_FALSE(onOuterBorder) << "the incision reached the border";
  }
}

TEST(Scalpel, ABladeThatPausesInsideGoesOnWithTheSameIncision) {
  // In from the left border, still for 0.1 s at x = 0.4 (two keyframes alike), then on to 0.7:
  // one incision from the border (one border loop). The sheet falls slowly in its own plane
  // (gravity along -y, nothing fixed), so that where the blade meets it after the pause is not
  // the incision's tip: the incision goes on from its tip all the same.
  const std::string path =
      R"([[0, -0.1, 0.43, -0.01, 0, 0, 1], [0.1, 0.4, 0.43, -0.01, 0, 0, 1],
          [0.2, 0.4, 0.43, -0.01, 0, 0, 1], [0.3, 0.7, 0.43, -0.01, 0, 0, 1]])";
  SceneRunner runner(scalpelScene(path, 0.35, 0.02, "[0, -0.5, 0]"));
  run(runner);
  EXPECT_GT(runner.cutsDone(), 2);
  EXPECT_EQ(borderLoops(runner.simulation().topology()), 1u);
  for (const Vec3& p : newPoints(runner.simulation())) {
    // (the sheet falls 0.5 g t^2 / 2 by t: 3 cm by the end, so the incision runs up the rest
    // sheet by as much)
    EXPECT_GT(p[1], 0.43 - 0.006);
    EXPECT_LT(p[1], 0.43 + 0.035);
  }
  // It ends where the blade stopped, x = 0.7 (a grid vertex there: snapped onto it).
  const auto& topo = runner.simulation().topology();
  double hi = 0;
  for (topology::EdgeId e : topo.edges())
    if (topo.isBoundaryEdge(e))
      for (PointId q : topo.edgeVertices(e)) {
        const Vec3 r = topo.restPosition(q);
        if (r[0] > 1e-9 && r[0] < 1 - 1e-9 && r[1] > 1e-9 && r[1] < 1 - 1e-9)
          hi = std::max(hi, r[0]);
      }
  EXPECT_NEAR(hi, 0.7, 0.1 * 0.05 * 1.01);
}

TEST(Scalpel, ABladeWhoseTipGrazesOutOfTheTissueGoesOnWithTheSameIncision) {
  // In from the left border; at x = 0.4 the tip rises 0.5 mm out of the sheet for a centimetre
  // (less than half an edge) and goes back in, on to x = 0.7: one incision (the tip kept while the
  // blade was out), where without it a second incision would start beside the first's tip.
  const std::string path =
      R"([[0, -0.1, 0.43, -0.002, 0, 0, 1], [0.1, 0.395, 0.43, -0.002, 0, 0, 1],
          [0.11, 0.40, 0.43, 0.0005, 0, 0, 1], [0.12, 0.405, 0.43, 0.0005, 0, 0, 1],
          [0.13, 0.41, 0.43, -0.002, 0, 0, 1], [0.3, 0.7, 0.43, -0.002, 0, 0, 1]])";
  SceneRunner runner(scalpelScene(path, 0.3, 0.02));
  run(runner);
  EXPECT_GT(runner.cutsDone(), 2);
  EXPECT_EQ(borderLoops(runner.simulation().topology()), 1u);
}

TEST(Scalpel, AboveTheSurfaceCutsNothing) {
  // 1 mm above the sheet, along its whole width.
  SceneRunner runner(
      parseScene(sheet(scalpel({-0.1, 0.4, 0.001}, {1.1, 0.45, 0.001}, {0, 0, 1}, 0.05, 0.1), 0.1),
                 "a.json", test::kSceneDir));
  run(runner);
  EXPECT_EQ(runner.cutsDone(), 0);
  EXPECT_EQ(runner.simulation().topology().numPoints(), 441u);
}

TEST(Scalpel, AlongACylindersAxisCutsAStraightLineOfTheRestSheet) {
  // The sheet rolled about an axis along y (three quarters of a turn); the blade pierces one layer
  // from inside and moves along the axis, across the whole sheet.
  const double R = 1.0 / (1.5 * kPi), X0 = 0.43, th = X0 / R;
  const auto roll = [&](const Vec3& r) {
    return Vec3{R * std::sin(r[0] / R), r[1], R - R * std::cos(r[0] / R)};
  };
  const Vec3 out{std::sin(th), 0, -std::cos(th)};
  const Vec3 c{0, 0, R};
  const auto at = [&](double y) {
    return Vec3{c[0] + (R - 0.01) * out[0], y, c[2] + (R - 0.01) * out[2]};
  };
  for (double to : {0.01, 0.2}) {
    SceneRunner runner(
        parseScene(sheet(scalpel(at(-0.1), at(1.1), out, 0.02, to, ", \"minAngle\": 0"), to + 0.01),
                   "a.json", test::kSceneDir));
    run(runner, roll);
    const auto added = newPoints(runner.simulation());
    ASSERT_GT(added.size(), 20u);
    // One straight line of the rest sheet, x = X* near X0 (the triangles are chords of the
    // cylinder: the plane meets them a little off the arc's X0), across the whole sheet.
    double lo = 1, hi = 0, ylo = 1, yhi = 0;
    for (const Vec3& p : added) {
      lo = std::min(lo, p[0]);
      hi = std::max(hi, p[0]);
      ylo = std::min(ylo, p[1]);
      yhi = std::max(yhi, p[1]);
    }
    if (to == 0.01) {
      EXPECT_LT(hi - lo, 1e-9) << "one step";
    } else {
      EXPECT_LT(hi - lo, 0.1 * 0.05 * 1.01) << "pieces' ends may snap by a tenth of an edge";
    }
    EXPECT_NEAR(lo, X0, 0.005);
    EXPECT_LT(ylo, 1e-9);
    EXPECT_GT(yhi, 1 - 1e-9);
  }
}

TEST(Scalpel, ADeepBladeCutsBothLayersOfAFoldAShallowOneTheLayerItReaches) {
  // The sheet folded over itself at x = 0.5: its right half lies 3 cm above its left half.
  const auto fold = [](const Vec3& r) {
    return r[0] <= 0.5 ? Vec3{r[0], r[1], 0} : Vec3{1 - r[0], r[1], 0.03};
  };
  struct Case {
    double tipZ, depth;
    bool bottom, top;
  };
  // In one step, and in 20 (each layer's incision going on from its own tip).
  for (const double to : {0.01, 0.2})
    for (const Case k : {Case{-0.01, 0.06, true, true}, Case{-0.01, 0.02, true, false},
                         Case{0.015, 0.03, false, true}}) {
      SCOPED_TRACE("over " + std::to_string(to) + " s, tip " + std::to_string(k.tipZ) + ", depth " +
                   std::to_string(k.depth));
      SceneRunner runner(parseScene(sheet(scalpel({0.23, -0.1, k.tipZ}, {0.23, 1.1, k.tipZ},
                                                  {0, 0, 1}, k.depth, to, ", \"minAngle\": 0"),
                                          to + 0.01),
                                    "a.json", test::kSceneDir));
      run(runner, fold);
      // New points on the lines (one step: exactly; pieces' ends snap by a tenth of an edge).
      const double tol = to == 0.01 ? 1e-9 : 0.1 * 0.05 * 1.01;
      bool bottom = false, top = false;
      for (const Vec3& p : newPoints(runner.simulation())) {
        if (std::abs(p[0] - 0.23) < tol)
          bottom = true;
        else if (std::abs(p[0] - 0.77) < tol)
          top = true;
        else
          ADD_FAILURE() << "a new point off both lines: " << p[0] << ", " << p[1];
      }
      EXPECT_EQ(bottom, k.bottom);
      EXPECT_EQ(top, k.top);
      if (to == 0.01) EXPECT_EQ(runner.cutsDone(), int(k.bottom) + int(k.top));
      // Each layer cut through from border to border parts a strip off: one loop more each.
      EXPECT_EQ(borderLoops(runner.simulation().topology()),
                1u + std::size_t(k.bottom) + std::size_t(k.top));
    }
}

TEST(Scalpel, BadInputIsRefusedBeforeTheRunNamingThePlace) {
  const std::string head = R"({"action": "scalpel", "from": 0, "to": 0.01, )";
  EXPECT_THAT(parseError(sheet(head + R"("depth": 0.02, "path": [[0, 0, 0, 0, 0, 0, 1],
      [0, 1, 0, 0, 0, 0, 1]]})")),
              HasSubstr("/timeline/0/path/1/0: path times must increase strictly"));
  EXPECT_THAT(parseError(sheet(head + R"("depth": 0.02, "path": [[0, 0, 0, 0, 0, 0, 0]]})")),
              HasSubstr("/timeline/0/path/0/4: the blade's axis"));
  EXPECT_THAT(parseError(sheet(head + R"("depth": 0, "path": [[0, 0, 0, 0, 0, 0, 1]]})")),
              HasSubstr("/timeline/0/depth: the blade's length must be a positive"));
  EXPECT_THAT(parseError(sheet(head + R"("depth": 0.02, "path": [[0, 0, 0, 0, 0, 0, 1],
      [0.01, 1, 0, 0, 0, 0, -1]]})")),
              HasSubstr("/timeline/0/path/1/4: the blade's axis turns by 180 degrees"));
  EXPECT_THAT(parseError(sheet(R"({"action": "scalpel", "at": 0, "depth": 0.02,
      "path": [[0, 0, 0, 0, 0, 0, 1]]})")),
              HasSubstr("/timeline/0/at: unknown key \"at\" for scalpel"));
  EXPECT_THAT(parseError(sheet(head + R"("path": [[0, 0, 0, 0, 0, 0, 1]]})")),
              HasSubstr("/timeline/0: missing key \"depth\""));
}

// ---- the cautery ----

/// A cautery entry over [from, from + length]: its path's rows (times from `from`), its radius,
/// more keys. (A test that puts the sheet somewhere starts it after the first step: the actions
/// due at 0 act when the run starts, before the sheet is put there.)
std::string cautery(const std::string& path, double length, double radius,
                    const std::string& extra = "", double from = 0.0) {
  return R"({"action": "cautery", "from": )" + text(from) + R"(, "to": )" + text(from + length) +
         R"(, "radius": )" + text(radius) + R"(, "path": )" + path + extra + "}";
}

/// The distance from p to the segment a-b less r: what the swept sphere's region is.
double capsuleLevel(const Vec3& p, const Vec3& a, const Vec3& b, double r) {
  const Vec3 ab{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double l2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
  double t =
      l2 > 0 ? ((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1] + (p[2] - a[2]) * ab[2]) / l2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return std::hypot(p[0] - a[0] - t * ab[0], p[1] - a[1] - t * ab[1], p[2] - a[2] - t * ab[2]) - r;
}

Vec3 worldOf(const Simulation& sim, PointId p) {
  const auto x = sim.state().x();
  return {x[3 * p.idx()], x[3 * p.idx() + 1], x[3 * p.idx() + 2]};
}

/// The rest area of the live triangles.
double restArea(const topology::Topology& t) {
  double area = 0.0;
  for (topology::TriangleId tri : t.triangles()) {
    const auto v = t.triangleVertices(tri);
    const Vec3 a = t.restPosition(v[0]), b = t.restPosition(v[1]), c = t.restPosition(v[2]);
    const Vec3 u{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    area += 0.5 * std::hypot(u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                             u[0] * w[1] - u[1] * w[0]);
  }
  return area;
}

/// Whether a rest position is on the sheet's outer border (the unit square's sides).
bool onOuterBorder(const Vec3& r) {
  return std::min({r[0], r[1], 1 - r[0], 1 - r[1]}) < 1e-12;
}

TEST(Cautery, HeldStillOnASheetAtRestCarvesAsTheRemovalOfItsSphere) {
  for (const char* minAngle : {"0", "20"}) {
    SCOPED_TRACE(std::string("minAngle ") + minAngle);
    const std::string extra = std::string(", \"minAngle\": ") + minAngle;
    SceneRunner removal(parseScene(
        sheet(R"({"action": "remove", "at": 0, "sphere": {"center": [0.43, 0.52, 0], "radius": )"
              R"(0.17})" +
                  extra + "}",
              0.02),
        "a.json", test::kSceneDir));
    SceneRunner burn(parseScene(sheet(cautery("[[0, 0.43, 0.52, 0]]", 0.02, 0.17, extra), 0.02),
                                "b.json", test::kSceneDir));
    run(removal);
    run(burn);
    const Shape x = shapeOf(removal.simulation().topology()),
                y = shapeOf(burn.simulation().topology());
    ASSERT_EQ(x.points.size(), y.points.size());
    ASSERT_LT(x.triangles.size(), 800u - 30u);  // (a hole was carved)
    for (std::size_t i = 0; i < x.points.size(); ++i)
      for (int d = 0; d < 3; ++d)
        EXPECT_NEAR(x.points[i][d], y.points[i][d], 1e-9) << "point " << i;
    EXPECT_EQ(x.triangles, y.triangles);
  }
}

TEST(Cautery, TouchedRemovesEveryTriangleWithinItsRadiusWhole) {
  // "boundary": "touched", held still on the sheet at rest, no repair: the triangles gone are
  // exactly those within the radius of its centre (brute force over the grid's triangles), none
  // cut.
  const Vec3 centre{0.43, 0.52, 0.01};
  const double r = 0.07;
  SceneRunner runner(parseScene(sheet(cautery("[[0, 0.43, 0.52, 0.01]]", 0.02, r,
                                              R"(, "boundary": "touched", "minAngle": 0)"),
                                      0.02),
                                "a.json", test::kSceneDir));
  SceneRunner plain(parseScene(sheet("", 0.02), "b.json", test::kSceneDir));
  plain.start();
  const Shape before = shapeOf(plain.simulation().topology());
  run(runner);
  const Shape after = shapeOf(runner.simulation().topology());
  std::size_t touched = 0;
  for (const auto& key : before.triangles) {
    const Vec3 a{key[0], key[1], key[2]}, b{key[3], key[4], key[5]}, c{key[6], key[7], key[8]};
    const bool within = std::sqrt(topology::geometry::dist2(
                            centre, topology::geometry::closestOnTriangle(centre, a, b, c))) <= r;
    touched += within ? 1 : 0;
    EXPECT_EQ(after.triangles.count(key), within ? 0u : 1u)
        << a[0] << ", " << a[1] << " / " << b[0] << ", " << b[1] << " / " << c[0] << ", " << c[1];
  }
  EXPECT_GT(touched, 6u);
  EXPECT_EQ(after.triangles.size(), before.triangles.size() - touched);
}

TEST(Cautery, OnAMovedSheetCarvesTheRegionItSweptInTheWorld) {
  // The sheet stood up in the plane x = 0.3 (rest y -> world y, rest x -> world z, shifted), a
  // sphere running down it along a slanted segment; over one step and over 30.
  const auto stand = [](const Vec3& r) { return Vec3{0.3, r[1] + 0.1, 0.5 - r[0]}; };
  const Vec3 a{0.32, 0.3, 0.3}, b{0.32, 0.8, -0.2};
  const double r = 0.08;
  for (const double to : {0.01, 0.3}) {
    SCOPED_TRACE("over " + std::to_string(to) + " s");
    const std::string path = "[[0, " + text(a[0]) + ", " + text(a[1]) + ", " + text(a[2]) + "], [" +
                             text(to) + ", " + text(b[0]) + ", " + text(b[1]) + ", " + text(b[2]) +
                             "]]";
    SceneRunner runner(
        parseScene(sheet(cautery(path, to, r, "", 0.01), to + 0.01), "a.json", test::kSceneDir));
    run(runner, stand);
    const Simulation& sim = runner.simulation();
    const topology::Topology& t = sim.topology();
    const double trace = std::sqrt(r * r - 0.02 * 0.02);  // the region's radius on the sheet
    // The rim is a polygon on the region's boundary: a point the repair adds on one of its edges
    // lies inside by at most the edge's sagitta, l^2 / (8 r').
    double sagitta = 0.0;
    for (topology::EdgeId e : t.edges()) {
      const auto v = t.edgeVertices(e);
      if (!t.isBoundaryEdge(e) || onOuterBorder(t.restPosition(v[0]))) continue;
      const Vec3 p = worldOf(sim, v[0]), q = worldOf(sim, v[1]);
      sagitta = std::max(sagitta, (std::pow(p[0] - q[0], 2) + std::pow(p[1] - q[1], 2) +
                                   std::pow(p[2] - q[2], 2)) /
                                      (8 * trace));
    }
    std::size_t rim = 0, onIt = 0;
    for (PointId p : t.points()) {
      const double level = capsuleLevel(worldOf(sim, p), a, b, r);
      // Nothing of the surface is left inside the region it swept, but for the rim's sagitta.
      EXPECT_GT(level, -sagitta - 1e-9) << "point " << p.idx();
      // The hole's rim lies on the region's boundary, in the world (its points were carried there
      // through their weights): most of it exactly (the carve's crossings), the points the
      // repair added on its edges within the sagitta.
      if (t.isBoundaryPoint(p) && !onOuterBorder(t.restPosition(p))) {
        ++rim;
        EXPECT_LT(std::abs(level), sagitta + 1e-9) << "rim point " << p.idx();
        onIt += std::abs(level) < 1e-6 ? 1 : 0;
      }
    }
    EXPECT_GT(rim, 20u);
    EXPECT_GT(onIt, rim / 2);
    // The area gone is the region's trace on the sheet, 2 cm from the segment (a stadium of
    // radius sqrt(r^2 - 0.02^2): 2 r' L + pi r'^2, from which its rim's chords cut a little).
    const double sx = a[1] - b[1], sz = a[2] - b[2], length = std::hypot(sx, sz);
    const double stadium = 2 * trace * length + kPi * trace * trace;
    const double gone = 1.0 - restArea(t);
    EXPECT_GT(gone, 0.95 * stadium);
    EXPECT_LE(gone, stadium * (1 + 1e-9));
  }
}

TEST(Cautery, OnAFoldCarvesTheLayerItReaches) {
  // The sheet folded over itself at x = 0.5: its right half lies 4 cm above its left half; a
  // sphere centred on the top layer, moving along y, of 3 cm carves the top layer only, of 5 cm
  // both.
  const auto fold = [](const Vec3& r) {
    return r[0] <= 0.5 ? Vec3{r[0], r[1], 0} : Vec3{1 - r[0], r[1], 0.04};
  };
  for (const double radius : {0.03, 0.05}) {
    SCOPED_TRACE("radius " + std::to_string(radius));
    SceneRunner runner(parseScene(
        sheet(cautery("[[0, 0.23, 0.2, 0.04], [0.2, 0.23, 0.8, 0.04]]", 0.2, radius, "", 0.01),
              0.22),
        "a.json", test::kSceneDir));
    run(runner, fold);
    const topology::Topology& t = runner.simulation().topology();
    bool bottom = false, top = false;
    for (PointId p : t.points()) {
      const Vec3 rest = t.restPosition(p);
      if (!t.isBoundaryPoint(p) || onOuterBorder(rest)) continue;
      (rest[0] < 0.5 ? bottom : top) = true;
      // Around x = 0.23 of the bottom layer, or x = 0.77 of the top one.
      EXPECT_LE(std::abs(rest[0] - (rest[0] < 0.5 ? 0.23 : 0.77)), radius + 1e-9) << rest[0];
    }
    EXPECT_TRUE(top);
    EXPECT_EQ(bottom, radius > 0.04);
  }
}

TEST(Cautery, DissectingReleasesExactlyThePointsItPassedOver) {
  // A sheet attached to the tissue beneath, moved 10 cm along x and lifted 5 cm in the world (its
  // attachment too soft to pull it back within the run): the points released are those within
  // the radius of the segment the sphere ran along, where the sheet is.
  const auto moved = [](const Vec3& r) { return Vec3{r[0] + 0.1, r[1], r[2] + 0.05}; };
  const Vec3 a{0.2, 0.25, 0.05}, b{0.9, 0.6, 0.05};
  const double r = 0.12;
  const std::string path = "[[0, 0.2, 0.25, 0.05], [0.1, 0.9, 0.6, 0.05]]";
  SceneRunner runner(
      parseScene(sheet(cautery(path, 0.1, r, R"(, "mode": "dissect")", 0.01), 0.11, "[0, 0, 0]",
                       R"(, {"type": "Attachment", "label": "tissue", "stiffness": 1e-9})"),
                 "a.json", test::kSceneDir));
  run(runner, moved);
  const Simulation& sim = runner.simulation();
  const forcefields::Attachment* attachment = nullptr;
  for (std::size_t i = 0; i < sim.model().numForceFields(); ++i)
    if (auto* f = dynamic_cast<const forcefields::Attachment*>(&sim.model().forceField(i)))
      attachment = f;
  ASSERT_NE(attachment, nullptr);
  EXPECT_EQ(sim.topology().triangles().size(), 800u);  // nothing carved
  std::size_t released = 0;
  for (PointId p : sim.topology().points()) {
    const double level = capsuleLevel(moved(sim.topology().restPosition(p)), a, b, r);
    if (std::abs(level) < 1e-6) continue;  // (on the boundary: either)
    EXPECT_EQ(attachment->attached(p), level < 0 ? 0.0 : 1.0) << "point " << p.idx();
    released += level < 0 ? 1 : 0;
  }
  EXPECT_GT(released, 40u);
}

TEST(Cautery, BadInputIsRefusedBeforeTheRunNamingThePlace) {
  const std::string head = R"({"action": "cautery", "from": 0, "to": 0.01, )";
  EXPECT_THAT(parseError(sheet(head + R"("radius": 0, "path": [[0, 0, 0, 0]]})")),
              HasSubstr("/timeline/0/radius: must be a positive number"));
  EXPECT_THAT(parseError(sheet(head + R"("radius": 0.1, "path": [[0, 0, 0, 0], [0, 1, 0, 0]]})")),
              HasSubstr("/timeline/0/path/1/0: path times must increase strictly"));
  EXPECT_THAT(parseError(sheet(head + R"("radius": 0.1, "length": 0.1,
      "path": [[0, 0, 0, 0, 0, 0, 0]]})")),
              HasSubstr("/timeline/0/path/0/4: the cautery's axis"));
  EXPECT_THAT(parseError(sheet(head + R"("radius": 0.1, "field": "tissue",
      "path": [[0, 0, 0, 0]]})")),
              HasSubstr("/timeline/0/field: is for a dissecting cautery"));
  EXPECT_THAT(parseError(sheet(head + R"("radius": 0.1, "mode": "dissect",
      "path": [[0, 0, 0, 0]]})")),
              HasSubstr("needs an Attachment force field: the scene has none"));
  EXPECT_THAT(parseError(sheet(R"({"action": "cautery", "at": 0, "radius": 0.1,
      "path": [[0, 0, 0, 0]]})")),
              HasSubstr("/timeline/0/at: unknown key \"at\" for cautery"));
}

// ---- the forceps ----

/// A forceps entry over [0.01, 0.01 + length] named "jaws": the jaws' axis along +z, closing
/// along x, radius r, 4 cm long; the path's rows [t, x, y, z, opening].
std::string forceps(const std::string& path, double length, double r,
                    const std::string& extra = "") {
  return R"({"action": "forceps", "name": "jaws", "from": 0.01, "to": )" + text(0.01 + length) +
         R"(, "axis": [0, 0, 1], "across": [1, 0, 0], "radius": )" + text(r) +
         R"(, "length": 0.04, "path": )" + path + extra + "}";
}

TEST(Forceps, ClosingOnAPointInsideATriangleCarriesItWithTheJaws) {
  // The sheet moved in the world (x + 0.2, z + 0.1); the jaws come down around the material
  // point (0.437, 0.521) of the rest sheet, far from every vertex (the nearest is 2.5 cm away,
  // the jaws 4 mm thick), close, lift it 10 cm while moving 5 cm along y, and open.
  const auto moved = [](const Vec3& r) { return Vec3{r[0] + 0.2, r[1], r[2] + 0.1}; };
  const Vec3 material{0.437, 0.521, 0}, world = moved(material);
  const auto row = [&](double t, const Vec3& d, double opening) {
    return "[" + text(t) + ", " + text(world[0] + d[0]) + ", " + text(world[1] + d[1]) + ", " +
           text(world[2] - 0.01 + d[2]) + ", " + text(opening) + "]";
  };
  const Vec3 lift{0, 0.05, 0.1};
  const std::string path = "[" + row(0, {0, 0, 0}, 0.03) + ", " + row(0.02, {0, 0, 0}, 0.008) +
                           ", " + row(0.12, lift, 0.008) + ", " + row(0.14, lift, 0.03) + "]";
  SceneRunner runner(parseScene(sheet(forceps(path, 0.14, 0.004), 0.2), "a.json", test::kSceneDir));
  runner.start();
  Simulation& sim = runner.simulation();
  for (PointId p : sim.topology().points()) {
    const Vec3 w = moved(sim.topology().restPosition(p));
    for (int d = 0; d < 3; ++d) sim.state().x()[3 * p.idx() + std::size_t(d)] = w[d];
  }
  PointId taken = PointId::invalid();
  bool held = false, released = false;
  while (!runner.finished()) {
    runner.advance();
    ASSERT_TRUE(sim.topology().validate().ok()) << "step " << runner.currentStep();
    const Grasp* g = sim.findGrasp("jaws");
    if (g && !held) {
      held = true;
      // The material point is a point of the mesh now, the only one the jaws hold.
      const auto points = g->points().points();
      ASSERT_EQ(points.size(), 1u);
      taken = points.front();
      const Vec3 rest = sim.topology().restPosition(taken);
      for (int d = 0; d < 3; ++d) EXPECT_NEAR(rest[d], material[d], 1e-12);
    }
    if (held && g) {
      // Where the jaws are: the tip's displacement since they closed (at t = 0.03).
      const double t = runner.time() - 0.01;
      const double f = std::clamp((t - 0.02) / 0.1, 0.0, 1.0);
      const Vec3 x = worldOf(sim, taken);
      for (int d = 0; d < 3; ++d) EXPECT_NEAR(x[d], world[d] + f * lift[d], 1e-9) << "t " << t;
    }
    if (held && !g) released = true;
  }
  EXPECT_TRUE(held);
  EXPECT_TRUE(released);  // the jaws opened
}

/// v turned by `angle` about the unit axis k (Rodrigues' formula).
Vec3 turnAbout(const Vec3& k, double angle, const Vec3& v) {
  const double c = std::cos(angle), s = std::sin(angle);
  const Vec3 kxv{k[1] * v[2] - k[2] * v[1], k[2] * v[0] - k[0] * v[2], k[0] * v[1] - k[1] * v[0]};
  const double kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
  Vec3 out;
  for (int d = 0; d < 3; ++d) out[d] = v[d] * c + kxv[d] * s + k[d] * kv * (1 - c);
  return out;
}

TEST(Forceps, TurningJawsCarryWhatTheyHoldAboutTheirTip) {
  // Jaws 6 cm thick (no repair) close around the material point (0.437, 0.521) of the sheet at
  // rest, their tip 1 cm under it; then their axis turns from +z to -y (a quarter turn about +x)
  // and on to +x (a quarter turn about +z: the two turns do not commute), at a constant rate each,
  // while the tip rises and moves along y. Every held point (the inserted one and the vertices
  // within 6 cm of the middle line) stays where a rigid motion about the tip puts them, and the
  // jaws are drawn along the turned axis and `across`, all computed here by Rodrigues' formula:
  // to 1e-9.
  const double r = 0.06;
  const std::string path =
      "[[0, 0.437, 0.521, -0.01, 0, 0, 1, 0.2], [0.02, 0.437, 0.521, -0.01, 0, 0, 1, 0.12], "
      "[0.07, 0.437, 0.521, 0.05, 0, -1, 0, 0.12], [0.12, 0.437, 0.6, 0.1, 1, 0, 0, 0.12], "
      "[0.13, 0.437, 0.6, 0.1, 1, 0, 0, 0.2]]";
  SceneRunner runner(parseScene(
      sheet(R"({"action": "forceps", "name": "jaws", "from": 0.01, "to": 0.14, "across": [1, 0, 0],
                "radius": )" +
                text(r) + R"(, "length": 0.04, "minAngle": 0, "path": )" + path + "}",
            0.16),
      "a.json", test::kSceneDir));
  runner.start();
  Simulation& sim = runner.simulation();
  // The tip and the turn at time t from the action's start, as the path gives them.
  const auto tipAt = [](double t) -> Vec3 {
    const double keys[4] = {0.02, 0.07, 0.12, 0.13};
    const Vec3 tips[4] = {
        {0.437, 0.521, -0.01}, {0.437, 0.521, 0.05}, {0.437, 0.6, 0.1}, {0.437, 0.6, 0.1}};
    if (t <= keys[0]) return tips[0];
    for (int k = 1; k < 4; ++k)
      if (t <= keys[k]) {
        const double f = (t - keys[k - 1]) / (keys[k] - keys[k - 1]);
        return topology::geometry::lerp(tips[k - 1], tips[k], f);
      }
    return tips[3];
  };
  const Vec3 ex{1, 0, 0}, ez{0, 0, 1};
  const auto first = [](double t) { return kPi / 2 * std::clamp((t - 0.02) / 0.05, 0.0, 1.0); };
  const auto second = [](double t) { return kPi / 2 * std::clamp((t - 0.07) / 0.05, 0.0, 1.0); };
  const auto turn = [&](double t, const Vec3& v) {
    return turnAbout(ez, second(t), turnAbout(ex, first(t), v));
  };
  const auto unturn = [&](double t, const Vec3& v) {
    return turnAbout(ex, -first(t), turnAbout(ez, -second(t), v));
  };
  std::size_t checked = 0;
  bool held = false, released = false;
  while (!runner.finished()) {
    runner.advance();
    ASSERT_TRUE(sim.topology().validate().ok()) << "step " << runner.currentStep();
    const Grasp* g = sim.findGrasp("jaws");
    if (g && !held) {
      held = true;
      EXPECT_EQ(g->points().size(), 5u);  // the inserted point and four vertices
    }
    if (!g) {
      released = released || held;
      continue;
    }
    const double t0 = g->startTime() - 0.01, t = runner.time() - 0.01;
    const Vec3 tip0 = tipAt(t0), tip = tipAt(t);
    for (PointId p : g->points().points()) {
      const Vec3& a = g->points().data(p);  // where it was taken
      const Vec3 arm = turn(t, unturn(t0, {a[0] - tip0[0], a[1] - tip0[1], a[2] - tip0[2]}));
      const Vec3 x = worldOf(sim, p);
      for (int d = 0; d < 3; ++d) EXPECT_NEAR(x[d], tip[d] + arm[d], 1e-9) << "t " << t;
      ++checked;
    }
    // The jaws drawn where they are: a jaw's wire starts with its axis, from its tip; the second
    // jaw's tip lies `across` from the first's.
    const auto wires = runner.instrumentSegments();
    ASSERT_EQ(wires.size() % 2, 0u);
    const auto& w = wires.front();
    const auto& w2 = wires[wires.size() / 2];
    const double length = std::sqrt(topology::geometry::dist2(w[0], w[1]));
    const double apart = std::sqrt(topology::geometry::dist2(w[0], w2[0]));
    ASSERT_NEAR(length, 0.04, 1e-9);
    ASSERT_GT(apart, 0.1);
    const Vec3 axis = turn(t, ez), across = turn(t, ex);
    for (int d = 0; d < 3; ++d) {
      EXPECT_NEAR((w[1][d] - w[0][d]) / length, axis[d], 1e-9);
      EXPECT_NEAR((w2[0][d] - w[0][d]) / apart, across[d], 1e-9);
    }
  }
  EXPECT_TRUE(held);
  EXPECT_TRUE(released);
  EXPECT_GT(checked, 40u);
}

TEST(Forceps, ClosingAcrossAFoldTakesBothLayers) {
  // The sheet folded over itself at x = 0.5 (its right half 2 cm above its left half): jaws 4 cm
  // long closing around a vertical line through both layers take a point of each, inserted where
  // the line crosses them.
  const auto fold = [](const Vec3& r) {
    return r[0] <= 0.5 ? Vec3{r[0], r[1], 0} : Vec3{1 - r[0], r[1], 0.02};
  };
  SceneRunner runner(parseScene(
      sheet(forceps("[[0, 0.313, 0.427, -0.01, 0.03], [0.01, 0.313, 0.427, -0.01, 0.002]]", 0.02,
                    0.001),
            0.05),
      "a.json", test::kSceneDir));
  run(runner, fold);
  const Grasp* g = runner.simulation().findGrasp("jaws");
  ASSERT_NE(g, nullptr);
  std::vector<Vec3> rest;
  for (PointId p : g->points().points())
    rest.push_back(runner.simulation().topology().restPosition(p));
  ASSERT_EQ(rest.size(), 2u);
  std::sort(rest.begin(), rest.end());
  EXPECT_NEAR(rest[0][0], 0.313, 1e-12);      // the bottom layer
  EXPECT_NEAR(rest[1][0], 1 - 0.313, 1e-12);  // the top layer
  for (const Vec3& r : rest) EXPECT_NEAR(r[1], 0.427, 1e-12);
}

TEST(Forceps, ACutThroughTheHeldRegionKeepsBothSidesHeld) {
  // Jaws 18 cm thick closed on the sheet at rest hold the points within 9 cm of their middle
  // line (3 x 3 of the grid); a cut across that region (rest coordinates) while they lift: the
  // points of both lips stay held, each where the jaws carry it.
  const std::string path =
      "[[0, 0.5, 0.5, -0.01, 0.3], [0.01, 0.5, 0.5, -0.01, 0.18], [0.1, 0.5, 0.5, 0.05, 0.18]]";
  SceneRunner runner(parseScene(sheet(forceps(path, 0.1, 0.09) + R"(, {"action": "cut", "at": 0.05,
             "polyline": [[0.3, 0.5, 0], [0.7, 0.5, 0]], "minAngle": 0})",
                                      0.12),
                                "a.json", test::kSceneDir));
  run(runner);
  Simulation& sim = runner.simulation();
  const Grasp* g = sim.findGrasp("jaws");
  ASSERT_NE(g, nullptr);
  EXPECT_EQ(runner.cutsDone(), 1);
  std::size_t below = 0, above = 0, onCut = 0;
  for (PointId p : g->points().points()) {
    const Vec3 r = sim.topology().restPosition(p);
    if (std::abs(r[1] - 0.5) < 1e-12)
      ++onCut;
    else
      (r[1] < 0.5 ? below : above) += 1;
    const Vec3 x = worldOf(sim, p), target = g->target(p, runner.time());
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(x[d], target[d], 1e-9);
  }
  EXPECT_EQ(below, 3u);
  EXPECT_EQ(above, 3u);
  // Both copies of each held point on the cut are held (one per lip).
  EXPECT_EQ(onCut, 6u);
}

TEST(Forceps, BadInputIsRefusedBeforeTheRunNamingThePlace) {
  const std::string head = R"({"action": "forceps", "name": "f", "from": 0, "to": 0.01, )";
  EXPECT_THAT(parseError(sheet(head + R"("axis": [0, 0, 1], "across": [1, 0, 0], "radius": 0.01,
      "length": 0.04, "path": [[0, 0, 0, 0, 0.01]]})")),
              HasSubstr("/timeline/0/path/0/4: the jaws' opening"));
  EXPECT_THAT(parseError(sheet(head + R"("axis": [0, 0, 1], "across": [0, 0, 2], "radius": 0.01,
      "length": 0.04, "path": [[0, 0, 0, 0, 0.03]]})")),
              HasSubstr("/timeline/0/across: must not be parallel to the axis"));
  EXPECT_THAT(parseError(sheet(head + R"("axis": [0, 0, 1], "across": [1, 0, 0], "radius": 0,
      "length": 0.04, "path": [[0, 0, 0, 0, 0.03]]})")),
              HasSubstr("/timeline/0/radius: must be a positive number"));
  EXPECT_THAT(parseError(sheet(head + R"("axis": [0, 0, 1], "across": [1, 0, 0], "radius": 0.01,
      "length": 0.04, "path": [[0, 0, 0, 0, 0.03], [0, 0, 0, 0, 0.03]]})")),
              HasSubstr("/timeline/0/path/1/0: path times must increase strictly"));
  EXPECT_THAT(parseError(sheet(head + R"("axis": [0, 0, 1], "across": [1, 0, 0], "radius": 0.01,
      "length": 0.04, "path": [[0, 0, 0, 0, 0.03]]}, {"at": 0, "action": "grasp", "name": "f",
      "points": [0], "path": [[0, 0, 0, 0]]})")),
              HasSubstr("/timeline/1/name: a grasp named \"f\" is already active"));
  // Turning jaws (no "axis"): rows of eight, the axis per keyframe.
  EXPECT_THAT(parseError(sheet(head + R"("across": [1, 0, 0], "radius": 0.01,
      "length": 0.04, "path": [[0, 0, 0, 0, 0.03]]})")),
              HasSubstr("/timeline/0/path/0: expected an array of 8 numbers"));
  EXPECT_THAT(parseError(sheet(head + R"("across": [1, 0, 0], "radius": 0.01,
      "length": 0.04, "path": [[0, 0, 0, 0, 0, 0, 1, 0.03], [1, 0, 0, 0, 0, 0, -1, 0.03]]})")),
              HasSubstr("/timeline/0/path/1/4: the forceps's axis turns by 180 degrees"));
  EXPECT_THAT(parseError(sheet(head + R"("across": [1, 0, 0], "radius": 0.01,
      "length": 0.04, "path": [[0, 0, 0, 0, 0, 0, 1, 0.01]]})")),
              HasSubstr("/timeline/0/path/0/7: the jaws' opening"));
  EXPECT_THAT(parseError(sheet(head + R"("across": [0, 0, 1], "radius": 0.01,
      "length": 0.04, "path": [[0, 0, 0, 0, 0, 0, 1, 0.03]]})")),
              HasSubstr("/timeline/0/across: must not be parallel to the axis"));
}

// ---- sutures ----

const forcefields::Sutures& suturesOf(const Simulation& sim) {
  for (std::size_t i = 0; i < sim.model().numForceFields(); ++i)
    if (auto* f = dynamic_cast<const forcefields::Sutures*>(&sim.model().forceField(i))) return *f;
  throw std::runtime_error("no Sutures field");
}

TEST(Suture, ANeedleThroughTwoPlacesTiesTheirMaterialPointsAndTightens) {
  // The needle goes down through the sheet at A and up through it at B: the two material points
  // become points of the mesh (neither is near a vertex) tied by a thread shortened to 0 over
  // 0.1 s, which pulls them together.
  const std::string needle = R"("needle": [[0.31, 0.42, 0.05], [0.31, 0.42, -0.05],
      [0.63, 0.57, -0.05], [0.63, 0.57, 0.05]])";
  // At t = 0.15 a cut passes 5 mm from A, whose repair must leave the tied point where it is.
  SceneRunner runner(parseScene(
      sheet(R"({"at": 0.02, "action": "suture", "tighten": 0.1, )" + needle +
                R"(}, {"at": 0.15, "action": "cut", "polyline": [[0, 0.425, 0], [0.5, 0.425, 0]]})",
            0.2, "[0, 0, 0]", R"(, {"type": "Sutures", "stiffness": 0.5})"),
      "a.json", test::kSceneDir));
  runner.start();
  Simulation& sim = runner.simulation();
  double placed = -1.0;
  while (!runner.finished()) {
    runner.advance();
    ASSERT_TRUE(sim.topology().validate().ok()) << "step " << runner.currentStep();
    const auto& stitches = suturesOf(sim).stitches();
    if (stitches.empty()) continue;
    ASSERT_EQ(stitches.size(), 1u);
    const auto& st = stitches.front();
    if (placed < 0) {
      const Vec3 a = sim.topology().restPosition(st.a), b = sim.topology().restPosition(st.b);
      EXPECT_NEAR(a[0], 0.31, 1e-12);
      EXPECT_NEAR(a[1], 0.42, 1e-12);
      EXPECT_NEAR(b[0], 0.63, 1e-12);
      EXPECT_NEAR(b[1], 0.57, 1e-12);
      placed = std::hypot(0.32, 0.15);
    }
    // The schedule: from its length when placed (t = 0.02) to 0 at t = 0.12.
    const double f = std::clamp((runner.time() - 0.02) / 0.1, 0.0, 1.0);
    EXPECT_NEAR(st.length, (1 - f) * placed, 1e-9) << "t " << runner.time();
  }
  EXPECT_EQ(runner.cutsDone(), 1);
  const auto& st = suturesOf(sim).stitches().front();
  ASSERT_TRUE(st.alive);  // (the cut's repair did not take the tied point)
  EXPECT_NEAR(sim.topology().restPosition(st.a)[1], 0.42, 1e-12);
  const Vec3 a = worldOf(sim, st.a), b = worldOf(sim, st.b);
  EXPECT_LT(std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]), 0.5 * placed);
}

TEST(Suture, ARunningSutureClosesAGapingWound) {
  // Skin under 5 % resting tension, its border held, slit across the middle: the wound gapes;
  // three stitches across it tightened to 0 over 0.2 s bring each pair of lips together.
  const std::string text = R"({
  "mesh": {"grid": {"nx": 15, "ny": 15, "size": [0.1, 0.1], "plane": "xy"}},
  "mass": {"total": 0.02},
  "gravity": [0, 0, 0],
  "forceFields": [{"type": "TriangularFEM", "youngModulus": 1e6, "poissonRatio": 0.45,
                   "thickness": 0.002, "restScale": 0.95},
                  {"type": "Sutures", "stiffness": 300, "damping": 0.5}],
  "constraints": [{"type": "fixed", "box": [[0, 0, -1], [0, 0.1, 1]]},
                  {"type": "fixed", "box": [[0.1, 0, -1], [0.1, 0.1, 1]]},
                  {"type": "fixed", "box": [[0, 0, -1], [0.1, 0, 1]]},
                  {"type": "fixed", "box": [[0, 0.1, -1], [0.1, 0.1, 1]]}],
  "integrator": {"type": "implicit-euler", "rayleighMass": 2.0},
  "linearSolver": {"type": "cholmod"},
  "timeStep": 0.005, "duration": 0.5,
  "timeline": [{"at": 0.02, "action": "cut", "polyline": [[0.025, 0.0517, 0], [0.075, 0.0517, 0]]},
               {"at": 0.15, "action": "suture", "bite": 0.002, "tighten": 0.2,
                "stitches": [[0.04, 0.045, 0, 0.04, 0.058, 0], [0.05, 0.045, 0, 0.05, 0.058, 0],
                             [0.06, 0.045, 0, 0.06, 0.058, 0]]}]
})";
  SceneRunner runner(parseScene(text, "wound.json", test::kSceneDir));
  runner.start();
  Simulation& sim = runner.simulation();
  // The wound's gape around x = 0.05: how far apart in y its lips' points there are (the two
  // copies of each point of the cut: the points of its border away from the patch's).
  const auto gape = [&sim] {
    double lo = 1.0, hi = -1.0;
    for (PointId p : sim.topology().points()) {
      const Vec3 r = sim.topology().restPosition(p);
      if (!sim.topology().isBoundaryPoint(p) || std::abs(r[0] - 0.05) > 0.005 ||
          std::abs(r[1] - 0.05) > 0.01)
        continue;
      lo = std::min(lo, worldOf(sim, p)[1]);
      hi = std::max(hi, worldOf(sim, p)[1]);
    }
    return hi - lo;
  };
  double before = -1.0;
  while (!runner.finished()) {
    runner.advance();
    ASSERT_TRUE(sim.topology().validate().ok()) << "step " << runner.currentStep();
    if (before < 0 && !suturesOf(sim).stitches().empty()) before = gape();
  }
  ASSERT_EQ(suturesOf(sim).stitches().size(), 3u);
  EXPECT_GT(before, 0.001);  // the wound gaped by more than a millimetre
  EXPECT_LT(gape(), 0.2 * before);
}

/// The skin of ARunningSutureClosesAGapingWound (border held; 5 % resting tension with
/// restScale 0.95, none with 1), slit across the middle at t = 0.02 s, then `timeline` (entries
/// after the cut's).
std::string wound(const std::string& timeline, double duration, double restScale = 0.95) {
  return R"({
  "mesh": {"grid": {"nx": 15, "ny": 15, "size": [0.1, 0.1], "plane": "xy"}},
  "mass": {"total": 0.02},
  "gravity": [0, 0, 0],
  "forceFields": [{"type": "TriangularFEM", "youngModulus": 1e6, "poissonRatio": 0.45,
                   "thickness": 0.002, "restScale": )" +
         text(restScale) + R"(},
                  {"type": "Sutures", "stiffness": 600, "damping": 0.5}],
  "constraints": [{"type": "fixed", "box": [[0, 0, -1], [0, 0.1, 1]]},
                  {"type": "fixed", "box": [[0.1, 0, -1], [0.1, 0.1, 1]]},
                  {"type": "fixed", "box": [[0, 0, -1], [0.1, 0, 1]]},
                  {"type": "fixed", "box": [[0, 0.1, -1], [0.1, 0.1, 1]]}],
  "integrator": {"type": "implicit-euler", "rayleighMass": 2.0},
  "linearSolver": {"type": "cholmod"},
  "timeStep": 0.005, "duration": )" +
         text(duration) + R"(,
  "timeline": [{"at": 0.02, "action": "cut", "polyline": [[0.025, 0.0517, 0], [0.075, 0.0517, 0]]},
               )" +
         timeline + R"(]
})";
}

/// Seven stitches across the wound, 4 mm either side of it, holding the lips where they are.
const std::string kStitches = R"({"at": 0.15, "action": "suture", "bite": 0.002, "length": 0.008,
    "stitches": [[0.035, 0.0477, 0, 0.035, 0.0557, 0], [0.04, 0.0477, 0, 0.04, 0.0557, 0],
                 [0.045, 0.0477, 0, 0.045, 0.0557, 0], [0.05, 0.0477, 0, 0.05, 0.0557, 0],
                 [0.055, 0.0477, 0, 0.055, 0.0557, 0], [0.06, 0.0477, 0, 0.06, 0.0557, 0],
                 [0.065, 0.0477, 0, 0.065, 0.0557, 0]]})";

TEST(Sew, ASuturedWoundSewnIsOneSurfaceAgain) {
  // Skin without tension, slit, stitched, then sewn: the lips become one surface (the border is
  // the patch's outline alone), no two points left at one rest position, every observer
  // following at every step.
  SceneRunner runner(parseScene(
      wound(kStitches + R"(, {"at": 0.45, "action": "sew", "tolerance": 0.0008, "minAngle": 0})",
            0.55, 1.0),
      "wound.json", test::kSceneDir));
  runner.start();
  Simulation& sim = runner.simulation();
  std::optional<Shape> cut;
  std::size_t lipsBefore = 0;
  while (!runner.finished()) {
    runner.advance();
    ASSERT_TRUE(sim.topology().validate().ok()) << "step " << runner.currentStep();
    if (runner.simulation().time() < 0.44) {
      cut = shapeOf(sim.topology());
      lipsBefore = 0;
      for (topology::EdgeId e : sim.topology().edges())
        lipsBefore += sim.topology().isBoundaryEdge(e) ? 1 : 0;
    }
  }
  ASSERT_TRUE(cut.has_value());
  std::size_t alive = 0;
  for (const auto& st : suturesOf(sim).stitches()) alive += st.alive ? 1 : 0;
  EXPECT_EQ(alive, 7u) << "the stitches' points are off the lips: the sew keeps every thread";
  EXPECT_EQ(borderLoops(sim.topology()), 1u) << "the wound is still open";
  std::size_t border = 0;
  for (topology::EdgeId e : sim.topology().edges()) {
    if (!sim.topology().isBoundaryEdge(e)) continue;
    ++border;
    for (PointId p : sim.topology().edgeVertices(e)) {
      const Vec3 r = sim.topology().restPosition(p);
      EXPECT_TRUE(r[0] < 1e-12 || r[1] < 1e-12 || r[0] > 0.1 - 1e-12 || r[1] > 0.1 - 1e-12)
          << "a lip left open at (" << r[0] << ", " << r[1] << ")";
    }
  }
  EXPECT_EQ(border, 4u * 14u);
  EXPECT_LT(border, lipsBefore);
  const topology::Topology& t = sim.topology();
  EXPECT_EQ(t.numEdges(), t.numPoints() + t.numTriangles() - 1) << "not one disc";
  std::vector<Vec3> unique = cut->points;
  unique.erase(std::unique(unique.begin(), unique.end()), unique.end());
  const Shape now = shapeOf(t);
  std::vector<Vec3> nowUnique = now.points;
  nowUnique.erase(std::unique(nowUnique.begin(), nowUnique.end()), nowUnique.end());
  EXPECT_EQ(nowUnique.size(), now.points.size()) << "two points left at one rest position";
  // Each of the cut's rest positions is still a point's, or lies near the new point at the mean
  // of the lips' points it was joined with (where the stitches' repair moved one lip's).
  for (const Vec3& r : unique) {
    double nearest = 1.0;
    for (const Vec3& q : now.points)
      nearest = std::min(nearest, std::hypot(q[0] - r[0], q[1] - r[1], q[2] - r[2]));
    EXPECT_LT(nearest, 0.001) << "the cut's point at (" << r[0] << ", " << r[1] << ") is lost";
  }
  for (double x : sim.state().x()) ASSERT_TRUE(std::isfinite(x));
}

TEST(Sew, LipsApartAreRefusedSayingHowFarAndBadKeysNamed) {
  // Without stitches the wound gapes by millimetres: a sew with a tolerance of half a millimetre
  // finds no lips within it, says how far apart the closest are, and the run stops there.
  std::string message;
  try {
    SceneRunner runner(
        parseScene(wound(R"({"at": 0.3, "action": "sew", "tolerance": 0.0005})", 0.35),
                   "wound.json", test::kSceneDir));
    runner.start();
    while (!runner.finished()) runner.advance();
  } catch (const std::exception& e) {
    message = e.what();
  }
  EXPECT_THAT(message, HasSubstr("/timeline/1: at t = 0.3"));
  EXPECT_THAT(message, HasSubstr("no lips lie within the tolerance 0.0005 of each other"));
  EXPECT_THAT(message, HasSubstr(" apart"));
  EXPECT_THAT(parseError(wound(R"({"at": 0.3, "action": "sew"})", 0.35)),
              HasSubstr("/timeline/1: missing key \"tolerance\""));
  EXPECT_THAT(parseError(wound(R"({"at": 0.3, "action": "sew", "tolerance": -1})", 0.35)),
              HasSubstr("/timeline/1/tolerance: must be a positive distance"));
  EXPECT_THAT(parseError(wound(
                  R"({"at": 0.3, "action": "sew", "tolerance": 1e-3, "near": [[0, 0, 0]]})", 0.35)),
              HasSubstr("/timeline/1: missing key \"radius\""));
  EXPECT_THAT(
      parseError(wound(R"({"at": 0.3, "action": "sew", "tolerance": 1e-3, "radius": 0.01})", 0.35)),
      HasSubstr("/timeline/1/radius: goes with \"near\""));
}

TEST(Sew, OnlyTheLipsNearItsPath) {
  // Lips that meet at rest (no tension: the cut does not gape), sewn only near x in [0.02, 0.05].
  SceneRunner runner(parseScene(wound(R"({"at": 0.1, "action": "sew", "tolerance": 1e-4,
      "near": [[0.0, 0.0517, 0], [0.05, 0.0517, 0]], "radius": 0.003})",
                                      0.15, 1.0),
                                "wound.json", test::kSceneDir));
  run(runner);
  const topology::Topology& t = runner.simulation().topology();
  EXPECT_EQ(borderLoops(t), 2u) << "the lips beyond the path should stay open";
  for (topology::EdgeId e : t.edges()) {
    if (!t.isBoundaryEdge(e)) continue;
    for (PointId p : t.edgeVertices(e)) {
      const Vec3 r = t.restPosition(p);
      const bool outline = r[0] < 1e-12 || r[1] < 1e-12 || r[0] > 0.1 - 1e-12 || r[1] > 0.1 - 1e-12;
      if (!outline) EXPECT_GT(r[0], 0.045) << "a lip left open near the path";
    }
  }
}

TEST(Suture, ANeedleThatMissesALipOrASceneWithoutThreadsIsRefusedNamingIt) {
  const std::string fields = R"(, {"type": "Sutures", "stiffness": 1})";
  auto runError = [&](const std::string& action) -> std::string {
    try {
      SceneRunner runner(
          parseScene(sheet(action, 0.05, "[0, 0, 0]", fields), "a.json", test::kSceneDir));
      runner.start();
      while (!runner.finished()) runner.advance();
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_THAT(runError(R"({"at": 0.01, "action": "suture",
      "needle": [[0.3, 0.4, 0.05], [0.3, 0.4, -0.05], [0.3, 0.5, -0.05]]})"),
              HasSubstr("pierces the surface once only, at (0.3, 0.4, 0)"));
  EXPECT_THAT(runError(R"({"at": 0.01, "action": "suture",
      "needle": [[0.3, 0.4, 0.05], [0.3, 0.5, 0.05]]})"),
              HasSubstr("the needle misses the surface"));
  EXPECT_THAT(parseError(sheet(R"({"at": 0.01, "action": "suture",
      "needle": [[0.3, 0.4, 0.05], [0.3, 0.4, -0.05]]})")),
              HasSubstr("stitches need a Sutures force field"));
  EXPECT_THAT(parseError(sheet(R"({"at": 0.01, "action": "suture",
      "stitches": [[0.3, 0.4, 0, 0.3, 0.5, 0]]})",
                               0.05, "[0, 0, 0]", fields)),
              HasSubstr("/timeline/0: missing key \"bite\""));
  EXPECT_THAT(parseError(sheet(R"({"at": 0.01, "action": "suture", "bite": 0.01,
      "needle": [[0.3, 0.4, 0.05], [0.3, 0.4, -0.05]]})",
                               0.05, "[0, 0, 0]", fields)),
              HasSubstr("/timeline/0/bite: is for a running suture"));
}

}  // namespace
}  // namespace cutsim::core
