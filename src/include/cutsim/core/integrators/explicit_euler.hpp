#pragma once
// Symplectic (semi-implicit) Euler (the method: cutsim/core/integrator.hpp; registered as
// "explicit-euler" in src/core/integrators/).
#include "cutsim/core/integrator.hpp"

namespace cutsim::core {

class ExplicitEuler final : public Integrator {
 public:
  std::string_view name() const override { return "explicit-euler"; }
  bool isExplicit() const override { return true; }
  bool checkpointable() const override { return true; }  // nothing kept between steps
  void step(Model& model, const StepInput& in, StepOutput& out, StepStats& stats) override;
};

}  // namespace cutsim::core
