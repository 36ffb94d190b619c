#pragma once
// Backward Euler linearised once per step (the method: cutsim/core/integrator.hpp; registered as
// "implicit-euler" in src/core/integrators/).
#include "cutsim/core/integrator.hpp"

namespace cutsim::core {

class ImplicitEuler final : public ImplicitIntegrator {
 public:
  using ImplicitIntegrator::ImplicitIntegrator;
  std::string_view name() const override { return "implicit-euler"; }
  void step(Model& model, const StepInput& in, StepOutput& out, StepStats& stats) override;
};

}  // namespace cutsim::core
