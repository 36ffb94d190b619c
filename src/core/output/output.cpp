#include "cutsim/core/output.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <sstream>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/core/contact_step.hpp"
#include "cutsim/forcefields/contact.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/topology/geometry.hpp"
#include "timeline/tearing.hpp"

namespace cutsim::core {

std::string formatNumber(double v) {
  std::array<char, 64> buf{};
  const auto res = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return std::string(buf.data(), res.ptr);
}

void writeFileAtomically(const std::filesystem::path& path,
                         const std::function<void(std::ostream&)>& write) {
  std::string name = ".";  // appended, not "." + ...: GCC 12 warns (-Wrestrict) on that falsely
  name += path.filename().string();
  name += ".tmp";
  const std::filesystem::path temp = path.parent_path() / name;
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) throw Error("cannot create " + temp.string());
    write(out);
    out.flush();
    if (!out) throw Error("cannot write " + temp.string());
  }
  std::error_code ec;
  std::filesystem::rename(temp, path, ec);
  if (ec)
    throw Error("cannot rename " + temp.string() + " to " + path.string() + ": " + ec.message());
}

namespace {

/// Live points densely renumbered: ids[k] is the slot of point k, dense[slot] its number.
struct Numbering {
  topology::MeshData mesh;  // rest positions, renumbered triangles
  std::vector<PointId> ids;
  std::vector<topology::Index> dense;
  std::vector<topology::TriangleId> triangles;  // slots of mesh.triangles, same order
};

Numbering numbering(const Simulation& sim) {
  Numbering n;
  const topology::Topology& topo = sim.topology();
  n.mesh = topo.toMeshData(&n.ids);
  n.dense.assign(topo.pointCapacity(), topology::kInvalidIndex);
  for (std::size_t k = 0; k < n.ids.size(); ++k) n.dense[n.ids[k].idx()] = topology::Index(k);
  n.triangles = topo.triangles();
  return n;
}

void writeTriplets(std::ostream& out, std::span<const double> a, const std::vector<PointId>& ids) {
  for (PointId p : ids) {
    out << formatNumber(a[3 * p.idx()]) << ' ' << formatNumber(a[3 * p.idx() + 1]) << ' '
        << formatNumber(a[3 * p.idx() + 2]) << '\n';
  }
}

void vtpHeader(std::ostream& out) {
  out << "<?xml version=\"1.0\"?>\n"
         "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\">\n"
         "  <PolyData>\n";
}

void vtpFooter(std::ostream& out) {
  out << "    </Piece>\n"
         "  </PolyData>\n"
         "</VTKFile>\n";
}

void pointsBlock(std::ostream& out, const Simulation& sim, const std::vector<PointId>& ids) {
  out << "      <Points>\n"
         "        <DataArray type=\"Float64\" Name=\"position\" NumberOfComponents=\"3\" "
         "format=\"ascii\">\n";
  writeTriplets(out, sim.state().x(), ids);
  out << "        </DataArray>\n"
         "      </Points>\n";
}

/// A PolyData file of lines between the live points (numbered as in the surface), with an
/// optional integer cell array.
void linesPiece(std::ostream& out, const Simulation& sim, const Numbering& n,
                const std::vector<std::array<topology::Index, 2>>& lines, const char* cellArray,
                const std::vector<int>& cellValues) {
  vtpHeader(out);
  out << "    <Piece NumberOfPoints=\"" << n.ids.size() << "\" NumberOfVerts=\"0\" NumberOfLines=\""
      << lines.size() << "\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n";
  if (cellArray) {
    out << "      <CellData Scalars=\"" << cellArray << "\">\n"
        << "        <DataArray type=\"Int32\" Name=\"" << cellArray << "\" format=\"ascii\">\n";
    for (int v : cellValues) out << v << '\n';
    out << "        </DataArray>\n"
           "      </CellData>\n";
  }
  pointsBlock(out, sim, n.ids);
  out << "      <Lines>\n"
         "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
  for (const auto& l : lines) out << l[0] << ' ' << l[1] << '\n';
  out << "        </DataArray>\n"
         "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
  for (std::size_t i = 0; i < lines.size(); ++i) out << 2 * (i + 1) << '\n';
  out << "        </DataArray>\n"
         "      </Lines>\n";
  vtpFooter(out);
}

}  // namespace

void writeSurfaceVtp(std::ostream& out, const Simulation& sim) {
  const Numbering n = numbering(sim);
  const std::span<const double> x = sim.state().x();
  vtpHeader(out);
  out << "    <Piece NumberOfPoints=\"" << n.ids.size()
      << "\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\""
      << n.mesh.triangles.size() << "\">\n";
  out << "      <PointData Vectors=\"velocity\">\n"
         "        <DataArray type=\"Float64\" Name=\"velocity\" NumberOfComponents=\"3\" "
         "format=\"ascii\">\n";
  writeTriplets(out, sim.state().v(), n.ids);
  out << "        </DataArray>\n"
         "        <DataArray type=\"Float64\" Name=\"rest_position\" NumberOfComponents=\"3\" "
         "format=\"ascii\">\n";
  writeTriplets(out, sim.state().rest(), n.ids);
  out << "        </DataArray>\n"
         "        <DataArray type=\"Int64\" Name=\"slot\" format=\"ascii\">\n";
  for (PointId p : n.ids) out << p << '\n';
  // 0 free, 1 fixed, 2 held by a grasp (a point is held by one constraint at most).
  out << "        </DataArray>\n"
         "        <DataArray type=\"Int32\" Name=\"constraint\" format=\"ascii\">\n";
  for (PointId p : n.ids) {
    int held = sim.fixed().contains(p) ? 1 : 0;
    for (std::size_t g = 0; g < sim.numGrasps() && held == 0; ++g)
      if (sim.grasp(g).points().contains(p)) held = 2;
    out << held << '\n';
  }
  out << "        </DataArray>\n"
         "      </PointData>\n"
         "      <CellData Scalars=\"strain\">\n"
         "        <DataArray type=\"Float64\" Name=\"strain\" format=\"ascii\">\n";
  for (topology::TriangleId t : n.triangles) {
    const double e = maxPrincipalStrain(sim.topology(), x, t);
    if (!std::isfinite(e))
      throw SolverError("at t = " + formatNumber(sim.time()) + " the strain of triangle " +
                        std::to_string(t.idx()) +
                        " is not finite: its deformation is beyond the range of doubles, the "
                        "simulation has blown up (no "
                        "frame is written; with an explicit integrator, try a smaller time step or "
                        "an implicit solver)");
    out << formatNumber(e) << '\n';
  }
  out << "        </DataArray>\n"
         "      </CellData>\n";
  pointsBlock(out, sim, n.ids);
  out << "      <Polys>\n"
         "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
  for (const auto& t : n.mesh.triangles) out << t[0] << ' ' << t[1] << ' ' << t[2] << '\n';
  out << "        </DataArray>\n"
         "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
  for (std::size_t i = 0; i < n.mesh.triangles.size(); ++i) out << 3 * (i + 1) << '\n';
  out << "        </DataArray>\n"
         "      </Polys>\n";
  vtpFooter(out);
}

void writeNetworkVtp(std::ostream& out, const Simulation& sim,
                     const forcefields::ForceField& field) {
  std::vector<std::array<PointId, 2>> segments;
  field.draw(segments);
  writeNetworkVtp(out, sim, segments);
}

void writeNetworkVtp(std::ostream& out, const Simulation& sim,
                     std::span<const std::array<PointId, 2>> segments) {
  const Numbering n = numbering(sim);
  std::vector<std::array<topology::Index, 2>> lines;
  lines.reserve(segments.size());
  for (const auto& s : segments) {
    if (s[0].idx() >= n.dense.size() || s[1].idx() >= n.dense.size()) continue;
    const topology::Index a = n.dense[s[0].idx()], b = n.dense[s[1].idx()];
    if (a == topology::kInvalidIndex || b == topology::kInvalidIndex) continue;
    lines.push_back({a, b});
  }
  linesPiece(out, sim, n, lines, nullptr, {});
}

OriginalBorder restBorder(const topology::Topology& topo) {
  OriginalBorder out;
  for (topology::EdgeId e : topo.edges()) {
    if (!topo.isBoundaryEdge(e)) continue;
    const auto v = topo.edgeVertices(e);
    out.segments.push_back({topo.restPosition(v[0]), topo.restPosition(v[1])});
  }
  return out;
}

std::vector<BorderEdge> borderEdges(const topology::Topology& topo,
                                    const OriginalBorder& original) {
  // The tolerance: a millionth of the original border's extent.
  double extent = 0.0;
  for (const auto& s : original.segments)
    for (std::size_t k = 0; k < 3; ++k)
      extent = std::max({extent, std::abs(s[0][k]), std::abs(s[1][k])});
  const double tolerance = 1e-6 * std::max(extent, 1e-300);
  auto onOriginal = [&](const Vec3& p) {
    for (const auto& s : original.segments)
      if (topology::geometry::distanceToSegment(p, s[0], s[1]) <= tolerance) return true;
    return false;
  };
  std::vector<BorderEdge> border;
  for (topology::EdgeId e : topo.edges()) {
    if (!topo.isBoundaryEdge(e)) continue;
    const auto v = topo.edgeVertices(e);
    const Vec3 a = topo.restPosition(v[0]), b = topo.restPosition(v[1]);
    const Vec3 mid{(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2};
    // Opened during the run: an edge whose rest points or midpoint leave the first border.
    std::array<double, 6> key{a[0], a[1], a[2], b[0], b[1], b[2]};
    if (std::lexicographical_compare(key.begin() + 3, key.end(), key.begin(), key.begin() + 3))
      key = {b[0], b[1], b[2], a[0], a[1], a[2]};
    auto it = original.known.find(key);
    if (it == original.known.end())
      it = original.known.emplace(key, onOriginal(a) && onOriginal(b) && onOriginal(mid)).first;
    border.push_back({v[0], v[1], !it->second});
  }
  return border;
}

void writeBordersVtp(std::ostream& out, const Simulation& sim, const OriginalBorder& original) {
  const Numbering n = numbering(sim);
  const std::vector<BorderEdge> border = borderEdges(sim.topology(), original);
  std::vector<std::array<topology::Index, 2>> lines;
  std::vector<int> lip;
  for (const BorderEdge& b : border) {
    lines.push_back({n.dense[b.a.idx()], n.dense[b.b.idx()]});
    lip.push_back(b.lip ? 1 : 0);
  }
  linesPiece(out, sim, n, lines, "lip", lip);
}

void writePvd(std::ostream& out, const std::vector<std::pair<double, std::string>>& frames) {
  out << "<?xml version=\"1.0\"?>\n"
         "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
         "  <Collection>\n";
  for (const auto& [t, file] : frames) {
    out << "    <DataSet timestep=\"" << formatNumber(t) << "\" group=\"\" part=\"0\" file=\""
        << file << "\"/>\n";
  }
  out << "  </Collection>\n"
         "</VTKFile>\n";
}

namespace {
/// A piece's <Points> in world coordinates (the instruments', the obstacles').
void worldPoints(std::ostream& out, const std::vector<Vec3>& points) {
  out << "      <Points>\n"
         "        <DataArray type=\"Float64\" Name=\"position\" NumberOfComponents=\"3\" "
         "format=\"ascii\">\n";
  for (const Vec3& p : points)
    out << formatNumber(p[0]) << ' ' << formatNumber(p[1]) << ' ' << formatNumber(p[2]) << '\n';
  out << "        </DataArray>\n"
         "      </Points>\n";
}
}  // namespace

void writeSegmentsVtp(std::ostream& out, std::span<const std::array<Vec3, 2>> segments) {
  vtpHeader(out);
  out << "    <Piece NumberOfPoints=\"" << 2 * segments.size()
      << "\" NumberOfVerts=\"0\" NumberOfLines=\"" << segments.size()
      << "\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n";
  std::vector<Vec3> points;
  for (const auto& s : segments) points.insert(points.end(), s.begin(), s.end());
  worldPoints(out, points);
  out << "      <Lines>\n"
         "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
  for (std::size_t k = 0; k < segments.size(); ++k) out << 2 * k << ' ' << 2 * k + 1 << '\n';
  out << "        </DataArray>\n"
         "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
  for (std::size_t k = 0; k < segments.size(); ++k) out << 2 * (k + 1) << '\n';
  out << "        </DataArray>\n"
         "      </Lines>\n";
  vtpFooter(out);
}

void writeObstaclesVtp(std::ostream& out, const std::vector<forcefields::Obstacle>& obstacles,
                       double t, double planeSize) {
  std::vector<Vec3> points;
  std::vector<std::array<int, 3>> tris;
  std::vector<std::size_t> owner;
  for (std::size_t k = 0; k < obstacles.size(); ++k) {
    std::vector<Vec3> p;
    std::vector<std::array<int, 3>> tr;
    obstacles[k].surface(obstacles[k].offsetAt(t), planeSize, p, tr);
    const int base = int(points.size());
    points.insert(points.end(), p.begin(), p.end());
    for (auto x : tr) {
      tris.push_back({x[0] + base, x[1] + base, x[2] + base});
      owner.push_back(k);
    }
  }
  vtpHeader(out);
  out << "    <Piece NumberOfPoints=\"" << points.size()
      << "\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\""
      << tris.size() << "\">\n";
  out << "      <CellData Scalars=\"obstacle\">\n"
         "        <DataArray type=\"Int32\" Name=\"obstacle\" format=\"ascii\">\n";
  for (std::size_t o : owner) out << o << '\n';
  out << "        </DataArray>\n"
         "      </CellData>\n";
  worldPoints(out, points);
  out << "      <Polys>\n"
         "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
  for (const auto& tr : tris) out << tr[0] << ' ' << tr[1] << ' ' << tr[2] << '\n';
  out << "        </DataArray>\n"
         "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
  for (std::size_t i = 0; i < tris.size(); ++i) out << 3 * (i + 1) << '\n';
  out << "        </DataArray>\n"
         "      </Polys>\n";
  vtpFooter(out);
}

void writeRunInfo(const std::filesystem::path& dir, const Scene& scene) {
  nlohmann::ordered_json info;
  info["scene"] = scene.name;
  info["description"] = scene.description;
  info["gravity"] = scene.gravity;
  info["time_step"] = scene.timeStep;
  info["duration"] = scene.duration;
  writeFileAtomically(dir / "run.json", [&](std::ostream& o) { o << info.dump(2) << '\n'; });
}

void writeSurfaceObj(std::ostream& out, const Simulation& sim) {
  const Numbering n = numbering(sim);
  std::vector<Vec3> points;
  points.reserve(n.ids.size());
  const auto x = sim.state().x();
  for (PointId p : n.ids)
    points.push_back({x[3 * p.idx()], x[3 * p.idx() + 1], x[3 * p.idx() + 2]});
  topology::writeObj(out, points, n.mesh.triangles);
}

// ---------------------------------------------------------------------------------------------

namespace {

const forcefields::FastTriangularBendingSprings* firstBending(const Simulation& sim) {
  for (std::size_t i = 0; i < sim.numForceFields(); ++i) {
    if (auto* f =
            dynamic_cast<const forcefields::FastTriangularBendingSprings*>(&sim.forceField(i))) {
      return f;
    }
  }
  return nullptr;
}

/// "network_" and the label with every character outside [A-Za-z0-9_-] replaced by '_'.
std::string networkSeriesName(const std::string& label) {
  std::string out = "network_";
  for (char c : label)
    out += (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-') ? c : '_';
  return out;
}

std::string frameName(const std::string& prefix, std::size_t index, const std::string& ext) {
  std::array<char, 32> buf{};
  std::snprintf(buf.data(), buf.size(), "%06zu", index);
  return prefix + "_" + buf.data() + ext;
}

}  // namespace

OutputWriter::OutputWriter(Columns, std::filesystem::path dir, OutputSettings settings,
                           std::vector<std::string> fieldLabels,
                           std::vector<std::string> graspNames, bool contact,
                           std::vector<std::string> obstacleNames)
    : dir_(std::move(dir)),
      settings_(settings),
      labels_(std::move(fieldLabels)),
      grasps_(std::move(graspNames)),
      contact_(contact),
      obstacles_(std::move(obstacleNames)) {}

OutputWriter::OutputWriter(std::filesystem::path dir, OutputSettings settings,
                           std::vector<std::string> fieldLabels,
                           std::vector<std::string> graspNames, bool contact,
                           std::vector<std::string> obstacleNames)
    : OutputWriter(Columns{}, std::move(dir), settings, std::move(fieldLabels),
                   std::move(graspNames), contact, std::move(obstacleNames)) {
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  if (ec || !std::filesystem::is_directory(dir_)) {
    throw Error("cannot create the output folder " + dir_.string() +
                (ec ? ": " + ec.message() : std::string()));
  }
  // One run at a time in a folder; what an earlier run left there goes, so that its frames and
  // CSV cannot be mistaken for this run's.
  lockFolder("give this one another --out folder");
  for (const auto& entry : std::filesystem::directory_iterator(dir_, ec)) {
    if (!entry.is_regular_file(ec) || !isRunOutput(entry.path().filename().string())) continue;
    if (std::filesystem::remove(entry.path(), ec)) ++replaced_;
  }
  if (settings_.csv) {
    // Written under a temporary name, renamed when the run finishes.
    csvTemp_ = dir_ / ".steps.csv.tmp";
    csv_.open(csvTemp_, std::ios::binary | std::ios::trunc);
    if (!csv_) throw Error("cannot create " + csvTemp_.string());
    writeCsv(csvHeader() + '\n');
  }
}

void OutputWriter::lockFolder(const char* hint) {
  const std::filesystem::path lock = dir_ / ".cutsim.lock";
  lockFd_ = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lockFd_ < 0) throw Error("cannot create " + lock.string() + ": " + std::strerror(errno));
  if (::flock(lockFd_, LOCK_EX | LOCK_NB) != 0) {
    ::close(lockFd_);
    lockFd_ = -1;
    throw Error("another run is writing into the output folder " + dir_.string() + " (" + hint +
                ")");
  }
}

namespace {
using Frames = std::vector<std::pair<double, std::string>>;
void saveFrames(ArchiveWriter& out, const Frames& frames) {
  out.u64(frames.size());
  for (const auto& [t, name] : frames) {
    out.f64(t);
    out.str(name);
  }
}
/// `blank`: a list of times without files (the surface's frames when only OBJ frames are written).
Frames loadFrames(ArchiveReader& in, bool blank = false) {
  const std::uint64_t n = in.u64();
  if (n > in.remaining()) in.fail("output: a count of " + std::to_string(n) + " frames");
  Frames frames(n);
  for (auto& [t, name] : frames) {
    t = in.f64();
    name = in.str();
    if (blank ? !name.empty()
              : (name.find('/') != std::string::npos || !OutputWriter::isRunOutput(name)))
      in.fail("output: \"" + name + "\" is not the name of a frame");
  }
  return frames;
}
/// The number of a frame file ("surface_000012.vtp": 12), if the name has one.
std::optional<std::size_t> frameNumber(const std::string& name) {
  const std::size_t dot = name.rfind('.'), bar = name.rfind('_', dot);
  if (dot == std::string::npos || bar == std::string::npos || dot - bar != 7) return std::nullopt;
  std::size_t n = 0;
  for (std::size_t i = bar + 1; i < dot; ++i) {
    if (!std::isdigit(static_cast<unsigned char>(name[i]))) return std::nullopt;
    n = 10 * n + std::size_t(name[i] - '0');
  }
  return n;
}
}  // namespace

void OutputWriter::writeCsv(const std::string& text) {
  csv_ << text;
  csvCrc_ = crc32Of(csvCrc_, text.data(), text.size());
}

void OutputWriter::saveState(ArchiveWriter& out) {
  out.begin("output");
  saveFrames(out, surfaceFrames_);
  saveFrames(out, borderFrames_);
  saveFrames(out, obstacleFrames_);
  out.u64(networkFrames_.size());
  for (const auto& [series, frames] : networkFrames_) {
    out.str(series);
    saveFrames(out, frames);
  }
  out.u64(originalBorder_.segments.size());
  for (const auto& s : originalBorder_.segments)
    for (const Vec3& p : s) out.raw(p.data(), sizeof(double) * 3);
  out.i64(lastFrameStep_);
  out.u64(nextPartial_);
  out.u64(partialFrames_);
  // The last frame's file, which ties the folder to this run (its CSV may be off).
  std::string last;
  if (!surfaceFrames_.empty())
    last = settings_.vtk
               ? surfaceFrames_.back().second
               : (settings_.obj ? frameName("frame", surfaceFrames_.size() - 1, ".obj") : "");
  out.str(last);
  if (!last.empty()) {
    const auto crc = fileCrc32(dir_ / last);
    if (!crc) throw Error("cannot read back " + (dir_ / last).string());
    out.u64(*crc);
  }
  out.boolean(settings_.csv);
  if (settings_.csv) {
    csv_.flush();
    if (!csv_) throw Error("cannot write " + csvTemp_.string());
    out.u64(std::uint64_t(csv_.tellp()));
    out.u64(csvCrc_);
  }
}

OutputWriter::OutputWriter(std::filesystem::path dir, OutputSettings settings,
                           std::vector<std::string> fieldLabels,
                           std::vector<std::string> graspNames, bool contact,
                           std::vector<std::string> obstacleNames, ArchiveReader& in)
    : OutputWriter(Columns{}, std::move(dir), settings, std::move(fieldLabels),
                   std::move(graspNames), contact, std::move(obstacleNames)) {
  in.open("output");
  surfaceFrames_ = loadFrames(in, !settings_.vtk);
  borderFrames_ = loadFrames(in);
  obstacleFrames_ = loadFrames(in);
  const std::uint64_t series = in.u64();
  if (series > in.remaining()) in.fail("output: a count of " + std::to_string(series) + " series");
  for (std::uint64_t k = 0; k < series; ++k) {
    const std::string name = in.str();
    networkFrames_[name] = loadFrames(in);
  }
  const std::uint64_t segments = in.u64();
  if (segments > in.remaining() / (6 * sizeof(double)))
    in.fail("output: a count of " + std::to_string(segments) + " border segments");
  originalBorder_.segments.resize(segments);
  for (auto& s : originalBorder_.segments)
    for (Vec3& p : s) in.raw(p.data(), sizeof(double) * 3);
  lastFrameStep_ = long(in.i64());
  nextPartial_ = std::size_t(in.u64());
  partialFrames_ = std::size_t(in.u64());
  const std::string lastFrame = in.str();
  const std::uint64_t lastCrc = lastFrame.empty() ? 0 : in.u64();
  const bool csv = in.boolean();
  if (csv != settings_.csv) in.fail("output: the saved run and the scene differ in writing a CSV");
  std::uint64_t length = 0, crc = 0;
  if (csv) {
    length = in.u64();
    crc = in.u64();
  }
  in.close();
  if (partialFrames_ > surfaceFrames_.size() || (!lastFrame.empty() && !isRunOutput(lastFrame)))
    in.fail("output: frames that the run did not write");

  if (!std::filesystem::is_directory(dir_))
    throw Error("cannot resume into " + dir_.string() + ": the folder of the run is gone");
  lockFolder("a run resumes once at a time, into its own folder: wait for the other to end");
  // Every frame up to the checkpoint must be there.
  std::vector<std::string> missing;
  auto need = [&](const Frames& frames) {
    for (const auto& f : frames)
      if (!f.second.empty() && !std::filesystem::exists(dir_ / f.second))
        missing.push_back(f.second);
  };
  need(surfaceFrames_);
  need(borderFrames_);
  need(obstacleFrames_);
  for (const auto& [name, frames] : networkFrames_) need(frames);
  if (settings_.obj)
    for (std::size_t i = 0; i < surfaceFrames_.size(); ++i) {
      const std::string obj = frameName("frame", i, ".obj");
      if (!std::filesystem::exists(dir_ / obj)) missing.push_back(obj);
    }
  if (!missing.empty())
    throw Error("cannot resume into " + dir_.string() + ": " + std::to_string(missing.size()) +
                " frames of the run up to the checkpoint are missing (" + missing.front() +
                ", ...)");
  if (!lastFrame.empty() &&
      fileCrc32(dir_ / lastFrame) != std::optional<std::uint32_t>(std::uint32_t(lastCrc)))
    throw Error(
        "cannot resume into " + dir_.string() + ": its " + lastFrame +
        " is not the frame the checkpoint's run wrote (another run wrote into the folder since)");
  // The CSV up to the checkpoint: the one being written, a partial one, or a finished one.
  if (settings_.csv) {
    csvTemp_ = dir_ / ".steps.csv.tmp";
    std::filesystem::path found;
    for (const char* name : {".steps.csv.tmp", "steps.partial.csv", "steps.csv"}) {
      const std::filesystem::path p = dir_ / name;
      std::error_code ec;
      const auto size = std::filesystem::file_size(p, ec);
      if (ec || size < length) continue;
      if (fileCrc32(p, length) != std::optional<std::uint32_t>(std::uint32_t(crc))) continue;
      found = p;
      break;
    }
    if (found.empty())
      throw Error("cannot resume into " + dir_.string() +
                  ": no steps.csv, steps.partial.csv or .steps.csv.tmp there holds "
                  "the run's rows up to the checkpoint (" +
                  std::to_string(length) + " bytes, byte for byte: changed or removed since)");
    std::error_code ec;
    std::filesystem::resize_file(found, length, ec);
    if (!ec && found != csvTemp_) std::filesystem::rename(found, csvTemp_, ec);
    if (ec) throw Error("cannot resume the CSV " + found.string() + ": " + ec.message());
    csv_.open(csvTemp_, std::ios::binary | std::ios::app);
    if (!csv_) throw Error("cannot open " + csvTemp_.string());
    csvCrc_ = std::uint32_t(crc);
  }
  // What the run wrote after the checkpoint, and every collection (written again at the end).
  const std::size_t frames = surfaceFrames_.size();
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir_, ec)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_regular_file(ec) || !isRunOutput(name) || name == ".steps.csv.tmp" ||
        name == "checkpoint.ckpt" || name == "run.json")
      continue;
    const auto number = frameNumber(name);
    const bool later = number && *number >= frames;
    const bool stale = name == "steps.csv" || name == "steps.partial.csv" ||
                       name.ends_with(".pvd") || name == "player.html" || name == "player.png" ||
                       (name.front() == '.' && name.ends_with(".tmp"));
    if (later || stale) {
      std::error_code removeError;
      if (std::filesystem::remove(entry.path(), removeError)) ++replaced_;
    }
  }
  // The partial collections as the run last wrote them (a resumed run that fails before it
  // writes them again leaves what the run made without a stop leaves).
  writeCollections(".partial.pvd", partialFrames_);
}

OutputWriter::~OutputWriter() {
  if (lockFd_ >= 0) ::close(lockFd_);  // releases the folder's lock
}

bool OutputWriter::isRunOutput(const std::string& name) {
  auto ends = [&](const char* suffix) {
    const std::size_t n = std::strlen(suffix);
    return name.size() >= n && name.compare(name.size() - n, n, suffix) == 0;
  };
  auto starts = [&](const char* prefix) { return name.rfind(prefix, 0) == 0; };
  if (name == "steps.csv" || name == "steps.partial.csv" || name == ".steps.csv.tmp" ||
      name == "run.json" || name == "checkpoint.ckpt")
    return true;
  if (name == "player.html" || name == "player.png")
    return true;                                 // cutsim view's, of the earlier run
  if (ends(".pvd")) return true;                 // the collections, final or partial
  if (starts(".") && ends(".tmp")) return true;  // a frame being written when a run was killed
  if (ends(".vtp"))
    return starts("surface_") || starts("borders_") || starts("springs_") || starts("network_") ||
           starts("stitches_") || starts("obstacles_") || starts("instruments_");
  return starts("frame_") && ends(".obj");
}

bool OutputWriter::partialDue(std::size_t frames) {
  // Rewritten after a frame when the count reaches the next eighth of itself (every frame while
  // there are few): the collections lag by at most an eighth, and rewriting them costs a time
  // linear in the frames, not quadratic.
  if (frames <= 16 || frames >= nextPartial_) {
    nextPartial_ = frames + std::max<std::size_t>(1, frames / 8);
    return true;
  }
  return false;
}

std::string OutputWriter::csvHeader() const {
  std::string h = "time,kinetic_energy";
  for (const std::string& l : labels_) h += ",potential_" + l;
  h += ",gravity_energy,solver_iterations,solver_residual,solver_flags,newton_iterations,active_"
       "springs,"
       "points,edges,triangles";
  for (const std::string& g : grasps_) h += "," + g + "_fx," + g + "_fy," + g + "_fz";
  if (contact_) {
    h += ",contact_candidates,contact_active,contact_excluded,contact_clamped,contact_splits,"
         "self_normal_force,self_friction_force";
    for (const std::string& o : obstacles_) h += "," + o + "_normal_force," + o + "_friction_force";
  }
  if (settings_.energy)
    h += ",energy_stored,work_gravity,work_constraints,work_contact,dissipated_damping,energy_"
         "removed,energy_balance,energy_drift,step_work_gravity,step_work_constraints,step_work_"
         "contact,step_dissipated_damping,step_energy_removed,step_energy_drift";
  return h;
}

void OutputWriter::record(Simulation& sim, const StepRecord& r, bool last) {
  if (settings_.csv) {
    // Every number is checked: no infinity or NaN reaches the CSV (the run stops, naming it).
    auto num = [&](double v, const std::string& column) {
      if (!std::isfinite(v))
        throw SolverError("step " + std::to_string(r.step) + " (t = " + formatNumber(r.time) +
                          "): " + column + " is " + formatNumber(v) +
                          ", not a finite number: the run stops before it reaches steps.csv");
      return formatNumber(v);
    };
    std::ostringstream row;
    row << num(r.time, "time") << ',' << num(sim.kineticEnergy(), "kinetic_energy");
    for (std::size_t i = 0; i < sim.numForceFields(); ++i) {
      row << ',' << num(sim.potentialEnergy(i), "potential_" + sim.forceFieldLabel(i));
    }
    const auto* bending = firstBending(sim);
    row << ',' << num(sim.gravityEnergy(), "gravity_energy") << ',' << r.stats.iterations << ','
        << num(r.stats.residual, "solver_residual") << ',' << r.stats.flagText() << ','
        << r.stats.newtonIterations << ',' << (bending ? bending->numActiveSprings() : 0) << ','
        << sim.topology().numPoints() << ',' << sim.topology().numEdges() << ','
        << sim.topology().numTriangles();
    for (const std::string& g : grasps_) {
      const Grasp* grasp = sim.findGrasp(g);
      const Vec3 f = grasp ? grasp->reaction() : Vec3{0, 0, 0};
      row << ',' << num(f[0], g + "_fx") << ',' << num(f[1], g + "_fy") << ','
          << num(f[2], g + "_fz");
    }
    if (contact_) {
      const forcefields::Contact* c = findContact(sim);
      forcefields::ContactMeasure m;
      if (c) m = c->lastStep();
      row << ',' << m.candidates << ',' << m.active << ',' << m.excluded << ',' << r.stats.clamped
          << ',' << r.stats.splits << ',' << num(m.selfNormal, "self_normal_force") << ','
          << num(m.selfFriction, "self_friction_force");
      for (std::size_t k = 0; k < obstacles_.size(); ++k)
        row << ','
            << num(k < m.obstacleNormal.size() ? m.obstacleNormal[k] : 0.0,
                   obstacles_[k] + "_normal_force")
            << ','
            << num(k < m.obstacleFriction.size() ? m.obstacleFriction[k] : 0.0,
                   obstacles_[k] + "_friction_force");
    }
    if (settings_.energy) {
      const EnergyLedger* e = sim.energy();
      if (!e)
        throw Error(
            "the scene's output asks for energy columns but the simulation does not "
            "account for energy");
      const EnergyFlows& t = e->total();
      const EnergyFlows& s = e->lastStep();
      row << ',' << num(e->storedEnergy(), "energy_stored") << ',' << num(t.gravity, "work_gravity")
          << ',' << num(t.constraints, "work_constraints") << ',' << num(t.contact, "work_contact")
          << ',' << num(t.damping, "dissipated_damping") << ',' << num(t.removed, "energy_removed")
          << ',' << num(e->balance(), "energy_balance") << ',' << num(e->drift(), "energy_drift")
          << ',' << num(s.gravity, "step_work_gravity") << ','
          << num(s.constraints, "step_work_constraints") << ','
          << num(s.contact, "step_work_contact") << ',' << num(s.damping, "step_dissipated_damping")
          << ',' << num(s.removed, "step_energy_removed") << ','
          << num(e->stepDrift(), "step_energy_drift");
    }
    writeCsv(row.str() + '\n');
  }
  if ((r.step % settings_.every == 0 || last) && r.step != lastFrameStep_) writeFrame(sim, r);
}

void OutputWriter::writeFrame(Simulation& sim, const StepRecord& r) {
  lastFrameStep_ = r.step;
  const std::size_t index = surfaceFrames_.size();
  if (settings_.vtk) {
    const std::string surface = frameName("surface", index, ".vtp");
    writeFileAtomically(dir_ / surface, [&](std::ostream& o) { writeSurfaceVtp(o, sim); });
    surfaceFrames_.emplace_back(r.time, surface);
    // While the run goes on the collections carry ".partial" in their names (ParaView can open
    // them to watch); finish() writes the final surface.pvd and springs.pvd. A run that stops
    // early leaves no collection that looks complete.
    const bool partial = partialDue(surfaceFrames_.size());
    const std::string borders = frameName("borders", index, ".vtp");
    if (borderFrames_.empty()) originalBorder_ = restBorder(sim.topology());
    writeFileAtomically(dir_ / borders,
                        [&](std::ostream& o) { writeBordersVtp(o, sim, originalBorder_); });
    borderFrames_.emplace_back(r.time, borders);
    if (partial) {
      partialFrames_ = surfaceFrames_.size();
      writeFileAtomically(dir_ / "surface.partial.pvd",
                          [&](std::ostream& o) { writePvd(o, surfaceFrames_); });
      writeFileAtomically(dir_ / "borders.partial.pvd",
                          [&](std::ostream& o) { writePvd(o, borderFrames_); });
    }
    if (settings_.springs) {
      // Every field that draws: the first FastTriangularBendingSprings as "springs", the first
      // Sutures as "stitches" (their threads), the others as "network_<label>".
      const auto* bending = firstBending(sim);
      const forcefields::ForceField* sutures = nullptr;
      for (std::size_t i = 0; i < sim.numForceFields() && !sutures; ++i)
        if (sim.forceField(i).typeName() == "Sutures") sutures = &sim.forceField(i);
      for (std::size_t i = 0; i < sim.numForceFields(); ++i) {
        const forcefields::ForceField& field = sim.forceField(i);
        std::vector<std::array<PointId, 2>> segments;
        field.draw(segments);
        const std::string series = &field == bending   ? "springs"
                                   : &field == sutures ? "stitches"
                                                       : networkSeriesName(sim.forceFieldLabel(i));
        // A field that has never drawn anything has no series; one that has keeps a frame for
        // every frame of the run, empty or not, so that its collection has no gap.
        if (segments.empty() && &field != bending && !networkFrames_.count(series)) continue;
        auto& frames = networkFrames_[series];
        const std::string name = frameName(series, index, ".vtp");
        writeFileAtomically(dir_ / name,
                            [&](std::ostream& o) { writeNetworkVtp(o, sim, segments); });
        frames.emplace_back(r.time, name);
        if (partial)
          writeFileAtomically(dir_ / (series + ".partial.pvd"),
                              [&](std::ostream& o) { writePvd(o, frames); });
      }
    }
    const forcefields::Contact* c = findContact(sim);
    if (c && !c->obstacles().empty()) {
      // Planes are drawn as squares three times the size of the surface's rest extent.
      double extent = 0.0;
      topology::Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
      for (PointId p : sim.topology().points()) {
        const topology::Vec3 q = sim.topology().restPosition(p);
        for (int k = 0; k < 3; ++k) {
          lo[std::size_t(k)] = std::min(lo[std::size_t(k)], q[std::size_t(k)]);
          hi[std::size_t(k)] = std::max(hi[std::size_t(k)], q[std::size_t(k)]);
        }
      }
      for (int k = 0; k < 3; ++k)
        extent = std::max(extent, hi[std::size_t(k)] - lo[std::size_t(k)]);
      const std::string name = frameName("obstacles", index, ".vtp");
      writeFileAtomically(dir_ / name, [&](std::ostream& o) {
        writeObstaclesVtp(o, c->obstacles(), r.time, 3 * std::max(extent, 1e-3));
      });
      obstacleFrames_.emplace_back(r.time, name);
      if (partial)
        writeFileAtomically(dir_ / "obstacles.partial.pvd",
                            [&](std::ostream& o) { writePvd(o, obstacleFrames_); });
    }
    if (instruments_) {
      // A series from the first frame with an instrument on, then a frame for every frame (empty
      // while none is), so that its collection has no gap.
      const std::vector<std::array<Vec3, 2>> segments = instruments_();
      if (!segments.empty() || networkFrames_.count("instruments")) {
        auto& frames = networkFrames_["instruments"];
        const std::string name = frameName("instruments", index, ".vtp");
        writeFileAtomically(dir_ / name, [&](std::ostream& o) { writeSegmentsVtp(o, segments); });
        frames.emplace_back(r.time, name);
        if (partial)
          writeFileAtomically(dir_ / "instruments.partial.pvd",
                              [&](std::ostream& o) { writePvd(o, frames); });
      }
    }
  } else {
    surfaceFrames_.emplace_back(r.time, "");
  }
  if (settings_.obj) {
    writeFileAtomically(dir_ / frameName("frame", index, ".obj"),
                        [&](std::ostream& o) { writeSurfaceObj(o, sim); });
  }
}

void OutputWriter::closeCsv() {
  if (!settings_.csv || !csv_.is_open()) return;
  csv_.flush();
  const bool ok = bool(csv_);
  csv_.close();
  if (!ok) throw Error("cannot write " + csvTemp_.string());
}

void OutputWriter::writeCollections(const std::string& suffix, std::size_t frames,
                                    std::vector<std::filesystem::path>* written) {
  // Each collection lists its frames numbered below `frames` (a series may start late); an
  // empty one is not written.
  auto write = [&](const std::string& name, const Frames& all) {
    Frames listed;
    for (const auto& f : all)
      if (const auto k = frameNumber(f.second); k && *k < frames) listed.push_back(f);
    if (listed.empty()) return;
    writeFileAtomically(dir_ / (name + suffix), [&](std::ostream& o) { writePvd(o, listed); });
    if (written) written->push_back(dir_ / (name + suffix));
  };
  if (!settings_.vtk) return;
  write("surface", surfaceFrames_);
  write("borders", borderFrames_);
  write("obstacles", obstacleFrames_);
  for (const auto& [series, all] : networkFrames_) write(series, all);
}

void OutputWriter::renameCsv(const std::string& name) {
  if (!settings_.csv || csvTemp_.empty()) return;
  std::error_code ec;
  std::filesystem::rename(csvTemp_, dir_ / name, ec);
  if (ec) throw Error("cannot rename " + csvTemp_.string() + ": " + ec.message());
  csvTemp_.clear();
}

void OutputWriter::releaseFolder() {
  if (lockFd_ < 0) return;
  std::error_code ignored;
  std::filesystem::remove(dir_ / ".cutsim.lock", ignored);
  ::close(lockFd_);
  lockFd_ = -1;
}

void OutputWriter::finish() {
  // The CSV's data first: if the disk is full, the run stops here with its collections still
  // marked partial, and nothing looks complete.
  closeCsv();
  // Then every final collection under a staging name: one that cannot be written (a full disk)
  // leaves no final collection beside the partial ones; the renames that follow need no space.
  // (Only the files written here are renamed: a stale staged file of an earlier run that died
  // is not taken for this run's.)
  const std::string staged = ".pvd.next";
  std::vector<std::filesystem::path> written;
  try {
    writeCollections(staged, ~std::size_t(0), &written);
  } catch (...) {
    std::error_code ignored;
    for (const auto& p : written) std::filesystem::remove(p, ignored);
    throw;
  }
  for (const auto& p : written) {
    const std::string name = p.filename().string();
    std::error_code ec;
    std::filesystem::rename(p, dir_ / (name.substr(0, name.size() - staged.size()) + ".pvd"), ec);
    if (ec) throw Error("cannot rename " + p.string() + ": " + ec.message());
  }
  std::error_code removeError;
  for (const auto& name :
       {std::string("surface"), std::string("borders"), std::string("obstacles")})
    std::filesystem::remove(dir_ / (name + ".partial.pvd"), removeError);
  for (const auto& entry : networkFrames_)
    std::filesystem::remove(dir_ / (entry.first + ".partial.pvd"), removeError);
  renameCsv("steps.csv");
  releaseFolder();  // the run is complete: the folder is free, and holds only its outputs
}

void OutputWriter::finishPartial() {
  closeCsv();
  writeCollections(".partial.pvd");
  renameCsv("steps.partial.csv");
  releaseFolder();
}

void dumpFinal(const std::filesystem::path& dir, const Simulation& sim,
               const forcefields::FastTriangularBendingSprings* bending) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir)) {
    throw Error("cannot create the folder " + dir.string() +
                (ec ? ": " + ec.message() : std::string()));
  }
  std::vector<PointId> ids;
  const topology::MeshData rest = sim.topology().toMeshData(&ids);
  const auto x = sim.state().x();
  std::vector<Vec3> current;
  current.reserve(ids.size());
  for (PointId p : ids) current.push_back({x[3 * p.idx()], x[3 * p.idx() + 1], x[3 * p.idx() + 2]});
  writeFileAtomically(dir / "final_rest.obj",
                      [&](std::ostream& o) { topology::writeObj(o, rest.points, rest.triangles); });
  writeFileAtomically(dir / "final.obj",
                      [&](std::ostream& o) { topology::writeObj(o, current, rest.triangles); });
  if (!bending) return;
  std::vector<double> f(x.size(), 0.0), v(x.size(), 0.0);
  bending->addForce(x, v, f);
  const forcefields::BendingCounters& c = bending->counters();
  const forcefields::BendingParameters& params = bending->parameters();
  nlohmann::ordered_json j;
  j["energy"] = bending->potentialEnergy(x);
  j["active_springs"] = c.activeSprings;
  nlohmann::json forces = nlohmann::json::array();
  for (PointId p : ids) forces.push_back({f[3 * p.idx()], f[3 * p.idx() + 1], f[3 * p.idx() + 2]});
  j["forces"] = std::move(forces);
  j["degenerate_hinges"] = c.degenerate();
  j["degenerate_by_reason"] = {{"short_wing_distance", c.shortWingDistance},
                               {"short_edge", c.shortEdge},
                               {"small_height", c.smallHeight},
                               {"unrepresentable", c.unrepresentable}};
  j["signed_fallbacks"] = c.signedFallbacks;
  j["bending_stiffness"] = params.bendingStiffness;
  j["min_dist_validity"] = params.minDistValidity;
  j["area_weights"] = std::string(forcefields::toString(params.areaWeights));
  j["rayleigh_stiffness"] = params.rayleighStiffness;
  writeFileAtomically(dir / "final_forces.json", [&](std::ostream& o) { o << j.dump() << '\n'; });
}

}  // namespace cutsim::core
