#pragma once
// Reading and writing triangle meshes: Wavefront OBJ, OFF and Gmsh's ASCII .msh (versions 1, 2).
#include <cstddef>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "cutsim/topology/types.hpp"

namespace cutsim::topology {

/// A triangle soup as read from a file, with the line each element came from (1-based, 0 when
/// the mesh was not read from a file) so that later checks can name the place of a problem.
struct MeshData {
  std::vector<Vec3> points;
  std::vector<TriangleVertices> triangles;
  std::vector<std::size_t> pointLines;     ///< source line of points[i]
  std::vector<std::size_t> triangleLines;  ///< source line of triangles[i]
  std::string source;                      ///< the path it was read from ("" if none)
};

/// Reads OBJ (v and f records; f may use v/vt/vn forms and OBJ's relative negative indices; other
/// records are ignored), OFF or Gmsh (ASCII versions 1 and 2: nodes in file order, their ids mapped
/// to 0-based indices; triangles kept, points and lines skipped, other elements an error), chosen
/// by the file's extension (.obj, .off, .msh; case-insensitive).
/// Throws InvalidInput with where() = "PATH:LINE" for a malformed record, an out-of-range index,
/// a face that is not a triangle, a repeated vertex in a face, a NaN or infinite coordinate;
/// where() = "PATH" for a missing or unreadable file or an unknown extension.
MeshData readMesh(const std::filesystem::path& path);
MeshData readObj(std::istream& in, const std::string& sourceName);
MeshData readOff(std::istream& in, const std::string& sourceName);
MeshData readGmsh(std::istream& in, const std::string& sourceName);

/// Checks that the soup describes a manifold surface: no edge with three or more triangles, no two
/// triangles using an edge in the same direction (inconsistent orientation), no vertex whose
/// triangles form two or more fans (a bowtie). Throws InvalidInput naming the first offending
/// triangle's line (or the vertex's line for a bowtie).
void checkManifold(const MeshData& mesh);

/// Writes OBJ with 17 significant digits (1-based indices).
void writeObj(std::ostream& out, const std::vector<Vec3>& points,
              const std::vector<TriangleVertices>& triangles);
void writeObj(const std::filesystem::path& path, const std::vector<Vec3>& points,
              const std::vector<TriangleVertices>& triangles);

}  // namespace cutsim::topology
