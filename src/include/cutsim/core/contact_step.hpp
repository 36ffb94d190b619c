#pragma once
// Contact's step hook: before each step the contact's obstacles move to their poses and its
// pairs are collected (forcefields::Contact::beginStep); after the solve its displacement bound
// limits the proposal, and a step that clamped more than the contact's splitAbove fraction of the
// live points is redone as two halves, at most maxSplits times in a row; after the step its
// figures are recorded for the CSV. The contact itself is a force field of the model.
#include <memory>
#include <string>

#include "cutsim/core/step_hook.hpp"

namespace cutsim::forcefields {
class Contact;
}

namespace cutsim::core {

class Simulation;

class ContactStep final : public StepHook {
 public:
  /// `contact` is a force field of the simulation's model and outlives the hook.
  explicit ContactStep(forcefields::Contact& contact) : contact_(contact) {}
  std::string_view name() const override { return "contact"; }
  void beginStep(const StepStart& s) override;
  StepVerdict afterSolve(const StepProposal& p) override;
  void endStep(const StepEnd& e) override;
  forcefields::Contact& contact() const { return contact_; }

 private:
  forcefields::Contact& contact_;
};

/// Adds `contact` to the simulation's force fields under `label` and its ContactStep to its step
/// hooks (what a scene's "contact" section builds).
ContactStep& addContact(Simulation& sim, std::unique_ptr<forcefields::Contact> contact,
                        std::string label = "contact");

/// The contact of a simulation (the field its ContactStep drives), or null.
forcefields::Contact* findContact(const Simulation& sim);

}  // namespace cutsim::core
