#pragma once
// Small hand-built meshes for the tests, named for what they are.
#include <cstdint>

#include "cutsim/topology/mesh_io.hpp"

namespace cutsim::test {

/// Flat grid on [0, size]^2 (z = 0) with n x n vertices (n >= 2); vertex (i, j) has index
/// j * n + i and sits at (size i / (n - 1), size j / (n - 1), 0). Every quad
/// (x,y),(x+1,y),(x+1,y+1),(x,y+1) is split along its (x,y)-(x+1,y+1) diagonal, counter-clockwise.
/// With jitter > 0 every interior vertex moves in the plane by up to jitter * spacing in x and y
/// (seeded, reproducible).
topology::MeshData grid(int n, double size = 10.0, double jitter = 0.0, std::uint64_t seed = 1);

/// One hinge: two triangles (C, D, A) and (D, C, B) on the edge CD, points in the order A, B, C, D.
topology::MeshData oneHinge(const topology::Vec3& a, const topology::Vec3& b,
                            const topology::Vec3& c, const topology::Vec3& d);

/// A fan of `sectors` triangles around a centre vertex 0, rim on the unit circle lifted by
/// z = height * sin(2 angle) (closed if `closed`).
topology::MeshData fan(int sectors, bool closed, double height = 0.0);

/// The same mesh with its vertices renumbered by a seeded random permutation; `newOfOld` (if not
/// null) receives the new index of each old vertex.
topology::MeshData shuffledVertices(const topology::MeshData& mesh, std::uint64_t seed,
                                    std::vector<topology::PointId>* newOfOld = nullptr);

}  // namespace cutsim::test
