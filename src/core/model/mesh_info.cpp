// computeMeshInfo: one pass over the triangles' edges with a hash map, and a union-find over the
// triangles for the face-connected components.
#include "cutsim/core/mesh_info.hpp"

#include <cstdint>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/base/union_find.hpp"

namespace cutsim::core {

MeshInfo computeMeshInfo(const topology::MeshData& mesh) {
  const std::size_t nv = mesh.points.size();
  const std::size_t nt = mesh.triangles.size();
  MeshInfo info;
  info.vertices = nv;
  info.triangles = nt;

  struct EdgeUse {
    std::size_t count = 0;
    std::size_t firstTriangle = 0;
  };
  std::unordered_map<std::uint64_t, EdgeUse> edges;
  edges.reserve(2 * nt + 1);
  std::vector<bool> used(nv, false);
  UnionFind components(nt);
  std::size_t merges = 0;

  for (std::size_t t = 0; t < nt; ++t) {
    const topology::TriangleVertices& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) {
      if (tri[k].idx() >= nv) {
        const std::size_t line = t < mesh.triangleLines.size() ? mesh.triangleLines[t] : 0;
        throw InvalidInput(line == 0 ? mesh.source : mesh.source + ":" + std::to_string(line),
                           "triangle " + std::to_string(t) + " uses vertex " +
                               std::to_string(tri[k].idx()) + " but the mesh has " +
                               std::to_string(nv) + " vertices");
      }
      used[tri[k].idx()] = true;
      std::uint32_t a = tri[k].idx();
      std::uint32_t b = tri[(k + 1) % 3].idx();
      if (a == b) continue;  // a degenerate triangle's zero-length side is no edge
      if (a > b) std::swap(a, b);
      EdgeUse& use = edges[(std::uint64_t{a} << 32) | b];
      if (use.count == 0) {
        use.firstTriangle = t;
      } else if (components.unite(use.firstTriangle, t)) {
        ++merges;
      }
      ++use.count;
    }
  }

  info.edges = edges.size();
  for (const auto& [key, use] : edges) {
    if (use.count == 1) ++info.boundary_edges;
  }
  info.components = nt - merges;
  for (const bool u : used) {
    if (!u) ++info.isolated_vertices;
  }
  return info;
}

}  // namespace cutsim::core
