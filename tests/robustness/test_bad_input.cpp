// Bad input that the corpora of tests/data/bad and tests/data/scenes/bad do not cover (inline, so
// that the corpus's own "every file is listed" checks stay as they are): each case names its
// expected place and message. And a run that fails leaves no output that looks complete.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cfenv>
#include <chrono>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/output.hpp"
#include "cutsim/core/scene.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/topology/mesh_io.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/ids.hpp"
#include "support/scene_text.hpp"

namespace cutsim::test {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::StartsWith;

struct NoFpTraps {
  int saved = fegetexcept();
  NoFpTraps() { fedisableexcept(FE_ALL_EXCEPT); }
  ~NoFpTraps() {
    feclearexcept(FE_ALL_EXCEPT);
    feenableexcept(saved);
  }
};

// ---- meshes ----

struct MeshCase {
  const char* what;
  bool off;
  std::string text;
  std::string where;   ///< "inline.obj:LINE" (or .off)
  std::string phrase;  ///< part of the message
};

std::string readError(const MeshCase& c) {
  std::istringstream in(c.text);
  try {
    const auto mesh =
        c.off ? topology::readOff(in, "inline.off") : topology::readObj(in, "inline.obj");
    topology::checkManifold(mesh);
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.where(), c.where) << e.what();
    return e.what();
  }
  return "";
}

TEST(BadMeshInput, EachCaseNamesItsPlaceAndProblem) {
  const std::vector<MeshCase> cases = {
      {"OFF announcing a billion vertices (no huge allocation first)", true,
       "OFF\n1000000000 1 0\n0 0 0\n", "inline.off:3", "expected 1000000000 vertices, found 1"},
      {"OFF with a negative count", true, "OFF\n-3 1 0\n0 0 0\n", "inline.off:2",
       "malformed count '-3'"},
      {"OBJ face with two vertices", false, "v 0 0 0\nv 1 0 0\nf 1 2\n", "inline.obj:3",
       "face has 2 vertices; only triangles are supported"},
      {"OBJ index beyond 64 bits", false, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n",
       "inline.obj:4", "99999999999999999999"},
      {"OBJ coordinate with a NUL byte", false, std::string("v 0 0 0\nv 1 0\0 0\n", 17),
       "inline.obj:2", "malformed number '0"},
      {"OBJ face that is a single repeated vertex", false, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 1 1\n",
       "inline.obj:4", "face repeats vertex 1"},
      {"OFF nan in the counts", true, "OFF\nnan 1 0\n", "inline.off:2", "malformed count 'nan'"},
  };
  for (const MeshCase& c : cases) {
    SCOPED_TRACE(c.what);
    const std::string message = readError(c);
    EXPECT_THAT(message, StartsWith(c.where + ": "));
    EXPECT_THAT(message, HasSubstr(c.phrase));
  }
}

TEST(BadMeshInput, APillowOfTwoTrianglesIsAcceptedWithDegenerateHinges) {
  // Two triangles on the same three vertices, facing away from each other: a closed, manifold
  // surface (every edge has two triangles running it both ways). Accepted; each hinge has the same
  // vertex as both wings, so every one is deactivated as a short wing distance, never NaN.
  std::istringstream in("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 3 2\n");
  const auto m = topology::readObj(in, "inline.obj");
  EXPECT_NO_THROW(topology::checkManifold(m));
  topology::Topology t(m);
  EXPECT_EQ(t.numEdges(), 3u);
  forcefields::FastTriangularBendingSprings f(t, forcefields::BendingParameters{});
  EXPECT_EQ(f.numActiveSprings(), 0u);
  EXPECT_EQ(f.counters().shortWingDistance, 3u);
  EXPECT_TRUE(t.validate().ok()) << t.validate().summary();
}

TEST(BadMeshInput, LimitCoordinatesAreReadOrRejectedNeverNaN) {
  // Underflow reads as a (sub)normal or zero; the largest finite double reads; beyond is rejected.
  std::istringstream in("v 1e-400 0 0\nv 1.7976931348623157e308 0 0\nv 0 4.9e-324 0\nf 1 2 3\n");
  const auto m = topology::readObj(in, "inline.obj");
  ASSERT_EQ(m.points.size(), 3u);
  EXPECT_EQ(m.points[0][0], 0.0);
  EXPECT_EQ(m.points[1][0], 1.7976931348623157e308);
  EXPECT_GT(m.points[2][1], 0.0);
}

TEST(BadMeshInput, AHugeFlatTriangleBuildsWithoutOverflow) {
  // Coordinates near the top of the double range: the topology accepts them (connectivity only),
  // the bending springs count the hinge as unrepresentable instead of overflowing.
  const double big = 1e200;
  topology::MeshData m;
  m.points = {{0, big, 0}, {0, -big, 0}, {0, 0, 0}, {big, 0, 0}};
  m.triangles = {tri(2, 3, 0), tri(3, 2, 1)};
  topology::Topology t(m);
  forcefields::FastTriangularBendingSprings f(t, forcefields::BendingParameters{});
  EXPECT_EQ(f.numActiveSprings(), 0u);
  EXPECT_EQ(f.counters().unrepresentable, 1u);
}

// ---- scenes ----

TEST(BadSceneInput, EachCaseNamesItsPlaceAndProblem) {
  struct Case {
    std::string text;
    std::string expected;  // what() starts with "inline.json:" + this
  };
  const std::string polyline =
      "\"polyline\": [[0.1, 0.1, 0], [0.9, 0.9, 0], [0.9, 0.1, 0], [0.1, 0.9, 0]]";
  const std::vector<Case> cases = {
      {"", "1: invalid JSON"},
      {"\xEF\xBB\xBF{}", "1: "},
      {"{\n\"mesh\": {\"grid\": {\"nx\": 1, \"ny\": 5}}, \"timeStep\": 0.1, \"duration\": 1}",
       "2: /mesh/grid/nx: must be between 2 and 2000 (got 1)"},
      {"{\n\"mesh\": {\"grid\": {\"nx\": 2001, \"ny\": 5}}, \"timeStep\": 0.1, \"duration\": 1}",
       "2: /mesh/grid/nx: must be between 2 and 2000 (got 2001)"},
      {"{\n\"mesh\": {\"grid\": {\"nx\": 3, \"ny\": 3}}, \"mass\": {\"density\": "
       "1},\n\"timeStep\": 1e-9,\n\"duration\": 1}",
       "4: /duration: more than 1e8 steps of timeStep"},
      {"{\n\"mesh\": {\"grid\": {\"nx\": 3, \"ny\": 3, \"size\": [0, 1]}},\n\"mass\": {\"total\": "
       "1},\n\"timeStep\": 0.1, \"duration\": 1}",
       "2: /mesh/grid/size"},
      {scene("\"solver\": {\"iterations\": 0}"), "6: /solver/iterations: must be between 1"},
      {scene("\"output\": {\"every\": 0}"), "6: /output/every: must be between 1"},
      {scene("\"timeline\": [{\"at\": 0, \"action\": \"cut\", \"snapTolerance\": 0.5, "
             "\"polyline\": [[0, 0.5, 0], [1, 0.5, 0]]}]"),
       "6: /timeline/0/snapTolerance: "},
      {scene("\"timeline\": [{\"at\": 0, \"action\": \"cut\", \"polyline\": [[0, 0.5, 0]]}]"),
       "6: /timeline/0/polyline: "},
      {scene("\"timeline\": [{\"at\": 0, \"action\": \"cut\", " + polyline + "}]"),
       "6: /timeline/0/polyline: "},
      {scene("\"mesh\": \"../bad/quad_face.obj\""), ""},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.text.substr(0, 200));
    const std::string message = parseError(c.text);
    if (c.expected.empty()) {
      EXPECT_FALSE(message.empty());
    } else {
      EXPECT_THAT(message, StartsWith("inline.json:" + c.expected));
    }
  }
}

double secondsToReject(const std::string& text) {
  const auto start = std::chrono::steady_clock::now();
  EXPECT_THAT(parseError(text), StartsWith("inline.json:1: invalid JSON"));
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

TEST(BadSceneInput, DeeplyNestedArraysAreRejected) {
  EXPECT_LT(secondsToReject(std::string(1000, '[')), 1.0);
  EXPECT_LT(secondsToReject(std::string(10000, '[')), 5.0);
}

// Rejecting N nested '[' used to take time quadratic in N (about 30 s for 10^5): the scene parser
// now refuses nesting deeper than 64 levels as soon as it meets it.
TEST(BadSceneInput, DeeplyNestedArraysAreRejectedInLinearTime) {
  EXPECT_LT(secondsToReject(std::string(100000, '[')), 1.0);
}

TEST(BadSceneInput, ANumberBeyondTheDoubleRangeIsRejected) {
  NoFpTraps noTraps;  // the JSON lexer's strtod raises the overflow flag on 1e999
  EXPECT_THAT(parseError("{\n\"mesh\": {\"grid\": {\"nx\": 3, \"ny\": 3}},\n\"timeStep\": 1e999, "
                         "\"duration\": 1}"),
              StartsWith("inline.json:3: invalid JSON: number overflow parsing '1e999' (beyond the "
                         "range of doubles"));
  EXPECT_THAT(parseError(scene("\"forceFields\": [{\"type\": \"StretchSprings\", \"stiffness\": "
                               "-1e999}]")),
              StartsWith("inline.json:6: "));
}

TEST(BadSceneInput, ACrossingCutNamesTheCrossingSegments) {
  const std::string text = scene(
      "\"timeline\": [{\"at\": 0, \"action\": \"cut\", \"polyline\": [[0.1, 0.1, 0], [0.9, 0.9, "
      "0], [0.9, 0.1, 0], [0.1, 0.9, 0]]}]");
  EXPECT_THAT(parseError(text), HasSubstr("crosses itself (segments 0 and 2)"));
}

TEST(BadSceneInput, ABadMeshFileIsReportedAtItsOwnLine) {
  // The mesh file's problem is named by the mesh file's path and line, not by the scene's.
  const std::string message = parseError(
      "{\n\"mesh\": \"../bad/quad_face.obj\",\n\"mass\": {\"density\": 1}, \"timeStep\": 0.1, "
      "\"duration\": 1}");
  EXPECT_THAT(message, HasSubstr("quad_face.obj:5: face has 4 vertices"));
}

// ---- a failed run leaves nothing that looks complete ----

/// What `cutsim run` does (src/cli/cmd_run.cpp): load, build, write frames while stepping, finish.
void runLikeTheProgram(const std::string& text, const fs::path& out) {
  const core::Scene s = core::parseScene(text, "inline.json", kSceneDir);
  core::SceneRunner runner(s);
  core::OutputWriter writer(out, s.output, s.forceFieldLabels(), s.graspNames());
  runner.start();
  writer.record(runner.simulation(), {0, 0.0, {}}, runner.finished());
  while (!runner.finished()) {
    const core::StepStats stats = runner.advance();
    writer.record(runner.simulation(), {runner.currentStep(), runner.time(), stats},
                  runner.finished());
  }
  writer.finish();
}

struct TempDir {
  fs::path path = fs::temp_directory_path() /
                  ("cutsim_robustness_" +
                   std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

std::vector<std::string> listing(const fs::path& dir) {
  std::vector<std::string> names;
  if (!fs::exists(dir)) return names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

TEST(FailedRun, ABadSceneCreatesNoOutputAtAll) {
  TempDir tmp;
  EXPECT_THROW(runLikeTheProgram(scene("\"solver\": {\"type\": \"magic\"}"), tmp.path / "out"),
               InvalidInput);
  EXPECT_FALSE(fs::exists(tmp.path / "out"));
}

/// A scene that loads but blows up at run time (explicit, huge stiffness, big step).
std::string explodingScene() {
  return "{\n"
         "  \"mesh\": {\"grid\": {\"nx\": 5, \"ny\": 5}},\n"
         "  \"mass\": {\"density\": 0.001},\n"
         "  \"forceFields\": [{\"type\": \"StretchSprings\", \"stiffness\": 1e9}],\n"
         "  \"solver\": {\"type\": \"explicit\"},\n"
         "  \"gravity\": [0, 0, -9.81],\n"
         "  \"constraints\": [{\"type\": \"fixed\", \"points\": [0]}],\n"
         "  \"timeStep\": 0.1,\n"
         "  \"duration\": 100,\n"
         "  \"output\": {\"every\": 1}\n"
         "}\n";
}

TEST(FailedRun, ARunThatBlowsUpLeavesNoFinalCsv) {
  NoFpTraps noTraps;
  TempDir tmp;
  try {
    runLikeTheProgram(explodingScene(), tmp.path);
    FAIL() << "the run did not blow up";
  } catch (const SolverError& e) {
    EXPECT_THAT(e.what(), HasSubstr("smaller"));
  }
  const auto names = listing(tmp.path);
  EXPECT_EQ(std::count(names.begin(), names.end(), "steps.csv"), 0);
  EXPECT_EQ(std::count(names.begin(), names.end(), ".steps.csv.tmp"), 1);
}

// A run that fails part-way leaves its collections under their ".partial" names only: nothing
// looks complete (OutputWriter::finish() writes the final ones, after the CSV's data).
TEST(FailedRun, ARunThatBlowsUpLeavesNoPvdCollection) {
  NoFpTraps noTraps;
  TempDir tmp;
  EXPECT_THROW(runLikeTheProgram(explodingScene(), tmp.path), SolverError);
  const auto names = listing(tmp.path);
  EXPECT_EQ(std::count(names.begin(), names.end(), "surface.pvd"), 0);
  EXPECT_EQ(std::count(names.begin(), names.end(), "springs.pvd"), 0);
}

}  // namespace
}  // namespace cutsim::test
