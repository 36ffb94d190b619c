// Contact's step hook (contact_step.hpp).
#include "cutsim/core/contact_step.hpp"

#include "cutsim/base/errors.hpp"
#include "cutsim/core/model.hpp"
#include "cutsim/core/simulation.hpp"
#include "cutsim/forcefields/contact.hpp"

namespace cutsim::core {

void ContactStep::beginStep(const StepStart& s) {
  contact_.beginStep(s.model.state().x(), s.model.state().v(), s.t0, s.dt);
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

forcefields::Contact* findContact(const Simulation& sim) {
  for (std::size_t i = 0; i < sim.numStepHooks(); ++i)
    if (const auto* c = dynamic_cast<const ContactStep*>(&sim.stepHook(i))) return &c->contact();
  return nullptr;
}

}  // namespace cutsim::core
