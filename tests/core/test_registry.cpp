// The component registries: every registered force field, integrator and linear solver is read
// from a scene, built and stepped; unknown types and keys name the alternatives.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cutsim/core/integrators/newton.hpp"
#include "cutsim/core/registries.hpp"
#include "cutsim/core/scene.hpp"
#include "support/scene_text.hpp"

namespace cutsim::test {
namespace {

using test::scene;
using ::testing::HasSubstr;

/// A JSON value of a key's declared type: a number, an integer, a boolean, a choice's or a
/// string's last declared value (a choice's default comes first: the last is another one), a box,
/// an object's declared example.
std::string valueOf(const KeyInfo& key) {
  switch (key.type) {
    case KeyType::Number:
      return "0.2";
    case KeyType::Integer:
      return "1";
    case KeyType::Boolean:
      return "false";
    case KeyType::Choice:
    case KeyType::String:
      if (key.choices.empty())
        ADD_FAILURE() << key.name << ": a " << toString(key.type) << " key declares no value";
      return "\"" + (key.choices.empty() ? std::string() : key.choices.back()) + "\"";
    case KeyType::Box:
      return "[[-1, -1, -1], [1, 1, 1]]";
    case KeyType::Object:
      if (!key.choices.empty()) return key.choices.back();  // an example object, as JSON
      [[fallthrough]];
    default:
      ADD_FAILURE() << key.name << ": no value made for a key of type " << toString(key.type);
      return "null";
  }
}

/// What a force field needs besides its type: its required keys, with values of their types.
std::string requiredKeys(const std::string& type, const std::string& except = "") {
  std::string out;
  for (const KeyInfo& k : forcefields::ForceFieldRegistry::instance().find(type)->keys)
    if (k.required && k.name != except) out += ", \"" + k.name + "\": " + valueOf(k);
  return out;
}

/// The names joined by ", ", each with a prefix ("the linear solver ").
std::string joined(const std::vector<std::string>& names, const std::string& prefix = "") {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + prefix + n;
  return out;
}

std::string sceneWith(const std::string& forceFields, const std::string& stepping) {
  return "{\n"
         "  \"mesh\": {\"grid\": {\"nx\": 6, \"ny\": 6, \"size\": [0.5, 0.5]}},\n"
         "  \"mass\": {\"density\": 1},\n"
         "  \"gravity\": [0, 0, -9.81],\n"
         "  \"constraints\": [{\"type\": \"fixed\", \"points\": [0, 5]}],\n"
         "  \"forceFields\": [" +
         forceFields + "],\n" + (stepping.empty() ? "" : "  " + stepping + ",\n") +
         "  \"timeStep\": 0.001,\n"
         "  \"duration\": 0.005\n"
         "}\n";
}

/// Loads, builds and runs the scene; every point stays finite and the free ones fall.
void runsAndFalls(const std::string& text) {
  const core::Scene s = core::parseScene(text, "inline.json", kSceneDir);
  core::SceneRunner runner(s);
  runner.start();
  while (!runner.finished()) runner.advance();
  const auto& sim = runner.simulation();
  auto x = sim.state().x();
  for (double c : x) ASSERT_TRUE(std::isfinite(c));
  EXPECT_LT(x[3 * 20 + 2], 0.0);  // an interior point moved down
  EXPECT_EQ(x[3 * 5 + 2], 0.0);   // a fixed one did not
}

/// docs/scenes.md, where every component a scene can name is documented.
std::string scenesDoc() {
  std::ifstream in(std::filesystem::path(CUTSIM_DATA_DIR).parent_path() / "docs" / "scenes.md");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Every registered component is documented where scene writers look (a new one is its own file,
// its tests, and its lines in docs/scenes.md); the libraries are linked whole, so the core's
// registrations are all there (the bending springs among them).
TEST(Registry, EveryRegisteredComponentIsDocumentedInTheSceneFormat) {
  const std::string doc = scenesDoc();
  ASSERT_FALSE(doc.empty());
  auto documented = [&](const std::vector<std::string>& names, const char* kind) {
    EXPECT_FALSE(names.empty()) << kind;
    for (const std::string& n : names)
      EXPECT_TRUE(doc.find("`" + n + "`") != std::string::npos ||
                  doc.find("\"" + n + "\"") != std::string::npos)
          << "the " << kind << " " << n << " is not named in docs/scenes.md";
  };
  documented(forcefields::ForceFieldRegistry::instance().names(), "force field");
  documented(core::IntegratorRegistry::instance().names(), "integrator");
  documented(core::LinearSolverRegistry::instance().names(), "linear solver");
  documented(core::ActionRegistry::instance().names(), "action");
  documented(core::ConstraintRegistry::instance().names(), "constraint");
  documented(forcefields::ObstacleShapeRegistry::instance().names(), "obstacle shape");
  documented(core::StepHookRegistry::instance().names(), "step hook");
  EXPECT_NE(forcefields::ForceFieldRegistry::instance().find("FastTriangularBendingSprings"),
            nullptr);
}

TEST(Registry, ActionsAndConstraintsNameTheirKeysAndTheAlternatives) {
  const std::string ok = "{\"type\": \"StretchSprings\", \"stiffness\": 20}";
  auto timeline = [&](const std::string& action) {
    return sceneWith(ok, "\"timeline\": [" + action + "]");
  };
  EXPECT_THAT(parseError(timeline("{\"at\": 0, \"action\": \"explode\"}")),
              HasSubstr("/timeline/0/action: unknown action \"explode\" (" +
                        joined(core::ActionRegistry::instance().names()) + ")"));
  EXPECT_THAT(
      parseError(
          timeline("{\"at\": 0, \"action\": \"tearing\", \"threshold\": 0.3, \"girth\": 1}")),
      HasSubstr(
          "/timeline/0/girth: unknown key \"girth\" for tearing; expected one of: action, at, "
          "threshold, maxPerStep"));
  // A key of another action says whose it is.
  EXPECT_THAT(
      parseError(
          timeline("{\"at\": 0, \"action\": \"tearing\", \"threshold\": 0.3, \"radius\": 1}")),
      HasSubstr("/timeline/0/radius: unknown key \"radius\" for tearing (it belongs to cautery, "
                "forceps, sew)"));
  EXPECT_THAT(parseError(timeline(
                  "{\"at\": 0, \"action\": \"tearing\", \"threshold\": 0.3, \"polyline\": []}")),
              HasSubstr("(it belongs to cut, dissect)"));
  EXPECT_THAT(
      parseError(timeline("{\"at\": 0, \"action\": \"remove\", \"sphere\": {\"center\": [0, 0, 0], "
                          "\"radius\": 1, \"colour\": 2}}")),
      HasSubstr("/timeline/0/sphere/colour: unknown key \"colour\""));
  EXPECT_THAT(
      parseError(scene("\"constraints\": [{\"type\": \"fixed\", \"box\": [[0, 0, 0], [1, 1, 1]], "
                       "\"points\": [1]}]")),
      HasSubstr("/constraints/0: give exactly one of \"points\", \"box\" or \"near\""));
}

TEST(Registry, EveryForceFieldParsesBuildsAndSteps) {
  for (const std::string& type : forcefields::ForceFieldRegistry::instance().names()) {
    SCOPED_TRACE(type);
    // Stretch springs keep the sheet together under every field.
    const std::string fields = "{\"type\": \"StretchSprings\", \"stiffness\": 100}, {\"type\": \"" +
                               type + "\"" + requiredKeys(type) + ", \"label\": \"under test\"}";
    runsAndFalls(sceneWith(fields, ""));
  }
}

// Every step hook is read from its own section (named as its entry), with every key given a value
// of its declared type, builds and steps; each key it declares required is refused when missing.
TEST(Registry, EveryStepHookTakesItsKeysBuildsStepsAndNeedsItsRequiredOnes) {
  const std::string ok = "{\"type\": \"StretchSprings\", \"stiffness\": 100}";
  const auto& registry = core::StepHookRegistry::instance();
  ASSERT_FALSE(registry.names().empty());
  for (const auto& [name, entry] : registry.entries()) {
    SCOPED_TRACE(name);
    auto section = [&](const std::string& except) {
      std::string keys;
      for (const KeyInfo& k : entry.keys)
        if (k.name != except)
          keys += std::string(keys.empty() ? "" : ", ") + "\"" + k.name + "\": " + valueOf(k);
      return "\"" + name + "\": {" + keys + "}";
    };
    runsAndFalls(sceneWith(ok, section("")));
    for (const KeyInfo& k : entry.keys) {
      if (!k.required) continue;
      EXPECT_THAT(parseError(sceneWith(ok, section(k.name))),
                  HasSubstr("missing key \"" + k.name + "\""));
    }
    EXPECT_THAT(parseError(sceneWith(ok, "\"" + name + "\": {\"colour\": 1}")),
                HasSubstr("/" + name + "/colour: unknown key \"colour\" for " + name +
                          "; expected one of: " + entry.keys.front().name));
  }
}

TEST(Registry, EveryForceFieldTakesEachOfItsKeys) {
  const auto& registry = forcefields::ForceFieldRegistry::instance();
  for (const auto& [type, entry] : registry.entries()) {
    for (const KeyInfo& key : entry.keys) {
      SCOPED_TRACE(type + "." + key.name + " (" + toString(key.type) + ")");
      // A value of the key's declared type: parsing must accept it.
      const std::string field = "{\"type\": \"" + type + "\", \"" + key.name +
                                "\": " + valueOf(key) + requiredKeys(type, key.name) + "}";
      EXPECT_EQ(parseError(sceneWith(field, "")), "");
    }
  }
}

// A key declared required is: the field refuses to be read without it.
TEST(Registry, EveryRequiredKeyOfAForceFieldIsRequired) {
  for (const auto& [type, entry] : forcefields::ForceFieldRegistry::instance().entries())
    for (const KeyInfo& key : entry.keys) {
      if (!key.required) continue;
      SCOPED_TRACE(type + "." + key.name);
      EXPECT_THAT(parseError(sceneWith(
                      "{\"type\": \"" + type + "\"" + requiredKeys(type, key.name) + "}", "")),
                  HasSubstr("missing key \"" + key.name + "\""));
    }
}

const std::string kStretch = "{\"type\": \"StretchSprings\", \"stiffness\": 20}";

/// The first linear solver a scene may give the integrator (some take only their own).
std::string solverFor(const std::string& integrator) {
  for (const std::string& solver : core::LinearSolverRegistry::instance().names())
    if (parseError(sceneWith(kStretch, "\"integrator\": {\"type\": \"" + integrator +
                                           "\"}, \"linearSolver\": {\"type\": \"" + solver + "\"}"))
            .empty())
      return solver;
  ADD_FAILURE() << "no linear solver for " << integrator;
  return "";
}

/// The first integrator that solves with the linear solver in a scene.
std::string integratorFor(const std::string& solver) {
  for (const auto& [name, entry] : core::IntegratorRegistry::instance().entries())
    if (!entry.uses.empty() &&
        parseError(sceneWith(kStretch, "\"integrator\": {\"type\": \"" + name +
                                           "\"}, \"linearSolver\": {\"type\": \"" + solver + "\"}"))
            .empty())
      return name;
  ADD_FAILURE() << "no integrator solves with " << solver;
  return "";
}

// Each key of every integrator and linear solver takes a value of its declared type.
TEST(Registry, EveryIntegratorAndLinearSolverTakesEachOfItsKeys) {
  const std::string fields = "{\"type\": \"StretchSprings\", \"stiffness\": 20}";
  for (const auto& [name, entry] : core::IntegratorRegistry::instance().entries())
    for (const KeyInfo& key : entry.keys) {
      SCOPED_TRACE(name + "." + key.name + " (" + toString(key.type) + ")");
      const std::string solver =
          entry.uses.empty() ? "" : ", \"linearSolver\": {\"type\": \"" + solverFor(name) + "\"}";
      const std::string integrator = "\"integrator\": {\"type\": \"" + name + "\", \"" + key.name +
                                     "\": " + valueOf(key) + "}" + solver;
      EXPECT_EQ(parseError(sceneWith(fields, integrator)), "");
    }
  for (const auto& [name, entry] : core::LinearSolverRegistry::instance().entries())
    for (const KeyInfo& key : entry.keys) {
      SCOPED_TRACE(name + "." + key.name + " (" + toString(key.type) + ")");
      const std::string integrator = "\"integrator\": {\"type\": \"" + integratorFor(name) +
                                     "\"}, \"linearSolver\": {\"type\": \"" + name + "\", \"" +
                                     key.name + "\": " + valueOf(key) + "}";
      EXPECT_EQ(parseError(sceneWith(fields, integrator)), "");
    }
}

TEST(Registry, EveryIntegratorWithEveryLinearSolverSteps) {
  for (const auto& [name, entry] : core::IntegratorRegistry::instance().entries()) {
    const bool usesSolver = !entry.uses.empty();
    const std::vector<std::string> solvers =
        usesSolver ? core::LinearSolverRegistry::instance().names() : std::vector<std::string>{""};
    for (const std::string& solver : solvers) {
      SCOPED_TRACE(name + " " + solver);
      std::string stepping = "\"integrator\": {\"type\": \"" + name + "\"}";
      if (!solver.empty()) stepping += ", \"linearSolver\": {\"type\": \"" + solver + "\"}";
      const std::string fields = "{\"type\": \"StretchSprings\", \"stiffness\": 20}";
      if (name == "sofa-euler" && solver != "sofa-cg") {  // SOFA's pair only, said so
        EXPECT_THAT(parseError(sceneWith(fields, stepping)), HasSubstr("solves with \"sofa-cg\""));
        continue;
      }
      const core::Scene s = core::parseScene(sceneWith(fields, stepping), "inline.json", kSceneDir);
      EXPECT_EQ(s.integrator.type, name);
      core::SceneRunner runner(s);
      EXPECT_EQ(runner.simulation().integrator().name(), name);
      if (usesSolver) {
        EXPECT_EQ(runner.simulation().integrator().linearSolver()->name(), solver);
      }
      runsAndFalls(sceneWith(fields, stepping));
    }
  }
}

TEST(Registry, IntegratorSettingsReachTheIntegrator) {
  const std::string text = sceneWith("{\"type\": \"StretchSprings\", \"stiffness\": 20}",
                                     "\"integrator\": {\"type\": \"newton\", \"maxIterations\": 7, "
                                     "\"rayleighMass\": 0.25, \"onSolveFailure\": \"warn\"}, "
                                     "\"linearSolver\": {\"type\": \"cg\", \"iterations\": 33}");
  core::SceneRunner runner(core::parseScene(text, "inline.json", kSceneDir));
  auto& newton = dynamic_cast<core::NewtonImplicitEuler&>(runner.simulation().integrator());
  EXPECT_EQ(newton.newtonSettings().maxIterations, 7);
  EXPECT_EQ(newton.settings().rayleighMass, 0.25);
  EXPECT_EQ(newton.settings().onSolveFailure, core::SolveFailurePolicy::Warn);
  auto& cg = dynamic_cast<core::ConjugateGradient&>(*newton.linearSolver());
  EXPECT_EQ(cg.settings().maxIterations, 33);
}

struct BadCase {
  std::string forceFields, stepping, where, phrase;
};

TEST(Registry, BadComponentsNameTheAlternatives) {
  const std::string ok = "{\"type\": \"StretchSprings\", \"stiffness\": 20}";
  // The alternatives the messages name, from the registries (a new component changes nothing here).
  const auto& fields = forcefields::ForceFieldRegistry::instance();
  const auto& integrators = core::IntegratorRegistry::instance();
  const auto& solvers = core::LinearSolverRegistry::instance();
  std::vector<std::string> solving, ownersOfYoung = fields.ownersOf("youngModulus"),
                                    ownersOfRayleigh = integrators.ownersOf("rayleighMass");
  for (const auto& [name, entry] : integrators.entries())
    if (!entry.uses.empty()) solving.push_back(name);
  const std::vector<BadCase> cases = {
      {"{\"type\": \"Magnet\"}", "", "inline.json:6: /forceFields/0/type: ",
       "unknown force field type \"Magnet\" (registered: " + joined(fields.names()) + ")"},
      {"{\"type\": \"FastTriangularBendingSprings\", \"youngModulus\": 3}", "",
       "inline.json:6: /forceFields/0/youngModulus: ",
       "unknown key \"youngModulus\" for FastTriangularBendingSprings (it belongs to " +
           joined(ownersOfYoung) + "); expected one of: type, label, bendingStiffness"},
      {"{\"type\": \"TriangularFEM\", \"poissonRatio\": 0.5}", "",
       "inline.json:6: /forceFields/0/poissonRatio: ", "0.5"},
      {ok, "\"integrator\": {\"type\": \"rk4\"}", "inline.json:7: /integrator/type: ",
       "unknown integrator type \"rk4\" (registered: " + joined(integrators.names()) + ")"},
      {ok, "\"integrator\": {\"type\": \"newton\"}, \"linearSolver\": {\"type\": \"pardiso\"}",
       "inline.json:7: /linearSolver/type: ",
       "unknown linear solver type \"pardiso\" (registered: " + joined(solvers.names()) + ")"},
      {ok, "\"integrator\": {\"type\": \"implicit-euler\", \"iterations\": 20}",
       "inline.json:7: /integrator/iterations: ",
       "unknown key \"iterations\" for implicit-euler (it belongs to " +
           joined(solvers.ownersOf("iterations"), "the linear solver ") +
           "); expected one of: type, rayleighMass"},
      {ok, "\"integrator\": {\"type\": \"explicit-euler\"}, \"linearSolver\": {\"type\": \"cg\"}",
       "inline.json:7: /linearSolver: ",
       "the integrator \"explicit-euler\" uses no linear solver (the integrators that do: " +
           joined(solving) + ")"},
      {ok, "\"integrator\": {\"type\": \"explicit-euler\", \"rayleighMass\": 0.1}",
       "inline.json:7: /integrator/rayleighMass: ",
       "unknown key \"rayleighMass\" for explicit-euler (it belongs to " +
           joined(ownersOfRayleigh) + ")"},
      {ok, "\"integrator\": {\"type\": \"bdf2\", \"fallbackSolver\": \"pardiso\"}",
       "inline.json:7: /integrator/fallbackSolver: ",
       "unknown linear solver \"pardiso\" (" + joined(solvers.names()) + ")"},
      {ok,
       "\"integrator\": {\"type\": \"bdf2\", \"onSolveFailure\": \"warn\", \"fallbackSolver\": "
       "\"cg\"}",
       "inline.json:7: /integrator/fallbackSolver: ",
       "is used only with \"onSolveFailure\": \"fallback\""},
      {ok, "\"integrator\": {\"type\": \"bdf2\", \"onSolveFailure\": \"retry\"}",
       "inline.json:7: /integrator/onSolveFailure: ",
       "unknown value \"retry\" (warn, fail, fallback)"},
      {ok, "\"solver\": {\"type\": \"implicit-cg\"}, \"integrator\": {\"type\": \"bdf2\"}",
       "inline.json:7: /integrator: ",
       "give either \"solver\" (the shorthand of the first scenes) or \"integrator\" and "
       "\"linearSolver\""},
      {ok, "\"solver\": {\"type\": \"implicit-cg\", \"onSolveFailure\": \"warn\"}",
       "inline.json:7: /solver/onSolveFailure: ",
       "give \"integrator\" and \"linearSolver\" for every other setting"},
      {ok, "\"solver\": {\"type\": \"explicit\", \"iterations\": 20}",
       "inline.json:7: /solver/iterations: ",
       "the solver \"explicit\" does not use \"iterations\""},
      {ok, "\"linearSolver\": {\"type\": \"cg\", \"iterations\": 0}",
       "inline.json:7: /linearSolver/iterations: ", "must be between 1 and 1000000"},
  };
  for (const BadCase& c : cases) {
    SCOPED_TRACE(c.stepping + " " + c.forceFields);
    const std::string message = parseError(sceneWith(c.forceFields, c.stepping));
    EXPECT_THAT(message, ::testing::StartsWith(c.where));
    EXPECT_THAT(message, HasSubstr(c.phrase));
  }
}

TEST(Registry, TheSolverShorthandStillReadsTheFirstScenes) {
  const std::string ok = "{\"type\": \"StretchSprings\", \"stiffness\": 20}";
  struct Case {
    std::string solver, integrator, linear;
  };
  for (const Case& c : std::vector<Case>{{"explicit", "explicit-euler", ""},
                                         {"implicit-cg", "implicit-euler", "cg"},
                                         {"implicit-cholmod", "implicit-euler", "cholmod"}}) {
    const core::Scene s = core::parseScene(
        sceneWith(ok, "\"solver\": {\"type\": \"" + c.solver + "\"}"), "inline.json", kSceneDir);
    EXPECT_EQ(s.integrator.type, c.integrator);
    EXPECT_EQ(s.linearSolver ? s.linearSolver->type : "", c.linear);
  }
}

}  // namespace
}  // namespace cutsim::test
