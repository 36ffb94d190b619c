// Contact's step hook (contact_step.hpp).
#include "cutsim/core/contact_step.hpp"

#include <cmath>
#include <string>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/model.hpp"
#include "cutsim/core/simulation.hpp"
#include "cutsim/forcefields/contact.hpp"

namespace cutsim::core {

void ContactStep::beginStep(const StepStart& s) {
  forcefields::ObstaclePoses poses;
  for (const forcefields::Obstacle& o : contact_.obstacles()) {
    poses.start.push_back(o.offsetAt(s.t0));
    poses.end.push_back(o.offsetAt(s.t0 + s.dt));
  }
  contact_.beginStep(s.model.state().x(), s.model.state().v(), poses, s.dt);
}

void ContactStep::moveObstacle(std::size_t k, double now, const Vec3& delta, double duration) {
  const auto& obstacles = contact_.obstacles();
  if (k >= obstacles.size()) throw InvalidInput("obstacle", "no obstacle " + std::to_string(k));
  const forcefields::Obstacle& o = obstacles[k];
  const std::string where = "obstacle \"" + o.name + "\"";
  if (!std::isfinite(now) || !(duration > 0) || !std::isfinite(duration))
    throw InvalidInput(where,
                       "a move needs a finite duration > 0 (an obstacle sweeps; it does not jump)");
  for (double c : delta)
    if (!std::isfinite(c)) throw InvalidInput(where, "non-finite displacement");
  const Vec3 d0 = o.offsetAt(now);
  std::vector<forcefields::ObstacleKey> path;
  for (const forcefields::ObstacleKey& key : o.path)
    if (key.time < now) path.push_back(key);
  path.push_back({now, d0});
  path.push_back({now + duration, {d0[0] + delta[0], d0[1] + delta[1], d0[2] + delta[2]}});
  contact_.setObstaclePath(k, std::move(path));
}

StepVerdict ContactStep::afterSolve(const StepProposal& p) {
  StepVerdict verdict;
  verdict.limited = contact_.limitDisplacement(p.x0, p.x1, p.v1, p.dt, p.constrained);
  const forcefields::ContactParameters& P = contact_.parameters();
  const double live = double(p.model.topology().numPoints());
  verdict.split =
      verdict.limited > 0 && double(verdict.limited) > P.splitAbove * live && p.depth < P.maxSplits;
  return verdict;
}

void ContactStep::endStep(const StepEnd& e) {
  contact_.recordStep(e.model.state().x(), e.model.state().v());
}

ContactStep& addContact(Simulation& sim, std::unique_ptr<forcefields::Contact> contact,
                        std::string label) {
  if (!contact) throw InvalidInput("contact", "no contact");
  if (findContact(sim)) throw InvalidInput("contact", "the simulation has contact already");
  forcefields::Contact& field = *contact;
  sim.addForceField(std::move(contact), std::move(label));
  return static_cast<ContactStep&>(sim.addStepHook(std::make_unique<ContactStep>(field)));
}

ContactStep* findContactStep(Simulation& sim) {
  for (std::size_t i = 0; i < sim.numStepHooks(); ++i)
    if (auto* c = dynamic_cast<ContactStep*>(&sim.stepHook(i))) return c;
  return nullptr;
}

forcefields::Contact* findContact(const Simulation& sim) {
  for (std::size_t i = 0; i < sim.numStepHooks(); ++i)
    if (const auto* c = dynamic_cast<const ContactStep*>(&sim.stepHook(i))) return &c->contact();
  return nullptr;
}

}  // namespace cutsim::core
