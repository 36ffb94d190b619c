// checkManifold (see mesh_io.hpp): plain hashing and a union-find over triangle corners, no CGAL.
// Expected O(n) in the number of triangles.
//
// The checks run in this order, each reporting the first offender in file order:
//   1. triangle indices in range and distinct (a MeshData built by hand may break them);
//   2. non-manifold edges: the first triangle that is the third on an edge;
//   3. inconsistent orientation: the first triangle that runs an edge in the same direction as
//      the triangle before it on that edge;
//   4. bowtie vertices: the lowest-numbered vertex whose triangles form two or more fans.
// Vertex indices in the messages are 0-based (the MeshData's numbering).
#include <algorithm>
#include <array>
#include <cstdint>
#include <numeric>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/base/union_find.hpp"
#include "cutsim/topology/mesh_io.hpp"

namespace cutsim::topology {
namespace {

std::string whereTriangle(const MeshData& mesh, std::size_t t) {
  const std::size_t line = t < mesh.triangleLines.size() ? mesh.triangleLines[t] : 0;
  if (line == 0) {
    const std::string id = "triangle " + std::to_string(t);
    return mesh.source.empty() ? id : mesh.source + " (" + id + ")";
  }
  return mesh.source.empty() ? "line " + std::to_string(line)
                             : mesh.source + ":" + std::to_string(line);
}

std::string whereVertex(const MeshData& mesh, std::size_t v) {
  const std::size_t line = v < mesh.pointLines.size() ? mesh.pointLines[v] : 0;
  if (line == 0) {
    const std::string id = "vertex " + std::to_string(v);
    return mesh.source.empty() ? id : mesh.source + " (" + id + ")";
  }
  return mesh.source.empty() ? "line " + std::to_string(line)
                             : mesh.source + ":" + std::to_string(line);
}

/// "line 12" of triangle t, or "triangle 3" when the mesh has no line numbers.
std::string describeTriangle(const MeshData& mesh, std::size_t t) {
  const std::size_t line = t < mesh.triangleLines.size() ? mesh.triangleLines[t] : 0;
  return line == 0 ? "triangle " + std::to_string(t) : "line " + std::to_string(line);
}

std::uint64_t undirectedKey(PointId a, PointId b) {
  if (a > b) std::swap(a, b);
  return (std::uint64_t{a.idx()} << 32) | b.idx();
}

std::string edgeName(PointId a, PointId b) {
  return "edge between vertices " + std::to_string(a.idx()) + " and " + std::to_string(b.idx());
}

/// What the first pass learns about one undirected edge.
struct EdgeUse {
  std::uint32_t count = 0;
  std::array<std::uint32_t, 2> triangles{};  ///< the first two triangles on the edge
  std::array<std::uint8_t, 2> corner{};      ///< local index of the edge's first vertex in each
};

}  // namespace

void checkManifold(const MeshData& mesh) {
  const std::size_t nt = mesh.triangles.size();
  const std::size_t nv = mesh.points.size();

  // 1. indices
  for (std::size_t t = 0; t < nt; ++t) {
    const TriangleVertices& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) {
      if (tri[k].idx() >= nv) {
        throw InvalidInput(whereTriangle(mesh, t),
                           "vertex index " + std::to_string(tri[k].idx()) +
                               " out of range: valid " +
                               (nv == 0 ? std::string("none (no vertices)")
                                        : "range is 0.." + std::to_string(nv - 1)));
      }
    }
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) {
      const PointId repeated = tri[0] == tri[1] || tri[0] == tri[2] ? tri[0] : tri[1];
      throw InvalidInput(
          whereTriangle(mesh, t),
          "triangle repeats vertex " + std::to_string(repeated.idx()) + " (a degenerate triangle)");
    }
  }

  // 2. non-manifold edges. Edge k of a triangle runs from corner k to corner k+1.
  std::unordered_map<std::uint64_t, EdgeUse> edges;
  edges.reserve(nt * 2 + 1);
  for (std::size_t t = 0; t < nt; ++t) {
    const TriangleVertices& tri = mesh.triangles[t];
    for (std::uint8_t k = 0; k < 3; ++k) {
      const PointId a = tri[k];
      const PointId b = tri[(k + 1) % 3];
      EdgeUse& use = edges[undirectedKey(a, b)];
      if (use.count == 2) {
        throw InvalidInput(whereTriangle(mesh, t),
                           "non-manifold " + edgeName(a, b) +
                               ": shared by three or more triangles (" +
                               describeTriangle(mesh, use.triangles[0]) + ", " +
                               describeTriangle(mesh, use.triangles[1]) + " and this one)");
      }
      use.triangles[use.count] = static_cast<std::uint32_t>(t);
      use.corner[use.count] = k;
      ++use.count;
    }
  }

  // 3. orientation: on an edge with two triangles, each must run it in the other direction.
  for (std::size_t t = 0; t < nt; ++t) {
    const TriangleVertices& tri = mesh.triangles[t];
    for (std::uint8_t k = 0; k < 3; ++k) {
      const PointId a = tri[k];
      const PointId b = tri[(k + 1) % 3];
      const EdgeUse& use = edges.find(undirectedKey(a, b))->second;
      if (use.count != 2 || use.triangles[1] != t) continue;
      const TriangleVertices& other = mesh.triangles[use.triangles[0]];
      if (other[use.corner[0]] == a) {  // the other triangle also runs a -> b
        throw InvalidInput(whereTriangle(mesh, t),
                           "inconsistent orientation: " + edgeName(a, b) + " is run from " +
                               std::to_string(a.idx()) + " to " + std::to_string(b.idx()) +
                               " by this triangle and by the triangle at " +
                               describeTriangle(mesh, use.triangles[0]) +
                               " (neighbouring triangles must run a shared edge in opposite "
                               "directions)");
      }
    }
  }

  // 4. bowties. Corners 3t+k; two corners of the same vertex are in the same fan when their
  // triangles share an edge at that vertex.
  UnionFind fans(3 * nt);
  for (const auto& [key, use] : edges) {
    if (use.count != 2) continue;
    const std::size_t t0 = use.triangles[0];
    const std::size_t t1 = use.triangles[1];
    // In t0 the edge runs corner c0 -> c0+1; in t1 (opposite direction) corner c1 -> c1+1 runs
    // the other way, so t0's c0 matches t1's c1+1 and t0's c0+1 matches t1's c1.
    const std::size_t c0 = use.corner[0];
    const std::size_t c1 = use.corner[1];
    fans.unite(3 * t0 + c0, 3 * t1 + (c1 + 1) % 3);
    fans.unite(3 * t0 + (c0 + 1) % 3, 3 * t1 + c1);
  }
  std::vector<std::size_t> firstFan(nv, SIZE_MAX);
  std::vector<bool> bowtie(nv, false);
  for (std::size_t c = 0; c < 3 * nt; ++c) {
    const PointId v = mesh.triangles[c / 3][c % 3];
    const std::size_t root = fans.find(c);
    if (firstFan[v.idx()] == SIZE_MAX) {
      firstFan[v.idx()] = root;
    } else if (firstFan[v.idx()] != root) {
      bowtie[v.idx()] = true;
    }
  }
  for (std::size_t v = 0; v < nv; ++v) {
    if (!bowtie[v]) continue;
    std::vector<std::size_t> roots;
    for (std::size_t c = 0; c < 3 * nt; ++c) {
      if (mesh.triangles[c / 3][c % 3].idx() == v) roots.push_back(fans.find(c));
    }
    std::sort(roots.begin(), roots.end());
    const auto nFans = std::unique(roots.begin(), roots.end()) - roots.begin();
    throw InvalidInput(whereVertex(mesh, v),
                       "bowtie vertex " + std::to_string(v) + ": its triangles form " +
                           std::to_string(nFans) +
                           " separate fans that touch only at this vertex (non-manifold vertex)");
  }
}

}  // namespace cutsim::topology
