// The tissue beneath a surface in scenes: the Attachment force field and the dissect action, their
// bad input refused before the run with the place, dissection releasing exactly where its path
// passes, and a flap that stays on the tissue until it is undermined.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>
#include <string>

#include "cutsim/core/scene.hpp"
#include "cutsim/core/simulation.hpp"
#include "cutsim/forcefields/attachment.hpp"
#include "support/scene_text.hpp"

namespace cutsim::core {
namespace {

using test::parseError;
using ::testing::HasSubstr;

std::string sheet(const std::string& fields, const std::string& timeline) {
  return R"({
  "mesh": {"grid": {"nx": 11, "ny": 11, "size": [1, 1]}},
  "mass": {"total": 0.1},
  "gravity": [0, 0, -9.81],
  "forceFields": [
    {"type": "StretchSprings", "stiffness": 100},
    )" + fields +
         R"(
  ],
  "integrator": {"type": "implicit-euler", "rayleighMass": 1},
  "linearSolver": {"type": "cholmod"},
  "timeStep": 0.01, "duration": 0.3,
  "timeline": [)" +
         timeline + R"(]
})";
}

const std::string kTissue =
    R"({"type": "Attachment", "label": "tissue", "stiffness": 500, "damping": 1})";

TEST(Tissue, BadInputIsRefusedBeforeTheRunNamingThePlace) {
  EXPECT_THAT(parseError(sheet(R"({"type": "Attachment", "stiffness": -1})", "")),
              HasSubstr("inline.json:7: /forceFields/1/stiffness: "));
  EXPECT_THAT(parseError(sheet(R"({"type": "Attachment", "damping": 1})", "")),
              HasSubstr("/forceFields/1: missing key \"stiffness\""));
  EXPECT_THAT(parseError(sheet(R"({"type": "Attachment", "stiffness": 1, "sphere": )"
                               R"({"center": [0, 0, 0], "radius": 0}})",
                               "")),
              HasSubstr("/forceFields/1/sphere"));
  // A path off the surface releases nothing.
  EXPECT_THAT(
      parseError(sheet(kTissue, R"({"at": 0.1, "action": "dissect",
        "polyline": [[0, 0, 0.5], [1, 1, 0.5]], "width": 0.1})")),
      HasSubstr("/timeline/0/polyline: releases nothing: no point of the surface lies within"));
  EXPECT_THAT(parseError(sheet(kTissue, R"({"at": 0.1, "action": "dissect",
        "box": [[2, 2, -1], [3, 3, 1]]})")),
              HasSubstr("/timeline/0/box: releases nothing"));
  // Nothing to release, or not the field named.
  EXPECT_THAT(
      parseError(sheet(R"({"type": "StretchSprings", "stiffness": 1, "label": "more"})",
                       R"({"at": 0.1, "action": "dissect", "box": [[0, 0, -1], [1, 1, 1]]})")),
      HasSubstr("/timeline/0: the scene has no Attachment force field to release"));
  EXPECT_THAT(parseError(sheet(kTissue, R"({"at": 0.1, "action": "dissect", "field": "fascia",
        "box": [[0, 0, -1], [1, 1, 1]]})")),
              HasSubstr("/timeline/0/field: no Attachment force field is labelled \"fascia\""));
  EXPECT_THAT(parseError(sheet(kTissue, R"({"at": 0.1, "action": "dissect",
        "polyline": [[0, 0, 0], [1, 1, 0]]})")),
              HasSubstr("/timeline/0: missing key \"width\""));
  EXPECT_THAT(parseError(sheet(kTissue, R"({"at": 0.1, "action": "dissect",
        "polyline": [[0, 0, 0], [1, 1, 0]], "width": -0.1})")),
              HasSubstr("/timeline/0/width"));
}

const forcefields::Attachment& attachmentOf(const Simulation& sim) {
  for (std::size_t i = 0; i < sim.model().numForceFields(); ++i) {
    if (const auto* a = dynamic_cast<const forcefields::Attachment*>(&sim.model().forceField(i)))
      return *a;
  }
  throw std::runtime_error("no Attachment");
}

TEST(Tissue, DissectionReleasesExactlyWhereItsPathPasses) {
  const Scene scene = parseScene(sheet(kTissue, R"({"at": 0.1, "action": "dissect",
        "polyline": [[0.2, 0.3, 0], [0.7, 0.6, 0]], "width": 0.25})"),
                                 "inline.json", test::kSceneDir);
  SceneRunner runner(scene);
  runner.start();
  const Simulation& sim = runner.simulation();
  EXPECT_EQ(attachmentOf(sim).numAttached(), sim.topology().numPoints());
  while (!runner.finished()) runner.advance();
  // The distance to the segment, written out here (not the action's own nearPolyline).
  const auto near = [](const Vec3& x) {
    const double ax = 0.2, ay = 0.3, bx = 0.7, by = 0.6;
    const double s = std::clamp(((x[0] - ax) * (bx - ax) + (x[1] - ay) * (by - ay)) /
                                    ((bx - ax) * (bx - ax) + (by - ay) * (by - ay)),
                                0.0, 1.0);
    return std::hypot(x[0] - (ax + s * (bx - ax)), x[1] - (ay + s * (by - ay))) <= 0.125;
  };
  std::size_t released = 0;
  for (PointId p : sim.topology().points()) {
    const bool nearPath = near(sim.topology().restPosition(p));
    released += nearPath ? 1 : 0;
    EXPECT_EQ(attachmentOf(sim).attached(p), nearPath ? 0.0 : 1.0) << "point " << p.idx();
  }
  EXPECT_GT(released, 3u);
  // New parameters between steps (Python's set_parameters) keep the dissection.
  runner.replaceForceField(
      1, parseForceFieldEntry(R"({"type": "Attachment", "label": "tissue", "stiffness": 800})",
                              "<set_parameters>"));
  EXPECT_EQ(attachmentOf(sim).parameters().stiffness, 800.0);
  for (PointId p : sim.topology().points())
    EXPECT_EQ(attachmentOf(sim).attached(p), near(sim.topology().restPosition(p)) ? 0.0 : 1.0);
}

TEST(Tissue, ADissectionGivenWhileRunningThatReleasesNothingFails) {
  const Scene scene = parseScene(sheet(kTissue, ""), "inline.json", test::kSceneDir);
  SceneRunner runner(scene);
  runner.start();
  runner.advance();
  try {  // due now: it starts at once
    runner.schedule(parseActionEntry(
        R"({"at": 0.01, "action": "dissect", "polyline": [[0, 0, 0.5], [1, 1, 0.5]], "width": 0.1})",
        "<act>", runner.simulation().time()));
    runner.advance();
    ADD_FAILURE() << "a dissection off the surface was carried out";
  } catch (const InvalidInput& e) {
    EXPECT_THAT(e.what(), HasSubstr("the dissection releases nothing"));
  }
}

/// The grasp force that lifts the tip of a flap cut free on three sides by 5 cm, with the flap
/// undermined first or not.
double liftForce(bool undermined) {
  const std::string dissect =
      undermined
          ? R"({"at": 0.01, "action": "dissect", "box": [[0.28, 0.28, -1], [0.72, 0.72, 1]]},)"
          : "";
  const Scene scene = parseScene(sheet(R"({"type": "Attachment", "stiffness": 5000, "damping": 1})",
                                       R"({"at": 0, "action": "cut",
          "polyline": [[0.3, 0.7, 0], [0.3, 0.3, 0], [0.7, 0.3, 0], [0.7, 0.7, 0]]},
        )" + dissect + R"({"at": 0.02, "action": "grasp", "name": "forceps",
          "box": [[0.45, 0.29, -1], [0.55, 0.41, 1]], "seed": [0.5, 0.4, 0], "path": [[0, 0, 0, 0], [0.25, 0, 0, 0.05]]})"),
                                 "inline.json", test::kSceneDir);
  SceneRunner runner(scene);
  runner.start();
  while (!runner.finished()) runner.advance();
  const Simulation& sim = runner.simulation();
  for (std::size_t i = 0; i < sim.model().numGrasps(); ++i) {
    if (sim.model().grasp(i).name() != "forceps") continue;
    const Vec3& f = sim.model().grasp(i).reaction();
    return std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
  }
  throw std::runtime_error("no forceps");
}

TEST(Tissue, AFlapStaysOnTheTissueUntilItIsUndermined) {
  const double held = liftForce(false), free = liftForce(true);
  EXPECT_GT(held, 4.0 * free) << "held " << held << " N, undermined " << free << " N";
}

}  // namespace
}  // namespace cutsim::core

namespace cutsim::core {
namespace {

/// The rest positions of the points a grasp took, after a cut across its box at y = 0.45.
std::vector<Vec3> graspedAcrossACut(const std::string& piece) {
  const Scene scene = parseScene(
      sheet(kTissue, R"({"at": 0, "action": "cut", "polyline": [[0, 0.45, 0], [1, 0.45, 0]]},
        {"at": 0, "action": "grasp", "name": "forceps", "box": [[0.35, 0.35, -1], [0.65, 0.65, 1]])" +
                         piece + R"(, "path": [[0, 0, 0, 0], [0.2, 0, 0, 0.05]]})"),
      "inline.json", test::kSceneDir);
  SceneRunner runner(scene);
  runner.start();
  runner.advance();
  const Simulation& sim = runner.simulation();
  std::vector<Vec3> out;
  for (PointId p : sim.model().grasp(0).points().points())
    out.push_back(sim.topology().restPosition(p));
  return out;
}

TEST(GraspPiece, ABoxStraddlingACutTakesTheSideOfItsSeed) {
  // Default: the piece of the box's centre (above the cut); the cut's lip points appear once.
  const std::vector<Vec3> one = graspedAcrossACut("");
  ASSERT_FALSE(one.empty());
  std::size_t onLip = 0;
  for (const Vec3& x : one) {
    EXPECT_GE(x[1], 0.45 - 1e-12) << "a point below the cut was taken";
    onLip += std::fabs(x[1] - 0.45) < 1e-12 ? 1 : 0;
  }
  std::set<double> lipXs;
  for (const Vec3& x : one)
    if (std::fabs(x[1] - 0.45) < 1e-12) lipXs.insert(x[0]);
  EXPECT_EQ(onLip, lipXs.size()) << "both copies of a lip point were taken";
  EXPECT_GT(onLip, 0u);
  // A seed below the cut takes the other side; "all" takes both.
  for (const Vec3& x : graspedAcrossACut(R"(, "seed": [0.5, 0.36, 0])"))
    EXPECT_LE(x[1], 0.45 + 1e-12) << "a point above the cut was taken";
  const std::vector<Vec3> all = graspedAcrossACut(R"(, "piece": "all")");
  EXPECT_GT(all.size(), one.size());
  EXPECT_TRUE(std::any_of(all.begin(), all.end(), [](const Vec3& x) { return x[1] < 0.44; }));
}

TEST(GraspPiece, PieceAndSeedAreForABox) {
  EXPECT_THAT(parseError(sheet(kTissue, R"({"at": 0, "action": "grasp", "name": "g",
        "points": [3], "piece": "all", "path": [[0, 0, 0, 0]]})")),
              HasSubstr("/timeline/0/piece: is for a box"));
  EXPECT_THAT(parseError(sheet(kTissue, R"({"at": 0, "action": "grasp", "name": "g",
        "box": [[0, 0, -1], [1, 1, 1]], "piece": "half", "path": [[0, 0, 0, 0]]})")),
              HasSubstr("/timeline/0/piece"));
}

}  // namespace
}  // namespace cutsim::core

namespace cutsim::core {
namespace {

TEST(GraspPiece, ASphereInWorldCoordinatesTakesWhatItMeetsNow) {
  // A corner of the sheet is lifted 0.2 above its rest plane (a grasp, released just before);
  // the sphere is centred where the corner IS, not where it rests.
  const Scene scene = parseScene(sheet(kTissue, R"({"at": 0, "action": "grasp", "name": "lift",
          "box": [[0.75, 0.75, -1], [1, 1, 1]], "piece": "all", "path": [[0, 0, 0, 0], [0.1, 0, 0, 0.2]]},
        {"at": 0.14, "action": "release", "name": "lift"},
        {"at": 0.15, "action": "grasp", "name": "forceps",
          "sphere": {"center": [0.95, 0.95, 0.2], "radius": 0.12}, "path": [[0, 0, 0, 0]]})"),
                                 "inline.json", test::kSceneDir);
  EXPECT_THAT(
      parseError(sheet(kTissue,
                       R"({"at": 0, "action": "grasp", "name": "g", "box": [[0, 0, -1], [1, 1, 1]],
        "sphere": {"center": [0, 0, 0], "radius": 0.1}, "path": [[0, 0, 0, 0]]})")),
      HasSubstr("/timeline/0/box: give a sphere or a selection, not both"));
  SceneRunner runner(scene);
  runner.start();
  while (runner.simulation().time() < 0.16) runner.advance();
  const Simulation& sim = runner.simulation();
  ASSERT_EQ(sim.model().numGrasps(), 1u);
  const auto taken = sim.model().grasp(0).points().points();
  ASSERT_FALSE(taken.empty());
  for (PointId p : taken) {
    double d2 = 0.0;
    const Vec3 c = {0.95, 0.95, 0.2};
    for (int k = 0; k < 3; ++k) d2 += std::pow(sim.state().x()[3 * p.idx() + k] - c[k], 2);
    // Grasped when the sphere met it (it has not moved since: the grasp holds it).
    EXPECT_LE(std::sqrt(d2), 0.12 + 1e-9) << "point " << p.idx();
  }
  // Nothing of the surface was within the sphere at rest: a rest-space choice would take nothing.
  for (PointId p : sim.topology().points()) {
    const Vec3 r = sim.topology().restPosition(p);
    EXPECT_GT(std::hypot(r[0] - 0.95, r[1] - 0.95, r[2] - 0.2), 0.12);
  }
}

}  // namespace
}  // namespace cutsim::core
