#pragma once
// Private to cutsim::core: what the scene's schema and dry run share.
#include "cutsim/core/scene.hpp"

namespace cutsim::core::detail {

class Reader;

/// Checks every constraint and action of the scene, in order, on a copy of the rest mesh (each
/// one's dryRun). Fails through r.
void dryRun(const Reader& r, const Scene& scene, const topology::MeshData& mesh);

}  // namespace cutsim::core::detail
