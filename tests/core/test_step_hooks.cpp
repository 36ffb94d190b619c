// The step seam: the simulation calls its step hooks in order at each step's start, after its
// solve (where a hook may limit the proposal or have the step split) and at its end; contact is a
// force field and its hook (ContactStep), wired once by addContact.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "cutsim/core/contact_step.hpp"
#include "cutsim/core/simulation.hpp"
#include "cutsim/core/step_hook.hpp"
#include "cutsim/forcefields/contact.hpp"
#include "cutsim/forcefields/stretch_springs.hpp"
#include "support/fixtures.hpp"
#include "support/scene_text.hpp"

namespace cutsim::test {
namespace {

using core::Simulation;
using core::StepEnd;
using core::StepHook;
using core::StepProposal;
using core::StepStart;
using core::StepVerdict;

/// Records what it is told in a shared log; asks for a split on its first `splits` proposals at
/// depth 0, and stops every point's motion along z (its "limit"), counting the points it moved.
class Recorder final : public StepHook {
 public:
  Recorder(std::string name, std::vector<std::string>& log, int splits = 0, bool limitZ = false)
      : name_(std::move(name)), log_(log), splits_(splits), limitZ_(limitZ) {}
  std::string_view name() const override { return name_; }
  void beginStep(const StepStart& s) override {
    log_.push_back(name_ + " begin t0=" + std::to_string(s.t0) + " dt=" + std::to_string(s.dt));
  }
  StepVerdict afterSolve(const StepProposal& p) override {
    log_.push_back(name_ + " after depth=" + std::to_string(p.depth));
    StepVerdict v;
    if (p.depth == 0 && splits_ > 0) {
      --splits_;
      v.split = true;
      return v;
    }
    if (limitZ_)
      for (std::size_t i = 2; i < p.x1.size(); i += 3)
        if (p.x1[i] != p.x0[i]) {
          p.x1[i] = p.x0[i];
          p.v1[i] = 0.0;
          ++v.limited;
        }
    return v;
  }
  void endStep(const StepEnd& e) override {
    log_.push_back(name_ + " end t=" + std::to_string(e.t));
  }

 private:
  std::string name_;
  std::vector<std::string>& log_;
  int splits_;
  bool limitZ_;
};

std::unique_ptr<Simulation> fallingSheet() {
  auto sim = std::make_unique<Simulation>(std::make_unique<topology::Topology>(grid(4, 1.0)), 1.0);
  forcefields::StretchParameters sp;
  sp.stiffness = 50.0;
  sim->addForceField(std::make_unique<forcefields::StretchSprings>(sim->topology(), sp));
  sim->setGravity({0, 0, -9.81});
  return sim;
}

TEST(StepHooks, AreCalledInOrderAtEachStepsStartAfterItsSolveAndAtItsEnd) {
  auto sim = fallingSheet();
  std::vector<std::string> log;
  sim->addStepHook(std::make_unique<Recorder>("a", log));
  sim->addStepHook(std::make_unique<Recorder>("b", log));
  sim->step(0.5);
  EXPECT_EQ(log,
            (std::vector<std::string>{"a begin t0=0.000000 dt=0.500000",
                                      "b begin t0=0.000000 dt=0.500000", "a after depth=0",
                                      "b after depth=0", "a end t=0.500000", "b end t=0.500000"}));
}

// A hook that asks for a split has the step redone as two halves, each through the whole
// sequence; the hooks after it are not asked about the discarded proposal.
TEST(StepHooks, ASplitRedoesTheStepAsTwoHalvesWithoutAskingTheLaterHooks) {
  auto sim = fallingSheet();
  std::vector<std::string> log;
  sim->addStepHook(std::make_unique<Recorder>("a", log, /*splits*/ 1));
  sim->addStepHook(std::make_unique<Recorder>("b", log));
  const core::StepStats stats = sim->step(0.5);
  EXPECT_EQ(stats.splits, 1);
  EXPECT_EQ(stats.substeps, 2);
  EXPECT_EQ(log, (std::vector<std::string>{
                     "a begin t0=0.000000 dt=0.500000", "b begin t0=0.000000 dt=0.500000",
                     "a after depth=0", "a begin t0=0.000000 dt=0.250000",
                     "b begin t0=0.000000 dt=0.250000", "a after depth=1", "b after depth=1",
                     "a end t=0.250000", "b end t=0.250000", "a begin t0=0.250000 dt=0.250000",
                     "b begin t0=0.250000 dt=0.250000", "a after depth=1", "b after depth=1",
                     "a end t=0.500000", "b end t=0.500000"}));
  EXPECT_DOUBLE_EQ(sim->time(), 0.5);
}

// What a hook writes into the proposal is what the step commits; the points it limited are the
// step's clamped count.
TEST(StepHooks, AHookLimitsTheProposalInPlace) {
  auto sim = fallingSheet();
  const std::vector<double> before(sim->state().x().begin(), sim->state().x().end());
  std::vector<std::string> log;
  sim->addStepHook(std::make_unique<Recorder>("z", log, 0, /*limitZ*/ true));
  const core::StepStats stats = sim->step(0.01);
  auto x = sim->state().x();
  auto v = sim->state().v();
  for (std::size_t i = 2; i < x.size(); i += 3) {
    EXPECT_EQ(x[i], before[i]);
    EXPECT_EQ(v[i], 0.0);
  }
  EXPECT_EQ(stats.clamped, int(sim->topology().numPoints()));  // gravity moved every point
}

std::unique_ptr<forcefields::Contact> contactOn(topology::Topology& t) {
  forcefields::ContactParameters p;
  p.thickness = 0.01;
  p.stiffness = 1.0;
  return std::make_unique<forcefields::Contact>(t, p, std::vector<forcefields::Obstacle>{});
}

TEST(StepHooks, ContactIsAFieldAndItsHookWiredOnceAndNotReplaced) {
  auto sim = fallingSheet();
  EXPECT_EQ(core::findContact(*sim), nullptr);
  core::ContactStep& hook = core::addContact(*sim, contactOn(sim->topology()));
  EXPECT_EQ(core::findContact(*sim), &hook.contact());
  EXPECT_EQ(sim->numStepHooks(), 1u);
  EXPECT_EQ(sim->forceFieldLabel(sim->numForceFields() - 1), "contact");
  EXPECT_THROW(core::addContact(*sim, contactOn(sim->topology())), InvalidInput);
  EXPECT_THAT(
      [&] {
        sim->model().replaceForceField(sim->numForceFields() - 1, contactOn(sim->topology()));
      },
      ::testing::ThrowsMessage<InvalidInput>(::testing::HasSubstr("cannot be replaced")));
  EXPECT_THROW(sim->addStepHook(nullptr), InvalidInput);
  sim->step(0.01);  // the hook drives the field: its figures are recorded at the step's end
  EXPECT_GE(hook.contact().searches(), 1u);
}

}  // namespace
}  // namespace cutsim::test

namespace cutsim::test {
namespace {

// The "tear" action (what Python's sim.tear plays): the scene check tears it on the rest mesh and
// names an edge that is not one; the run tears it, counts it and records its incision.
TEST(TearAction, TearsTheEdgeOfTwoPointsAndRefusesOneThatIsNotAnEdge) {
  // Grid 5 x 5 (alternating): points 6 and 7 are neighbours inside the sheet; 0 and 24 are not.
  EXPECT_THAT(
      parseError(scene("\"timeline\": [{\"at\": 0, \"action\": \"tear\", \"points\": [0, 24]}]")),
      ::testing::HasSubstr("/timeline/0/points: the edge of points 0 and 24 is not an edge"));
  EXPECT_THAT(
      parseError(scene("\"timeline\": [{\"at\": 0, \"action\": \"tear\", \"points\": [6, 6]}]")),
      ::testing::HasSubstr("must differ"));
  const core::Scene s = core::parseScene(
      scene("\"timeline\": [{\"at\": 0.02, \"action\": \"tear\", \"points\": [6, 7]}]"),
      "inline.json", kSceneDir);
  core::SceneRunner runner(s);
  runner.start();
  const std::size_t before = runner.simulation().topology().numPoints();
  while (!runner.finished()) runner.advance();
  EXPECT_EQ(runner.tornEdges(), 1);
  EXPECT_GT(runner.simulation().topology().numPoints(), before);  // the lips have their own points
  const auto& t = runner.simulation().topology();
  const topology::EdgeId e = t.findEdge(topology::PointId(6), topology::PointId(7));
  EXPECT_TRUE(topology::Index(e) == topology::kInvalidIndex || t.isBoundaryEdge(e));  // a lip now
  EXPECT_TRUE(runner.simulation().topology().validate().ok());
}

}  // namespace
}  // namespace cutsim::test
