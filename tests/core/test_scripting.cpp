// What scripts (the Python module) use of the core: actions, constraints and force-field
// parameters given while a scene runs, steps past the duration, a changing time step, grasps moved
// by a displacement, and state buffers that outlive a topology change.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/scene.hpp"
#include "support/scene_text.hpp"

namespace cutsim::test {
namespace {

using core::SceneRunner;

std::string cloth(const std::string& extra = "") {
  return scene(
      "\"gravity\": [0, 0, -9.81],\n"
      "  \"forceFields\": [{\"type\": \"StretchSprings\", \"stiffness\": 100},\n"
      "                  {\"type\": \"FastTriangularBendingSprings\", \"bendingStiffness\": "
      "0.01}],\n"
      "  \"constraints\": [{\"type\": \"fixed\", \"near\": [[0, 1, 0], [1, 1, 0]]}]" +
      (extra.empty() ? "" : ",\n  " + extra));
}

std::string actionError(SceneRunner& r, const std::string& text) {
  try {
    r.schedule(core::parseActionEntry(text, "<action>", r.time()));
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Scripting, SlotBuffersOutliveTheirTable) {
  const core::Scene s = core::parseScene(cloth(), "inline.json", kSceneDir);
  SceneRunner r(s);
  r.start();
  auto& state = r.simulation().state();
  std::shared_ptr<const void> held = state.xBuffer();
  const double* old = state.x().data();
  const std::vector<double> before(state.x().begin(), state.x().end());
  // Cut until the positions move to a new buffer (never a reallocation in place).
  int k = 0;
  while (state.x().data() == old) {
    ASSERT_LT(++k, 40);
    const double y = 0.05 + 0.02 * k;
    r.simulation().topology().cutPolyline(std::vector<core::Vec3>{{0, y, 0}, {0.6, y + 0.01, 0}});
  }
  const std::vector<double> left(old, old + before.size());
  for (int i = 0; i < 5; ++i) r.stepOnce();  // writes go to the new buffer only
  EXPECT_EQ(std::vector<double>(old, old + before.size()), left);
  EXPECT_NE(state.xBuffer(), held);
  EXPECT_TRUE(r.simulation().topology().validate().ok());
}

TEST(Scripting, ActionsGivenWhileRunning) {
  const core::Scene s = core::parseScene(cloth(), "inline.json", kSceneDir);
  SceneRunner r(s);
  for (int i = 0; i < 3; ++i) r.advance();
  EXPECT_NE(actionError(
                r, "{\"action\": \"cut\", \"at\": 0.0, \"polyline\": [[0, 0.5, 0], [0.5, 0.5, 0]]}")
                .find("<action>:1: /at: time 0 is before the current time 0.03"),
            std::string::npos);
  EXPECT_NE(actionError(r, "{\"action\": \"tearing\",\n \"at\": 1,\n \"threshold\": -2}")
                .find("<action>:3: /threshold:"),
            std::string::npos);
  // Due now: it runs at once; later: when its time comes (past the scene's duration too).
  const auto points = r.simulation().topology().numPoints();
  EXPECT_EQ(
      actionError(
          r, "{\"action\": \"cut\", \"at\": 0.03, \"polyline\": [[0, 0.5, 0], [0.5, 0.5, 0]]}"),
      "");
  EXPECT_GT(r.simulation().topology().numPoints(), points);
  EXPECT_EQ(actionError(
                r,
                "{\"action\": \"remove\", \"at\": 0.15, \"sphere\": {\"center\": [0.75, 0.25, 0], "
                "\"radius\": 0.2}, \"boundary\": \"centroid\"}"),
            "");
  const auto triangles = r.simulation().topology().numTriangles();
  while (!r.finished()) r.advance();
  EXPECT_EQ(r.simulation().topology().numTriangles(), triangles);
  for (int i = 0; i < 6; ++i) r.stepOnce();
  EXPECT_LT(r.simulation().topology().numTriangles(), triangles);
  EXPECT_NEAR(r.time(), 0.16, 1e-12);
  // A failing action names its own source, and does not stay in the timeline.
  EXPECT_NE(
      actionError(r, "{\"action\": \"cut\", \"polyline\": [[5, 5, 0], [6, 5, 0]], \"at\": 0.16}")
          .find("<action>:1: /: at t = 0.16 the cut failed"),
      std::string::npos);
  r.stepOnce();
  EXPECT_TRUE(r.simulation().topology().validate().ok());
}

TEST(Scripting, ActionsGivenOutOfOrderKeepTheirOwnSpecs) {
  const core::Scene s = core::parseScene(cloth(), "inline.json", kSceneDir);
  SceneRunner r(s);
  r.start();
  // A progressive cut that runs off the surface, then actions inserted before and after it in
  // time: when the cut fails, its failure names the cut, not another action.
  r.schedule(
      core::parseActionEntry("{\"action\": \"cut\", \"from\": 0, \"to\": 0.05, \"polyline\": "
                             "[[0.3, 0.5, 0], [0.5, 0.5, 0], [3, 0.5, 0]]}",
                             "<the cut>", 0.0));
  for (const char* at : {"0.2", "0.21", "0.22", "0.1", "0.15"})
    r.schedule(core::parseActionEntry(
        std::string("{\"action\": \"tearing\", \"threshold\": 10, \"at\": ") + at + "}",
        std::string("<tearing at ") + at + ">", 0.0));
  std::vector<std::string> failures;
  for (int i = 0; i < 25; ++i) {
    try {
      r.stepOnce();
    } catch (const Error& e) {
      failures.push_back(e.what());
    }
  }
  ASSERT_EQ(failures.size(), 1u);  // once: the failed action leaves the timeline
  EXPECT_EQ(failures[0].rfind("<the cut>:1: /: at t = ", 0), 0u) << failures[0];
  EXPECT_EQ(r.currentStep(), 25);  // every step was taken
  EXPECT_TRUE(r.simulation().topology().validate().ok());
}

TEST(Scripting, TimeStepChanges) {
  const core::Scene s = core::parseScene(cloth(), "inline.json", kSceneDir);
  SceneRunner r(s);
  for (int i = 0; i < 4; ++i) r.advance();
  r.setTimeStep(0.0025);
  for (int i = 0; i < 4; ++i) r.advance();
  EXPECT_NEAR(r.time(), 0.05, 1e-15);
  EXPECT_NEAR(r.simulation().time(), 0.05, 1e-12);
  EXPECT_EQ(r.numSteps(), 8 + 20);  // the rest of the duration (0.1) in steps of 0.0025
  while (!r.finished()) r.advance();
  EXPECT_NEAR(r.time(), 0.1, 1e-12);
  EXPECT_THROW(r.setTimeStep(0.0), InvalidInput);
  EXPECT_THROW(r.setTimeStep(std::nan("")), InvalidInput);
}

TEST(Scripting, ForceFieldParametersChange) {
  const core::Scene s = core::parseScene(cloth(), "inline.json", kSceneDir);
  SceneRunner r(s);
  for (int i = 0; i < 5; ++i) r.advance();
  auto& sim = r.simulation();
  const double e = sim.potentialEnergy(1);
  ASSERT_GT(e, 0);
  r.replaceForceField(
      1, core::parseForceFieldEntry(
             "{\"type\": \"FastTriangularBendingSprings\", \"bendingStiffness\": 0.03}", "<f>"));
  EXPECT_NEAR(sim.potentialEnergy(1), 3 * e, 1e-12 * e);
  EXPECT_EQ(sim.forceFieldLabel(1), "FastTriangularBendingSprings");
  // Another type is refused, and changes nothing.
  EXPECT_THROW(
      r.replaceForceField(
          1, core::parseForceFieldEntry("{\"type\": \"StretchSprings\", \"stiffness\": 1}", "<f>")),
      InvalidInput);
  EXPECT_NEAR(sim.potentialEnergy(1), 3 * e, 1e-12 * e);
  // The new field follows the topology: cut, then every observer agrees with its rebuild.
  sim.topology().cutPolyline(std::vector<core::Vec3>{{0, 0.5, 0}, {0.6, 0.5, 0}});
  EXPECT_TRUE(sim.topology().validate().ok()) << sim.topology().validate().summary();
  r.advance();
}

TEST(Scripting, GraspMovedByADisplacement) {
  const core::Scene s = core::parseScene(cloth(), "inline.json", kSceneDir);
  SceneRunner r(s);
  r.start();
  r.schedule(
      core::parseActionEntry("{\"action\": \"grasp\", \"at\": 0, \"name\": \"g\", \"near\": [[0.5, "
                             "0, 0]], \"path\": [[0, 0, 0, 0], [0.02, 0, 0, 0.01]]}",
                             "<a>", 0.0));
  core::Grasp* g = r.simulation().findGrasp("g");
  ASSERT_NE(g, nullptr);
  const auto p = g->points().points().front();
  for (int i = 0; i < 2; ++i) r.advance();  // t = 0.02: the path's end
  EXPECT_NEAR(r.simulation().state().x()[3 * p.idx() + 2], 0.01, 1e-12);
  g->moveBy(r.time(), {0.1, 0, 0}, 0.04);  // 0.1 along x over 0.04 s
  for (int i = 0; i < 2; ++i) r.advance();
  EXPECT_NEAR(r.simulation().state().x()[3 * p.idx()], 0.5 + 0.05, 1e-12);
  for (int i = 0; i < 4; ++i) r.advance();
  EXPECT_NEAR(r.simulation().state().x()[3 * p.idx()], 0.5 + 0.1, 1e-12);
  EXPECT_NEAR(r.simulation().state().x()[3 * p.idx() + 2], 0.01, 1e-12);
  EXPECT_THROW(g->moveBy(r.time(), {std::nan(""), 0, 0}, 0.1), InvalidInput);
  EXPECT_THROW(g->moveBy(r.time(), {0, 0, 0}, -1), InvalidInput);
}

TEST(Scripting, ConstraintsGivenWhileRunning) {
  const core::Scene s =
      core::parseScene(scene("\"gravity\": [0, 0, -9.81]"), "inline.json", kSceneDir);
  SceneRunner r(s);
  r.applyConstraint(
      core::parseConstraintEntry("{\"type\": \"fixed\", \"near\": [[0, 0, 0]]}", "<c>"));
  ASSERT_EQ(r.simulation().fixed().size(), 1u);
  const auto p = r.simulation().fixed().points().front();
  r.advance();
  EXPECT_EQ(r.simulation().state().x()[3 * p.idx() + 2], 0.0);
  r.simulation().fixed().remove(p);
  EXPECT_EQ(r.simulation().fixed().size(), 0u);
  r.advance();
  EXPECT_LT(r.simulation().state().x()[3 * p.idx() + 2], 0.0);
  try {
    core::parseConstraintEntry("{\"type\": \"fixed\",\n \"box\": 3}", "<c>");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("<c>:2: /box:"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cutsim::test

namespace cutsim::test {
namespace {

TEST(Robustness, LabelsAndGraspNamesNameCsvColumns) {
  auto error = [](const std::string& extra) { return parseError(scene(extra)); };
  EXPECT_NE(
      error(
          "\"forceFields\": [{\"type\": \"StretchSprings\", \"stiffness\": 1, \"label\": \"a,b\"}]")
          .find("/forceFields/0/label: must not contain a comma"),
      std::string::npos);
  EXPECT_NE(
      error(
          "\"forceFields\": [{\"type\": \"StretchSprings\", \"stiffness\": 1, \"label\": \"x\"},\n"
          "  {\"type\": \"FastTriangularBendingSprings\", \"label\": \"x\"}]")
          .find("/forceFields/1/label: another force field has the label \"x\""),
      std::string::npos);
  EXPECT_NE(
      error(
          "\"timeline\": [{\"at\": 0, \"action\": \"grasp\", \"name\": \"a\\nb\", \"points\": [0], "
          "\"path\": [[0, 0, 0, 0]]}]")
          .find("/timeline/0/name: must not contain a comma"),
      std::string::npos);
  // Unlabelled fields of one type are numbered, as before.
  const core::Scene s =
      core::parseScene(scene("\"forceFields\": [{\"type\": \"StretchSprings\", \"stiffness\": 1},\n"
                             "  {\"type\": \"StretchSprings\", \"stiffness\": 2}]"),
                       "inline.json", kSceneDir);
  EXPECT_EQ(s.forceFieldLabels(), (std::vector<std::string>{"StretchSprings", "StretchSprings_2"}));
}

TEST(Robustness, AProgressiveCutIsCheckedPieceByPieceAmongTheOtherActions) {
  // A scalpel along y = 0.52 over 0.1 s, and at t = 0.03 a removal of a disc on its path ahead:
  // made whole at once (the per-action check), the cut passes; piece by piece, as the run makes
  // it, it reaches the hole and leaves the surface. The scene check plays the timeline and fails
  // there, naming the cut and the time, before anything runs.
  const std::string text =
      "{\"mesh\": {\"grid\": {\"nx\": 21, \"ny\": 21}}, \"mass\": {\"total\": 0.2}, \"timeStep\": "
      "0.01,\n"
      " \"duration\": 0.2, \"timeline\": [\n"
      "  {\"from\": 0, \"to\": 0.1, \"action\": \"cut\", \"polyline\": [[0, 0.52, 0], [0.9, 0.52, "
      "0]]},\n"
      "  {\"at\": 0.03, \"action\": \"remove\", \"sphere\": {\"center\": [0.55, 0.52, 0], "
      "\"radius\": 0.12}}]}";
  const std::string message = parseError(text);
  EXPECT_NE(message.find("inline.json:3: /timeline/0: at t = 0.1 the cut failed"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("the timeline played before the run"), std::string::npos) << message;
  // The removal after the cut's end: both pass.
  const std::string later =
      "{\"mesh\": {\"grid\": {\"nx\": 21, \"ny\": 21}}, \"mass\": {\"total\": 0.2}, \"timeStep\": "
      "0.01,\n"
      " \"duration\": 0.2, \"timeline\": [\n"
      "  {\"from\": 0, \"to\": 0.1, \"action\": \"cut\", \"polyline\": [[0, 0.52, 0], [0.9, 0.52, "
      "0]]},\n"
      "  {\"at\": 0.15, \"action\": \"remove\", \"sphere\": {\"center\": [0.55, 0.52, 0], "
      "\"radius\": 0.12}}]}";
  EXPECT_EQ(parseError(later), "");
  // And the run then makes what the rehearsal made.
  const core::Scene s = core::parseScene(later, "inline.json", kSceneDir);
  core::SceneRunner r(s);
  r.start();
  while (!r.finished()) r.advance();
  EXPECT_GE(r.cutsDone(), 2);
}

// A cut along the border opens nothing: it is refused at the check, naming it (it used to run
// uncounted, without a word); the cut that opens something is counted.
TEST(Robustness, ACutAlongTheBorderIsRefusedAndACutThatOpensIsCounted) {
  EXPECT_THAT(
      parseError(scene(
          "\"timeline\": [{\"at\": 0.01, \"action\": \"cut\", \"polyline\": [[0, 0, 0], [1, 0, "
          "0]]},\n"
          "  {\"at\": 0.02, \"action\": \"cut\", \"polyline\": [[0, 0.5, 0], [0.6, 0.5, 0]]}]")),
      ::testing::HasSubstr("/timeline/0/polyline: the cut opens nothing"));
  const core::Scene s = core::parseScene(
      scene("\"timeline\": [{\"at\": 0.02, \"action\": \"cut\", \"polyline\": [[0, 0.5, 0], "
            "[0.6, 0.5, 0]]}]"),
      "inline.json", kSceneDir);
  core::SceneRunner r(s);
  r.advance();  // t = 0.01
  EXPECT_EQ(r.cutsDone(), 0);
  r.advance();  // t = 0.02
  EXPECT_EQ(r.cutsDone(), 1);
}

}  // namespace
}  // namespace cutsim::test

namespace cutsim::test {
namespace {

TEST(Robustness, SceneValuesThatWouldFailWhileRunningFailFirst) {
  auto error = [](const std::string& text) { return parseError(text); };
  const std::string tail = "\"mass\": {\"total\": 1}, \"timeStep\": 0.01, \"duration\": 0.1}";
  EXPECT_NE(
      error("{\"mesh\": {\"grid\": {\"nx\": 3, \"ny\": 3, \"size\": [1e200, 1e200]}}, " + tail)
          .find("/mesh/grid/size/0: must be at most 1e100"),
      std::string::npos);
  EXPECT_NE(
      error("{\"mesh\": {\"grid\": {\"nx\": 3, \"ny\": 3, \"origin\": [0, 1e308, 0]}}, " + tail)
          .find("/mesh/grid/origin/1: must be at most 1e100"),
      std::string::npos);
  EXPECT_NE(error("{\"name\": \"a\\nb\", \"mesh\": {\"grid\": {\"nx\": 3, \"ny\": 3}}, " + tail)
                .find("/name: must not contain control characters"),
            std::string::npos);
  EXPECT_NE(error("{\"name\": \"" + std::string(300, 'n') +
                  "\", \"mesh\": {\"grid\": {\"nx\": 3, \"ny\": 3}}, " + tail)
                .find("/name: must be at most 200 bytes"),
            std::string::npos);
  // A mesh without area can carry no mass.
  const auto dir =
      std::filesystem::temp_directory_path() / ("cutsim_flat_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "flat.obj") << "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n";
  try {
    core::parseScene(
        "{\"mesh\": \"flat.obj\", \"mass\": {\"density\": 1}, \"timeStep\": 0.1, \"duration\": 1}",
        "flat.json", dir);
    ADD_FAILURE() << "a mesh without area was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("/mass/density: the mesh has no area"), std::string::npos)
        << e.what();
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cutsim::test
