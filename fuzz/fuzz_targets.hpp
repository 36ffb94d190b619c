#pragma once
// The bodies of the three fuzz targets as plain functions, shared by the libFuzzer entry points
// (fuzz/fuzz_*.cpp, clang only) and the g++-buildable replay test
// (tests/robustness/test_fuzz_replay.cpp), so that CI exercises the same logic without clang.
//
// Contract of each function: bad input may only end in a cutsim::Error (caught here); anything
// else that goes wrong (a broken invariant, a NaN, a validate() problem) throws FuzzFailure, and
// any other exception escapes. The libFuzzer entry points turn both into a crash.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/scene.hpp"
#include "cutsim/core/simulation.hpp"
#include "cutsim/core/state.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/topology/mesh_io.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/mirror_observer.hpp"

namespace cutsim::fuzz {

/// A broken guarantee found by a fuzz target (never a cutsim::Error: it must not be caught as one).
class FuzzFailure : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

/// Inputs longer than this are ignored (the targets look for logic bugs, not for slowness).
inline constexpr std::size_t kMaxInputSize = 4096;

namespace detail {

inline void require(bool ok, const std::string& what) {
  if (!ok) throw FuzzFailure(what);
}

inline bool allFinite(std::span<const double> a) {
  return std::all_of(a.begin(), a.end(), [](double v) { return std::isfinite(v); });
}

/// validate() must be ok; the problems are in the message otherwise.
inline void requireValid(const topology::Topology& t, const std::string& after) {
  const topology::ValidationReport r = t.validate();
  require(r.ok(), "validate() after " + after + ": " + r.summary());
}

/// Reads bytes in order; past the end every read gives 0.
class Bytes {
 public:
  Bytes(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool done() const { return pos_ >= size_; }
  std::uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }
  /// A number in [0, 1] from two bytes.
  double unit() {
    const unsigned hi = byte(), lo = byte();
    return double((hi << 8) | lo) / 65535.0;
  }
  /// An index in [0, n) (n > 0).
  std::size_t pick(std::size_t n) {
    const unsigned hi = byte(), lo = byte();
    return ((hi << 8) | lo) % n;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

/// Whatever the mesh reader accepted must respect its promises, and whatever checkManifold accepts
/// must build a valid topology and bending table with finite forces at rest.
inline void checkReadMesh(const topology::MeshData& m) {
  require(m.pointLines.size() == m.points.size(), "pointLines size differs from points");
  require(m.triangleLines.size() == m.triangles.size(), "triangleLines size differs");
  for (const auto& p : m.points)
    require(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]),
            "the reader accepted a non-finite coordinate");
  for (const auto& t : m.triangles) {
    for (auto v : t)
      require(v.idx() < m.points.size(), "the reader accepted an out-of-range index");
    require(t[0] != t[1] && t[1] != t[2] && t[0] != t[2], "the reader accepted a repeated vertex");
  }
  try {
    topology::checkManifold(m);
  } catch (const Error&) {
    // Rejecting is allowed; the topology must then reject it too.
    try {
      topology::Topology t(m);
    } catch (const Error&) {
      return;
    }
    throw FuzzFailure("checkManifold rejected a mesh the Topology constructor accepted");
  }
  std::unique_ptr<topology::Topology> topo;
  try {
    topo = std::make_unique<topology::Topology>(m);
  } catch (const Error& e) {
    throw FuzzFailure(std::string("checkManifold accepted a mesh the Topology rejected: ") +
                      e.what());
  }
  require(topo->numPoints() == m.points.size(), "point count changed by the topology");
  require(topo->numTriangles() == m.triangles.size(), "triangle count changed by the topology");
  forcefields::FastTriangularBendingSprings springs(*topo, forcefields::BendingParameters{});
  core::MechanicalState state(*topo);
  requireValid(*topo, "construction");
  std::vector<double> f(state.x().size(), 0.0);
  std::vector<double> v(state.x().size(), 0.0);
  springs.addForce(state.x(), v, f);
  require(allFinite(f), "non-finite bending force at rest");
  require(std::isfinite(springs.potentialEnergy(state.x())), "non-finite energy at rest");
}

/// Skips scenes whose grid is larger than 40 x 40 (a 2000 x 2000 grid is valid but slow: the
/// fuzzer is after logic errors, not after the cost of big meshes).
inline bool gridTooLarge(std::string_view text) {
  for (std::string_view key : {"\"nx\"", "\"ny\""}) {
    for (std::size_t at = text.find(key); at != std::string_view::npos;
         at = text.find(key, at + 1)) {
      std::size_t i = at + key.size();
      while (i < text.size() && (text[i] == ' ' || text[i] == ':' || text[i] == '\n' ||
                                 text[i] == '\t' || text[i] == '\r'))
        ++i;
      const std::string number(text.substr(i, std::min<std::size_t>(32, text.size() - i)));
      const double value = std::strtod(number.c_str(), nullptr);
      if (!(value <= 40)) return true;  // NaN too
    }
  }
  return false;
}

}  // namespace detail

/// fuzz_mesh_reader: the bytes as OBJ and as OFF; every mesh read is checked (see checkReadMesh).
inline void fuzzMeshReader(const std::uint8_t* data, std::size_t size) {
  if (size > kMaxInputSize) return;
  const std::string text(reinterpret_cast<const char*>(data), size);
  for (const bool off : {false, true}) {
    std::istringstream in(text);
    topology::MeshData mesh;
    try {
      mesh = off ? topology::readOff(in, "fuzz.off") : topology::readObj(in, "fuzz.obj");
    } catch (const InvalidInput& e) {
      detail::require(e.where().rfind(off ? "fuzz.off" : "fuzz.obj", 0) == 0,
                      std::string("reader error without the source name: ") + e.what());
      continue;
    }
    detail::checkReadMesh(mesh);
  }
}

/// fuzz_scene_reader: the bytes as a scene's JSON text (mesh files resolved against baseDir); a
/// scene that loads is built and run for up to three steps; the topology stays valid.
inline void fuzzSceneReader(const std::uint8_t* data, std::size_t size,
                            const std::filesystem::path& baseDir) {
  if (size > kMaxInputSize) return;
  const std::string text(reinterpret_cast<const char*>(data), size);
  if (detail::gridTooLarge(text)) return;
  core::Scene scene;
  try {
    scene = core::parseScene(text, "fuzz.json", baseDir);
  } catch (const InvalidInput& e) {
    detail::require(e.where().rfind("fuzz.json", 0) == 0,
                    std::string("scene error without the source name: ") + e.what());
    return;
  }
  detail::require(scene.timeStep > 0 && std::isfinite(scene.timeStep), "accepted a bad timeStep");
  detail::require(scene.duration >= 0 && std::isfinite(scene.duration), "accepted a bad duration");
  const topology::MeshData mesh = scene.mesh();
  if (mesh.points.size() > 5000) return;
  try {
    core::SceneRunner runner(scene);
    runner.start();
    detail::requireValid(runner.simulation().topology(), "start()");
    for (int i = 0; i < 3 && !runner.finished(); ++i) {
      runner.advance();
      detail::requireValid(runner.simulation().topology(), "advance()");
      detail::require(detail::allFinite(runner.simulation().state().x()),
                      "non-finite position after a step that did not throw");
    }
  } catch (const SolverError&) {
    // Allowed (a blow-up is reported); the state must still be finite (left as before the step).
  } catch (const Error&) {
    // Run-time problems (a cut that fails on a torn mesh, ...) are allowed.
  }
}

/// fuzz_topology_ops: the bytes as a sequence of operations on a small grid, with the bending
/// springs, the mechanical state and a MirrorObserver subscribed; validate() after every one.
/// `log` (optional) receives one line per operation: its description, then " -> done" or
/// " -> rejected: " and the message.
inline void fuzzTopologyOps(const std::uint8_t* data, std::size_t size,
                            std::vector<std::string>* log = nullptr) {
  if (size > kMaxInputSize) return;
  detail::Bytes in(data, size);
  core::GridSpec g;
  g.nx = 2 + in.byte() % 5;
  g.ny = 2 + in.byte() % 5;
  g.alternating = in.byte() % 2 == 0;
  topology::Topology topo(core::makeGrid(g));
  forcefields::BendingParameters params;
  params.areaWeights =
      in.byte() % 2 ? forcefields::AreaWeights::Signed : forcefields::AreaWeights::Unsigned;
  forcefields::FastTriangularBendingSprings springs(topo, params);
  core::MechanicalState state(topo);
  test::MirrorObserver mirror(topo);
  topology::Subscription mirrorSubscription = topo.subscribe(mirror);
  detail::requireValid(topo, "construction");

  static constexpr std::array<double, 6> kNudges = {0.0, 1e-14, 1e-12, 1e-9, 1e-6, 1e-3};
  static constexpr std::array<double, 6> kSnaps = {0.0, 0.0, 0.01, 0.1, 0.3, 0.49};
  // A coordinate on a lattice of eighths of the grid spacing, a little outside the sheet too,
  // nudged by a tiny amount so that crossings fall very close to vertices and edges.
  auto coordinate = [&](double spacing, double extent) {
    const double lattice = spacing * (int(in.byte() % 64) - 4) / 8.0;
    const double magnitude = kNudges[in.byte() % kNudges.size()];  // (reads in a fixed order)
    const double nudge = in.byte() % 2 ? magnitude : -magnitude;
    return std::clamp(lattice, -0.5 * spacing, extent + 0.5 * spacing) + nudge;
  };

  int op = 0;
  std::string history = "  grid " + std::to_string(g.nx) + " x " + std::to_string(g.ny) +
                        (g.alternating ? " alternating" : " one-way") +
                        "\n";  // every operation so far, for the failure message
  auto fmt = [](const topology::Vec3& p) {
    std::ostringstream o;
    o.precision(17);
    o << "{" << p[0] << ", " << p[1] << ", " << p[2] << "}";
    return o.str();
  };
  while (!in.done() && op < 64) {
    ++op;
    const std::uint8_t code = in.byte() % 8;
    const std::size_t points = topo.numPoints(), edges = topo.numEdges(),
                      triangles = topo.numTriangles();
    const std::uint64_t revision = topo.revision();
    const std::uint64_t digest = topo.digest();
    const std::size_t transactions = mirror.transactions;
    std::string name, outcome = " -> done";
    try {
      switch (code) {
        case 0: {
          name = "splitEdge";
          const auto live = topo.edges();
          if (live.empty()) break;
          const topology::EdgeId e = live[in.pick(live.size())];
          const double t = in.unit();
          name += " " + std::to_string(e.idx()) + " t " + std::to_string(t);
          topo.splitEdge(e, t);
          break;
        }
        case 1: {
          name = "tear";
          const auto live = topo.edges();
          if (live.empty()) break;
          const topology::EdgeId e = live[in.pick(live.size())];
          name += " " + std::to_string(e.idx());
          topo.tear(e);
          break;
        }
        case 2: {
          name = "incise";
          const auto live = topo.points();
          if (live.empty()) break;
          std::vector<topology::PointId> path{live[in.pick(live.size())]};
          const int length = 1 + in.byte() % 4;
          for (int k = 0; k < length; ++k) {
            const auto around = topo.edgesAroundPoint(path.back());
            if (around.empty()) break;
            const auto ev = topo.edgeVertices(around[in.pick(around.size())]);
            path.push_back(ev[0] == path.back() ? ev[1] : ev[0]);
          }
          for (auto p : path) name += " " + std::to_string(p.idx());
          topo.incise(path);
          break;
        }
        case 3: {
          name = "removeTriangles";
          const auto live = topo.triangles();
          if (live.empty()) break;
          std::vector<topology::TriangleId> chosen;
          const int n = 1 + in.byte() % 3;
          for (int k = 0; k < n; ++k) chosen.push_back(live[in.pick(live.size())]);
          for (auto t : chosen) name += " " + std::to_string(t.idx());
          topo.removeTriangles(chosen);
          break;
        }
        case 4:
        case 5: {
          name = "cutPolyline";
          const int n = 2 + in.byte() % 3;
          const double sx = 1.0 / (g.nx - 1), sy = 1.0 / (g.ny - 1);
          std::vector<topology::Vec3> polyline;
          for (int k = 0; k < n; ++k) {
            const double x = coordinate(sx, 1.0), y = coordinate(sy, 1.0);
            polyline.push_back({x, y, kNudges[in.byte() % kNudges.size()]});
          }
          topology::CutOptions options;
          options.snapTolerance = kSnaps[in.byte() % kSnaps.size()];
          name += " snap " + std::to_string(options.snapTolerance) + ":";
          for (const auto& p : polyline) name += " " + fmt(p);
          topo.cutPolyline(polyline, options);
          break;
        }
        case 6: {
          name = "compact";
          topo.compact();
          break;
        }
        default: {
          name = "splitTriangle";
          const auto live = topo.triangles();
          if (live.empty()) break;
          const double a = 0.02 + in.unit(), b = 0.02 + in.unit(), c = 0.02 + in.unit();
          const double s = a + b + c;
          topo.splitTriangle(live[in.pick(live.size())], {a / s, b / s, 1.0 - a / s - b / s});
          break;
        }
      }
    } catch (const TopologyError& e) {
      // A rejected request changes nothing, sends no event, and is not an internal error (which
      // would also be how a transaction left open shows: "nested transaction").
      outcome = std::string(" -> rejected: ") + e.what();
      detail::require(topo.numPoints() == points && topo.numEdges() == edges &&
                          topo.numTriangles() == triangles && topo.revision() == revision &&
                          topo.digest() == digest && mirror.transactions == transactions,
                      "op " + std::to_string(op) + " (" + name +
                          ") was rejected but changed the mesh: " + e.what() + "\nafter:\n" +
                          history);
      detail::require(
          std::string(e.what()).find("internal error") == std::string::npos,
          "op " + std::to_string(op) + " (" + name + "): " + e.what() + "\nafter:\n" + history);
    } catch (const InvalidInput& e) {
      outcome = std::string(" -> invalid input: ") + e.what();
      detail::require(
          topo.numPoints() == points && topo.numTriangles() == triangles,
          "op " + std::to_string(op) + " (" + name + ") threw InvalidInput but changed the mesh");
    }
    detail::requireValid(topo, "op " + std::to_string(op) + " (" + name + ") after:\n" + history);
    history += "  " + name + "\n";
    if (log) log->push_back(name + outcome);
    // The state follows: positions finite (interpolated from finite ones), forces finite.
    detail::require(detail::allFinite(state.x()), "non-finite position after " + name);
    std::vector<double> f(state.x().size(), 0.0), v(state.x().size(), 0.0);
    springs.addForce(state.x(), v, f);
    detail::require(detail::allFinite(f), "non-finite bending force after " + name);
  }
}

}  // namespace cutsim::fuzz
