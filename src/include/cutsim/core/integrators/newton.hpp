#pragma once
// Backward Euler solved to convergence by Newton's method with a line search (the method:
// cutsim/core/integrator.hpp; registered as "newton" in src/core/integrators/).
#include <vector>

#include "cutsim/core/integrator.hpp"

namespace cutsim::core {

/// Newton's own settings.
struct NewtonSettings {
  int maxIterations = 20;   ///< >= 1
  double tolerance = 1e-8;  ///< |residual| <= tolerance |first residual| ends the iterations (> 0)
  bool exactStiffness = true;  ///< ask the fields for their exact K
  bool lineSearch = true;      ///< backtracking line search on the incremental potential
  void validate() const;
};

/// What a scene's "newton" integrator reads (its ComponentSpec's parameters).
struct NewtonParameters {
  ImplicitSettings implicit;
  NewtonSettings newton;
};

class NewtonImplicitEuler final : public ImplicitIntegrator {
 public:
  NewtonImplicitEuler(ImplicitSettings settings, NewtonSettings newton,
                      std::unique_ptr<LinearSolver> solver);
  std::string_view name() const override { return "newton"; }
  void step(Model& model, const StepInput& in, StepOutput& out, StepStats& stats) override;
  const NewtonSettings& newtonSettings() const { return newton_; }
  /// |residual| after each iteration of the last step (the first entry: before any), for the
  /// convergence study.
  const std::vector<double>& lastResiduals() const { return residuals_; }

 private:
  NewtonSettings newton_;
  std::vector<double> residuals_;
};

}  // namespace cutsim::core
