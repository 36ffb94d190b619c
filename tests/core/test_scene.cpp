// Scenes: loading, every kind of bad scene with its message ("FILE:LINE: /pointer: message"),
// the runner (cuts, progressive cuts, removal, grasps, tearing) and the strain measures.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <ostream>
#include <string>
#include <vector>

#include "../../src/core/timeline/tearing.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/base/threads.hpp"
#include "cutsim/core/scene.hpp"
#include "cutsim/forcefields/stretch_springs.hpp"
#include "cutsim/forcefields/triangular_fem.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/scene_text.hpp"

namespace cutsim::core {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

using test::parseError;
using test::scene;
const std::filesystem::path& kScenes = test::kSceneDir;
const std::filesystem::path kDemoScenes = std::filesystem::path(CUTSIM_DATA_DIR) / "scenes";

// ---- loading ----

TEST(Scene, LoadsTheSmallScene) {
  const Scene s = loadScene(kScenes / "small.json");
  EXPECT_EQ(s.name, "small");
  ASSERT_TRUE(s.grid.has_value());
  EXPECT_EQ(s.grid->nx, 9);
  EXPECT_FALSE(s.massByTotal);
  EXPECT_DOUBLE_EQ(s.density, 0.5);
  EXPECT_DOUBLE_EQ(s.gravity[2], -9.81);
  ASSERT_EQ(s.forceFields.size(), 2u);
  EXPECT_EQ(s.forceFields[0].type, "StretchSprings");
  EXPECT_DOUBLE_EQ(
      std::any_cast<const forcefields::StretchParameters&>(s.forceFields[0].parameters).stiffness,
      200);
  EXPECT_EQ(s.forceFields[1].type, "FastTriangularBendingSprings");
  EXPECT_EQ(
      std::any_cast<const forcefields::BendingParameters&>(s.forceFields[1].parameters).areaWeights,
      forcefields::AreaWeights::Signed);
  EXPECT_EQ(s.forceFieldLabels(),
            (std::vector<std::string>{"StretchSprings", "FastTriangularBendingSprings"}));
  EXPECT_EQ(s.constraints.size(), 2u);
  // The "solver" shorthand implicit-cg: implicit Euler with CG.
  EXPECT_EQ(s.integrator.type, "implicit-euler");
  ASSERT_TRUE(s.linearSolver.has_value());
  EXPECT_EQ(s.linearSolver->type, "cg");
  EXPECT_EQ(std::any_cast<const core::CGSettings&>(s.linearSolver->parameters).maxIterations, 200);
  EXPECT_EQ(s.numSteps(), 30);
  EXPECT_EQ(s.output.every, 5);
  EXPECT_TRUE(s.output.obj);
  ASSERT_EQ(s.timeline.size(), 7u);
  // Sorted by start time, file order at ties (the remove and the progressive cut both at 0.1).
  EXPECT_EQ(s.timeline[0].type, "cut");
  EXPECT_FALSE(s.timeline[0].timing.interval);
  EXPECT_EQ(s.timeline[1].type, "cut");
  EXPECT_TRUE(s.timeline[1].timing.interval);  // a progressive cut
  EXPECT_EQ(s.timeline[1].location.pointer, "/timeline/1");
  EXPECT_EQ(s.timeline[1].location.line, 17u);
  EXPECT_EQ(s.timeline[2].type, "remove");
  EXPECT_EQ(s.timeline[3].type, "grasp");
  EXPECT_EQ(std::any_cast<const core::GraspParameters&>(s.timeline[3].parameters).path.times.size(),
            2u);
  EXPECT_EQ(s.timeline.back().type, "remove");
  EXPECT_DOUBLE_EQ(s.timeline.back().timing.at, 0.3);  // at the duration: allowed
  EXPECT_EQ(s.graspNames(), std::vector<std::string>{"pin"});
}

TEST(Scene, LoadsEveryDemoScene) {
  for (const char* name :
       {"hanging.json", "hanging_cut.json", "tearing.json", "surgery_incision.json",
        "drape_cut.json", "fold_ground.json", "surgery_flap.json", "drape_scalpel.json",
        "surgery_excision.json", "surgery_suture.json", "surgery_organ.json"}) {
    SCOPED_TRACE(name);
    const Scene s = loadScene(kDemoScenes / name);
    EXPECT_GT(s.numSteps(), 0);
    EXPECT_FALSE(s.description.empty());
  }
}

TEST(Scene, MeshFileRelativeToTheScene) {
  const std::string text =
      "{\"mesh\": \"../../../data/meshes/grid_10x10.obj\", \"mass\": {\"total\": 2},"
      " \"timeStep\": 0.1, \"duration\": 0.2}";
  const Scene s = parseScene(text, "x.json", kScenes);
  ASSERT_TRUE(s.meshFile.has_value());
  EXPECT_EQ(s.mesh().points.size(), 100u);
  EXPECT_TRUE(s.massByTotal);
  SceneRunner runner(s);
  EXPECT_NEAR(runner.simulation().mass().total(), 2.0, 1e-12);
  EXPECT_EQ(runner.simulation().numForceFields(), 0u);  // only what the scene lists
}

TEST(Scene, StepsRoundToTheNearestWholeNumber) {
  Scene s;
  s.timeStep = 0.1;
  s.duration = 0.3;  // 2.9999999999999996 steps
  EXPECT_EQ(s.numSteps(), 3);
  s.duration = 0.35;
  EXPECT_EQ(s.numSteps(), 4);
  s.duration = 0;
  EXPECT_EQ(s.numSteps(), 0);
}

TEST(Scene, GridLayoutAndOrientation) {
  GridSpec g;
  g.nx = 4;
  g.ny = 3;
  g.width = 3;
  g.height = 1;
  const topology::MeshData m = makeGrid(g);
  EXPECT_EQ(m.points.size(), 12u);
  EXPECT_EQ(m.triangles.size(), 2u * 3 * 2);
  EXPECT_EQ(m.points[5], (Vec3{1, 0.5, 0}));
  for (bool xz : {false, true}) {
    g.planeXZ = xz;
    g.origin = {1, 2, 3};
    const topology::MeshData mm = makeGrid(g);
    topology::checkManifold(mm);
    for (const auto& t : mm.triangles) {
      const Vec3 &a = mm.points[t[0].idx()], &b = mm.points[t[1].idx()], &c = mm.points[t[2].idx()];
      const Vec3 u{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
      const Vec3 n{u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
      if (xz) {
        EXPECT_LT(n[1], 0);  // facing -y
        EXPECT_DOUBLE_EQ(a[1], 2);
      } else {
        EXPECT_GT(n[2], 0);  // facing +z
        EXPECT_DOUBLE_EQ(a[2], 3);
      }
    }
  }
}

// ---- bad scenes: files ----

struct BadScene {
  const char* file;
  int line;
  const char* pointer;
  const char* phrase;
};

// Readable test names in CTest (instead of the parameter's bytes).
void PrintTo(const BadScene& b, std::ostream* os) {
  *os << b.file;
}

class BadSceneFile : public ::testing::TestWithParam<BadScene> {};

TEST_P(BadSceneFile, NamesFileLinePointerAndProblem) {
  const BadScene& b = GetParam();
  const std::filesystem::path path = kScenes / "bad" / b.file;
  try {
    loadScene(path);
    FAIL() << "no error for " << b.file;
  } catch (const InvalidInput& e) {
    const std::string prefix = path.string() + ":" + std::to_string(b.line) + ": " + b.pointer;
    EXPECT_THAT(e.what(), StartsWith(prefix));
    EXPECT_THAT(e.what(), HasSubstr(b.phrase));
    EXPECT_EQ(e.where(), path.string() + ":" + std::to_string(b.line));
  }
}

INSTANTIATE_TEST_SUITE_P(
    Scene, BadSceneFile,
    ::testing::Values(
        BadScene{"unknown_key.json", 5, "/solver/iteration: ", "unknown key \"iteration\""},
        BadScene{"wrong_type.json", 5,
                 "/forceFields/0/bendingStiffness: ", "expected a number, got a string"},
        BadScene{"missing_mesh.json", 3, "/mesh: ", "\"no_such_mesh.obj\" not found"},
        BadScene{"negative_stiffness.json", 7,
                 "/forceFields/1/bendingStiffness: ", "must be >= 0 (got -2.5)"},
        BadScene{"negative_time_step.json", 4, "/timeStep: ", "must be > 0 (got -0.01)"},
        BadScene{"negative_action_time.json", 8, "/timeline/1/at: ", "negative time"},
        BadScene{"action_after_duration.json", 6, "/timeline/0/at: ", "after the end of the scene"},
        BadScene{"cut_misses_surface.json", 9, "/timeline/0/polyline/2: ",
                 "the cut misses the surface: point (2, 0.5, 0) is 1 away"},
        BadScene{"unknown_action.json", 7, "/timeline/0/action: ", "unknown action \"explode\""},
        BadScene{"unknown_force_field.json", 4,
                 "/forceFields/0/type: ", "unknown force field type \"Magnet\""},
        BadScene{"invalid_json.json", 4, "invalid JSON", "syntax error"}),
    [](const ::testing::TestParamInfo<BadScene>& param) {
      std::string name = param.param.file;
      name = name.substr(0, name.find('.'));
      return name;
    });

TEST(Scene, MissingSceneFile) {
  try {
    loadScene(kScenes / "bad" / "no_such_scene.json");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_THAT(e.what(), HasSubstr("no_such_scene.json: cannot open"));
  }
}

// ---- bad scenes: inline ----

TEST(Scene, InlineProblemsNameTheirPlace) {
  struct Case {
    std::string extra;
    std::string expected;  // the message after "inline.json:"
  };
  const std::vector<Case> cases = {
      {"\"gravity\": [0, 0]", "6: /gravity: expected [x, y, z]"},
      // contact's sections, read in their own file (SceneSections): still named by the reader
      {"\"obstacles\": [{\"type\": \"plane\"}]",
       "6: /obstacles: obstacles need a \"contact\" section (its thickness and stiffness)"},
      {"\"contact\": {\"thickness\": 0.01}", "6: /contact: missing key \"stiffness\""},
      {"\"contact\": {\"thickness\": 0.01, \"stiffness\": 10}, \"obstacles\": [{\"type\": "
       "\"plane\", \"point\": [0, 0, -1], \"normal\": [0, 0, 1], \"name\": \"a\"}, "
       "{\"type\": \"plane\", \"point\": [0, 0, -2], \"normal\": [0, 0, 1], \"name\": \"a\"}]",
       "6: /obstacles/1/name: another obstacle has the name \"a\""},
      {"\"obstacle\": []",
       "6: /obstacle: unknown key \"obstacle\" (expected one of: name, "
       "description, mesh, mass, gravity, forceFields, constraints, solver, "
       "integrator, linearSolver, timeStep, duration, output, timeline, ignored, "
       "threads, contact, obstacles)"},
      {"\"gravity\": [0, 0, \"down\"]", "6: /gravity/2: expected a number, got a string"},
      {"\"solver\": {\"type\": \"magic\"}", "6: /solver/type: unknown solver type \"magic\""},
      {"\"solver\": {\"iterations\": 2.5}", "6: /solver/iterations: expected an integer"},
      {"\"solver\": {\"tolerance\": -1}", "6: /solver/tolerance: must be > 0"},
      {"\"solver\": {\"warmStart\": 1}", "6: /solver/warmStart: expected true or false"},
      {"\"forceFields\": [{\"type\": \"StretchSprings\", \"stiffness\": -1}]",
       "6: /forceFields/0/stiffness: must be >= 0"},
      {"\"forceFields\": [{\"type\": \"StretchSprings\"}]",
       "6: /forceFields/0: missing key \"stiffness\""},
      {"\"forceFields\": [{\"type\": \"TriangularFEM\", \"restScale\": 0}]",
       "6: /forceFields/0/restScale: must be > 0 (got 0)"},
      {"\"forceFields\": [{\"type\": \"StretchSprings\", \"stiffness\": 5, \"restScale\": -0.5}]",
       "6: /forceFields/0/restScale: must be > 0 (got -0.5)"},
      {"\"forceFields\": [{\"type\": \"FastTriangularBendingSprings\", \"areaWeights\": \"x\"}]",
       "6: /forceFields/0/areaWeights: unknown value \"x\""},
      {"\"constraints\": [{\"type\": \"fixed\", \"points\": [3, 99]}]",
       "6: /constraints/0/points/1: must be between 0 and 24 (got 99)"},
      {"\"constraints\": [{\"type\": \"fixed\", \"box\": [[5, 5, 5], [6, 6, 6]]}]",
       "6: /constraints/0/box: selects no point"},
      {"\"constraints\": [{\"type\": \"glue\", \"points\": [1]}]",
       "6: /constraints/0/type: unknown constraint type \"glue\""},
      {"\"constraints\": [{\"type\": \"fixed\", \"points\": [1], \"near\": [[0, 0, 0]]}]",
       "6: /constraints/0: give exactly one of"},
      {"\"timeline\": [{\"at\": 0.05, \"action\": \"release\", \"name\": \"hand\"}]",
       "6: /timeline/0/name: no grasp named \"hand\" is active"},
      {"\"timeline\": [{\"at\": 0.05, \"action\": \"remove\", \"sphere\": {\"center\": [9, 9, "
       "9], \"radius\": 0.1}}]",
       "6: /timeline/0/sphere: removes no triangle"},
      {"\"timeline\": [{\"at\": 0.05, \"action\": \"remove\", \"sphere\": {\"center\": [0.5, 0.5, "
       "0], \"radius\": 0.2}, \"boundary\": \"jagged\"}]",
       "6: /timeline/0/boundary: must be \"cut\" or \"centroid\""},
      {"\"timeline\": [{\"at\": 0.05, \"action\": \"remove\", \"sphere\": {\"center\": [0.5, 0.5, "
       "0], \"radius\": 0.2}, \"minAngle\": 60}]",
       "6: /timeline/0/minAngle: must be in [0, 60) degrees"},
      {"\"timeline\": [{\"at\": 0.05, \"action\": \"cut\", \"polyline\": [[0, 0.5, 0], [0.5, 0.5, "
       "0]], \"minAngle\": -1}]",
       "6: /timeline/0/minAngle: must be in [0, 60) degrees"},
      {"\"timeline\": [{\"at\": 0.05, \"action\": \"tearing\", \"threshold\": 0.3, \"minAngle\": "
       "75}]",
       "6: /timeline/0/minAngle: must be in [0, 60) degrees"},
      {"\"timeline\": [{\"from\": 0.05, \"to\": 0.01, \"action\": \"cut\", \"polyline\": [[0, "
       "0.5, 0], [0.5, 0.5, 0]]}]",
       "6: /timeline/0/to: must be after \"from\""},
      {"\"timeline\": [{\"at\": 0.01, \"action\": \"grasp\", \"name\": \"g\", \"points\": [1], "
       "\"path\": [[0.1, 0, 0, 0], [0.1, 1, 0, 0]]}]",
       "6: /timeline/0/path/1/0: path times must increase strictly"},
      {"\"timeline\": [{\"at\": 0.01, \"action\": \"cut\", \"polyline\": [[0, 0.5, 0], [0.5, "
       "0.5, 0]]}, {\"at\": 0.02, \"action\": \"cut\", \"polyline\": [[0.25, 0, 0], [0.25, 1, "
       "0]]}]",
       "6: /timeline/1/polyline: the cut cannot be made on the rest surface"},
      // A second cut a millimetre beside the first snaps onto its lips and opens nothing; a cut
      // along the border opens nothing either: both used to be run and not counted, unsaid.
      {"\"timeline\": [{\"at\": 0.01, \"action\": \"cut\", \"polyline\": [[0, 0.5, 0], [0.5, "
       "0.5, 0]]}, {\"at\": 0.02, \"action\": \"cut\", \"polyline\": [[0, 0.501, 0], [0.5, "
       "0.501, 0]]}]",
       "6: /timeline/1/polyline: the cut opens nothing: its path runs along the border or along "
       "the lips of an earlier cut"},
      {"\"timeline\": [{\"at\": 0.01, \"action\": \"cut\", \"polyline\": [[0, 0, 0], [1, 0, "
       "0]]}]",
       "6: /timeline/0/polyline: the cut opens nothing"},
      {"\"timeline\": {}", "6: /timeline: expected an array, got an object"},
      {"\"name\": \"a/b\"", "6: /name: must be a plain file name"},
      {"\"duration\": 1", "6: /duration: duplicate key"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.extra);
    EXPECT_THAT(parseError(scene(c.extra)), StartsWith("inline.json:" + c.expected));
  }
}

// Values that would make a run do nothing are refused, naming them: a duration that rounds to no
// step, a relative tolerance of 1 or more (met before the first iteration).
TEST(Scene, ValuesThatWouldMakeARunDoNothingAreRefused) {
  std::string text = scene();
  text.replace(text.find("\"duration\": 0.1"), 15, "\"duration\": 1e-12");
  EXPECT_THAT(parseError(text),
              StartsWith("inline.json:5: /duration: is 1e-12 s, a vanishing part "
                         "of the time step (0.01 s): the run would take no step"));
  text = scene();
  text.replace(text.find("\"duration\": 0.1"), 15, "\"duration\": 0");
  EXPECT_EQ(parseScene(text, "inline.json", kScenes).numSteps(), 0);  // on purpose: allowed
  EXPECT_THAT(parseError(scene("\"linearSolver\": {\"type\": \"cg\", \"tolerance\": 1e300}")),
              StartsWith("inline.json:6: /linearSolver/tolerance: must be < 1, got 1e+300"));
  EXPECT_THAT(parseError(scene("\"solver\": {\"tolerance\": 1}")),
              StartsWith("inline.json:6: /solver/tolerance: must be < 1, got 1"));
  EXPECT_THAT(parseError(scene("\"integrator\": {\"type\": \"newton\", \"tolerance\": 2}")),
              StartsWith("inline.json:6: /integrator/tolerance: must be < 1, got 2"));
}

// The check estimates the memory a run needs (scene_memory.cpp: 1.28 KB a point and 16 MB, and
// CHOLMOD's factor 160 B 3N log2(3N)) against the machine's (here as CUTSIM_MEMORY gives it: its
// total, then what is available now): a run that cannot fit the machine is refused at the mesh's
// size, a direct solve whose factor cannot at the solver's type; a run, or a fallback to CHOLMOD,
// that needs more than is available now is said.
TEST(Scene, ARunBeyondTheMemoryIsRefusedAndAFallbackBeyondItIsSaid) {
  struct Memory {
    explicit Memory(const char* value) { ::setenv("CUTSIM_MEMORY", value, 1); }
    ~Memory() { ::unsetenv("CUTSIM_MEMORY"); }
  };
  // 25 points: the run 16.03 MB, the factor 75 KB more.
  const std::string cholmod = scene("\"linearSolver\": {\"type\": \"cholmod\"}");
  {
    Memory m("1e7");
    EXPECT_THAT(parseError(scene()),
                StartsWith("inline.json:2: /mesh/grid/nx: a mesh of 25 points needs about "));
    EXPECT_THAT(parseError(cholmod), HasSubstr("more than this machine's 10 MB: a coarser mesh"));
  }
  {
    Memory m("16.05e6");  // the run fits, not with the factor
    EXPECT_THAT(parseError(cholmod),
                StartsWith("inline.json:6: /linearSolver/type: CHOLMOD's factor of 25 points "
                           "needs about "));
    Scene s = parseScene(scene(), "inline.json", kScenes);
    ASSERT_EQ(s.warnings.size(), 1u);
    EXPECT_THAT(s.warnings[0],
                StartsWith("inline.json:2: /mesh/grid/nx: a solve that misses its tolerance falls "
                           "back to CHOLMOD, whose factor of 25 points needs about "));
    s = parseScene(scene("\"integrator\": {\"type\": \"bdf2\"}"), "inline.json", kScenes);
    ASSERT_EQ(s.warnings.size(), 1u);
    EXPECT_THAT(s.warnings[0], StartsWith("inline.json:6: /integrator: a solve that misses"));
    s = parseScene(scene("\"integrator\": {\"type\": \"newton\"}"), "inline.json", kScenes);
    EXPECT_EQ(s.warnings.size(), 1u);
    for (const char* extra : {"\"integrator\": {\"type\": \"implicit-euler\", "
                              "\"onSolveFailure\": \"warn\"}",
                              "\"integrator\": {\"type\": \"explicit-euler\"}"})
      EXPECT_TRUE(parseScene(scene(extra), "inline.json", kScenes).warnings.empty()) << extra;
  }
  {
    Memory m("1e12,16.05e6");  // a large machine, busy: said, not refused
    const Scene s = parseScene(cholmod, "inline.json", kScenes);
    ASSERT_EQ(s.warnings.size(), 1u);
    EXPECT_THAT(s.warnings[0],
                StartsWith("inline.json:6: /linearSolver/type: the run needs about "));
    EXPECT_THAT(s.warnings[0], HasSubstr("more than the 16 MB available now (of 1000 GB)"));
  }
  for (const char* value : {"1e12", "off"}) {
    Memory m(value);
    EXPECT_TRUE(parseScene(cholmod, "inline.json", kScenes).warnings.empty()) << value;
    EXPECT_TRUE(parseScene(scene(), "inline.json", kScenes).warnings.empty()) << value;
  }
  for (const char* bad : {"8G", "1e12,", "-1", "nan"}) {
    Memory m(bad);
    EXPECT_THAT(parseError(scene()), HasSubstr("the memory check: CUTSIM_MEMORY: expected")) << bad;
  }
}

// "threads" sets the process's thread setting when the run is built; `--threads` (an override)
// beats scenes; bad values are refused at their key.
TEST(Scene, ThreadsSetTheProcesssSettingUnlessOverridden) {
  const Scene s = parseScene(scene("\"threads\": 3"), "inline.json", kScenes);
  EXPECT_EQ(s.threads, 3);
  setThreads(0);
  EXPECT_EQ(parseScene(scene(), "inline.json", kScenes).threads, 0);
  {
    SceneRunner runner(s);
    EXPECT_EQ(threads(), 3);
  }
  overrideThreads(2);
  {
    SceneRunner runner(s);
    EXPECT_EQ(threads(), 2) << "the command line's setting holds against the scene's";
  }
  overrideThreads(0);
  setThreads(0);
  EXPECT_GE(threads(), 1);
  EXPECT_THAT(parseError(scene("\"threads\": 0")),
              StartsWith("inline.json:6: /threads: must be between 1 and 256"));
  EXPECT_THAT(parseError(scene("\"threads\": 2.5")), StartsWith("inline.json:6: /threads:"));
  EXPECT_THROW(setThreads(257), InvalidInput);
}

// A bending stiffness whose springs a hinge cannot hold (1e308: every spring would be dropped as
// unrepresentable) is refused when the run is built, naming the key, not run without bending.
TEST(Scene, ABendingStiffnessThatWouldDropEverySpringIsRefused) {
  const Scene s = parseScene(
      scene("\"forceFields\": [{\"type\": \"FastTriangularBendingSprings\", \"bendingStiffness\": "
            "1e308}]"),
      "inline.json", kScenes);
  try {
    SceneRunner runner(s);
    FAIL() << "a run without its bending springs was built";
  } catch (const InvalidInput& e) {
    EXPECT_THAT(e.what(), StartsWith("inline.json:6: /forceFields/0/bendingStiffness: 40 of 40 "
                                     "springs would be dropped"));
  }
  const Scene fine = parseScene(
      scene("\"forceFields\": [{\"type\": \"FastTriangularBendingSprings\", \"bendingStiffness\": "
            "1e290}]"),
      "inline.json", kScenes);
  EXPECT_NO_THROW(SceneRunner{fine});
  // The same for DihedralBending, whose hinges would not be dropped but would overflow the
  // solve (it failed at step 7 with a residual of 1e131).
  const Scene dihedral = parseScene(
      scene("\"forceFields\": [{\"type\": \"DihedralBending\", \"bendingStiffness\": 1e308}]"),
      "inline.json", kScenes);
  try {
    SceneRunner runner(dihedral);
    FAIL() << "a run whose hinges overflow was built";
  } catch (const InvalidInput& e) {
    EXPECT_THAT(e.what(), StartsWith("inline.json:6: /forceFields/0/bendingStiffness: 40 of 40 "
                                     "hinges would be stiffer than the solves can hold"));
  }
  EXPECT_NO_THROW(SceneRunner{parseScene(
      scene("\"forceFields\": [{\"type\": \"DihedralBending\", \"bendingStiffness\": 1e290}]"),
      "inline.json", kScenes)});
}

TEST(Scene, StretchFieldsReadTheirRestScale) {
  const Scene s =
      parseScene(scene("\"forceFields\": [{\"type\": \"StretchSprings\", \"stiffness\": 5, "
                       "\"restScale\": 0.98}, {\"type\": \"TriangularFEM\", "
                       "\"restScale\": 0.95}, {\"type\": \"TriangularFEM\"}]"),
                 "inline.json", kScenes);
  ASSERT_EQ(s.forceFields.size(), 3u);
  using Springs = forcefields::StretchParameters;
  using Fem = forcefields::TriangularFEMParameters;
  EXPECT_EQ(std::any_cast<const Springs&>(s.forceFields[0].parameters).restScale, 0.98);
  EXPECT_EQ(std::any_cast<const Fem&>(s.forceFields[1].parameters).restScale, 0.95);
  EXPECT_EQ(std::any_cast<const Fem&>(s.forceFields[2].parameters).restScale, 1.0);  // default
}

TEST(Scene, MissingTopLevelKeysNameTheRoot) {
  EXPECT_THAT(parseError("{\"mesh\": {\"grid\": {\"nx\": 3, \"ny\": 3}}, \"timeStep\": 1, "
                         "\"duration\": 1}"),
              StartsWith("inline.json:1: /: missing key \"mass\""));
  EXPECT_THAT(parseError("[1, 2]"), StartsWith("inline.json:1: /: expected an object"));
  EXPECT_THAT(parseError("{}\n{}"), StartsWith("inline.json:2: invalid JSON"));
}

TEST(Scene, PointersEscapeSlashAndTilde) {
  EXPECT_THAT(parseError("{\n\"a/b~c\": 1}"),
              StartsWith("inline.json:2: /a~1b~0c: unknown key \"a/b~c\""));
}

TEST(Scene, NumbersOnTheirOwnLine) {
  // A number is recognised when the character after it is read: a newline must not count.
  const std::string text = scene("\"output\": {\"every\":\n    0\n  }");
  EXPECT_THAT(parseError(text), StartsWith("inline.json:7: /output/every: must be between 1"));
}

// ---- running ----

TEST(SceneRunner, PlaysTheSmallScene) {
  const Scene s = loadScene(kScenes / "small.json");
  SceneRunner runner(s);
  Simulation& sim = runner.simulation();
  EXPECT_EQ(sim.numForceFields(), 2u);
  EXPECT_EQ(sim.forceFieldLabel(0), "StretchSprings");
  EXPECT_EQ(sim.fixed().size(), 2u);
  const double mass0 = sim.mass().total();
  EXPECT_NEAR(mass0, 0.5, 1e-12);
  runner.start();
  EXPECT_EQ(runner.cutsDone(), 0);
  bool sawGrasp = false;
  while (!runner.finished()) {
    runner.advance();
    if (sim.findGrasp("pin")) sawGrasp = true;
    if (runner.currentStep() == 6) {
      EXPECT_EQ(runner.cutsDone(), 1);                // the cut at 0.05
      EXPECT_NEAR(sim.mass().total(), mass0, 1e-12);  // a cut conserves mass
    }
    const topology::ValidationReport report = sim.topology().validate();
    ASSERT_TRUE(report.ok()) << "step " << runner.currentStep() << ": " << report.summary();
  }
  EXPECT_TRUE(sawGrasp);
  EXPECT_EQ(sim.findGrasp("pin"), nullptr);  // released at 0.25
  EXPECT_EQ(runner.currentStep(), 30);
  EXPECT_NEAR(runner.time(), 0.3, 1e-12);
  // The whole cut, the progressive cut in pieces (more than one), two removals.
  EXPECT_GT(runner.cutsDone(), 2);
  EXPECT_LT(sim.mass().total(), mass0);
  // The removal at t = duration ran: no triangle has its rest centroid in the corner box.
  for (topology::TriangleId t : sim.topology().triangles()) {
    const auto v = sim.topology().triangleVertices(t);
    double cx = 0, cy = 0;
    for (int i = 0; i < 3; ++i) {
      cx += sim.topology().restPosition(v[i])[0] / 3;
      cy += sim.topology().restPosition(v[i])[1] / 3;
    }
    EXPECT_FALSE(cx >= 0.8 && cy >= 0.8) << "triangle " << t << " centroid " << cx << ", " << cy;
  }
  ASSERT_NE(runner.bendingField(), nullptr);
}

TEST(SceneRunner, ProgressiveCutEndsWhereTheWholeCutWould) {
  // The same polyline cut at once and as a scalpel: both open the sheet along it, and the
  // progressive one does it in several pieces that join (one path: no stray tips). Without the
  // quality repair, which would change the point counts compared below.
  const std::string poly =
      "\"polyline\": [[0, 0.5, 0], [0.6, 0.55, 0], [0.75, 0.3, 0]], \"minAngle\": 0";
  const Scene once =
      parseScene(scene("\"timeline\": [{\"at\": 0.02, \"action\": \"cut\", " + poly + "}]"),
                 "a.json", kScenes);
  const Scene scalpel = parseScene(
      scene("\"timeline\": [{\"from\": 0.0, \"to\": 0.1, \"action\": \"cut\", " + poly + "}]"),
      "b.json", kScenes);
  SceneRunner a(once), b(scalpel);
  a.start();
  b.start();
  while (!a.finished()) a.advance();
  while (!b.finished()) b.advance();
  EXPECT_EQ(a.cutsDone(), 1);
  EXPECT_GT(b.cutsDone(), 2);
  auto boundary = [](const topology::Topology& t) {
    std::size_t n = 0;
    for (topology::EdgeId e : t.edges()) n += t.isBoundaryEdge(e);
    return n;
  };
  EXPECT_TRUE(b.simulation().topology().validate().ok());
  // Both opened: more border edges than the uncut grid's 16.
  EXPECT_GT(boundary(a.simulation().topology()), 16u);
  EXPECT_GT(boundary(b.simulation().topology()), 16u);
  // Each cut ends at one interior tip: every point where the cut ends has one copy at most, and
  // the number of points added differs only by the extra vertices where pieces meet.
  EXPECT_GE(b.simulation().topology().numPoints(), a.simulation().topology().numPoints());
}

/// The surgery demo's progressive U incision: after every step the rest mesh's smallest altitude
/// stays above an eighth of the median edge (a tiny triangle sets the stable explicit time step).
/// Pieces that would end just short of, or just past, a corner of the U end at the corner; without
/// that, a tip a fraction of an edge before a corner left a triangle with an altitude of 0.05 of
/// the median edge for the rest of the run.
TEST(SceneRunner, ProgressiveIncisionLeavesNoTinyTriangles) {
  SceneRunner runner(loadScene(kDemoScenes / "surgery_incision.json"));
  runner.start();
  auto altitudes = [](const topology::Topology& t, double& smallest, double& median) {
    std::vector<double> edges;
    smallest = 1e300;
    for (topology::TriangleId f : t.triangles()) {
      auto v = t.triangleVertices(f);
      std::array<topology::Vec3, 3> p{t.restPosition(v[0]), t.restPosition(v[1]),
                                      t.restPosition(v[2])};
      double longest = 0;
      for (int k = 0; k < 3; ++k) {
        const auto& a = p[std::size_t(k)];
        const auto& b = p[std::size_t((k + 1) % 3)];
        const double l = std::hypot(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
        edges.push_back(l);
        longest = std::max(longest, l);
      }
      const double ux = p[1][0] - p[0][0], uy = p[1][1] - p[0][1], wx = p[2][0] - p[0][0],
                   wy = p[2][1] - p[0][1];
      smallest = std::min(smallest, std::abs(ux * wy - uy * wx) / longest);
    }
    std::nth_element(edges.begin(), edges.begin() + std::ptrdiff_t(edges.size() / 2), edges.end());
    median = edges[edges.size() / 2];
  };
  double worst = 1e300, median = 0;
  while (!runner.finished() && runner.simulation().time() < 1.25) {
    runner.advance();
    double smallest = 0;
    altitudes(runner.simulation().topology(), smallest, median);
    worst = std::min(worst, smallest / median);
    ASSERT_GE(smallest, median / 8) << "at t = " << runner.simulation().time();
  }
  EXPECT_GT(runner.cutsDone(), 10);
  std::cout << "progressive U incision: smallest altitude over the run " << worst
            << " of the median edge\n";
}

TEST(SceneRunner, TearingRunsAcrossThePull) {
  // A 2 m x 0.75 m strip with a notch in the middle of its top border, pulled slowly along x by
  // its two ends: the crack starts at the notch and runs across the strip to the bottom border.
  const std::string text =
      "{\n"
      "  \"mesh\": {\"grid\": {\"nx\": 17, \"ny\": 7, \"size\": [2, 0.75]}},\n"
      "  \"mass\": {\"total\": 0.1},\n"
      "  \"forceFields\": [{\"type\": \"StretchSprings\", \"stiffness\": 100, \"damping\": 0.1}],\n"
      "  \"solver\": {\"type\": \"implicit-cg\", \"iterations\": 200, \"tolerance\": 1e-10,\n"
      "             \"rayleighMass\": 1},\n"
      "  \"timeStep\": 0.02,\n"
      "  \"duration\": 4,\n"
      "  \"timeline\": [\n"
      "    {\"at\": 0, \"action\": \"tearing\", \"threshold\": 0.3, \"maxPerStep\": 1},\n"
      "    {\"at\": 0, \"action\": \"cut\", \"polyline\": [[1, 0.75, 0], [1, 0.5, 0]]},\n"
      "    {\"at\": 0, \"action\": \"grasp\", \"name\": \"l\", \"box\": [[0, 0, -1], [0, 1, 1]],\n"
      "     \"path\": [[0, 0, 0, 0], [4, -0.5, 0, 0]]},\n"
      "    {\"at\": 0, \"action\": \"grasp\", \"name\": \"r\", \"box\": [[2, 0, -1], [2, 1, 1]],\n"
      "     \"path\": [[0, 0, 0, 0], [4, 0.5, 0, 0]]}\n"
      "  ]\n"
      "}\n";
  const Scene s = parseScene(text, "tear.json", kScenes);
  SceneRunner runner(s);
  runner.start();
  double maxReaction = 0;
  while (!runner.finished()) {
    runner.advance();
    maxReaction =
        std::max(maxReaction, std::abs(runner.simulation().findGrasp("r")->reaction()[0]));
    ASSERT_TRUE(runner.simulation().topology().validate().ok());
  }
  EXPECT_GT(runner.tornEdges(), 5);
  const topology::Topology& topo = runner.simulation().topology();
  // The copies made by the tears (points sharing a rest position) stay near the middle of the
  // strip: the crack runs across the pull, not along it; one reached the bottom border.
  const topology::MeshData m = topo.toMeshData();
  std::size_t copies = 0;
  bool bottom = false;
  for (std::size_t i = 0; i < m.points.size(); ++i) {
    for (std::size_t j = i + 1; j < m.points.size(); ++j) {
      if (m.points[i] == m.points[j]) {
        ++copies;
        EXPECT_NEAR(m.points[i][0], 1.0, 0.55) << "copy at y = " << m.points[i][1];
        bottom = bottom || m.points[i][1] == 0.0;
      }
    }
  }
  EXPECT_GT(copies, 6u);
  EXPECT_TRUE(bottom);
  // Parted: the right grasp ends up pulling (almost) nothing.
  EXPECT_LT(std::abs(runner.simulation().findGrasp("r")->reaction()[0]), 0.01 * maxReaction);
}

// ---- strain measures ----

TEST(Tearing, StrainOfAUniformStretch) {
  const topology::MeshData m = makeGrid(GridSpec{3, 3, 1, 1, true, false, {0, 0, 0}});
  topology::Topology topo(m);
  std::vector<double> x;
  for (const Vec3& p : m.points) {
    x.push_back(1.2 * p[0]);  // 20 % along x
    x.push_back(p[1]);
    x.push_back(p[2]);
  }
  const double green = 0.5 * (1.2 * 1.2 - 1);
  for (topology::TriangleId t : topo.triangles()) {
    const auto e = triangleGreenStrain(topo, x, t);
    EXPECT_NEAR(maxPrincipalStrain(topo, x, t), green, 1e-12);
    EXPECT_NEAR(e[0] + e[2], green, 1e-12);  // the trace is frame-independent
    for (topology::EdgeId edge : topo.triangleEdges(t)) {
      const auto v = topo.edgeVertices(edge);
      const Vec3 a = topo.restPosition(v[0]), b = topo.restPosition(v[1]);
      const double s = strainNormalToEdge(topo, x, t, edge);
      if (a[0] == b[0]) {
        EXPECT_NEAR(s, green, 1e-12);  // an edge along y: its normal is x
      } else if (a[1] == b[1]) {
        EXPECT_NEAR(s, 0.0, 1e-12);  // an edge along x: its normal is y
      } else {
        EXPECT_NEAR(s, 0.5 * green, 1e-12);  // a diagonal: normal at 45 degrees
      }
    }
  }
  // Rigid motion: no strain anywhere, nothing to tear.
  std::vector<double> rigid;
  for (const Vec3& p : m.points) {
    rigid.push_back(-p[1] + 3);  // rotated by 90 degrees about z, then moved
    rigid.push_back(p[0]);
    rigid.push_back(p[2] + 1);
  }
  for (topology::TriangleId t : topo.triangles()) {
    EXPECT_NEAR(maxPrincipalStrain(topo, rigid, t), 0.0, 1e-12);
  }
  EXPECT_TRUE(tearCandidates(topo, rigid, 1e-6).empty());
  // Under the stretch, only the interior edges along y are candidates.
  const auto candidates = tearCandidates(topo, x, 0.5 * green + 0.01);
  EXPECT_EQ(candidates.size(), 2u);  // the interior vertical edges of a 3 x 3 grid
  for (const TearCandidate& c : candidates) {
    const auto v = topo.edgeVertices(c.edge);
    EXPECT_EQ(topo.restPosition(v[0])[0], topo.restPosition(v[1])[0]);
  }
}

}  // namespace
}  // namespace cutsim::core
