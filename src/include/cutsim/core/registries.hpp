#pragma once
// The registries of the core's components (cutsim/base/registry.hpp has the scheme,
// cutsim/forcefields/registry.hpp the force fields'):
// integrators are built with the linear solver their entry "uses" (null for explicit ones).
#include <memory>

#include "cutsim/core/integrator.hpp"
#include "cutsim/core/linear_solver.hpp"
#include "cutsim/core/step_hook.hpp"
#include "cutsim/forcefields/registry.hpp"

namespace cutsim::core {

using LinearSolverRegistry = Registry<LinearSolver>;
using IntegratorRegistry = Registry<Integrator, std::unique_ptr<LinearSolver>>;
class Simulation;
/// Step hooks a scene asks for by a section of its own ("contact"): an entry's build may add what
/// the hook drives to the simulation (contact adds its force field, under the label given) and
/// returns the hook, which the scene's runner then adds.
using StepHookRegistry = Registry<StepHook, Simulation&, const std::string&>;

/// The keys every implicit integrator reads (rayleighMass, rayleighStiffness, onSolveFailure,
/// fallbackAbove, fallbackSolver), and reading them.
std::vector<KeyInfo> implicitKeys();
ImplicitSettings readImplicitSettings(const ParameterSource& s);
/// The linear solver registered under `name`, with its default settings (InvalidInput at
/// "fallbackSolver" for an unknown name).
std::unique_ptr<LinearSolver> makeFallbackSolver(const std::string& name);

/// Registers an implicit integrator T(ImplicitSettings, linear solver) that reads only the shared
/// implicit keys (implicit Euler, BDF2).
template <class T>
bool registerImplicitIntegrator(std::string name, std::string summary) {
  return IntegratorRegistry::instance().add(
      {std::move(name),
       std::move(summary),
       implicitKeys(),
       {"linearSolver"},
       [](const ParameterSource& s) -> std::any { return readImplicitSettings(s); },
       [](const std::any& p, std::unique_ptr<LinearSolver> ls) -> std::unique_ptr<Integrator> {
         return std::make_unique<T>(std::any_cast<const ImplicitSettings&>(p), std::move(ls));
       }});
}

}  // namespace cutsim::core
