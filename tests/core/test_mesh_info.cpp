// computeMeshInfo: exact counts on the project's meshes (data/meshes) and on small test files.
#include <gtest/gtest.h>

#include <filesystem>
#include <ostream>
#include <string>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/mesh_info.hpp"
#include "cutsim/topology/mesh_io.hpp"
#include "support/ids.hpp"

namespace cutsim::core {

// Found by GoogleTest through argument-dependent lookup: readable failure messages.
void PrintTo(const MeshInfo& m, std::ostream* os);
void PrintTo(const MeshInfo& m, std::ostream* os) {
  *os << "{vertices " << m.vertices << ", edges " << m.edges << ", triangles " << m.triangles
      << ", boundary_edges " << m.boundary_edges << ", components " << m.components
      << ", isolated_vertices " << m.isolated_vertices << "}";
}

namespace {

const std::filesystem::path kTestData = CUTSIM_TEST_DATA_DIR;
const std::filesystem::path kMeshes = std::filesystem::path(CUTSIM_DATA_DIR) / "meshes";

MeshInfo infoOf(const std::filesystem::path& path) {
  const topology::MeshData mesh = topology::readMesh(path);
  topology::checkManifold(mesh);
  return computeMeshInfo(mesh);
}

/// vertices, edges, triangles, boundary edges, components, isolated vertices
MeshInfo expected(std::size_t v, std::size_t e, std::size_t t, std::size_t b, std::size_t c,
                  std::size_t i) {
  return MeshInfo{v, e, t, b, c, i};
}

TEST(MeshInfo, ClosedOctahedron) {
  EXPECT_EQ(infoOf(kMeshes / "octahedron.off"), expected(6, 12, 8, 0, 1, 0));
}

TEST(MeshInfo, ClosedIcosphereSatisfiesEuler) {
  const MeshInfo m = infoOf(kMeshes / "icosphere_1.off");
  EXPECT_EQ(m, expected(42, 120, 80, 0, 1, 0));
  EXPECT_EQ(m.vertices + m.triangles, m.edges + 2);  // V - E + F = 2
}

TEST(MeshInfo, GridCountsFollowTheFormulas) {
  // An nx x ny vertex grid with one diagonal per cell.
  const std::size_t nx = 10, ny = 10;
  const std::size_t cells = (nx - 1) * (ny - 1);
  const MeshInfo m = infoOf(kMeshes / "grid_10x10.obj");
  EXPECT_EQ(m, expected(nx * ny, nx * (ny - 1) + ny * (nx - 1) + cells, 2 * cells,
                        2 * (nx - 1) + 2 * (ny - 1), 1, 0));
  EXPECT_EQ(m, expected(100, 261, 162, 36, 1, 0));
}

TEST(MeshInfo, HingeStripAndTwoComponents) {
  EXPECT_EQ(infoOf(kMeshes / "hinge.obj"), expected(4, 5, 2, 4, 1, 0));
  EXPECT_EQ(infoOf(kMeshes / "strip.off"), expected(12, 21, 10, 12, 1, 0));
  EXPECT_EQ(infoOf(kMeshes / "two_components.obj"), expected(8, 10, 4, 8, 2, 0));
}

TEST(MeshInfo, TheOrganAndTheSkinOnIt) {
  // The icosphere subdivided four times: 10 * 4^4 + 2 points, 20 * 4^4 triangles, closed.
  EXPECT_EQ(infoOf(kMeshes / "organ.obj"), expected(2562, 7680, 5120, 0, 1, 0));
  // The 31 x 31 grid with one diagonal per cell, lifted: the formulas of the flat grid.
  EXPECT_EQ(infoOf(kMeshes / "organ_skin.obj"),
            expected(31 * 31, 2 * 31 * 30 + 30 * 30, 2 * 30 * 30, 4 * 30, 1, 0));
}

TEST(MeshInfo, IsolatedVertexIsCountedButIsNoComponent) {
  EXPECT_EQ(infoOf(kTestData / "good" / "isolated_vertex.obj"), expected(4, 3, 1, 3, 1, 1));
}

TEST(MeshInfo, SofaReferenceMeshesHaveTheirSpringCounts) {
  // Active springs = interior edges = edges - boundary edges (tests/data/sofa-reference/README.md).
  const MeshInfo cylinder = infoOf(kTestData / "sofa-reference" / "cylinder_patch_rest.obj");
  EXPECT_EQ(cylinder.vertices, 35u);
  EXPECT_EQ(cylinder.triangles, 48u);
  EXPECT_EQ(cylinder.edges - cylinder.boundary_edges, 62u);
  const MeshInfo grid = infoOf(kTestData / "sofa-reference" / "grid7x6_alt_jitter_rest.obj");
  EXPECT_EQ(grid.vertices, 42u);
  EXPECT_EQ(grid.triangles, 60u);
  EXPECT_EQ(grid.edges - grid.boundary_edges, 79u);
}

TEST(MeshInfo, SoupWithoutTrianglesAndNonManifoldEdges) {
  topology::MeshData mesh;
  mesh.points.assign(3, topology::Vec3{0.0, 0.0, 0.0});
  EXPECT_EQ(computeMeshInfo(mesh), expected(3, 0, 0, 0, 0, 3));
  // Three triangles on one edge: one component, the shared edge is not a boundary edge.
  mesh.points.assign(5, topology::Vec3{0.0, 0.0, 0.0});
  mesh.triangles = {tri(0, 1, 2), tri(1, 0, 3), tri(0, 1, 4)};
  EXPECT_EQ(computeMeshInfo(mesh), expected(5, 7, 3, 6, 1, 0));
}

TEST(MeshInfo, RejectsAnIndexOutOfRange) {
  topology::MeshData mesh;
  mesh.points.assign(3, topology::Vec3{0.0, 0.0, 0.0});
  mesh.triangles = {tri(0, 1, 3)};
  EXPECT_THROW(computeMeshInfo(mesh), InvalidInput);
}

}  // namespace
}  // namespace cutsim::core
