// Checkpoints of a whole run (SceneRunner::save and its restoring constructor): a runner restored
// at a random step goes on bit for bit as the runner that wrote it, whatever the integrator and
// linear solver, through every kind of action; what does not fit is refused.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <string>
#include <vector>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/core/scene.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/scene_text.hpp"

namespace cutsim::core {
namespace {

std::string readFile(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

/// small.json (every kind of action: cuts at a time and progressive, removals, a grasp and its
/// release, tearing) with its "solver" entry replaced by `solver`.
std::string smallScene(const std::string& solver, const std::string& timeStep = "0.01") {
  const std::string text = readFile(test::kSceneDir / "small.json");
  return std::regex_replace(std::regex_replace(text, std::regex("\"solver\": \\{[^}]*\\}"), solver),
                            std::regex("\"timeStep\": 0.01"), "\"timeStep\": " + timeStep);
}

struct Snapshot {
  std::vector<double> x, v;
  std::uint64_t digest;
  long cuts, torn;
  bool operator==(const Snapshot&) const = default;
};
Snapshot snapshot(const SceneRunner& r) {
  const Simulation& s = r.simulation();
  return {std::vector<double>(s.state().x().begin(), s.state().x().end()),
          std::vector<double>(s.state().v().begin(), s.state().v().end()), s.topology().digest(),
          r.cutsDone(), r.tornEdges()};
}

/// Steps a runner of `scene` to `stop`, saves it to `file`, restores it and steps both to the end:
/// at the checkpoint and after every step, the two must be the same to the bit.
void resumeAndCompare(const Scene& scene, long stop, const std::filesystem::path& file) {
  SceneRunner a(scene);
  a.start();
  while (a.currentStep() < stop) a.advance();
  {
    ArchiveWriter w;
    a.save(w);
    w.save(file);
  }
  ArchiveReader in(file);
  SceneRunner b(scene, in);
  ASSERT_EQ(b.currentStep(), stop);
  ASSERT_EQ(b.time(), a.time());
  ASSERT_TRUE(snapshot(a) == snapshot(b)) << "at the checkpoint, step " << stop;
  while (!a.finished()) {
    a.advance();
    b.advance();
    ASSERT_TRUE(snapshot(a) == snapshot(b))
        << "restored at step " << stop << ", differs at step " << a.currentStep();
  }
  EXPECT_TRUE(b.finished());
  EXPECT_EQ(a.simulation().solveSummary().flaggedSteps, b.simulation().solveSummary().flaggedSteps);
  EXPECT_TRUE(b.simulation().topology().validate().ok());
}

class CheckpointRun : public ::testing::TestWithParam<std::pair<const char*, const char*>> {};

TEST_P(CheckpointRun, ARestoredRunnerGoesOnBitForBitAsTheOneThatWroteIt) {
  const std::string text = smallScene(GetParam().second, "0.01");
  const Scene scene = parseScene(text, "small.json", test::kSceneDir);
  const std::filesystem::path file = std::filesystem::path(::testing::TempDir()) /
                                     (std::string("cutsim_ck_") + GetParam().first + ".ckpt");
  std::mt19937 rng(std::hash<std::string>{}(GetParam().first));
  const long steps = scene.numSteps();
  // At steps whose actions changed the mesh after the step (a cut, a removal, a piece of the
  // progressive cut: tables saved before they catch up), and at random ones.
  if (std::string(GetParam().first).rfind("Fallback", 0) == 0) {
    // The cases made to fall back must: else they would not save a fallback at all.
    SceneRunner probe(scene);
    probe.start();
    probe.advance();
    ASSERT_GT(probe.simulation().solveSummary().fellBack, 0);
  }
  for (long stop : {5L, 10L, 12L, 16L}) resumeAndCompare(scene, stop, file);
  for (int trial = 0; trial < 2; ++trial)
    resumeAndCompare(scene, std::uniform_int_distribution<long>(0, steps - 1)(rng), file);
  std::filesystem::remove(file);
}

INSTANTIATE_TEST_SUITE_P(
    Integrators, CheckpointRun,
    ::testing::Values(
        std::pair{
            "ImplicitCG",
            "\"solver\": {\"type\": \"implicit-cg\", \"iterations\": 200, \"tolerance\": 1e-10, "
            "\"rayleighMass\": 0.5}"},
        std::pair{"ImplicitCholmod",
                  "\"integrator\": {\"type\": \"implicit-euler\", \"rayleighMass\": 0.5}, "
                  "\"linearSolver\": {\"type\": \"cholmod\"}"},
        std::pair{"BDF2",
                  "\"integrator\": {\"type\": \"bdf2\"}, \"linearSolver\": {\"type\": \"cg\", "
                  "\"iterations\": 200, \"tolerance\": 1e-10}"},
        std::pair{
            "Newton",
            "\"integrator\": {\"type\": \"newton\"}, \"linearSolver\": {\"type\": \"cholmod\"}"},
        std::pair{"Explicit", "\"integrator\": {\"type\": \"explicit-euler\"}"},
        // A CG capped at 2 iterations falls back at every step: CHOLMOD (the default, saved as
        // before the fallback was named) and a named CG, whose warm start is saved with its name.
        std::pair{"FallbackCholmod",
                  "\"integrator\": {\"type\": \"implicit-euler\", \"rayleighMass\": 0.5}, "
                  "\"linearSolver\": {\"type\": \"cg\", \"iterations\": 2}"},
        std::pair{
            "FallbackCG",
            "\"integrator\": {\"type\": \"implicit-euler\", \"rayleighMass\": 0.5, "
            "\"fallbackSolver\": \"cg\"}, \"linearSolver\": {\"type\": \"cg\", \"iterations\": 2}"},
        std::pair{
            "Contact",
            "\"solver\": {\"type\": \"implicit-cg\", \"iterations\": 200, \"tolerance\": 1e-10}, "
            "\"contact\": {\"thickness\": 0.005, \"stiffness\": 0.5, \"friction\": 0.2}"},
        std::pair{"SofaEuler",
                  "\"integrator\": {\"type\": \"sofa-euler\", \"rayleighMass\": 0.5}, "
                  "\"linearSolver\": {\"type\": \"sofa-cg\", \"iterations\": 200}"}),
    [](const auto& info) { return std::string(info.param.first); });

TEST(Checkpoint, FEMDihedralAndFractureGoOnBitForBit) {
  // The surgery and tearing fields (TriangularFEM with a prestrain, its SOFA twin, dihedral and
  // SOFA's bending springs) and a crack that advances from a notch under a grasp.
  const std::string text = R"({
    "mesh": {"grid": {"nx": 13, "ny": 13, "size": [1, 1]}},
    "mass": {"density": 1},
    "forceFields": [
      {"type": "TriangularFEM", "youngModulus": 2000, "poissonRatio": 0.3, "restScale": 0.99},
      {"type": "TriangularFEMForceFieldOptim", "youngModulus": 500, "poissonRatio": 0.3},
      {"type": "DihedralBending", "bendingStiffness": 0.001},
      {"type": "TriangularBendingSprings", "stiffness": 1, "damping": 0}
    ],
    "constraints": [{"type": "fixed", "box": [[-1, -1, -1], [2, 0.01, 1]]}],
    "integrator": {"type": "implicit-euler"}, "linearSolver": {"type": "cholmod"},
    "timeStep": 0.005, "duration": 0.4,
    "timeline": [
      {"at": 0, "action": "cut", "polyline": [[0, 0.5, 0], [0.3, 0.5, 0]]},
      {"at": 0, "action": "grasp", "name": "top", "box": [[-1, 0.99, -1], [2, 2, 1]],
       "path": [[0, 0, 0, 0], [0.4, 0, 0.3, 0]]},
      {"at": 0, "action": "fracture", "criticalStrain": 0.02, "length": 0.15, "speed": 2}
    ]})";
  const Scene scene = parseScene(text, "inline.json", test::kSceneDir);
  const std::filesystem::path file =
      std::filesystem::path(::testing::TempDir()) / "cutsim_ck_fem.ckpt";
  for (long stop : {1L, 37L, 55L}) resumeAndCompare(scene, stop, file);
  SceneRunner probe(scene);
  probe.start();
  while (!probe.finished()) probe.advance();
  EXPECT_GT(probe.tornEdges() + probe.cutsDone(), 1) << "the crack should advance in this scene";
  std::filesystem::remove(file);
}

TEST(Checkpoint, ContactGoesOnBitForBitThroughACutAndAMovingObstacle) {
  // A cloth falls on a ball and a table, a box sweeps into it and a cut opens two lips at
  // distance zero (excluded pairs, released later): the pair cache, the hierarchy and the
  // exclusions all carry over.
  const std::string text = R"({
    "mesh": {"grid": {"nx": 13, "ny": 13, "size": [0.4, 0.4], "origin": [-0.2, -0.2, 0.12]}},
    "mass": {"total": 0.02},
    "gravity": [0, 0, -9.81],
    "forceFields": [
      {"type": "StretchSprings", "stiffness": 300, "damping": 0.1},
      {"type": "FastTriangularBendingSprings", "bendingStiffness": 0.0005}
    ],
    "contact": {"thickness": 0.008, "stiffness": 0.5, "friction": 0.2},
    "obstacles": [
      {"type": "sphere", "name": "ball", "center": [0, 0, 0.05], "radius": 0.05, "friction": 0.5},
      {"type": "plane", "name": "table", "point": [0, 0, 0], "normal": [0, 0, 1], "friction": 0.3},
      {"type": "box", "name": "pusher", "center": [0.3, 0, 0.03], "size": [0.04, 0.2, 0.06],
       "path": [[0, 0, 0, 0], [0.5, -0.2, 0, 0]]}
    ],
    "integrator": {"type": "implicit-euler", "rayleighMass": 0.5},
    "linearSolver": {"type": "cg", "iterations": 300, "tolerance": 1e-6},
    "timeStep": 0.004, "duration": 0.5,
    "timeline": [{"at": 0.2, "action": "cut", "polyline": [[-0.2, 0.05, 0.12], [0.2, 0.05, 0.12]]}]
  })";
  const Scene scene = parseScene(text, "inline.json", test::kSceneDir);
  const std::filesystem::path file =
      std::filesystem::path(::testing::TempDir()) / "cutsim_ck_contact.ckpt";
  for (long stop : {3L, 50L, 51L, 52L, 90L}) resumeAndCompare(scene, stop, file);
  std::filesystem::remove(file);
}

TEST(Checkpoint, TheDrapeDemoGoesOnBitForBitFromTheStepOfItsCut) {
  // The drape demo with its cut at t = 0.1: a checkpoint written right after the cut holds the
  // contact's tables and hierarchy of the mesh before it, which the next step replaces. (A
  // restored contact that took its tables as current kept a stale hierarchy: other pairs' order,
  // other rounding.)
  std::string text = readFile(std::filesystem::path(CUTSIM_DATA_DIR) / "scenes" / "drape_cut.json");
  text = std::regex_replace(text, std::regex("\"at\": 1.2"), "\"at\": 0.1");
  text = std::regex_replace(text, std::regex("\"duration\": 3"), "\"duration\": 0.2");
  const Scene scene =
      parseScene(text, "drape_cut.json", std::filesystem::path(CUTSIM_DATA_DIR) / "scenes");
  const std::filesystem::path file =
      std::filesystem::path(::testing::TempDir()) / "cutsim_ck_drape.ckpt";
  for (long stop : {49L, 50L, 51L}) resumeAndCompare(scene, stop, file);
  std::filesystem::remove(file);
}

/// A 1 m sheet of 11 x 11 points hanging from its top edge and swaying (gravity has a part along
/// -z), stretch and bending springs, CG, 0.3 s in steps of 0.01 s, with `timeline` (the entries of
/// its JSON list).
std::string hangingSheet(const std::string& timeline) {
  return R"({
  "mesh": {"grid": {"nx": 11, "ny": 11, "size": [1, 1]}},
  "mass": {"total": 0.1},
  "gravity": [0, -9.81, -2],
  "forceFields": [{"type": "StretchSprings", "stiffness": 200, "damping": 0.1},
                  {"type": "FastTriangularBendingSprings", "bendingStiffness": 0.01}],
  "constraints": [{"type": "fixed", "box": [[-0.01, 0.99, -1], [1.01, 1.01, 1]]}],
  "solver": {"type": "implicit-cg", "iterations": 200, "tolerance": 1e-10, "rayleighMass": 0.5},
  "timeStep": 0.01, "duration": 0.3,
  "timeline": [)" +
         timeline + "]\n}";
}

TEST(Checkpoint, AScalpelGoesOnBitForBitFromAnyStepOfItsIncision) {
  // A sheet hanging from its top border, cut by a blade that crosses it in world space while it
  // sways: checkpoints between the pieces of the incision (the blade's position at its last cut
  // and the incision's tip are saved), at a piece and at random steps.
  const std::string text =
      hangingSheet(R"({"action": "scalpel", "from": 0.02, "to": 0.22, "depth": 0.2,
                "path": [[0, -0.1, 0.5, -0.1, 0, 0, 1], [0.2, 0.7, 0.45, -0.1, 0, 0.3, 1]]})");
  const Scene scene = parseScene(text, "scalpel.json", test::kSceneDir);
  {
    SceneRunner probe(scene);
    probe.start();
    while (!probe.finished()) probe.advance();
    ASSERT_GT(probe.cutsDone(), 3);  // an incision in pieces, through the moving sheet
  }
  const std::filesystem::path file =
      std::filesystem::path(::testing::TempDir()) / "cutsim_ck_scalpel.ckpt";
  std::mt19937 rng(5);
  for (long stop : {3L, 8L, 13L, 22L}) resumeAndCompare(scene, stop, file);
  resumeAndCompare(scene, std::uniform_int_distribution<long>(2, 24)(rng), file);
  std::filesystem::remove(file);
}

TEST(Checkpoint, ACauteryGoesOnBitForBitFromAnyStepOfItsPath) {
  // A sheet hanging from its top border, swaying, through which a cautery's ball runs in world
  // space (carving every half mean edge it travels: its time at its last pass is saved), and a
  // second, dissecting, on an Attachment.
  const std::string text = R"({
  "mesh": {"grid": {"nx": 11, "ny": 11, "size": [1, 1]}},
  "mass": {"total": 0.1},
  "gravity": [0, -9.81, -2],
  "forceFields": [{"type": "StretchSprings", "stiffness": 200, "damping": 0.1},
                  {"type": "FastTriangularBendingSprings", "bendingStiffness": 0.01},
                  {"type": "Attachment", "stiffness": 5, "damping": 0.1}],
  "constraints": [{"type": "fixed", "box": [[-0.01, 0.99, -1], [1.01, 1.01, 1]]}],
  "solver": {"type": "implicit-cg", "iterations": 200, "tolerance": 1e-10, "rayleighMass": 0.5},
  "timeStep": 0.01, "duration": 0.3,
  "timeline": [{"action": "cautery", "from": 0.02, "to": 0.22, "radius": 0.12,
                "path": [[0, 0.1, 0.5, 0], [0.2, 0.8, 0.4, -0.03]]},
               {"action": "cautery", "from": 0.05, "to": 0.25, "radius": 0.1, "mode": "dissect",
                "path": [[0, 0.2, 0.2, 0], [0.2, 0.8, 0.25, 0]]}]
})";
  const Scene scene = parseScene(text, "cautery.json", test::kSceneDir);
  {
    SceneRunner probe(scene);
    probe.start();
    while (!probe.finished()) probe.advance();
    ASSERT_LT(probe.simulation().topology().triangles().size(), 200u - 10u);  // it carved
  }
  const std::filesystem::path file =
      std::filesystem::path(::testing::TempDir()) / "cutsim_ck_cautery.ckpt";
  std::mt19937 rng(7);
  for (long stop : {3L, 9L, 14L, 23L}) resumeAndCompare(scene, stop, file);
  resumeAndCompare(scene, std::uniform_int_distribution<long>(2, 24)(rng), file);
  std::filesystem::remove(file);
}

TEST(Checkpoint, ForcepsGoOnBitForBitOpenClosedAndHolding) {
  // Jaws that come down on a hanging, swaying sheet, close on it (a point inserted where their
  // middle line crosses it), carry it aside and open: checkpoints before, while and after they
  // hold (the grasp they made is the simulation's; the jaws keep whether they hold).
  const std::string text =
      hangingSheet(R"({"action": "forceps", "name": "jaws", "from": 0.02, "to": 0.25,
                "axis": [0, 0, 1], "across": [1, 0, 0], "radius": 0.01, "length": 0.3,
                "path": [[0, 0.43, 0.47, -0.15, 0.1], [0.03, 0.43, 0.47, -0.15, 0.02],
                         [0.15, 0.6, 0.5, 0.0, 0.02], [0.2, 0.6, 0.5, 0.0, 0.1]]})");
  const Scene scene = parseScene(text, "forceps.json", test::kSceneDir);
  {
    SceneRunner probe(scene);
    probe.start();
    bool held = false;
    while (!probe.finished()) {
      probe.advance();
      held = held || probe.simulation().findGrasp("jaws");
    }
    ASSERT_TRUE(held);
    ASSERT_EQ(probe.simulation().findGrasp("jaws"), nullptr);  // opened
  }
  const std::filesystem::path file =
      std::filesystem::path(::testing::TempDir()) / "cutsim_ck_forceps.ckpt";
  std::mt19937 rng(11);
  for (long stop : {2L, 5L, 6L, 12L, 21L, 25L}) resumeAndCompare(scene, stop, file);
  resumeAndCompare(scene, std::uniform_int_distribution<long>(2, 28)(rng), file);
  std::filesystem::remove(file);
}

TEST(Checkpoint, TurningForcepsGoOnBitForBitWhileTheyTurn) {
  // Jaws with an axis per keyframe: they close on the hanging sheet, lift it while their axis
  // turns by 120 degrees (what they hold turns with them about their tip), and open. The grasp's
  // rotations and pivot are part of the checkpoint.
  const std::string text =
      hangingSheet(R"({"action": "forceps", "name": "jaws", "from": 0.02, "to": 0.25,
                "across": [1, 0, 0], "radius": 0.06, "length": 0.3,
                "path": [[0, 0.43, 0.47, -0.15, 0, 0, 1, 0.2], [0.03, 0.43, 0.47, -0.15, 0, 0, 1, 0.12],
                         [0.1, 0.5, 0.45, -0.1, 0, -1, 0, 0.12],
                         [0.15, 0.6, 0.4, -0.05, 0, -0.5, -0.866, 0.12],
                         [0.2, 0.6, 0.4, -0.05, 0, -0.5, -0.866, 0.2]]})");
  const Scene scene = parseScene(text, "forceps.json", test::kSceneDir);
  {
    SceneRunner probe(scene);
    probe.start();
    bool turned = false;
    while (!probe.finished()) {
      probe.advance();
      if (const Grasp* g = probe.simulation().findGrasp("jaws"))
        turned = turned || (g->points().size() > 1 && !g->path().rotations.empty());
    }
    ASSERT_TRUE(turned);
    ASSERT_EQ(probe.simulation().findGrasp("jaws"), nullptr);  // opened
  }
  const std::filesystem::path file =
      std::filesystem::path(::testing::TempDir()) / "cutsim_ck_forceps_turning.ckpt";
  std::mt19937 rng(17);
  for (long stop : {4L, 8L, 13L, 21L}) resumeAndCompare(scene, stop, file);
  resumeAndCompare(scene, std::uniform_int_distribution<long>(2, 28)(rng), file);
  std::filesystem::remove(file);
}

TEST(Checkpoint, SuturesGoOnBitForBitWhileTheyTighten) {
  // Two stitches placed across a hanging, swaying sheet (points inserted where the needles
  // pierce it) and tightened over 0.15 s: checkpoints before, while and after (the threads are
  // the Sutures field's, their schedule the action's).
  const std::string text = R"({
  "mesh": {"grid": {"nx": 11, "ny": 11, "size": [1, 1]}},
  "mass": {"total": 0.1},
  "gravity": [0, -9.81, -2],
  "forceFields": [{"type": "StretchSprings", "stiffness": 200, "damping": 0.1},
                  {"type": "FastTriangularBendingSprings", "bendingStiffness": 0.01},
                  {"type": "Sutures", "stiffness": 50, "damping": 0.2}],
  "constraints": [{"type": "fixed", "box": [[-0.01, 0.99, -1], [1.01, 1.01, 1]]}],
  "solver": {"type": "implicit-cg", "iterations": 200, "tolerance": 1e-10, "rayleighMass": 0.5},
  "timeStep": 0.01, "duration": 0.3,
  "timeline": [{"at": 0.05, "action": "suture", "bite": 0.3, "tighten": 0.15, "length": 0.05,
                "stitches": [[0.23, 0.47, 0, 0.61, 0.52, 0], [0.37, 0.33, 0, 0.52, 0.71, 0]]}]
})";
  const Scene scene = parseScene(text, "sutures.json", test::kSceneDir);
  const std::filesystem::path file =
      std::filesystem::path(::testing::TempDir()) / "cutsim_ck_sutures.ckpt";
  std::mt19937 rng(13);
  for (long stop : {3L, 6L, 7L, 12L, 22L}) resumeAndCompare(scene, stop, file);
  resumeAndCompare(scene, std::uniform_int_distribution<long>(2, 28)(rng), file);
  std::filesystem::remove(file);
}

TEST(Checkpoint, WhatCannotBeSavedIsNamedAndWhatDoesNotFitIsRefused) {
  // A run changed while running (an action given, a field replaced) is not the scene's run any
  // more: its checkpoint could not be resumed from the scene.
  const Scene plain = parseScene(test::scene(), "inline.json", test::kSceneDir);
  SceneRunner edited(plain);
  EXPECT_TRUE(edited.notCheckpointable().empty());
  edited.schedule(parseActionEntry(
      R"({"at": 0.05, "action": "cut", "polyline": [[0, 0.5, 0], [0.5, 0.5, 0]]})", "typed", 0.0));
  ASSERT_EQ(edited.notCheckpointable().size(), 1u);
  EXPECT_NE(edited.notCheckpointable().front().find("changes made while running"),
            std::string::npos);
  ArchiveWriter w;
  try {
    edited.save(w);
    FAIL() << "an edited run was saved";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("this run cannot be saved: changes made while running"),
              std::string::npos)
        << e.what();
  }

  // A checkpoint of one scene does not restore into another.
  const std::filesystem::path file =
      std::filesystem::path(::testing::TempDir()) / "cutsim_ck_other.ckpt";
  const Scene small = parseScene(smallScene("\"solver\": {\"type\": \"implicit-cg\"}"),
                                 "small.json", test::kSceneDir);
  SceneRunner a(small);
  a.start();
  for (int i = 0; i < 12; ++i) a.advance();
  {
    ArchiveWriter out;
    a.save(out);
    out.save(file);
  }
  auto refusal = [&](const Scene& other) -> std::string {
    try {
      ArchiveReader in(file);
      SceneRunner b(other, in);
    } catch (const InvalidInput& e) {
      return e.what();
    }
    return "";
  };
  const Scene bending =
      parseScene(test::scene("\"forceFields\": [{\"type\": \"FastTriangularBendingSprings\", "
                             "\"bendingStiffness\": 1}]"),
                 "inline.json", test::kSceneDir);
  const std::string wrongMesh = refusal(bending);
  EXPECT_NE(wrongMesh.find("cutsim_ck_other.ckpt"), std::string::npos) << wrongMesh;
  EXPECT_FALSE(wrongMesh.empty());
  const Scene cholmod = parseScene(smallScene("\"integrator\": {\"type\": \"implicit-euler\"}, "
                                              "\"linearSolver\": {\"type\": \"cholmod\"}"),
                                   "small.json", test::kSceneDir);
  const std::string wrongSolver = refusal(cholmod);
  EXPECT_NE(wrongSolver.find("the saved linear solver is cg, the scene's cholmod"),
            std::string::npos)
      << wrongSolver;

  // A damaged byte anywhere is caught by the section's checksum before anything is built.
  std::string bytes = readFile(file);
  std::mt19937 rng(5);
  for (int k = 0; k < 20; ++k) {
    std::string damaged = bytes;
    const std::size_t at = std::uniform_int_distribution<std::size_t>(16, bytes.size() - 1)(rng);
    damaged[at] = char(damaged[at] ^ 0x10);
    std::ofstream(file, std::ios::binary | std::ios::trunc) << damaged;
    EXPECT_NE(refusal(small), "") << "byte " << at << " damaged, restored anyway";
  }
  std::filesystem::remove(file);
}

}  // namespace
}  // namespace cutsim::core
