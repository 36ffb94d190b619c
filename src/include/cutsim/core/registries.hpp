#pragma once
// The registries of the core's components (registry.hpp has the force fields' and the scheme):
// integrators are built with the linear solver their entry "uses" (null for explicit ones).
#include <memory>

#include "cutsim/core/integrator.hpp"
#include "cutsim/core/linear_solver.hpp"
#include "cutsim/forcefields/registry.hpp"

namespace cutsim::core {

using LinearSolverRegistry = Registry<LinearSolver>;
using IntegratorRegistry = Registry<Integrator, std::unique_ptr<LinearSolver>>;

/// The keys every implicit integrator reads (rayleighMass, rayleighStiffness, onSolveFailure,
/// fallbackAbove), and reading them.
std::vector<KeyInfo> implicitKeys();
ImplicitSettings readImplicitSettings(const ParameterSource& s);

}  // namespace cutsim::core
