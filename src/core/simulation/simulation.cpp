// Simulation: the clock, the guard and the statistics around an integrator's step
// (simulation.hpp).
#include "cutsim/core/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"

namespace cutsim::core {

Simulation::Simulation(std::unique_ptr<topology::Topology> topology, double density)
    : Simulation(std::move(topology), MassLaw::areaDensity(density)) {}

Simulation::Simulation(std::unique_ptr<topology::Topology> topology, MassLaw mass)
    : model_(std::make_unique<Model>(std::move(topology), mass)) {
  setSolver(SolverSettings{});
}

Simulation::~Simulation() = default;

StepHook::~StepHook() = default;

StepHook& Simulation::addStepHook(std::unique_ptr<StepHook> hook) {
  if (!hook) throw InvalidInput("stepHooks", "no step hook");
  hooks_.push_back(std::move(hook));
  return *hooks_.back();
}

void Simulation::setIntegrator(std::unique_ptr<Integrator> integrator) {
  if (!integrator) throw InvalidInput("integrator", "no integrator");
  integrator_ = std::move(integrator);
}

void Simulation::setSolver(const SolverSettings& s) {
  setIntegrator(makeIntegrator(s));
}

StepStats Simulation::step(double dt) {
  requireFinitePositive("timeStep", dt);
  if (!model_->hasMass())
    throw SolverError("the simulation has no mass: give a density or a total mass");
  StepStats stats;
  stats.substeps = 0;
  const double t0 = time_;
  // A failed step leaves the accounts as they were, like the state.
  std::optional<EnergyLedger> ledger0;
  if (ledger_) {
    ledger_->beginStep(*model_);
    ledger0 = *ledger_;
  }
  // With step hooks a step may be taken in parts: a failing part leaves the state as at the start.
  std::vector<double> x0, v0;
  if (!hooks_.empty()) {
    x0.assign(model_->state().x().begin(), model_->state().x().end());
    v0.assign(model_->state().v().begin(), model_->state().v().end());
  }
  try {
    advance(dt, 0, stats);
  } catch (...) {
    time_ = t0;
    if (!x0.empty()) {
      std::copy(x0.begin(), x0.end(), model_->state().x().begin());
      std::copy(v0.begin(), v0.end(), model_->state().v().begin());
    }
    if (ledger0) *ledger_ = *ledger0;
    throw;
  }
  if (ledger_) ledger_->endStep(*model_);
  time_ = t0 + dt;
  ++steps_;
  if (stats.flagged()) {
    ++summary_.flaggedSteps;
    if (stats.flags & StepStats::MissedTolerance) ++summary_.missedTolerance;
    if (stats.flags & StepStats::Indefinite) ++summary_.indefinite;
    if (stats.flags & StepStats::FellBack) ++summary_.fellBack;
    if (stats.flags & StepStats::NewtonNotConverged) ++summary_.newtonNotConverged;
    if (stats.flags & StepStats::ResidualEnergy) ++summary_.residualEnergy;
    const double worst = std::max(stats.worstResidual, stats.newtonResidual);
    if (!(worst <= summary_.worstResidual)) {
      summary_.worstResidual = worst;
      summary_.worstStep = steps_;
    }
  }
  return stats;
}

void Simulation::advance(double h, int depth, StepStats& stats) {
  auto stepName = [&] {
    std::ostringstream s;
    s << "step " << steps_ + 1 << " (t = " << time_ << "): ";
    return s.str();
  };
  const std::size_t n = model_->numSlots();
  std::vector<double> x0;
  if (!hooks_.empty()) {
    x0.assign(model_->state().x().begin(), model_->state().x().end());
    const StepStart start{*model_, time_, h};
    for (const auto& hook : hooks_) hook->beginStep(start);
  }
  const StepConstraints constraints = model_->constraints(time_ + h);
  StepInput in{h, &constraints, model_->topology().revision()};
  // Solved once, or twice when a hook asks for it (contact's friction held where it overshot).
  StepOutput out;
  EnergyFlows flows;
  std::vector<double> xp, vp;
  for (int solves = 1;; ++solves) {
    bool again = false;
    out = StepOutput{};
    // (A solve solved again counts as work; its flags and residuals are the kept solve's.)
    const StepStats before = stats;
    try {
      integrator_->step(*model_, in, out, stats);
      requireFinite(std::span<const double>(out.v.data(), std::size_t(out.v.size())), "velocity",
                    "");
      requireFinite(std::span<const double>(out.x.data(), std::size_t(out.x.size())), "position",
                    "");
      // Finite velocities are a blow-up too when their kinetic energy is beyond the range of
      // doubles (what the CSV's first column would meet): named here, with the same hint.
      const std::size_t slots = std::size_t(out.v.size()) / 3;
      std::size_t overflow = slots;
      model_->kineticEnergyOf(std::span<const double>(out.v.data(), std::size_t(out.v.size())),
                              &overflow);
      if (overflow < slots) throw NonFiniteValue{"kinetic energy", "", overflow};
    } catch (const NonFiniteValue& e) {
      std::ostringstream s;
      s << stepName() << "non-finite " << e.what;
      if (!e.component.empty()) s << " from " << e.component;
      s << " at point " << e.point;
      if (integrator_->isExplicit())
        s << "; the explicit integrator is unstable at this time step: try a smaller one or an "
             "implicit solver";
      throw SolverError(s.str());
    } catch (const StepFailure& e) {
      throw SolverError(stepName() + e.message);
    }
    // The step's energy flows, measured on the integrator's proposal (kept if no hook splits it).
    xp.clear();
    vp.clear();
    if (ledger_) {
      flows =
          ledger_->proposalFlows(*model_, *integrator_, h,
                                 std::span<const double>(out.x.data(), std::size_t(out.x.size())),
                                 std::span<const double>(out.v.data(), std::size_t(out.v.size())),
                                 out.reaction, constraints.constrained);
      if (!hooks_.empty()) {
        xp.assign(out.x.data(), out.x.data() + out.x.size());
        vp.assign(out.v.data(), out.v.data() + out.v.size());
      }
    }
    if (!hooks_.empty()) {
      const StepProposal proposal{*model_,
                                  time_,
                                  h,
                                  depth,
                                  x0,
                                  std::span<double>(out.x.data(), std::size_t(out.x.size())),
                                  std::span<double>(out.v.data(), std::size_t(out.v.size())),
                                  constraints.constrained,
                                  !integrator_->isExplicit(),
                                  solves};
      std::size_t limited = 0;
      for (const auto& hook : hooks_) {
        const StepVerdict verdict = hook->afterSolve(proposal);
        if (verdict.split) {  // the proposal is discarded: the later hooks are not asked
          ++stats.splits;
          advance(h / 2, depth + 1, stats);
          advance(h / 2, depth + 1, stats);
          return;
        }
        if (verdict.again && solves == 1) {  // solved again: the later hooks are not asked
          again = true;
          break;
        }
        limited += verdict.limited;
      }
      if (again) {
        const int iterations = stats.iterations - before.iterations,
                  linearSolves = stats.solves - before.solves;
        stats = before;
        stats.iterations += iterations;
        stats.solves += linearSolves;
        integrator_->rewind();
        continue;
      }
      stats.clamped += int(limited);
    }
    break;
  }
  ++stats.substeps;
  // Dead points and points without mass (isolated) do not move.
  auto xs = model_->state().x();
  auto vs = model_->state().v();
  auto m = model_->mass().perPoint();
  for (std::size_t p = 0; p < n; ++p) {
    const bool still = !(m[p] > 0) || !model_->topology().isPointAlive(topology::PointId(p));
    for (int c = 0; c < 3; ++c) {
      const std::size_t i = 3 * p + std::size_t(c);
      vs[i] = still ? 0.0 : out.v[Eigen::Index(i)];
      if (!still) xs[i] = out.x[Eigen::Index(i)];
    }
  }
  for (std::size_t g = 0; g < model_->numGrasps(); ++g) {
    Grasp& grasp = model_->grasp(g);
    Vec3 r{0, 0, 0};
    if (out.reaction.size() == Eigen::Index(3 * n))
      for (PointId p : grasp.points().points())
        for (int c = 0; c < 3; ++c) r[c] += out.reaction[Eigen::Index(3 * p.idx() + c)];
    grasp.setReaction(r);
  }
  if (ledger_) {
    // The hooks' corrections (contact's bound and response) are their work.
    const bool changed = !xp.empty() && (!std::equal(xp.begin(), xp.end(), out.x.data()) ||
                                         !std::equal(vp.begin(), vp.end(), out.v.data()));
    ledger_->commit(*model_, flows, xp, vp, changed, out.reaction, constraints.constrained);
  }
  time_ += h;
  const StepEnd end{*model_, time_};
  for (const auto& hook : hooks_) hook->endStep(end);
}

void Simulation::enableEnergyAccounting() {
  ledger_ = std::make_unique<EnergyLedger>(*model_);
}

const EnergyLedger* Simulation::energy() {
  if (ledger_) ledger_->settle(*model_);
  return ledger_.get();
}

std::vector<std::string> Simulation::notCheckpointable() const {
  std::vector<std::string> out = model_->notCheckpointable();
  if (!integrator_->checkpointable()) {
    std::string what = "the integrator " + std::string(integrator_->name());
    if (const LinearSolver* s = integrator_->linearSolver())
      what += " with " + std::string(s->name());
    out.push_back(what);
  }
  return out;
}

template <class Archive, class Self>
void Simulation::members(Archive& a, Self& s) {
  fields(a, s.time_, s.steps_, s.summary_.flaggedSteps, s.summary_.missedTolerance,
         s.summary_.indefinite, s.summary_.fellBack, s.summary_.newtonNotConverged,
         s.summary_.worstResidual, s.summary_.worstStep, s.summary_.residualEnergy);
}

void Simulation::saveState(ArchiveWriter& out) const {
  out.begin("sim");
  members(out, *this);
  out.begin("integr");
  out.str(integrator_->name());
  integrator_->saveState(out);
  model_->saveState(out);
  if (ledger_) {  // a section of its own: checkpoints of runs without accounting are unchanged
    out.begin("energy");
    ledger_->saveState(out);
  }
}

void Simulation::loadState(ArchiveReader& in) {
  in.open("sim");
  members(in, *this);
  in.close();
  if (!std::isfinite(time_) || steps_ < 0)
    in.fail("a time of " + std::to_string(time_) + " after " + std::to_string(steps_) + " steps");
  in.open("integr");
  const std::string name = in.str();
  if (name != integrator_->name())
    in.fail("the saved integrator is " + name + ", the scene's " +
            std::string(integrator_->name()));
  integrator_->loadState(in);
  in.close();
  model_->loadState(in);
  if (ledger_) {
    if (!in.has("energy"))
      in.fail(
          "the scene keeps energy accounts (\"output\": {\"energy\": true}) and the checkpoint "
          "has none (its run did not keep them): resume it without them, or run the scene from "
          "the start");
    in.open("energy");
    ledger_->loadState(in);
    in.close();
  }
}

}  // namespace cutsim::core
