#pragma once
// Private to cutsim::core: what the scene's schema, dry run and runner share.
#include <string>
#include <vector>

#include "cutsim/core/scene.hpp"

namespace cutsim::core::detail {

class Reader;

/// The live triangles whose rest centroid lies in the region.
std::vector<topology::TriangleId> trianglesInRegion(const topology::Topology& topo, const Region& region);
/// The pointer of a selection's key ("/points", "/box", "/near") under ptr.
std::string selectionPointer(const PointSelection& s, const std::string& ptr);
/// Runs the scene's timeline on a copy of the rest mesh: every selection resolves to a point,
/// every cut and removal can be made, grasps are started and released in order. Fails through r.
void dryRun(const Reader& r, const Scene& scene, const topology::MeshData& mesh);

}  // namespace cutsim::core::detail
