// Energy accounting (cutsim/core/energy.hpp, docs/energy.md): the balance of a closed system within
// each integrator's error (bounded and first order for symplectic Euler, only losing for implicit
// Euler, far less for BDF2), damping, grasps, gravity, a removal and contact each accounted,
// checkpoints, a failed step leaving the accounts as they were, the scene key and the CSV columns.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/core/energy.hpp"
#include "cutsim/core/output.hpp"
#include "cutsim/core/scene.hpp"
#include "cutsim/core/simulation.hpp"
#include "support/scene_text.hpp"

namespace cutsim::core {
namespace {

using ::testing::HasSubstr;

/// A free 1 m sheet whose springs are 10% shorter than its mesh: let go, it contracts and rings.
std::string ringing(const std::string& integrator, double dt, double duration,
                    const std::string& extra = "") {
  return R"({
  "mesh": {"grid": {"nx": 9, "ny": 9, "size": [1, 1]}},
  "mass": {"total": 0.1},
  "forceFields": [
    {"type": "StretchSprings", "stiffness": 50, "restScale": 0.9},
    {"type": "FastTriangularBendingSprings", "bendingStiffness": 0.001}
  ],
  "integrator": )" +
         integrator + R"(,
  "timeStep": )" +
         std::to_string(dt) + R"(, "duration": )" + std::to_string(duration) + extra + R"(,
  "output": {"energy": true}
})";
}

struct Account {
  double storedStart = 0, maxStored = 0;
  double worstDrift = 0;  // largest |drift| over the run
  double finalDrift = 0;
  EnergyFlows total;
  bool driftNeverPositive = true;  // beyond rounding
};

Account play(const std::string& text, long steps = -1) {
  const Scene scene = parseScene(text, "inline.json", test::kSceneDir);
  SceneRunner runner(scene);
  Simulation& sim = runner.simulation();
  Account r;
  r.storedStart = r.maxStored = EnergyLedger::stored(sim.model());
  runner.start();
  const long n = steps < 0 ? runner.numSteps() : steps;
  for (long i = 0; i < n; ++i) {
    runner.advance();
    const EnergyLedger* e = sim.energy();
    r.maxStored = std::max(r.maxStored, e->storedEnergy());
    r.worstDrift = std::max(r.worstDrift, std::abs(e->drift()));
    if (e->drift() > 1e-9 * r.maxStored) r.driftNeverPositive = false;
    r.finalDrift = e->drift();
    r.total = e->total();
  }
  return r;
}

TEST(Energy, SymplecticEulerKeepsTheBalanceOfAClosedSystemWithinFirstOrder) {
  // Symplectic Euler conserves a shadow energy: the balance oscillates within O(h), no drift.
  const Account coarse = play(ringing(R"({"type": "explicit-euler"})", 1e-4, 0.05));
  const Account fine = play(ringing(R"({"type": "explicit-euler"})", 5e-5, 0.05));
  ASSERT_GT(coarse.storedStart, 0.1);
  EXPECT_LT(coarse.worstDrift, 1e-2 * coarse.storedStart);
  const double ratio = fine.worstDrift / coarse.worstDrift;
  EXPECT_GT(ratio, 0.35) << fine.worstDrift << " / " << coarse.worstDrift;
  EXPECT_LT(ratio, 0.65) << fine.worstDrift << " / " << coarse.worstDrift;
  EXPECT_EQ(coarse.total.gravity, 0.0);
  EXPECT_EQ(coarse.total.damping, 0.0);
  EXPECT_EQ(coarse.total.removed, 0.0);
  EXPECT_EQ(coarse.total.constraints, 0.0);
}

TEST(Energy, ImplicitEulerOnlyLosesEnergyAndBDF2LosesFarLess) {
  const std::string solver = R"(, "linearSolver": {"type": "cholmod"})";
  const Account coarse = play(ringing(R"({"type": "implicit-euler"})", 2e-4, 0.05, solver));
  const Account fine = play(ringing(R"({"type": "implicit-euler"})", 1e-4, 0.05, solver));
  const Account bdf2 = play(ringing(R"({"type": "bdf2"})", 2e-4, 0.05, solver));
  // Numerical dissipation: the balance only falls, less at half the step.
  EXPECT_TRUE(coarse.driftNeverPositive);
  EXPECT_TRUE(fine.driftNeverPositive);
  EXPECT_LT(coarse.finalDrift, -0.05 * coarse.storedStart);
  EXPECT_LT(fine.finalDrift / coarse.finalDrift, 0.8)
      << fine.finalDrift << " / " << coarse.finalDrift;
  // BDF2, second order, loses a small part of what implicit Euler does at the same step.
  EXPECT_LT(std::abs(bdf2.finalDrift), 0.1 * std::abs(coarse.finalDrift))
      << bdf2.finalDrift << " against " << coarse.finalDrift;
}

TEST(Energy, WhatDampingTakesIsCountedAsDissipated) {
  const std::string solver = R"(, "linearSolver": {"type": "cholmod"})";
  // Rayleigh mass damping and the springs' own damping; Rayleigh stiffness damping.
  for (const std::string& text :
       {std::regex_replace(ringing(R"({"type": "bdf2", "rayleighMass": 20})", 1e-4, 0.05, solver),
                           std::regex("\"restScale\": 0.9"),
                           "\"restScale\": 0.9, \"damping\": 0.05"),
        ringing(R"({"type": "bdf2", "rayleighStiffness": 0.001})", 1e-4, 0.05, solver)}) {
    const Account a = play(text);
    // Half the energy and more goes, and the balance holds it to a thousandth of what went.
    EXPECT_GT(a.total.damping, 0.5 * a.storedStart);
    EXPECT_LT(a.worstDrift, 2e-3 * a.total.damping) << a.worstDrift << " of " << a.total.damping;
  }
}

TEST(Energy, GravityAndAGraspDoTheWorkOfTheirForces) {
  // A membrane held along x = 0, its other border grasped and pulled 0.1 m along x in 0.5 s,
  // sagging under gravity.
  const std::string text = R"({
  "mesh": {"grid": {"nx": 9, "ny": 9, "size": [1, 1]}},
  "mass": {"total": 0.1},
  "gravity": [0, 0, -9.81],
  "forceFields": [{"type": "TriangularFEM", "youngModulus": 1e4, "poissonRatio": 0.3,
                   "thickness": 0.01},
                  {"type": "FastTriangularBendingSprings", "bendingStiffness": 0.001}],
  "constraints": [{"type": "fixed", "box": [[-0.01, -0.01, -1], [0.01, 1.01, 1]]}],
  "integrator": {"type": "bdf2"}, "linearSolver": {"type": "cholmod"},
  "timeStep": 0.001, "duration": 0.5,
  "output": {"energy": true},
  "timeline": [{"at": 0, "action": "grasp", "name": "pull",
                "box": [[0.99, -0.01, -1], [1.01, 1.01, 1]], "path": [[0, 0, 0, 0], [0.5, 0.1, 0, 0]]}]
})";
  const Scene scene = parseScene(text, "inline.json", test::kSceneDir);
  SceneRunner runner(scene);
  Simulation& sim = runner.simulation();
  runner.start();
  auto centreHeight = [&] {
    const auto m = sim.mass().perPoint();
    const auto x = sim.state().x();
    double mz = 0.0;
    for (std::size_t p = 0; p < m.size(); ++p) mz += m[p] * x[3 * p + 2];
    return mz;
  };
  const double z0 = centreHeight();
  // The grasp's work from its reported force and its prescribed motion (0.2 m/s along x),
  // by the trapezoidal rule.
  double graspWork = 0.0, lastForce = 0.0;
  while (!runner.finished()) {
    runner.advance();
    const double f = sim.findGrasp("pull")->reaction()[0];
    graspWork += 0.5 * (lastForce + f) * 0.2 * 0.001;
    lastForce = f;
  }
  const EnergyLedger* e = sim.energy();
  ASSERT_NE(e, nullptr);
  // Gravity's work is its weight times the fall of the centre of mass, exactly.
  EXPECT_NEAR(e->total().gravity, -9.81 * (centreHeight() - z0),
              1e-12 + 1e-9 * std::abs(e->total().gravity));
  EXPECT_GT(std::abs(e->total().gravity), 1e-4);
  // The grasp's, its force along its path (the first step's jerk aside).
  EXPECT_NEAR(e->total().constraints, graspWork, 0.01 * graspWork);
  EXPECT_GT(e->total().constraints, 0.1);
  // Loaded slowly, the work is stored: the balance holds to a thousandth of it.
  EXPECT_LT(std::abs(e->drift()), 1e-3 * e->total().work()) << e->drift();
  EXPECT_EQ(e->total().damping, 0.0);
}

TEST(Energy, ARemovalTakesOutTheEnergyOfWhatItRemoves) {
  // A membrane 10% too small for its frame, held along its whole border: the strain, so the
  // energy per area, is the same everywhere; a box of whole triangles is removed at t = 0.
  const std::string text = R"({
  "mesh": {"grid": {"nx": 11, "ny": 11, "size": [1, 1]}},
  "mass": {"total": 0.1},
  "forceFields": [{"type": "TriangularFEM", "youngModulus": 1e4, "poissonRatio": 0.3,
                   "thickness": 0.01, "restScale": 0.9}],
  "constraints": [{"type": "fixed", "box": [[-0.01, -0.01, -1], [0.01, 1.01, 1]]},
                  {"type": "fixed", "box": [[0.99, -0.01, -1], [1.01, 1.01, 1]]},
                  {"type": "fixed", "box": [[-0.01, -0.01, -1], [1.01, 0.01, 1]]},
                  {"type": "fixed", "box": [[-0.01, 0.99, -1], [1.01, 1.01, 1]]}],
  "integrator": {"type": "bdf2"}, "linearSolver": {"type": "cholmod"},
  "timeStep": 0.0005, "duration": 0.02,
  "output": {"energy": true},
  "timeline": [{"at": 0, "action": "remove", "box": [[0.3, 0.3, -1], [0.7, 0.7, 1]],
                "boundary": "centroid", "minAngle": 0}]
})";
  const Scene scene = parseScene(text, "inline.json", test::kSceneDir);
  SceneRunner runner(scene);
  Simulation& sim = runner.simulation();
  const double before = EnergyLedger::stored(sim.model());
  const double trianglesBefore = double(sim.topology().numTriangles());
  runner.start();
  const double trianglesAfter = double(sim.topology().numTriangles());
  ASSERT_LT(trianglesAfter, trianglesBefore);
  const EnergyLedger* e = sim.energy();
  ASSERT_GT(before, 0.0);
  EXPECT_NEAR(e->total().removed, before * (1 - trianglesAfter / trianglesBefore), 1e-9 * before);
  // The hole's rim then pulls back (what BDF2 loses of that recoil is the drift); nothing more is
  // removed, and the balance never gains.
  while (!runner.finished()) {
    runner.advance();
    EXPECT_EQ(sim.energy()->lastStep().removed, 0.0);
    EXPECT_LT(sim.energy()->drift(), 1e-9 * before);
  }
}

/// A 0.3 m sheet dropped 3 cm onto a plane.
std::string drop(double friction, double slide) {
  return R"({
  "mesh": {"grid": {"nx": 11, "ny": 11, "size": [0.3, 0.3], "origin": [-0.15, -0.15, 0.03]}},
  "mass": {"total": 0.02},
  "gravity": [)" +
         std::to_string(slide) +
         R"(, 0, -9.81],
  "forceFields": [{"type": "StretchSprings", "stiffness": 300},
                  {"type": "FastTriangularBendingSprings", "bendingStiffness": 0.0005}],
  "contact": {"thickness": 0.005, "stiffness": 0.5, "friction": 0},
  "obstacles": [{"type": "plane", "name": "table", "point": [0, 0, 0], "normal": [0, 0, 1],
                 "friction": )" +
         std::to_string(friction) + R"(}],
  "integrator": {"type": "bdf2"}, "linearSolver": {"type": "cholmod"},
  "timeStep": 0.0005, "duration": 0.15,
  "output": {"energy": true}
})";
}

TEST(Energy, AStillObstacleDoesNoWorkAndFrictionTakesEnergy) {
  const Account still = play(drop(0.0, 0.0));
  // The penalty's energy is stored energy: the plane's force does no work of its own.
  EXPECT_EQ(still.total.contact, 0.0);
  EXPECT_GT(still.total.gravity, 1e-3);
  // What the bounce loses is BDF2's error on the stiff penalty: a part of the fall's energy.
  EXPECT_LT(still.worstDrift, 0.6 * still.maxStored);
  // Sliding down a slope (gravity tilted) with friction: friction's work is negative.
  const Account sliding = play(drop(0.5, 3.0));
  EXPECT_LT(sliding.total.contact, -1e-5);
}

TEST(Energy, AResumedRunKeepsTheSameAccounts) {
  const std::string text =
      std::regex_replace(drop(0.3, 1.0), std::regex("\"duration\": 0.15"), "\"duration\": 0.1");
  const Scene scene = parseScene(text, "inline.json", test::kSceneDir);
  const std::filesystem::path file =
      std::filesystem::path(::testing::TempDir()) / "cutsim_energy.ckpt";
  SceneRunner a(scene);
  a.start();
  while (a.currentStep() < 120) a.advance();
  {
    ArchiveWriter w;
    a.save(w);
    w.save(file);
  }
  ArchiveReader in(file);
  SceneRunner b(scene, in);
  while (!a.finished()) {
    a.advance();
    b.advance();
    const EnergyLedger* ea = a.simulation().energy();
    const EnergyLedger* eb = b.simulation().energy();
    ASSERT_EQ(ea->balance(), eb->balance()) << "at step " << a.currentStep();
    ASSERT_EQ(ea->total().contact, eb->total().contact);
    ASSERT_EQ(ea->stepDrift(), eb->stepDrift());
  }
  std::filesystem::remove(file);
}

TEST(Energy, AFailedStepLeavesTheAccountsAsTheyWere) {
  // A solve capped at one CG iteration under "fail": the step throws, the state and the
  // accounts are those before it.
  const std::string text = std::regex_replace(
      drop(0.3, 1.0),
      std::regex(R"("integrator": \{"type": "bdf2"\}, "linearSolver": \{"type": "cholmod"\})"),
      R"("integrator": {"type": "implicit-euler", "onSolveFailure": "fail"},
         "linearSolver": {"type": "cg", "iterations": 1, "tolerance": 1e-12})");
  ASSERT_NE(text, drop(0.3, 1.0));
  const Scene scene = parseScene(text, "inline.json", test::kSceneDir);
  SceneRunner runner(scene);
  Simulation& sim = runner.simulation();
  runner.start();
  const double balance = sim.energy()->balance();
  const EnergyFlows total = sim.energy()->total();
  const double stored = sim.energy()->storedEnergy();
  EXPECT_THROW(runner.advance(), SolverError);
  const EnergyLedger* e = sim.energy();
  EXPECT_EQ(e->balance(), balance);
  EXPECT_EQ(e->storedEnergy(), stored);
  EXPECT_EQ(e->total().gravity, total.gravity);
  EXPECT_EQ(e->total().contact, total.contact);
  EXPECT_EQ(e->total().removed, total.removed);
}

TEST(Energy, TheCsvHasTheAccountsColumnsWithTheLedgersValues) {
  const std::string text =
      std::regex_replace(drop(0.3, 1.0), std::regex("\"duration\": 0.15"), "\"duration\": 0.01");
  const Scene scene = parseScene(text, "inline.json", test::kSceneDir);
  SceneRunner runner(scene);
  const std::filesystem::path dir =
      std::filesystem::path(::testing::TempDir()) / "cutsim_energy_csv";
  std::filesystem::remove_all(dir);
  double balance = 0.0, gravity = 0.0;
  {
    OutputWriter writer(dir, scene.output, scene.forceFieldLabels(), scene.graspNames(), true,
                        {"table"});
    runner.start();
    writer.record(runner.simulation(), {0, 0.0, {}}, false);
    while (!runner.finished()) {
      const StepStats stats = runner.advance();
      writer.record(runner.simulation(), {runner.currentStep(), runner.time(), stats},
                    runner.finished());
    }
    writer.finish();
    balance = runner.simulation().energy()->balance();
    gravity = runner.simulation().energy()->lastStep().gravity;
  }
  std::ifstream in(dir / "steps.csv");
  std::string header, line, last;
  std::getline(in, header);
  while (std::getline(in, line)) last = line;
  auto column = [&](const std::string& name) {
    std::stringstream h(header), row(last);
    std::string n, v;
    while (std::getline(h, n, ',') && std::getline(row, v, ','))
      if (n == name) return std::stod(v);
    ADD_FAILURE() << "no column " << name << " in " << header;
    return std::nan("");
  };
  for (const char* name : {"energy_stored", "work_gravity", "work_constraints", "work_contact",
                           "dissipated_damping", "energy_removed", "energy_balance", "energy_drift",
                           "step_work_gravity", "step_work_constraints", "step_work_contact",
                           "step_dissipated_damping", "step_energy_removed", "step_energy_drift"})
    EXPECT_THAT(header, HasSubstr(std::string(",") + name));
  EXPECT_DOUBLE_EQ(column("energy_balance"), balance);
  EXPECT_DOUBLE_EQ(column("step_work_gravity"), gravity);
  EXPECT_GT(column("work_gravity"), 0.0);
  std::filesystem::remove_all(dir);
}

TEST(Energy, TheSceneKeyIsABoolean) {
  EXPECT_THAT(test::parseError(test::scene(R"("output": {"energy": 1})")),
              HasSubstr("/output/energy"));
  const Scene off = parseScene(test::scene(), "inline.json", test::kSceneDir);
  SceneRunner runner(off);
  EXPECT_EQ(runner.simulation().energy(), nullptr);
}

}  // namespace
}  // namespace cutsim::core
