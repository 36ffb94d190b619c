#pragma once
// Counts that describe a triangle mesh, as `cutsim info` prints them.
#include <cstddef>

#include "cutsim/topology/mesh_io.hpp"

namespace cutsim::core {

struct MeshInfo {
  std::size_t vertices = 0;  ///< all points, isolated ones included
  std::size_t edges = 0;     ///< distinct undirected edges of the triangles
  std::size_t triangles = 0;
  std::size_t boundary_edges = 0;     ///< edges with exactly one triangle
  std::size_t components = 0;         ///< sets of triangles connected through shared edges
  std::size_t isolated_vertices = 0;  ///< points in no triangle (not counted as components)

  bool operator==(const MeshInfo&) const = default;
};

/// Counts of a triangle soup. Needs valid indices (throws InvalidInput otherwise) but not a
/// manifold: an edge with three or more triangles is one edge, neither boundary nor special.
MeshInfo computeMeshInfo(const topology::MeshData& mesh);

}  // namespace cutsim::core
