// Contact's step hook (contact_step.hpp).
#include "cutsim/core/contact_step.hpp"

#include <cmath>
#include <string>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/model.hpp"
#include "cutsim/core/registries.hpp"
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
  // Friction that carried pairs past rest: held, and the step solved again (once).
  if (p.implicit && p.solves == 1 && contact_.holdOvershoots(p.v1, p.constrained) > 0) {
    verdict.again = true;
    return verdict;
  }
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

namespace {

const bool registered = StepHookRegistry::instance().add(
    {"contact",
     "self-contact and the obstacles' contact: a penalty with friction and a displacement bound "
     "that keeps the surface free of intersections (docs/contact.md); its obstacles are the "
     "scene's \"obstacles\" list",
     {{"thickness",
       KeyType::Number,
       "m, > 0: the distance within which primitives repel",
       {},
       true},
      {"stiffness", KeyType::Number, "N/m, > 0: E(s) = k/3 (d - s)^3 / s", {}, true},
      {"friction", KeyType::Number, ">= 0: the Coulomb coefficient of self-contact (default 0)"},
      {"stickVelocity", KeyType::Number, "m/s, > 0: below it friction is viscous (default 1e-3)"},
      {"selfContact", KeyType::Boolean, "whether the surface meets itself (default true)"},
      {"displacementFraction", KeyType::Number,
       "in (0, 0.5): how much of a pair's distance its points may travel in a step when it "
       "cannot be proven apart (default 0.4)"},
      {"splitAbove", KeyType::Number,
       "in [0, 1]: the fraction of points clamped above which a step is redone as two halves "
       "(default 0.01)"},
      {"maxSplits", KeyType::Integer, "0..20: halvings in a row at most (default 4)"}},
     {},
     [](const ParameterSource& s) -> std::any {
       forcefields::ContactSetup setup;
       forcefields::ContactParameters& c = setup.parameters;
       s.require("thickness");
       s.require("stiffness");
       c.thickness = s.positive("thickness", c.thickness);
       c.stiffness = s.positive("stiffness", c.stiffness);
       c.friction = s.nonNegative("friction", c.friction);
       c.stickVelocity = s.positive("stickVelocity", c.stickVelocity);
       c.selfContact = s.boolean("selfContact", c.selfContact);
       c.displacementFraction = s.positive("displacementFraction", c.displacementFraction);
       c.splitAbove = s.nonNegative("splitAbove", c.splitAbove);
       c.maxSplits = int(s.integer("maxSplits", 0, 20, c.maxSplits));
       s.check([&] { c.validate(); });
       return setup;
     },
     [](const std::any& p, Simulation& sim, const std::string& label) -> std::unique_ptr<StepHook> {
       const auto& setup = std::any_cast<const forcefields::ContactSetup&>(p);
       auto contact = std::make_unique<forcefields::Contact>(sim.topology(), setup.parameters,
                                                             setup.obstacles);
       forcefields::Contact& field = *contact;
       sim.addForceField(std::move(contact), label);
       return std::make_unique<ContactStep>(field);
     }});

}  // namespace

forcefields::Contact* findContact(const Simulation& sim) {
  for (std::size_t i = 0; i < sim.numStepHooks(); ++i)
    if (const auto* c = dynamic_cast<const ContactStep*>(&sim.stepHook(i))) return &c->contact();
  return nullptr;
}

}  // namespace cutsim::core
