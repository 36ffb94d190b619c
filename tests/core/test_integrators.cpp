// Each integrator through the seam: the free-fall recurrence it must follow exactly, its order of
// accuracy, Newton against the linearised step, and the failure policy of the solves.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>

#include "cutsim/core/integrator.hpp"
#include "cutsim/core/integrators/bdf2.hpp"
#include "cutsim/core/integrators/explicit_euler.hpp"
#include "cutsim/core/integrators/implicit_euler.hpp"
#include "cutsim/core/integrators/newton.hpp"
#include "cutsim/core/registries.hpp"
#include "cutsim/core/simulation.hpp"
#include "cutsim/forcefields/dihedral_bending.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/forcefields/stretch_springs.hpp"
#include "support/fixtures.hpp"
#include "support/scene_text.hpp"

namespace cutsim::test {
namespace {

using core::BDF2;
using core::CGSettings;
using core::CholmodSolver;
using core::ConjugateGradient;
using core::ExplicitEuler;
using core::ImplicitEuler;
using core::ImplicitSettings;
using core::Integrator;
using core::NewtonImplicitEuler;
using core::NewtonSettings;
using core::Simulation;
using core::StepStats;
using ::testing::HasSubstr;
using topology::Topology;
using topology::Vec3;

struct Config {
  std::string name;         ///< "integrator_solver", for the test's name
  std::string integrator;   ///< its registered name
  bool isExplicit = false;  ///< it uses no linear solver
  std::function<std::unique_ptr<Integrator>(ImplicitSettings)> make;
};

/// Whether a registry entry declares a key.
template <class Entry>
bool declares(const Entry& entry, const std::string& key) {
  for (const KeyInfo& k : entry.keys)
    if (k.name == key) return true;
  return false;
}

/// The pairs of integrator and linear solver whose build refuses them (allConfigs leaves them out).
std::vector<std::pair<std::string, std::string>>& refusedPairs() {
  static std::vector<std::pair<std::string, std::string>> pairs;
  return pairs;
}

/// Every registered integrator with every registered linear solver it takes (a pair its build
/// refuses is left out, and checked below to be one a scene refuses too), built through the
/// registries: the integrator with the settings it declares, the solver iterating to 1e-14 where
/// it declares an iteration cap and a tolerance, without a warm start or an absolute threshold
/// where it declares them.
std::vector<Config> allConfigs() {
  std::vector<Config> out;
  for (const auto& [name, entry] : core::IntegratorRegistry::instance().entries()) {
    const bool isExplicit = entry.uses.empty();
    const std::vector<std::string> solvers =
        isExplicit ? std::vector<std::string>{""} : core::LinearSolverRegistry::instance().names();
    for (const std::string& solver : solvers) {
      auto make = [integrator = name, solver](ImplicitSettings s) -> std::unique_ptr<Integrator> {
        const auto& e = *core::IntegratorRegistry::instance().find(integrator);
        std::map<std::string, ScalarParameters::Value, std::less<>> values;
        if (declares(e, "rayleighMass")) values["rayleighMass"] = s.rayleighMass;
        if (declares(e, "rayleighStiffness")) values["rayleighStiffness"] = s.rayleighStiffness;
        std::unique_ptr<core::LinearSolver> ls;
        if (!solver.empty()) {
          const auto& l = *core::LinearSolverRegistry::instance().find(solver);
          std::map<std::string, ScalarParameters::Value, std::less<>> tight;
          if (declares(l, "iterations")) tight["iterations"] = 5000L;
          if (declares(l, "tolerance")) tight["tolerance"] = 1e-14;
          if (declares(l, "warmStart")) tight["warmStart"] = false;
          if (declares(l, "threshold")) tight["threshold"] = 0.0;  // no absolute stop (SOFA's CG)
          ls = l.build(l.readValues(ScalarParameters("linearSolver", std::move(tight))));
        }
        return e.build(e.readValues(ScalarParameters("integrator", std::move(values))),
                       std::move(ls));
      };
      try {
        make(ImplicitSettings{});
      } catch (const InvalidInput&) {
        refusedPairs().emplace_back(name, solver);  // a pair the integrator refuses
        continue;
      }
      std::string label = name + (solver.empty() ? "" : "_" + solver);
      std::replace(label.begin(), label.end(), '-', '_');
      out.push_back({label, name, isExplicit, make});
    }
  }
  return out;
}

TEST(EveryIntegratorList, HoldsEveryRegisteredIntegrator) {
  std::set<std::string> covered;
  for (const Config& c : allConfigs()) covered.insert(c.integrator);
  const auto names = core::IntegratorRegistry::instance().names();
  EXPECT_EQ(covered, std::set<std::string>(names.begin(), names.end()));
}

// A pair left out is one the scene reader refuses as well, naming the linear solver: no pair a
// scene may give drops out of the test unseen.
TEST(EveryIntegratorList, LeavesOutOnlyThePairsScenesRefuse) {
  refusedPairs().clear();
  allConfigs();
  for (const auto& [integrator, solver] : refusedPairs()) {
    SCOPED_TRACE(integrator + " with " + solver);
    const std::string text =
        "{\"mesh\": {\"grid\": {\"nx\": 3, \"ny\": 3, \"size\": [1, 1]}},\n"
        " \"mass\": {\"density\": 1}, \"timeStep\": 0.01, \"duration\": 0.01,\n"
        " \"integrator\": {\"type\": \"" +
        integrator +
        "\"},\n"
        " \"linearSolver\": {\"type\": \"" +
        solver + "\"}}\n";
    EXPECT_THAT(parseError(text), HasSubstr("/linearSolver/type: "));
  }
}

class EveryIntegrator : public ::testing::TestWithParam<Config> {};

// Without force fields every method reduces to a recurrence on each point, which the step must
// follow to rounding: symplectic and backward Euler v_k+1 = (v_k + h g) / (1 + h rM) (rM = 0 for
// the explicit one), x_k+1 = x_k + h v_k+1; BDF2 from its implicit Euler start,
// v_k+1 = (4 v_k - v_k-1 + 2 h g) / (3 + 2 h rM), x_k+1 = (4 x_k - x_k-1 + 2 h v_k+1) / 3.
TEST_P(EveryIntegrator, FreeFallFollowsTheMethodsRecurrence) {
  const Config& config = GetParam();
  const bool isExplicit = config.isExplicit;
  const bool bdf2 = config.integrator == "bdf2";  // BDF2's own recurrence; Euler's for the others
  ImplicitSettings settings;
  settings.rayleighMass = isExplicit ? 0.0 : 0.7;
  Simulation sim(std::make_unique<Topology>(grid(4, 1.0)), 2.0);
  const Vec3 g{0.3, -9.81, 0.5};
  sim.setGravity(g);
  sim.setIntegrator(config.make(settings));
  const double h = 0.01, rM = settings.rayleighMass;
  std::vector<double> x(sim.state().x().begin(), sim.state().x().end());
  std::vector<double> v(x.size(), 0.0), xPrev, vPrev;
  for (int k = 0; k < 30; ++k) {
    sim.step(h);
    std::vector<double> xn(x.size()), vn(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) {
      if (bdf2 && k > 0) {
        vn[i] = (4 * v[i] - vPrev[i] + 2 * h * g[i % 3]) / (3 + 2 * h * rM);
        xn[i] = (4 * x[i] - xPrev[i] + 2 * h * vn[i]) / 3;
      } else {
        vn[i] = (v[i] + h * g[i % 3]) / (1 + h * rM);
        xn[i] = x[i] + h * vn[i];
      }
    }
    xPrev = x;
    vPrev = v;
    x = xn;
    v = vn;
    auto sx = sim.state().x();
    auto sv = sim.state().v();
    for (std::size_t i = 0; i < x.size(); ++i) {
      ASSERT_NEAR(sv[i], v[i], 1e-12) << "step " << k + 1 << " dof " << i;
      ASSERT_NEAR(sx[i], x[i], 1e-12) << "step " << k + 1 << " dof " << i;
    }
  }
  EXPECT_FALSE(sim.solveSummary().flaggedSteps);
}

INSTANTIATE_TEST_SUITE_P(Core, EveryIntegrator, ::testing::ValuesIn(allConfigs()),
                         [](const auto& info) { return info.param.name; });

/// A hanging sheet of stretch and bending springs, fixed along one side, swinging.
std::unique_ptr<Simulation> swingingSheet(std::unique_ptr<Integrator> integrator) {
  auto sim = std::make_unique<Simulation>(std::make_unique<Topology>(grid(5, 1.0)), 1.0);
  forcefields::StretchParameters sp;
  sp.stiffness = 60.0;
  sp.stableJacobian = false;
  sim->addForceField(std::make_unique<forcefields::StretchSprings>(sim->topology(), sp));
  forcefields::BendingParameters bp;
  bp.bendingStiffness = 0.05;
  sim->addForceField(
      std::make_unique<forcefields::FastTriangularBendingSprings>(sim->topology(), bp));
  for (topology::PointId p{0}; p.idx() < 5; ++p) sim->fixed().add(p);
  sim->setGravity({0, 0, -9.81});
  sim->setIntegrator(std::move(integrator));
  return sim;
}

std::vector<double> runTo(std::unique_ptr<Integrator> integrator, double T, int steps) {
  auto sim = swingingSheet(std::move(integrator));
  for (int i = 0; i < steps; ++i) sim->step(T / steps);
  return {sim->state().x().begin(), sim->state().x().end()};
}

double distance(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(s);
}

// The error against a fine reference falls by 2 per halving of h for implicit Euler and by 4 for
// BDF2 (first and second order).
TEST(IntegratorOrder, ImplicitEulerIsFirstOrderAndBDF2SecondOrder) {
  const double T = 0.2;
  auto cholmod = [] { return std::make_unique<CholmodSolver>(); };
  const std::vector<double> reference =
      runTo(std::make_unique<BDF2>(ImplicitSettings{}, cholmod()), T, 3200);
  std::vector<double> eulerErr, bdfErr;
  for (int steps : {25, 50, 100}) {
    eulerErr.push_back(
        distance(runTo(std::make_unique<ImplicitEuler>(ImplicitSettings{}, cholmod()), T, steps),
                 reference));
    bdfErr.push_back(distance(
        runTo(std::make_unique<BDF2>(ImplicitSettings{}, cholmod()), T, steps), reference));
  }
  for (std::size_t i = 0; i + 1 < eulerErr.size(); ++i) {
    const double eulerOrder = std::log2(eulerErr[i] / eulerErr[i + 1]);
    const double bdfOrder = std::log2(bdfErr[i] / bdfErr[i + 1]);
    EXPECT_NEAR(eulerOrder, 1.0, 0.25)
        << "implicit Euler errors " << eulerErr[i] << ", " << eulerErr[i + 1];
    EXPECT_NEAR(bdfOrder, 2.0, 0.3) << "BDF2 errors " << bdfErr[i] << ", " << bdfErr[i + 1];
    EXPECT_LT(bdfErr[i], eulerErr[i]);
  }
}

// On a field whose force is linear in x (the bending springs alone), Newton converges in one
// iteration to the linearised implicit Euler step.
TEST(Newton, OnALinearFieldItIsTheLinearisedStepInOneIteration) {
  auto make = [](std::unique_ptr<Integrator> integrator) {
    auto sim = std::make_unique<Simulation>(std::make_unique<Topology>(grid(5, 1.0, 0.2)), 1.0);
    forcefields::BendingParameters bp;
    bp.bendingStiffness = 3.0;
    sim->addForceField(
        std::make_unique<forcefields::FastTriangularBendingSprings>(sim->topology(), bp));
    sim->fixed().add(topology::PointId(0));
    sim->fixed().add(topology::PointId(1));
    sim->setGravity({0, 0, -9.81});
    sim->setIntegrator(std::move(integrator));
    return sim;
  };
  auto newtonSim = make(std::make_unique<NewtonImplicitEuler>(ImplicitSettings{}, NewtonSettings{},
                                                              std::make_unique<CholmodSolver>()));
  auto eulerSim =
      make(std::make_unique<ImplicitEuler>(ImplicitSettings{}, std::make_unique<CholmodSolver>()));
  for (int i = 0; i < 10; ++i) {
    const StepStats s = newtonSim->step(0.02);
    eulerSim->step(0.02);
    EXPECT_EQ(s.newtonIterations, 1);
    EXPECT_FALSE(s.flagged());
  }
  auto a = newtonSim->state().x();
  auto b = eulerSim->state().x();
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], b[i], 1e-10);
}

// On a nonlinear field Newton iterates until the implicit Euler equations hold.
TEST(Newton, SolvesTheImplicitEulerEquationsOfANonlinearField) {
  auto integrator = std::make_unique<NewtonImplicitEuler>(
      ImplicitSettings{}, NewtonSettings{30, 1e-10, true, true}, std::make_unique<CholmodSolver>());
  auto* newton = integrator.get();
  auto sim = swingingSheet(std::move(integrator));
  const double h = 0.05;
  for (int i = 0; i < 8; ++i) {
    std::vector<double> x0(sim->state().x().begin(), sim->state().x().end());
    std::vector<double> v0(sim->state().v().begin(), sim->state().v().end());
    const StepStats s = sim->step(h);
    EXPECT_FALSE(s.flagged());
    EXPECT_GE(s.newtonIterations, 2);
    // M (v1 - v0) = h F(x1) on the free points.
    const std::vector<double> f = sim->totalForce();
    auto m = sim->mass().perPoint();
    auto v1 = sim->state().v();
    double worst = 0, scale = 0;
    for (std::size_t p = 5; p < m.size(); ++p)
      for (int c = 0; c < 3; ++c) {
        const std::size_t k = 3 * p + std::size_t(c);
        worst = std::max(worst, std::abs(m[p] * (v1[k] - v0[k]) - h * f[k]));
        scale = std::max(scale, std::abs(h * f[k]));
      }
    EXPECT_LT(worst, 1e-8 * scale);
    const auto& r = newton->lastResiduals();
    ASSERT_GE(r.size(), 2u);
    EXPECT_LT(r.back(), 1e-10 * r.front());
  }
}

// ---- the failure policy ----

std::unique_ptr<Simulation> stiffCappedCG(core::SolveFailurePolicy policy, double fallbackAbove) {
  ImplicitSettings s;
  s.onSolveFailure = policy;
  s.fallbackAbove = fallbackAbove;
  auto sim = swingingSheet(std::make_unique<ImplicitEuler>(
      s, std::make_unique<ConjugateGradient>(CGSettings{2, 1e-10, false})));
  return sim;
}

TEST(SolveFailurePolicy, WarnFlagsTheStepAndKeepsTheCappedSolve) {
  auto sim = stiffCappedCG(core::SolveFailurePolicy::Warn, 1e-3);
  const StepStats s = sim->step(0.05);
  EXPECT_TRUE(s.flags & StepStats::MissedTolerance);
  EXPECT_FALSE(s.flags & StepStats::FellBack);
  EXPECT_EQ(s.solves, 1);
  EXPECT_GT(s.residual, 1e-10);
  EXPECT_EQ(s.flagText(), "missed-tolerance");
  EXPECT_EQ(sim->solveSummary().flaggedSteps, 1);
  EXPECT_EQ(sim->solveSummary().missedTolerance, 1);
  EXPECT_EQ(sim->solveSummary().worstStep, 1);
}

TEST(SolveFailurePolicy, FallbackResolvesWithTheDirectSolverAboveItsThreshold) {
  auto sim = stiffCappedCG(core::SolveFailurePolicy::Fallback, 1e-9);
  const StepStats s = sim->step(0.05);
  EXPECT_TRUE(s.flags & StepStats::MissedTolerance);
  EXPECT_TRUE(s.flags & StepStats::FellBack);
  EXPECT_EQ(s.solves, 2);
  EXPECT_LT(s.residual, 1e-10);
  EXPECT_GT(s.worstResidual, 1e-9);
  EXPECT_EQ(s.flagText(), "missed-tolerance+fallback");
  // The same step as CHOLMOD's.
  auto direct = swingingSheet(
      std::make_unique<ImplicitEuler>(ImplicitSettings{}, std::make_unique<CholmodSolver>()));
  direct->step(0.05);
  auto a = sim->state().x();
  auto b = direct->state().x();
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], b[i], 1e-12);
}

TEST(SolveFailurePolicy, FallbackKeepsACappedSolveThatGotClose) {
  auto sim = stiffCappedCG(core::SolveFailurePolicy::Fallback, 0.99);
  const StepStats s = sim->step(0.05);
  EXPECT_TRUE(s.flags & StepStats::MissedTolerance);
  EXPECT_FALSE(s.flags & StepStats::FellBack);
}

// The fallback solver is chosen by name: CG (its defaults: 100 iterations to 1e-8) re-solves
// the capped solve in many iterations where CHOLMOD counts one, and both agree with a direct step.
TEST(SolveFailurePolicy, TheFallbackSolverIsTheOneNamed) {
  ImplicitSettings s;
  s.fallbackSolver = "cg";
  auto sim = swingingSheet(std::make_unique<ImplicitEuler>(
      s, std::make_unique<ConjugateGradient>(CGSettings{2, 1e-10, false})));
  const StepStats st = sim->step(0.05);
  EXPECT_TRUE(st.flags & StepStats::FellBack);
  EXPECT_EQ(st.solves, 2);
  EXPECT_GT(st.iterations, 2 + 1);  // the capped solve's 2, then CG's, not CHOLMOD's one
  EXPECT_LT(st.residual, 1e-8);
  auto direct = swingingSheet(
      std::make_unique<ImplicitEuler>(ImplicitSettings{}, std::make_unique<CholmodSolver>()));
  direct->step(0.05);
  auto a = sim->state().x();
  auto b = direct->state().x();
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], b[i], 1e-6);
  EXPECT_THROW(core::makeFallbackSolver("pardiso"), InvalidInput);
}

// When the fallback misses its tolerance too, the step goes on with the better of the two answers
// (the smaller relative residual), flagged: here SOFA's CG (its defaults: 25 iterations) as the
// fallback of a CG capped at one iteration, on a stiff sheet where neither meets its tolerance.
TEST(SolveFailurePolicy, WhenBothMissTheBetterAnswerIsKeptAndFlagged) {
  auto stiff = [](core::SolveFailurePolicy policy, const char* fallback) {
    ImplicitSettings s;
    s.onSolveFailure = policy;
    s.fallbackAbove = 1e-12;
    s.fallbackSolver = fallback;
    return swingingSheet(std::make_unique<ImplicitEuler>(
        s, std::make_unique<ConjugateGradient>(CGSettings{1, 1e-14, false})));
  };
  auto sim = stiff(core::SolveFailurePolicy::Fallback, "sofa-cg");
  const StepStats s = sim->step(0.5);
  ASSERT_TRUE(s.flags & StepStats::FellBack);
  // (One CG iteration also leaves a residual of more kinetic energy than the motion allows.)
  EXPECT_EQ(s.flagText(), "missed-tolerance+fallback+residual-energy");
  EXPECT_EQ(s.solves, 2);
  EXPECT_GT(s.residual, 1e-5);  // SOFA's CG missed its tolerance too (it used to end the run)
  // The kept answer is the better one: at most the worse residual.
  EXPECT_LE(s.residual, s.worstResidual);
  // The capped CG alone (warn) is worse here: the step kept the fallback's answer.
  auto alone = stiff(core::SolveFailurePolicy::Warn, "sofa-cg");
  const StepStats w = alone->step(0.5);
  EXPECT_GT(w.residual, s.residual);
  EXPECT_EQ(s.worstResidual, w.residual);
}

// A spring damping huge against the masses (1e15 N s/m between points of 1.7 g, an 11 x 11 sheet
// of 0.2 kg held by two corners): the right-hand side is the damping force of relative velocities
// at rounding level, and CG meets its relative tolerance with an answer that creates energy
// (kinetic energy growing far beyond gravity's work, every step "ok"). The residual's kinetic
// energy says so: the step is flagged residual-energy and, under "fallback", solved again by
// CHOLMOD, whose run it then follows. The same sheet with a damping of 0.2 is never flagged.
namespace {
std::unique_ptr<Simulation> dampedSheet(core::SolveFailurePolicy policy, double damping,
                                        bool direct) {
  auto sim = std::make_unique<Simulation>(std::make_unique<Topology>(grid(11, 1.0)), 0.2);
  forcefields::StretchParameters sp;
  sp.stiffness = 1000.0;
  sp.damping = damping;
  sim->addForceField(std::make_unique<forcefields::StretchSprings>(sim->topology(), sp));
  forcefields::BendingParameters bp;
  bp.bendingStiffness = 0.002;
  sim->addForceField(
      std::make_unique<forcefields::FastTriangularBendingSprings>(sim->topology(), bp));
  sim->fixed().add(topology::PointId(0));
  sim->fixed().add(topology::PointId(10));
  sim->setGravity({0, 0, -9.81});
  ImplicitSettings s;
  s.onSolveFailure = policy;
  std::unique_ptr<core::LinearSolver> solver;
  if (direct)
    solver = std::make_unique<CholmodSolver>();
  else
    solver = std::make_unique<ConjugateGradient>(CGSettings{200, 1e-4, true});
  sim->setIntegrator(std::make_unique<ImplicitEuler>(s, std::move(solver)));
  return sim;
}
}  // namespace

TEST(SolveFailurePolicy, ASolveWhoseResidualCarriesTheMotionsEnergyIsNotKept) {
  const double h = 0.005;
  const int steps = 20;
  // What gravity alone could have given the sheet (all its mass falling freely for the run).
  const double freeFall = 0.5 * 0.2 * std::pow(9.81 * h * steps, 2);
  auto warned = dampedSheet(core::SolveFailurePolicy::Warn, 1e15, false);
  auto fallback = dampedSheet(core::SolveFailurePolicy::Fallback, 1e15, false);
  auto direct = dampedSheet(core::SolveFailurePolicy::Fallback, 1e15, true);
  auto normal = dampedSheet(core::SolveFailurePolicy::Fallback, 0.2, false);
  int warnedFlags = 0, fellBack = 0;
  for (int i = 0; i < steps; ++i) {
    const StepStats w = warned->step(h);
    warnedFlags += (w.flags & StepStats::ResidualEnergy) ? 1 : 0;
    EXPECT_FALSE(w.flags & StepStats::FellBack);
    const StepStats f = fallback->step(h);
    if (f.flags & StepStats::ResidualEnergy) {
      EXPECT_TRUE(f.flags & StepStats::FellBack);
      ++fellBack;
    }
    direct->step(h);
    const StepStats n = normal->step(h);
    EXPECT_FALSE(n.flags & StepStats::ResidualEnergy) << "step " << i + 1;
  }
  // Kept, the CG answers made energy out of nothing; each such step was flagged.
  ASSERT_GT(warnedFlags, steps / 2);
  EXPECT_GT(warned->kineticEnergy() + warned->potentialEnergy(0), 10 * freeFall);
  EXPECT_EQ(warned->solveSummary().residualEnergy, warnedFlags);
  // Solved again, the run is CHOLMOD's (but for the first step, whose CG answer was kept: a
  // system this badly conditioned carries its difference on, here 0.4% of the kinetic energy).
  EXPECT_GT(fellBack, steps / 2);
  EXPECT_LT(fallback->kineticEnergy() + fallback->potentialEnergy(0), freeFall);
  EXPECT_NEAR(fallback->kineticEnergy(), direct->kineticEnergy(), 2e-2 * direct->kineticEnergy());
  // The sheet's mean fall (z) too; the warned one's is nowhere near.
  auto meanZ = [](const Simulation& sim) {
    auto x = sim.state().x();
    double z = 0;
    for (std::size_t i = 2; i < x.size(); i += 3) z += x[i];
    return z / double(x.size() / 3);
  };
  EXPECT_NEAR(meanZ(*fallback), meanZ(*direct), 2e-2 * std::abs(meanZ(*direct)));
  EXPECT_GT(std::abs(meanZ(*warned) - meanZ(*direct)), 0.5 * std::abs(meanZ(*direct)));
  // Under "fail" the run stops at the first such step, saying why.
  auto failing = dampedSheet(core::SolveFailurePolicy::Fail, 1e15, false);
  try {
    for (int i = 0; i < steps; ++i) failing->step(h);
    ADD_FAILURE() << "no step failed";
  } catch (const SolverError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("its residual could carry"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("cholmod"));
  }
}

// And the other way: a capped CG that got further than the fallback (SOFA's CG, 25 iterations,
// against 40) keeps its own answer, bit for bit what the capped CG alone gives, still flagged.
TEST(SolveFailurePolicy, WhenBothMissTheFirstAnswerIsKeptWhenItIsTheBetter) {
  auto stiff = [](core::SolveFailurePolicy policy) {
    ImplicitSettings s;
    s.onSolveFailure = policy;
    s.fallbackAbove = 1e-300;  // (always re-solved)
    s.fallbackSolver = "sofa-cg";
    return swingingSheet(std::make_unique<ImplicitEuler>(
        s, std::make_unique<ConjugateGradient>(CGSettings{40, 1e-300, false})));
  };
  auto sim = stiff(core::SolveFailurePolicy::Fallback);
  const StepStats s = sim->step(0.5);
  ASSERT_TRUE(s.flags & StepStats::FellBack);
  EXPECT_EQ(s.flagText(), "missed-tolerance+fallback");
  EXPECT_EQ(s.solves, 2);
  auto alone = stiff(core::SolveFailurePolicy::Warn);
  const StepStats w = alone->step(0.5);
  // The fallback's answer was the worse one (else this test does not reach its branch).
  ASSERT_GT(s.worstResidual, w.residual);
  EXPECT_EQ(s.residual, w.residual);
  auto a = sim->state().x();
  auto b = alone->state().x();
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a[i], b[i]) << "coordinate " << i;
}

TEST(SolveFailurePolicy, FailNamesTheStepAndTheResidual) {
  auto sim = stiffCappedCG(core::SolveFailurePolicy::Fail, 1e-3);
  const std::vector<double> before(sim->state().x().begin(), sim->state().x().end());
  try {
    sim->step(0.05);
    FAIL() << "the capped solve did not fail";
  } catch (const SolverError& e) {
    EXPECT_THAT(e.what(), HasSubstr("step 1 (t = 0)"));
    EXPECT_THAT(e.what(),
                HasSubstr("the linear solve (cg) missed its tolerance: relative residual"));
    EXPECT_THAT(e.what(), HasSubstr("after 2 iterations"));
  }
  // The state is left as before the step.
  EXPECT_EQ(std::vector<double>(sim->state().x().begin(), sim->state().x().end()), before);
  EXPECT_EQ(sim->steps(), 0);
}

TEST(BDF2, RestartsAfterATopologyChangeOrAnEditOfTheState) {
  auto integrator = std::make_unique<BDF2>(ImplicitSettings{}, std::make_unique<CholmodSolver>());
  BDF2* bdf = integrator.get();
  auto sim = swingingSheet(std::move(integrator));
  sim->step(0.01);
  sim->step(0.01);
  EXPECT_EQ(bdf->restarts(), 1);
  sim->state().x()[3 * 12] += 1e-3;  // an edit between steps
  sim->step(0.01);
  EXPECT_EQ(bdf->restarts(), 2);
  sim->step(0.02);  // a new time step
  EXPECT_EQ(bdf->restarts(), 3);
  sim->topology().removeTriangles(
      std::vector<topology::TriangleId>{sim->topology().triangles().back()});
  sim->step(0.02);
  EXPECT_EQ(bdf->restarts(), 4);
  sim->step(0.02);
  EXPECT_EQ(bdf->restarts(), 4);
}

}  // namespace
}  // namespace cutsim::test

namespace cutsim::test {
namespace {

/// A 6 x 6 sheet folded by `angle` along x = 0.5 (the right half rotated about that line), at
/// rest flat: stretch springs and the dihedral bending model, both with exact stiffness on request.
std::unique_ptr<Simulation> foldedSheet(double angle, std::unique_ptr<Integrator> integrator) {
  auto sim = std::make_unique<Simulation>(std::make_unique<Topology>(grid(6, 1.0)), 10.0);
  forcefields::StretchParameters sp;
  sp.stiffness = 200.0;
  sp.stableJacobian = true;
  sim->addForceField(std::make_unique<forcefields::StretchSprings>(sim->topology(), sp));
  forcefields::DihedralBendingParameters dp;
  dp.bendingStiffness = 0.5;
  sim->addForceField(std::make_unique<forcefields::DihedralBending>(sim->topology(), dp));
  auto x = sim->state().x();
  for (std::size_t p = 0; p < x.size() / 3; ++p) {
    const double u = x[3 * p] - 0.5;
    if (u <= 0) continue;
    x[3 * p] = 0.5 + u * std::cos(angle);
    x[3 * p + 2] = u * std::sin(angle);
  }
  for (topology::Index p = 0; p < 36; p += 6) sim->fixed().add(topology::PointId(p));
  sim->setIntegrator(std::move(integrator));
  return sim;
}

/// Residuals of Newton's first step on the fold, relative to the first.
std::vector<double> newtonResiduals(bool exact) {
  auto integrator = std::make_unique<NewtonImplicitEuler>(ImplicitSettings{},
                                                          NewtonSettings{40, 1e-13, exact, true},
                                                          std::make_unique<CholmodSolver>());
  auto* newton = integrator.get();
  auto sim = foldedSheet(1.2, std::move(integrator));
  sim->step(0.02);
  std::vector<double> e;
  for (double r : newton->lastResiduals()) e.push_back(r / newton->lastResiduals().front());
  return e;
}

// With the exact Hessians Newton converges quadratically on a strong fold (the error is about
// squared by each iteration near the solution); with the fields' default, approximate stiffness
// it converges only linearly and needs more iterations.
TEST(Newton, ConvergesQuadraticallyWithTheExactStiffnessOnADihedralFold) {
  const std::vector<double> exact = newtonResiduals(true);
  const std::vector<double> approximate = newtonResiduals(false);
  std::ostringstream trace;
  for (double e : exact) trace << e << ' ';
  trace << "| ";
  for (double e : approximate) trace << e << ' ';
  SCOPED_TRACE(trace.str());
  ASSERT_GE(exact.size(), 3u);
  EXPECT_LT(exact.back(), 1e-13);
  EXPECT_LT(exact.size(), approximate.size());
  // Quadratic: some iteration takes an error below 1e-2 to below its square times 10.
  bool quadratic = false;
  for (std::size_t k = 0; k + 1 < exact.size(); ++k)
    if (exact[k] < 1e-2 && exact[k + 1] <= 10 * exact[k] * exact[k] && exact[k + 1] > 0)
      quadratic = true;
  EXPECT_TRUE(quadratic);
  // The fields are given back their own stiffness after the step.
  auto sim =
      foldedSheet(1.2, std::make_unique<NewtonImplicitEuler>(ImplicitSettings{}, NewtonSettings{},
                                                             std::make_unique<CholmodSolver>()));
  sim->step(0.05);
  EXPECT_FALSE(sim->forceField(0).stiffnessIsExact());
  EXPECT_FALSE(sim->forceField(1).stiffnessIsExact());
}

}  // namespace
}  // namespace cutsim::test
