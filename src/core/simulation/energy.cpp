// Energy accounting (energy.hpp, docs/energy.md).
#include "cutsim/core/energy.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "cutsim/base/archive.hpp"
#include "cutsim/core/integrator.hpp"
#include "cutsim/core/model.hpp"

namespace cutsim::core {
namespace {

double dot(std::span<const double> a, std::span<const double> b) {
  double s = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
  return s;
}

}  // namespace

EnergyFlows& EnergyFlows::operator+=(const EnergyFlows& o) {
  gravity += o.gravity;
  constraints += o.constraints;
  contact += o.contact;
  damping += o.damping;
  removed += o.removed;
  return *this;
}

EnergyLedger::EnergyLedger(const Model& model) {
  stored_ = stored(model);
  lastPotential_ = nonConservativePotential(model, model.state().x());
  initial_ = stepStart_ = balance();
}

double EnergyLedger::stored(const Model& model, std::span<const double> x,
                            std::span<const double> v) {
  double e = model.kineticEnergyOf(v);
  for (std::size_t i = 0; i < model.numForceFields(); ++i)
    e += model.forceField(i).potentialEnergy(x);
  return e;
}

double EnergyLedger::nonConservativePotential(const Model& model, std::span<const double> x) {
  double e = 0.0;
  for (std::size_t i = 0; i < model.numForceFields(); ++i) {
    const forcefields::ForceField& f = model.forceField(i);
    if (!f.conservative()) e += f.potentialEnergy(x);
  }
  return e;
}

double EnergyLedger::stored(const Model& model) {
  return stored(model, model.state().x(), model.state().v());
}

void EnergyLedger::settle(const Model& model) {
  const double now = stored(model);
  const double removed = stored_ - now;
  total_.removed += removed;
  step_.removed += removed;
  stored_ = now;
  lastPotential_ = nonConservativePotential(model, model.state().x());
}

void EnergyLedger::beginStep(const Model& model) {
  step_ = EnergyFlows{};
  stepStart_ = balance();
  settle(model);
}

EnergyFlows EnergyLedger::proposalFlows(const Model& model, const Integrator& integrator, double h,
                                        std::span<const double> xp, std::span<const double> vp,
                                        const Eigen::VectorXd& reaction,
                                        std::span<const char> constrained) const {
  EnergyFlows f;
  const auto x0 = model.state().x();
  const std::size_t N = x0.size();
  std::vector<double> dx(N);
  for (std::size_t i = 0; i < N; ++i) dx[i] = xp[i] - x0[i];
  // Gravity: sum m g . dx.
  if (model.hasMass()) {
    const auto m = model.mass().perPoint();
    const Vec3& g = model.gravity();
    for (std::size_t p = 0; p < m.size(); ++p)
      f.gravity += m[p] * (g[0] * dx[3 * p] + g[1] * dx[3 * p + 1] + g[2] * dx[3 * p + 2]);
  }
  // Fixed points and grasps: their reactions . dx (a fixed point does not move: nothing), by the
  // trapezoidal rule with the reaction the last substep ended with where it is known (the same
  // mesh, the point held then too), else by the step's own reaction: a grasp that loads a sheet
  // slowly does the work its stored energy gains, not the end force times the move.
  if (std::size_t(reaction.size()) == N) {
    const bool known = lastReaction_.size() == N && lastRevision_ == model.topology().revision();
    for (std::size_t p = 0; p < constrained.size(); ++p) {
      if (!constrained[p]) continue;
      for (std::size_t k = 0; k < 3; ++k) {
        const std::size_t i = 3 * p + k;
        const double r1 = reaction[Eigen::Index(i)];
        const double r0 = known && std::isfinite(lastReaction_[i]) ? lastReaction_[i] : r1;
        f.constraints += 0.5 * (r0 + r1) * dx[i];
      }
    }
  }
  // Rayleigh damping: h (rM v' M v - rK v' K v) at the proposal.
  const auto [rM, rK] = integrator.rayleigh();
  if (rM > 0.0) f.damping += h * rM * 2.0 * model.kineticEnergyOf(vp);
  std::vector<double> scratch(N, 0.0);
  if (rK > 0.0) {
    model.addDForce(xp, vp, scratch, 1.0, 0.0);
    f.damping -= h * rK * dot(vp, scratch);
  }
  // The conservative fields' own damping, -h v' B v. The others (contact), whose potential is
  // stored energy too: what their potential changed by at the step's start positions since it
  // was last read there (the obstacles moved to where the step ends, the pairs were found
  // again), the work of the obstacles' motion; and their friction's work, F_friction(xp, vp) .
  // dx. (Their potential force's work is the change of their potential, which the stored energy
  // holds exactly.)
  std::fill(scratch.begin(), scratch.end(), 0.0);
  std::vector<double> friction;  // sized when a field is not conservative
  double potential = 0.0;
  for (std::size_t i = 0; i < model.numForceFields(); ++i) {
    const forcefields::ForceField& field = model.forceField(i);
    if (field.conservative()) {
      field.addDForce(xp, vp, scratch, 0.0, 1.0);
    } else {
      if (friction.empty()) friction.assign(N, 0.0);
      field.addFrictionForce(xp, vp, friction);
      potential += field.potentialEnergy(x0);
    }
  }
  f.damping -= h * dot(vp, scratch);
  if (!friction.empty()) f.contact += dot(friction, dx) + potential - lastPotential_;
  return f;
}

void EnergyLedger::commit(const Model& model, EnergyFlows flows, std::span<const double> xp,
                          std::span<const double> vp, bool hooksChanged,
                          const Eigen::VectorXd& reaction, std::span<const char> constrained) {
  // The reactions the substep ended with, for the next one's trapezoidal rule.
  const std::size_t N = model.state().x().size();
  lastReaction_.assign(N, std::numeric_limits<double>::quiet_NaN());
  lastRevision_ = model.topology().revision();
  if (std::size_t(reaction.size()) == N)
    for (std::size_t p = 0; p < constrained.size(); ++p)
      if (constrained[p])
        for (std::size_t k = 0; k < 3; ++k)
          lastReaction_[3 * p + k] = reaction[Eigen::Index(3 * p + k)];
  const auto x = model.state().x();
  if (hooksChanged) {
    // What the hooks changed, kinetic, potential and gravity energy together, is their work.
    const auto v = model.state().v();
    flows.contact += (stored(model, x, v) + model.gravityEnergyOf(x)) -
                     (stored(model, xp, vp) + model.gravityEnergyOf(xp));
  }
  lastPotential_ = nonConservativePotential(model, x);
  total_ += flows;
  step_ += flows;
}

void EnergyLedger::endStep(const Model& model) {
  stored_ = stored(model);  // (lastPotential_: the last substep's commit read it at this state)
}

template <class Archive, class Self>
void EnergyLedger::members(Archive& a, Self& s) {
  auto flows = [&](auto& f) {
    fields(a, f.gravity, f.constraints, f.contact, f.damping, f.removed);
  };
  flows(s.total_);
  flows(s.step_);
  fields(a, s.stored_, s.initial_, s.stepStart_, s.lastPotential_, s.lastReaction_,
         s.lastRevision_);
}

void EnergyLedger::saveState(ArchiveWriter& out) const {
  members(out, *this);
}

void EnergyLedger::loadState(ArchiveReader& in) {
  members(in, *this);
}

}  // namespace cutsim::core
