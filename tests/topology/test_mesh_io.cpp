// Mesh reading and writing (OBJ, OFF) and the manifold check, on the files of tests/data/good and
// the bad-input corpus of tests/data/bad (see tests/data/README.md).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/topology/mesh_io.hpp"
#include "support/ids.hpp"

namespace cutsim::topology {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

const std::filesystem::path kTestData = CUTSIM_TEST_DATA_DIR;
const std::filesystem::path kData = CUTSIM_DATA_DIR;

std::string good(const std::string& name) {
  return (kTestData / "good" / name).string();
}
std::string bad(const std::string& name) {
  return (kTestData / "bad" / name).string();
}

/// readMesh then checkManifold, as every user of a mesh file does.
MeshData load(const std::string& path) {
  MeshData mesh = readMesh(path);
  checkManifold(mesh);
  return mesh;
}

// ---- good files ----

TEST(MeshIoObj, ReadsEveryFaceFormNegativeIndicesAndIgnoredRecords) {
  const MeshData mesh = load(good("all_forms.obj"));
  EXPECT_EQ(mesh.source, good("all_forms.obj"));
  ASSERT_EQ(mesh.points.size(), 6u);
  EXPECT_EQ(mesh.points[0], (Vec3{0.0, 0.0, 0.0}));
  EXPECT_EQ(mesh.points[1], (Vec3{1.5, 0.0, 0.0}));  // "+1.5"
  EXPECT_EQ(mesh.points[2], (Vec3{3.0, 0.0, 0.0}));  // "3.0e0", tab separated
  EXPECT_EQ(mesh.points[3], (Vec3{0.0, 2.25, -0.125}));
  EXPECT_EQ(mesh.points[4], (Vec3{1.5, 2.25, 1e-3}));  // with a w coordinate
  EXPECT_EQ(mesh.points[5], (Vec3{3.0, 2.25, 0.0}));   // defined after two faces
  EXPECT_THAT(mesh.pointLines, ElementsAre(4u, 5u, 6u, 7u, 8u, 19u));
  ASSERT_EQ(mesh.triangles.size(), 4u);
  EXPECT_EQ(mesh.triangles[0], (tri(0, 1, 4)));  // f 1 2 5
  EXPECT_EQ(mesh.triangles[1], (tri(0, 4, 3)));  // f 1/1 -1/3 -2/4 (5 defined)
  EXPECT_EQ(mesh.triangles[2], (tri(1, 2, 5)));  // f -5//1 -4//1 -1//1 (6 defined)
  EXPECT_EQ(mesh.triangles[3], (tri(1, 5, 4)));  // f 2/1/1 6/2/1 5/3/1
  EXPECT_THAT(mesh.triangleLines, ElementsAre(17u, 18u, 22u, 23u));
}

TEST(MeshIoObj, ToleratesCrlfLineEnds) {
  const MeshData mesh = load(good("crlf.obj"));
  ASSERT_EQ(mesh.points.size(), 3u);
  EXPECT_EQ(mesh.points[2], (Vec3{0.0, 1.0, 0.5}));
  EXPECT_THAT(mesh.pointLines, ElementsAre(2u, 3u, 5u));
  ASSERT_EQ(mesh.triangles.size(), 1u);
  EXPECT_EQ(mesh.triangles[0], (tri(0, 1, 2)));
  EXPECT_THAT(mesh.triangleLines, ElementsAre(6u));
}

TEST(MeshIoObj, ExtensionIsCaseInsensitiveAndIsolatedVerticesAreKept) {
  EXPECT_EQ(load(good("UPPER.OBJ")).triangles.size(), 1u);
  const MeshData mesh = load(good("isolated_vertex.obj"));
  EXPECT_EQ(mesh.points.size(), 4u);
  EXPECT_EQ(mesh.points[3], (Vec3{5.0, 5.0, 5.0}));
  EXPECT_EQ(mesh.triangles.size(), 1u);
}

TEST(MeshIoObj, PositiveIndicesMayReferToLaterVertices) {
  std::istringstream in("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n");
  const MeshData mesh = readObj(in, "stream");
  ASSERT_EQ(mesh.triangles.size(), 1u);
  EXPECT_EQ(mesh.triangles[0], (tri(0, 1, 2)));
  EXPECT_THAT(mesh.triangleLines, ElementsAre(1u));
  EXPECT_EQ(mesh.source, "stream");
}

TEST(MeshIoObj, SkipsAUtf8ByteOrderMark) {
  std::istringstream in("\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const MeshData mesh = readObj(in, "bom");
  EXPECT_EQ(mesh.points.size(), 3u);
  EXPECT_THAT(mesh.pointLines, ElementsAre(1u, 2u, 3u));
  std::istringstream off("\xEF\xBB\xBFOFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(readOff(off, "bom").triangles.size(), 1u);
}

TEST(MeshIoObj, ReportsTheStreamNameAndLine) {
  std::istringstream in("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
  try {
    readObj(in, "memory");
    FAIL() << "no exception";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.where(), "memory:4");
    EXPECT_EQ(std::string(e.what()), "memory:4: " + e.message());
  }
}

TEST(MeshIoOff, ReadsCommentsBlankLinesAndTrailingComments) {
  const MeshData mesh = load(good("comments.off"));
  ASSERT_EQ(mesh.points.size(), 4u);
  EXPECT_EQ(mesh.points[2], (Vec3{1.0, 1.0, 0.5}));
  EXPECT_EQ(mesh.points[3], (Vec3{0.0, 1.0, -0.25}));
  EXPECT_THAT(mesh.pointLines, ElementsAre(5u, 6u, 7u, 9u));
  ASSERT_EQ(mesh.triangles.size(), 2u);
  EXPECT_EQ(mesh.triangles[0], (tri(0, 1, 2)));
  EXPECT_EQ(mesh.triangles[1], (tri(0, 2, 3)));
  EXPECT_THAT(mesh.triangleLines, ElementsAre(10u, 11u));
}

TEST(MeshIoOff, HeaderIsOptionalAndMayHoldTheCounts) {
  const MeshData noHeader = load(good("no_header.off"));
  EXPECT_EQ(noHeader.points.size(), 3u);
  EXPECT_EQ(noHeader.triangles[0], (tri(0, 1, 2)));
  EXPECT_THAT(noHeader.triangleLines, ElementsAre(5u));
  const MeshData oneLine = load(good("header_and_counts.off"));
  EXPECT_EQ(oneLine.points[1], (Vec3{1.0, 0.0, 0.0}));
  EXPECT_EQ(oneLine.triangles[0], (tri(2, 0, 1)));
  EXPECT_THAT(oneLine.pointLines, ElementsAre(2u, 3u, 4u));
}

TEST(MeshIoOff, ToleratesCrlfLineEnds) {
  const MeshData mesh = load(good("crlf.off"));
  ASSERT_EQ(mesh.points.size(), 3u);
  EXPECT_EQ(mesh.points[2], (Vec3{0.0, 1.0, 0.5}));
  EXPECT_THAT(mesh.triangleLines, ElementsAre(6u));
}

TEST(MeshIoOff, ReadsTheProjectMeshes) {
  const MeshData octahedron = load((kData / "meshes" / "octahedron.off").string());
  EXPECT_EQ(octahedron.points.size(), 6u);
  EXPECT_EQ(octahedron.triangles.size(), 8u);
  const MeshData grid = load((kData / "meshes" / "grid_10x10.obj").string());
  EXPECT_EQ(grid.points.size(), 100u);
  EXPECT_EQ(grid.triangles.size(), 162u);
  for (const char* name : {"cylinder_patch_rest.obj", "grid7x6_alt_jitter_deformed.obj"}) {
    EXPECT_NO_THROW(load((kTestData / "sofa-reference" / name).string())) << name;
  }
}

TEST(MeshIoWrite, RoundTripsExactlyThroughObj) {
  const std::vector<Vec3> points = {{0.1, -2.0 / 3.0, 1e-300}, {1e300, 0.0, -0.0}, {3.0, 4.0, 5.5}};
  const std::vector<TriangleVertices> triangles = {tri(0, 1, 2), tri(2, 1, 0)};
  std::stringstream text;
  writeObj(text, points, triangles);
  EXPECT_THAT(text.str(), HasSubstr("\nf 1 2 3\nf 3 2 1\n"));
  const MeshData back = readObj(text, "written");
  EXPECT_EQ(back.points, points);  // 17 significant digits: every double reads back exactly
  EXPECT_EQ(back.triangles, triangles);
}

TEST(MeshIoWrite, WritesAFileThatReadMeshReads) {
  const auto path = std::filesystem::temp_directory_path() / "cutsim_test_mesh_io_write.obj";
  const MeshData hinge = load((kData / "meshes" / "hinge.obj").string());
  writeObj(path, hinge.points, hinge.triangles);
  const MeshData back = load(path.string());
  EXPECT_EQ(back.points, hinge.points);
  EXPECT_EQ(back.triangles, hinge.triangles);
  std::filesystem::remove(path);
}

TEST(MeshIoWrite, ReportsAPathThatCannotBeWritten) {
  const auto path = kTestData / "no_such_directory" / "out.obj";
  try {
    writeObj(path, {}, {});
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr(path.string() + ": cannot open for writing"));
  }
}

// ---- the manifold check on meshes built by hand ----

MeshData soup(std::vector<TriangleVertices> triangles, std::size_t nPoints) {
  MeshData mesh;
  mesh.points.assign(nPoints, Vec3{0.0, 0.0, 0.0});
  mesh.triangles = std::move(triangles);
  return mesh;
}

TEST(MeshIoManifold, AcceptsClosedAndOpenSurfaces) {
  // A closed tetrahedron and a fan around vertex 0 closed into a disk.
  EXPECT_NO_THROW(checkManifold(soup({tri(0, 2, 1), tri(0, 1, 3), tri(1, 2, 3), tri(0, 3, 2)}, 4)));
  EXPECT_NO_THROW(checkManifold(soup({tri(0, 1, 2), tri(0, 2, 3), tri(0, 3, 4), tri(0, 4, 1)}, 5)));
  EXPECT_NO_THROW(checkManifold(soup({}, 3)));
}

TEST(MeshIoManifold, NamesTrianglesByIndexWhenThereAreNoLines) {
  try {
    checkManifold(soup({tri(0, 1, 2), tri(0, 1, 3)}, 4));
    FAIL() << "no exception";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.where(), "triangle 1");
    EXPECT_THAT(e.message(), HasSubstr("inconsistent orientation"));
    EXPECT_THAT(e.message(), HasSubstr("vertices 0 and 1"));
  }
}

TEST(MeshIoManifold, RejectsOutOfRangeAndRepeatedIndices) {
  EXPECT_THROW(checkManifold(soup({tri(0, 1, 3)}, 3)), InvalidInput);
  EXPECT_THROW(checkManifold(soup({tri(0, 1, 1)}, 3)), InvalidInput);
}

TEST(MeshIoManifold, FindsABowtieInsideALargerFan) {
  // Vertex 0: a closed disk fan (1,2,3,4) plus a separate triangle (0,5,6) touching only at 0.
  MeshData mesh = soup({tri(0, 1, 2), tri(0, 2, 3), tri(0, 3, 4), tri(0, 4, 1), tri(0, 5, 6)}, 7);
  mesh.pointLines = {11, 12, 13, 14, 15, 16, 17};
  mesh.source = "hand";
  try {
    checkManifold(mesh);
    FAIL() << "no exception";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.where(), "hand:11");
    EXPECT_THAT(e.message(), HasSubstr("bowtie vertex 0"));
    EXPECT_THAT(e.message(), HasSubstr("2 separate fans"));
  }
}

TEST(MeshIoManifold, NonManifoldEdgeWinsOverOrientation) {
  // Triangles 0 and 1 run 0 -> 1 alike, but the third on the edge is the real problem.
  MeshData mesh = soup({tri(0, 1, 2), tri(0, 1, 3), tri(1, 0, 4)}, 5);
  mesh.triangleLines = {7, 8, 9};
  mesh.source = "m.obj";
  try {
    checkManifold(mesh);
    FAIL() << "no exception";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.where(), "m.obj:9");
    EXPECT_THAT(e.message(), HasSubstr("non-manifold edge between vertices 1 and 0"));
  }
}

// ---- the bad-input corpus: one file per case, exact place and key phrase ----

struct BadCase {
  const char* file;    ///< in tests/data/bad
  std::size_t line;    ///< 0: where() is the path alone
  const char* phrase;  ///< must appear in the message
};

void PrintTo(const BadCase& c, std::ostream* os) {
  *os << c.file;
}

class MeshIoBadInput : public ::testing::TestWithParam<BadCase> {};

TEST_P(MeshIoBadInput, ReportsPlaceAndCause) {
  const BadCase& c = GetParam();
  const std::string path = bad(c.file);
  const std::string where = c.line == 0 ? path : path + ":" + std::to_string(c.line);
  try {
    load(path);
    FAIL() << c.file << " was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.where(), where);
    EXPECT_THAT(e.message(), HasSubstr(c.phrase));
    EXPECT_EQ(std::string(e.what()), where + ": " + e.message());
  }
}

const BadCase kBadCases[] = {
    {"malformed_number.obj", 3, "malformed number '1.0.5'"},
    {"missing_coordinate.obj", 3, "vertex record has 2 numbers"},
    {"malformed_face.obj", 4, "malformed face corner '2/x'"},
    {"malformed_counts.off", 2, "malformed count 'one'"},
    {"bad_header.off", 1, "unexpected 'COFF'"},
    {"truncated_faces.off", 8, "expected 2 faces, found 1"},
    {"truncated_vertices.off", 5, "expected 5 vertices, found 3"},
    {"extra_data.off", 7, "unexpected data after the last face"},
    {"index_out_of_range.obj", 5, "vertex index 4 out of range: valid range is 1..3"},
    {"index_out_of_range.off", 6, "vertex index 3 out of range: valid range is 0..2"},
    {"negative_index.off", 6, "negative vertex index -1"},
    {"negative_index_out_of_range.obj", 3, "vertex index -3 out of range: valid range is -2..-1"},
    {"zero_index.obj", 4, "vertex index 0"},
    {"quad_face.obj", 5, "face has 4 vertices; only triangles are supported"},
    {"quad_face.off", 7, "face has 4 vertices; only triangles are supported"},
    {"repeated_vertex.obj", 5, "face repeats vertex 2"},
    {"nan_coordinate.obj", 2, "NaN coordinate 'nan' for y"},
    {"inf_coordinate.off", 4, "infinite coordinate '-inf' for z"},
    {"overflow_coordinate.obj", 3, "coordinate '1e999' for y overflows"},
    {"non_manifold_edge.obj", 9, "non-manifold edge between vertices 0 and 1"},
    {"inconsistent_orientation.obj", 7, "inconsistent orientation: edge between vertices 0 and 1"},
    {"bowtie_vertex.obj", 2, "bowtie vertex 0"},
    {"does_not_exist.obj", 0, "cannot open: No such file or directory"},
    {"unknown_extension.stl", 0, "unknown mesh file extension '.stl'"},
    {"empty.obj", 0, "no vertices"},
    {"empty.off", 0, "no vertices"},
    {"comments_only.obj", 0, "no vertices"},
};

INSTANTIATE_TEST_SUITE_P(MeshIoCorpus, MeshIoBadInput, ::testing::ValuesIn(kBadCases),
                         [](const ::testing::TestParamInfo<BadCase>& param) {
                           std::string name = param.param.file;
                           for (char& ch : name) {
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           }
                           return name;
                         });

TEST(MeshIoBadInputFiles, EveryCorpusFileIsCovered) {
  std::vector<std::string> covered;
  for (const BadCase& c : kBadCases) covered.emplace_back(c.file);
  for (const auto& entry : std::filesystem::directory_iterator(kTestData / "bad")) {
    const std::string name = entry.path().filename().string();
    EXPECT_NE(std::find(covered.begin(), covered.end(), name), covered.end())
        << name << " is in tests/data/bad but no test case uses it";
  }
}

TEST(MeshIoBadInputFiles, ADirectoryCannotBeOpened) {
  try {
    readMesh(kTestData / "bad");
    FAIL() << "no exception";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.where(), (kTestData / "bad").string());
    EXPECT_THAT(e.message(), HasSubstr("cannot open"));
  }
}

}  // namespace
}  // namespace cutsim::topology
