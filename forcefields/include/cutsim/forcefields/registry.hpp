#pragma once
// The force fields' registry: a Registry (cutsim/base/registry.hpp) of ForceField built on a
// topology. Each force field adds its entry at the end of its own .cpp (docs/architecture.md).
#include "cutsim/base/registry.hpp"
#include "cutsim/forcefields/force_field.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::forcefields {

using ForceFieldRegistry = Registry<ForceField, topology::Topology&>;

}  // namespace cutsim::forcefields
