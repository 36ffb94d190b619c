// `cutsim components [KIND]`: what a scene can name, read from the registries: every force field,
// integrator, linear solver, constraint, timeline action and obstacle shape with its one-line
// summary and keys.
#include <iostream>
#include <memory>
#include <string>

#include "commands.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/core/registries.hpp"
#include "cutsim/core/timeline.hpp"
#include "cutsim/forcefields/obstacle.hpp"

namespace cutsim::cli {
namespace {

template <class Registry>
void list(const char* title, const char* sceneKey, const Registry& registry) {
  std::cout << title;
  if (*sceneKey) std::cout << " (scene key \"" << sceneKey << "\")";
  std::cout << "\n";
  for (const auto& [name, entry] : registry.entries()) {
    std::cout << "  " << name << ": " << entry.summary << "\n";
    for (const std::string& u : entry.uses) std::cout << "      uses a " << u << "\n";
    for (const KeyInfo& k : entry.keys) {
      std::cout << "      " << k.name << " (" << toString(k.type)
                << (k.required ? ", required" : "");
      if (k.type == KeyType::Choice) {
        std::cout << ":";
        for (const std::string& c : k.choices) std::cout << " " << c;
      }
      std::cout << "): " << k.what << "\n";
    }
  }
}

}  // namespace

void registerComponentsCommand(CLI::App& app) {
  auto kind = std::make_shared<std::string>();
  CLI::App* cmd =
      app.add_subcommand("components",
                         "List what a scene can name (force fields, integrators, "
                         "linear solvers, constraints, actions, step hooks, obstacles) with their "
                         "keys");
  cmd->add_option(
      "kind", *kind,
      "forcefields, integrators, linearsolvers, constraints, actions, hooks or obstacles "
      "(default: all)");
  cmd->callback([kind] {
    const bool all = kind->empty();
    if (!all && *kind != "forcefields" && *kind != "integrators" && *kind != "linearsolvers" &&
        *kind != "constraints" && *kind != "actions" && *kind != "hooks" && *kind != "obstacles")
      throw InvalidInput("components",
                         "unknown kind \"" + *kind +
                             "\" (forcefields, integrators, linearsolvers, constraints, actions, "
                             "hooks, obstacles)");
    if (all || *kind == "forcefields")
      list("force fields", "forceFields", forcefields::ForceFieldRegistry::instance());
    if (all || *kind == "integrators")
      list("integrators", "integrator", core::IntegratorRegistry::instance());
    if (all || *kind == "linearsolvers")
      list("linear solvers", "linearSolver", core::LinearSolverRegistry::instance());
    if (all || *kind == "constraints")
      list("constraints", "constraints", core::ConstraintRegistry::instance());
    if (all || *kind == "actions")
      list("timeline actions", "timeline", core::ActionRegistry::instance());
    if (all || *kind == "hooks")
      list("step hooks (each a section of the scene, under its name)", "",
           core::StepHookRegistry::instance());
    if (all || *kind == "obstacles")
      list("obstacle shapes", "obstacles", forcefields::ObstacleShapeRegistry::instance());
    std::cout.flush();
    if (!std::cout) throw Error("cannot write to standard output");
  });
}

}  // namespace cutsim::cli
