// Instruments that act in world space: the scalpel cuts the surface where it is, not where its rest
// mesh is. On a flat sheet at rest it cuts as the polyline cut along the same path; on a sheet
// rolled onto a cylinder a blade moving along the axis cuts a straight line of the rest sheet; on a
// folded sheet a deep blade cuts both layers and a shallow one the one it reaches; a blade above
// the surface cuts nothing. Every step keeps the topology and every observer valid.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "cutsim/core/scene.hpp"
#include "cutsim/core/simulation.hpp"
#include "support/scene_text.hpp"

namespace cutsim::core {
namespace {

using test::parseError;
using ::testing::HasSubstr;

constexpr double kPi = 3.14159265358979323846;

/// A 1 m sheet of 21 x 21 points that hardly moves in a step (no gravity, soft springs), so that
/// the positions a test gives it are where the blade finds it.
std::string sheet(const std::string& timeline, double duration = 0.01) {
  return R"({
  "mesh": {"grid": {"nx": 21, "ny": 21, "size": [1, 1], "plane": "xy"}},
  "mass": {"total": 0.2},
  "gravity": [0, 0, 0],
  "forceFields": [{"type": "StretchSprings", "stiffness": 1e-9}],
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
  for (const Case k : {Case{-0.01, 0.06, true, true}, Case{-0.01, 0.02, true, false},
                       Case{0.015, 0.03, false, true}}) {
    SceneRunner runner(parseScene(sheet(scalpel({0.23, -0.1, k.tipZ}, {0.23, 1.1, k.tipZ},
                                                {0, 0, 1}, k.depth, 0.01, ", \"minAngle\": 0")),
                                  "a.json", test::kSceneDir));
    run(runner, fold);
    bool bottom = false, top = false;
    for (const Vec3& p : newPoints(runner.simulation())) {
      if (std::abs(p[0] - 0.23) < 1e-9)
        bottom = true;
      else if (std::abs(p[0] - 0.77) < 1e-9)
        top = true;
      else
        ADD_FAILURE() << "a new point off both lines: " << p[0] << ", " << p[1];
    }
    EXPECT_EQ(bottom, k.bottom) << "tip " << k.tipZ << ", depth " << k.depth;
    EXPECT_EQ(top, k.top) << "tip " << k.tipZ << ", depth " << k.depth;
    EXPECT_EQ(runner.cutsDone(), int(k.bottom) + int(k.top));
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

}  // namespace
}  // namespace cutsim::core
