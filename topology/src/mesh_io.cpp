// Reading and writing triangle meshes: Wavefront OBJ, OFF, Gmsh (see mesh_io.hpp).
//
// Both readers work line by line on string views and parse numbers with std::from_chars, so they
// do not depend on the locale and never raise floating-point exceptions (a "nan" or "inf" token is
// parsed to its value, then rejected by an explicit std::isfinite check).
#include "cutsim/topology/mesh_io.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <istream>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "cutsim/base/errors.hpp"

namespace cutsim::topology {
namespace {

// ---- small text helpers ----

bool isBlank(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}

/// Splits a line into whitespace-separated tokens, dropping a '#' comment.
std::vector<std::string_view> tokenize(std::string_view line) {
  if (const auto hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && isBlank(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !isBlank(line[i])) ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

/// from_chars does not accept a leading '+'; text formats do.
std::string_view stripPlus(std::string_view token) {
  if (token.size() > 1 && token[0] == '+' && token[1] != '-' && token[1] != '+') {
    return token.substr(1);
  }
  return token;
}

/// Parses a whole token as a double. Empty optional if the token is not a number; +-infinity for
/// a number beyond the range of double (the caller rejects it as not finite).
std::optional<double> parseDouble(std::string_view token) {
  const std::string_view text = stripPlus(token);
  double value = 0.0;
  const char* first = text.data();
  const char* last = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(first, last, value, std::chars_format::general);
  if (ptr != last || text.empty()) return std::nullopt;
  if (ec == std::errc::result_out_of_range) {
    // Overflow or underflow: tell them apart by the exponent's sign, without floating-point
    // arithmetic (traps may be on). Underflow becomes a signed zero.
    const bool negative = text.front() == '-';
    const auto e = text.find_first_of("eE");
    const bool underflow = e != std::string_view::npos && e + 1 < text.size() && text[e + 1] == '-';
    if (underflow) return negative ? -0.0 : 0.0;
    return negative ? -HUGE_VAL : HUGE_VAL;
  }
  if (ec != std::errc()) return std::nullopt;
  return value;
}

/// Parses a whole token as an integer.
std::optional<long long> parseInteger(std::string_view token) {
  const std::string_view text = stripPlus(token);
  long long value = 0;
  const char* last = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), last, value);
  if (text.empty() || ec != std::errc() || ptr != last) return std::nullopt;
  return value;
}

std::string inQuotes(std::string_view token) {
  std::string s;
  s.reserve(token.size() + 2);
  s += '\'';
  s += token;
  s += '\'';
  return s;
}

/// Reads the whole stream as lines (a final '\r' of each line is dropped: CRLF files work).
class LineReader {
 public:
  LineReader(std::istream& in, std::string source) : in_(in), source_(std::move(source)) {}

  /// Next line; false at the end of the stream.
  bool next(std::string_view& line) {
    if (!std::getline(in_, buffer_)) {
      if (in_.bad()) throw InvalidInput(source_, "read error after line " + std::to_string(line_));
      return false;
    }
    ++line_;
    if (!buffer_.empty() && buffer_.back() == '\r') buffer_.pop_back();
    // A UTF-8 byte order mark (some Windows tools write one) would hide the first keyword.
    if (line_ == 1 && buffer_.starts_with("\xEF\xBB\xBF")) buffer_.erase(0, 3);
    line = buffer_;
    return true;
  }

  std::size_t lineNumber() const { return line_; }
  const std::string& source() const { return source_; }
  std::string where() const { return whereAt(line_); }
  std::string whereAt(std::size_t line) const {
    return line == 0 ? source_ : source_ + ":" + std::to_string(line);
  }
  [[noreturn]] void fail(const std::string& message) const { throw InvalidInput(where(), message); }

 private:
  std::istream& in_;
  std::string source_;
  std::string buffer_;
  std::size_t line_ = 0;
};

const char* const kAxis[3] = {"x", "y", "z"};

/// Parses the three coordinates of a vertex record; rejects malformed and non-finite values.
Vec3 parsePoint(const LineReader& reader, const std::vector<std::string_view>& tokens,
                std::size_t first) {
  Vec3 p{};
  for (std::size_t k = 0; k < 3; ++k) {
    const std::string_view token = tokens[first + k];
    const auto value = parseDouble(token);
    if (!value) reader.fail("malformed number " + inQuotes(token) + " for coordinate " + kAxis[k]);
    if (std::isnan(*value)) {
      reader.fail("NaN coordinate " + inQuotes(token) + " for " + kAxis[k] +
                  " (coordinates must be finite)");
    }
    if (std::isinf(*value)) {
      const bool written = token.find_first_of("iI") != std::string_view::npos;  // inf, Infinity
      reader.fail((written ? "infinite coordinate " : "coordinate ") + inQuotes(token) + " for " +
                  kAxis[k] + (written ? " (coordinates must be finite)" : " overflows a double"));
    }
    p[k] = *value;
  }
  return p;
}

/// Throws if the triangle names a vertex twice. `shown` are the indices as written in the file.
void checkDistinct(const LineReader& reader, const TriangleVertices& t,
                   const std::array<long long, 3>& shown) {
  for (int a = 0; a < 3; ++a) {
    for (int b = a + 1; b < 3; ++b) {
      if (t[a] == t[b]) {
        reader.fail("face repeats vertex " + std::to_string(shown[b]) + " (a degenerate triangle)");
      }
    }
  }
}

void requireVertices(const MeshData& mesh) {
  if (mesh.points.empty()) throw InvalidInput(mesh.source, "no vertices");
}

// ---- OBJ ----

/// Parses the vertex index of one face corner: "i", "i/t", "i//n" or "i/t/n".
long long parseObjCorner(const LineReader& reader, std::string_view token) {
  std::string_view parts[3];
  std::size_t count = 0;
  std::size_t start = 0;
  while (true) {
    const std::size_t slash = token.find('/', start);
    if (count == 3) reader.fail("malformed face corner " + inQuotes(token));
    parts[count++] = token.substr(start, slash == std::string_view::npos ? slash : slash - start);
    if (slash == std::string_view::npos) break;
    start = slash + 1;
  }
  // "i/" and "i/t/" are not valid forms; the texture part may be empty only in "i//n".
  const bool emptyAllowed[3] = {false, count == 3, false};
  for (std::size_t k = 0; k < count; ++k) {
    if (parts[k].empty() && emptyAllowed[k]) continue;
    if (!parseInteger(parts[k])) reader.fail("malformed face corner " + inQuotes(token));
  }
  const long long index = *parseInteger(parts[0]);
  if (index == 0) {
    reader.fail("vertex index 0 in face corner " + inQuotes(token) +
                " (OBJ indices start at 1; negative ones count back from the last vertex)");
  }
  return index;
}

std::string objRangeAbsolute(std::size_t vertexCount) {
  return "valid range is 1.." + std::to_string(vertexCount) + " (the file defines " +
         std::to_string(vertexCount) + (vertexCount == 1 ? " vertex)" : " vertices)");
}

std::string objRangeRelative(std::size_t definedSoFar) {
  if (definedSoFar == 0) return "no vertex is defined before this line";
  return "valid range is -" + std::to_string(definedSoFar) + "..-1 (relative indices count back " +
         "from the " + std::to_string(definedSoFar) +
         (definedSoFar == 1 ? " vertex" : " vertices") + " defined before this line)";
}

}  // namespace

MeshData readObj(std::istream& in, const std::string& sourceName) {
  LineReader reader(in, sourceName);
  MeshData mesh;
  mesh.source = sourceName;

  // Positive indices may refer to vertices defined later in the file; they are checked at the end.
  struct PendingFace {
    std::array<long long, 3> shown;
    std::size_t line;
  };
  std::vector<PendingFace> pending;

  std::string_view line;
  while (reader.next(line)) {
    const auto tokens = tokenize(line);
    if (tokens.empty()) continue;
    const std::string_view keyword = tokens[0];
    if (keyword == "v") {
      const std::size_t n = tokens.size() - 1;
      // x y z, x y z w, or the common x y z r g b (vertex colours) extension.
      if (n != 3 && n != 4 && n != 6) {
        reader.fail("vertex record has " + std::to_string(n) +
                    " numbers; expected 'v x y z' or 'v x y z w'");
      }
      mesh.points.push_back(parsePoint(reader, tokens, 1));
      for (std::size_t k = 4; k < tokens.size(); ++k) {
        if (!parseDouble(tokens[k])) reader.fail("malformed number " + inQuotes(tokens[k]));
      }
      mesh.pointLines.push_back(reader.lineNumber());
    } else if (keyword == "f") {
      const std::size_t n = tokens.size() - 1;
      if (n != 3) {
        reader.fail("face has " + std::to_string(n) + " vertices; only triangles are supported");
      }
      const long long defined = static_cast<long long>(mesh.points.size());
      std::array<long long, 3> shown{};
      for (std::size_t k = 0; k < 3; ++k) {
        const long long index = parseObjCorner(reader, tokens[k + 1]);
        if (index < 0) {
          if (index < -defined) {
            reader.fail("vertex index " + std::to_string(index) +
                        " out of range: " + objRangeRelative(mesh.points.size()));
          }
          shown[k] = defined + index + 1;  // resolve now: relative to the vertices so far
        } else {
          shown[k] = index;
        }
      }
      pending.push_back({shown, reader.lineNumber()});
    }
    // Every other record (vt, vn, o, g, s, usemtl, mtllib, l, p, ...) is ignored.
  }

  requireVertices(mesh);
  const long long total = static_cast<long long>(mesh.points.size());
  mesh.triangles.reserve(pending.size());
  mesh.triangleLines.reserve(pending.size());
  for (const PendingFace& face : pending) {
    TriangleVertices t{};
    for (std::size_t k = 0; k < 3; ++k) {
      if (face.shown[k] > total) {
        throw InvalidInput(reader.whereAt(face.line),
                           "vertex index " + std::to_string(face.shown[k]) +
                               " out of range: " + objRangeAbsolute(mesh.points.size()));
      }
      t[k] = static_cast<PointId>(face.shown[k] - 1);
    }
    for (int a = 0; a < 3; ++a) {
      for (int b = a + 1; b < 3; ++b) {
        if (t[a] == t[b]) {
          throw InvalidInput(
              reader.whereAt(face.line),
              "face repeats vertex " + std::to_string(face.shown[b]) + " (a degenerate triangle)");
        }
      }
    }
    mesh.triangles.push_back(t);
    mesh.triangleLines.push_back(face.line);
  }
  return mesh;
}

// ---- OFF ----

MeshData readOff(std::istream& in, const std::string& sourceName) {
  LineReader reader(in, sourceName);
  MeshData mesh;
  mesh.source = sourceName;

  std::string_view line;
  std::vector<std::string_view> tokens;
  // Next line that is not blank or a comment; false at the end of the file.
  const auto nextRecord = [&]() {
    while (reader.next(line)) {
      tokens = tokenize(line);
      if (!tokens.empty()) return true;
    }
    return false;
  };

  // Header: "OFF" alone, or "OFF nv nf ne" on one line, or no header at all.
  if (!nextRecord()) requireVertices(mesh);  // an empty file
  std::size_t countsAt = 0;
  if (tokens[0] == "OFF") {
    if (tokens.size() > 1) {
      countsAt = 1;
    } else if (!nextRecord()) {
      throw InvalidInput(reader.where(), "expected the counts line 'vertices faces edges'");
    }
  } else if (!parseInteger(tokens[0])) {
    reader.fail("unexpected " + inQuotes(tokens[0]) +
                "; expected the 'OFF' header or the counts line 'vertices faces edges'");
  }
  const std::size_t nCounts = tokens.size() - countsAt;
  if (nCounts != 2 && nCounts != 3) {
    reader.fail("malformed counts line; expected 'vertices faces edges'");
  }
  long long counts[2] = {0, 0};
  for (std::size_t k = 0; k < nCounts; ++k) {
    const auto value = parseInteger(tokens[countsAt + k]);
    if (!value || *value < 0) {
      reader.fail("malformed count " + inQuotes(tokens[countsAt + k]) +
                  " in the counts line 'vertices faces edges'");
    }
    if (k < 2) counts[k] = *value;
  }
  const std::size_t nv = static_cast<std::size_t>(counts[0]);
  const std::size_t nf = static_cast<std::size_t>(counts[1]);
  if (nv > kInvalidIndex) reader.fail("too many vertices: " + std::to_string(nv));
  if (nv == 0) throw InvalidInput(reader.where(), "no vertices");
  // Reserve no more than the file could hold, so a wrong count cannot exhaust memory.
  constexpr std::size_t kReserveCap = std::size_t{1} << 20;
  mesh.points.reserve(std::min(nv, kReserveCap));
  mesh.pointLines.reserve(std::min(nv, kReserveCap));
  mesh.triangles.reserve(std::min(nf, kReserveCap));
  mesh.triangleLines.reserve(std::min(nf, kReserveCap));

  for (std::size_t i = 0; i < nv; ++i) {
    if (!nextRecord()) {
      throw InvalidInput(reader.where(), "truncated file: expected " + std::to_string(nv) +
                                             " vertices, found " + std::to_string(i));
    }
    if (tokens.size() < 3) {
      reader.fail("vertex record has " + std::to_string(tokens.size()) +
                  " numbers; expected 'x y z'");
    }
    mesh.points.push_back(parsePoint(reader, tokens, 0));
    for (std::size_t k = 3; k < tokens.size(); ++k) {  // optional colour values
      if (!parseDouble(tokens[k])) reader.fail("malformed number " + inQuotes(tokens[k]));
    }
    mesh.pointLines.push_back(reader.lineNumber());
  }

  const std::string range = "valid range is 0.." + std::to_string(nv - 1);
  for (std::size_t i = 0; i < nf; ++i) {
    if (!nextRecord()) {
      throw InvalidInput(reader.where(), "truncated file: expected " + std::to_string(nf) +
                                             " faces, found " + std::to_string(i));
    }
    const auto n = parseInteger(tokens[0]);
    if (!n) {
      reader.fail("malformed vertex count " + inQuotes(tokens[0]) + " at the start of a face");
    }
    if (*n != 3) {
      reader.fail("face has " + std::to_string(*n) + " vertices; only triangles are supported");
    }
    if (tokens.size() < 4) {
      reader.fail("face announces 3 vertices but lists " + std::to_string(tokens.size() - 1));
    }
    TriangleVertices t{};
    std::array<long long, 3> shown{};
    for (std::size_t k = 0; k < 3; ++k) {
      const auto index = parseInteger(tokens[k + 1]);
      if (!index) reader.fail("malformed vertex index " + inQuotes(tokens[k + 1]));
      if (*index < 0) {
        reader.fail("negative vertex index " + std::to_string(*index) +
                    " (OFF indices are 0-based; " + range + ")");
      }
      if (static_cast<unsigned long long>(*index) >= nv) {
        reader.fail("vertex index " + std::to_string(*index) + " out of range: " + range);
      }
      shown[k] = *index;
      t[k] = static_cast<PointId>(*index);
    }
    for (std::size_t k = 4; k < tokens.size(); ++k) {  // optional colour values
      if (!parseDouble(tokens[k])) reader.fail("malformed number " + inQuotes(tokens[k]));
    }
    checkDistinct(reader, t, shown);
    mesh.triangles.push_back(t);
    mesh.triangleLines.push_back(reader.lineNumber());
  }

  if (nextRecord()) {
    reader.fail("unexpected data after the last face: the counts line announced " +
                std::to_string(nf) + (nf == 1 ? " face" : " faces"));
  }
  return mesh;
}

// ---- Gmsh (.msh) ----
//
// ASCII formats 1 ($NOD ... $ENDNOD, $ELM ... $ENDELM) and 2 ($MeshFormat 2.x 0 8, $Nodes,
// $Elements). Nodes are numbered by the file's own ids, which may start anywhere and have gaps:
// the mesh's points are the nodes in the order of the file, ids mapped to 0-based indices (SOFA's
// MeshGmshLoader does the same). Elements of type 2 (3-node triangles) are the triangles; points
// (15) and lines (1) are a mesh's border markers and are skipped; any other type (quads, volumes,
// second-order elements) is an error, since the surface would lose part of itself.

MeshData readGmsh(std::istream& in, const std::string& sourceName) {
  LineReader reader(in, sourceName);
  MeshData mesh;
  mesh.source = sourceName;
  std::string_view line;
  std::vector<std::string_view> tokens;
  const auto nextRecord = [&]() {
    while (reader.next(line)) {
      tokens = tokenize(line);
      if (!tokens.empty()) return true;
    }
    return false;
  };
  const auto count = [&](const char* what) {
    if (!nextRecord())
      throw InvalidInput(reader.where(),
                         std::string("truncated file: expected the number of ") + what);
    const auto n = parseInteger(tokens[0]);
    if (tokens.size() != 1 || !n || *n < 0)
      reader.fail(std::string("malformed number of ") + what + " " + inQuotes(line));
    if (static_cast<unsigned long long>(*n) > kInvalidIndex)
      reader.fail(std::string("too many ") + what);
    return static_cast<std::size_t>(*n);
  };
  const auto expectEnd = [&](std::string_view end) {
    if (!nextRecord())
      throw InvalidInput(reader.where(), "truncated file: expected " + std::string(end));
    if (tokens[0] != end)
      reader.fail("expected " + std::string(end) + ", found " + inQuotes(tokens[0]));
  };
  constexpr std::size_t kReserveCap = std::size_t{1} << 20;
  std::vector<std::pair<long long, std::size_t>> ids;  // (file id, index), sorted after the nodes
  int version = 0;
  bool haveNodes = false, haveElements = false;
  while (nextRecord()) {
    const std::string_view section = tokens[0];
    if (section == "$MeshFormat") {
      if (!nextRecord() || tokens.size() < 3)
        throw InvalidInput(reader.where(),
                           "malformed $MeshFormat: expected 'version file-type data-size'");
      const auto v = parseDouble(tokens[0]);
      if (!v || *v < 2 || *v >= 3)
        reader.fail("Gmsh format version " + inQuotes(tokens[0]) +
                    " is not supported (versions 1 and 2 are)");
      if (tokens[1] != "0")
        reader.fail("binary Gmsh files are not supported (file-type " + inQuotes(tokens[1]) +
                    "); save as ASCII");
      version = 2;
      expectEnd("$EndMeshFormat");
    } else if (section == "$NOD" || section == "$Nodes") {
      if (haveNodes) reader.fail("a second node section");
      if (section == "$NOD")
        version = 1;
      else if (version != 2)
        reader.fail("$Nodes without a $MeshFormat section before it");
      haveNodes = true;
      const std::size_t n = count("nodes");
      mesh.points.reserve(std::min(n, kReserveCap));
      mesh.pointLines.reserve(std::min(n, kReserveCap));
      ids.reserve(std::min(n, kReserveCap));
      for (std::size_t i = 0; i < n; ++i) {
        if (!nextRecord())
          throw InvalidInput(reader.where(), "truncated file: expected " + std::to_string(n) +
                                                 " nodes, found " + std::to_string(i));
        if (tokens.size() != 4)
          reader.fail("node record has " + std::to_string(tokens.size()) +
                      " numbers; expected 'id x y z'");
        const auto id = parseInteger(tokens[0]);
        if (!id) reader.fail("malformed node id " + inQuotes(tokens[0]));
        ids.push_back({*id, mesh.points.size()});
        mesh.points.push_back(parsePoint(reader, tokens, 1));
        mesh.pointLines.push_back(reader.lineNumber());
      }
      expectEnd(version == 1 ? "$ENDNOD" : "$EndNodes");
      std::sort(ids.begin(), ids.end());
      for (std::size_t i = 1; i < ids.size(); ++i)
        if (ids[i].first == ids[i - 1].first)
          throw InvalidInput(reader.whereAt(mesh.pointLines[ids[i].second]),
                             "node id " + std::to_string(ids[i].first) + " is given twice");
    } else if (section == "$ELM" || section == "$Elements") {
      if (!haveNodes) reader.fail("elements before the nodes");
      if (haveElements) reader.fail("a second element section");
      haveElements = true;
      const std::size_t n = count("elements");
      for (std::size_t i = 0; i < n; ++i) {
        if (!nextRecord())
          throw InvalidInput(reader.where(), "truncated file: expected " + std::to_string(n) +
                                                 " elements, found " + std::to_string(i));
        // v1: id type physical elementary nodes n1 .. ; v2: id type ntags tag.. n1 ..
        std::vector<long long> v;
        for (auto t : tokens) {
          const auto x = parseInteger(t);
          if (!x) reader.fail("malformed number " + inQuotes(t) + " in an element record");
          v.push_back(*x);
        }
        if (v.size() < 3) reader.fail("element record too short");
        const long long type = v[1];
        std::size_t first = 0, nodes = 0;
        if (version == 1) {
          if (v.size() < 5)
            reader.fail(
                "element record too short; expected 'id type physical elementary nodes n1 ...'");
          first = 5;
          nodes = static_cast<std::size_t>(std::max(0LL, v[4]));
        } else {
          first = 3 + static_cast<std::size_t>(std::max(0LL, v[2]));
          nodes = v.size() > first ? v.size() - first : 0;
        }
        if (v.size() != first + nodes)
          reader.fail("element record lists " +
                      std::to_string(v.size() > first ? v.size() - first : 0) +
                      " nodes where its header announces " + std::to_string(nodes));
        if (type == 15 || type == 1) continue;  // points and lines: border markers
        if (type != 2)
          reader.fail("element type " + std::to_string(type) +
                      " is not supported (a surface mesh has triangles, type 2; lines and points "
                      "are skipped)");
        if (nodes != 3) reader.fail("a triangle (type 2) with " + std::to_string(nodes) + " nodes");
        TriangleVertices t{};
        std::array<long long, 3> shown{};
        for (std::size_t k = 0; k < 3; ++k) {
          shown[k] = v[first + k];
          auto it = std::lower_bound(ids.begin(), ids.end(),
                                     std::pair<long long, std::size_t>{shown[k], 0});
          if (it == ids.end() || it->first != shown[k])
            reader.fail("node id " + std::to_string(shown[k]) + " is not among the file's nodes");
          t[k] = static_cast<PointId>(it->second);
        }
        checkDistinct(reader, t, shown);
        mesh.triangles.push_back(t);
        mesh.triangleLines.push_back(reader.lineNumber());
      }
      expectEnd(version == 1 ? "$ENDELM" : "$EndElements");
    } else if (section.starts_with("$")) {
      // Another section ($PhysicalNames, $NodeData, ...): skipped up to its end marker.
      const std::string end = "$End" + std::string(section.substr(1));
      bool closed = false;
      while (nextRecord())
        if (tokens[0] == end) {
          closed = true;
          break;
        }
      if (!closed)
        throw InvalidInput(reader.where(),
                           "truncated file: section " + inQuotes(section) + " has no " + end);
    } else {
      reader.fail("unexpected " + inQuotes(section) +
                  " outside a section; expected $NOD, $ELM, $MeshFormat, $Nodes or $Elements");
    }
  }
  requireVertices(mesh);
  if (!haveElements) throw InvalidInput(sourceName, "no element section ($ELM or $Elements)");
  return mesh;
}

// ---- by file name ----

MeshData readMesh(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });

  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw InvalidInput(name, "cannot open: " + std::string(std::strerror(EISDIR)));
  }
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const int err = errno != 0 ? errno : ENOENT;
    throw InvalidInput(name, "cannot open: " + std::string(std::strerror(err)));
  }
  if (ext == ".obj") return readObj(in, name);
  if (ext == ".off") return readOff(in, name);
  if (ext == ".msh") return readGmsh(in, name);
  if (ext.empty()) throw InvalidInput(name, "no file extension; expected .obj, .off or .msh");
  throw InvalidInput(
      name, "unknown mesh file extension " + inQuotes(ext) + "; expected .obj, .off or .msh");
}

// ---- writing ----

void writeObj(std::ostream& out, const std::vector<Vec3>& points,
              const std::vector<TriangleVertices>& triangles) {
  char buffer[128];
  for (const Vec3& p : points) {
    const int n = std::snprintf(buffer, sizeof buffer, "v %.17g %.17g %.17g\n", p[0], p[1], p[2]);
    out.write(buffer, n);
  }
  for (const TriangleVertices& t : triangles) {
    out << "f " << t[0].idx() + 1ull << ' ' << t[1].idx() + 1ull << ' ' << t[2].idx() + 1ull
        << '\n';
  }
}

void writeObj(const std::filesystem::path& path, const std::vector<Vec3>& points,
              const std::vector<TriangleVertices>& triangles) {
  errno = 0;
  std::ofstream out(path, std::ios::binary);
  if (!out) {
    throw Error(path.string() +
                ": cannot open for writing: " + std::strerror(errno != 0 ? errno : EACCES));
  }
  writeObj(out, points, triangles);
  out.flush();
  if (!out) throw Error(path.string() + ": write error");
}

}  // namespace cutsim::topology
