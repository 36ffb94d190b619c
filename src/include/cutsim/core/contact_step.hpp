#pragma once
// Contact's step hook, where contact's time lives: before each step it reads the obstacles' poses
// at the step's start and end off their paths and hands them to the field, which collects its
// pairs (forcefields::Contact::beginStep; the field knows no time); after the solve its
// displacement bound limits the proposal, and a step that clamped more than the contact's
// splitAbove fraction of the live points is redone as two halves, at most maxSplits times in a row;
// after the step its figures are recorded for the CSV. The contact itself is a force field of the
// model.
#include <memory>
#include <string>

#include "cutsim/base/vec3.hpp"
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
  /// From time `now` on, obstacle k moves by `delta` more over `duration` (> 0: it sweeps, and
  /// the displacement bound sees what it sweeps), then holds; its path's keys after `now` are
  /// dropped. Throws InvalidInput naming the obstacle for a non-finite delta or time, or a
  /// duration that is not > 0.
  void moveObstacle(std::size_t k, double now, const Vec3& delta, double duration);

 private:
  forcefields::Contact& contact_;
};

/// A scene's "contact" section is the StepHookRegistry entry "contact" (contact_step.cpp): its keys
/// are the section's, its parameters a forcefields::ContactSetup (the scene's obstacles added to
/// it by the scene reader); its build adds the field and returns its ContactStep.
///
/// Adds `contact` to the simulation's force fields under `label` and its ContactStep to its step
/// hooks (what a scene's "contact" section builds).
ContactStep& addContact(Simulation& sim, std::unique_ptr<forcefields::Contact> contact,
                        std::string label = "contact");

/// The contact of a simulation (the field its ContactStep drives), or null.
forcefields::Contact* findContact(const Simulation& sim);
/// The simulation's ContactStep, or null.
ContactStep* findContactStep(Simulation& sim);

}  // namespace cutsim::core
