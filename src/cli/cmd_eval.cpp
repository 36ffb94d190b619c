// `cutsim eval --rest REST --current CURRENT [--bending-stiffness K] [--min-dist-validity E]
//  [--area-weights unsigned|signed]`: builds FastTriangularBendingSprings on the REST mesh and
// prints, as one JSON object, its energy and forces at the CURRENT positions.
#include <cmath>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "commands.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/topology/mesh_io.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::cli {
namespace {

struct EvalOptions {
  std::string rest;
  std::string current;
  forcefields::BendingParameters parameters;
  std::string areaWeights = "unsigned";
};

std::string faceText(const topology::TriangleVertices& t) {
  return "(" + std::to_string(t[0].idx() + 1) + " " + std::to_string(t[1].idx() + 1) + " " +
         std::to_string(t[2].idx() + 1) + ")";
}

/// The same oriented triangle, up to a cyclic rotation of its vertices.
bool sameTriangle(const topology::TriangleVertices& a, const topology::TriangleVertices& b) {
  for (int r = 0; r < 3; ++r) {
    if (a[0] == b[r] && a[1] == b[(r + 1) % 3] && a[2] == b[(r + 2) % 3]) return true;
  }
  return false;
}

/// CURRENT must have REST's vertices and, if it has faces, REST's faces.
void checkCompatible(const topology::MeshData& rest, const topology::MeshData& current) {
  if (current.points.size() != rest.points.size()) {
    throw InvalidInput(current.source, "has " + std::to_string(current.points.size()) +
                                           " vertices, the rest mesh " + rest.source + " has " +
                                           std::to_string(rest.points.size()));
  }
  if (current.triangles.empty()) return;
  if (current.triangles.size() != rest.triangles.size()) {
    throw InvalidInput(current.source, "has " + std::to_string(current.triangles.size()) +
                                           " faces, the rest mesh " + rest.source + " has " +
                                           std::to_string(rest.triangles.size()));
  }
  for (std::size_t i = 0; i < rest.triangles.size(); ++i) {
    if (!sameTriangle(current.triangles[i], rest.triangles[i])) {
      const std::size_t line = i < current.triangleLines.size() ? current.triangleLines[i] : 0;
      throw InvalidInput(current.source,
                         "face " + std::to_string(i + 1) + " " + faceText(current.triangles[i]) +
                             (line ? " (line " + std::to_string(line) + ")" : std::string()) +
                             " differs from the rest mesh's " + faceText(rest.triangles[i]));
    }
  }
}

void runEval(EvalOptions options) {
  options.parameters.areaWeights = forcefields::parseAreaWeights(options.areaWeights);
  options.parameters.validate();
  const topology::MeshData rest = topology::readMesh(options.rest);
  const topology::MeshData current = topology::readMesh(options.current);
  checkCompatible(rest, current);

  topology::Topology topo(rest);  // checks manifoldness, naming REST's lines
  const forcefields::FastTriangularBendingSprings field(topo, options.parameters);

  const std::size_t n = current.points.size();
  if (topo.pointCapacity() != n) {
    throw Error("internal error: the topology holds " + std::to_string(topo.pointCapacity()) +
                " point slots for " + std::to_string(n) + " vertices");
  }
  std::vector<double> x(3 * n), v(3 * n, 0.0), f(3 * n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) x[3 * i + k] = current.points[i][k];
  }
  field.addForce(x, v, f);
  const double energy = field.potentialEnergy(x);
  bool finite = std::isfinite(energy);
  for (double fi : f) finite = finite && std::isfinite(fi);
  if (!finite) {
    throw InvalidInput(current.source,
                       "the energy or the forces overflow (coordinates or stiffness too large)");
  }

  const forcefields::BendingCounters& c = field.counters();
  nlohmann::ordered_json j;
  j["energy"] = energy;
  j["active_springs"] = c.activeSprings;
  nlohmann::json forces = nlohmann::json::array();
  for (std::size_t i = 0; i < n; ++i) forces.push_back({f[3 * i], f[3 * i + 1], f[3 * i + 2]});
  j["forces"] = std::move(forces);
  j["degenerate_hinges"] = c.degenerate();
  j["degenerate_by_reason"] = {{"short_wing_distance", c.shortWingDistance},
                               {"short_edge", c.shortEdge},
                               {"small_height", c.smallHeight},
                               {"unrepresentable", c.unrepresentable}};
  j["signed_fallbacks"] = c.signedFallbacks;
  j["bending_stiffness"] = options.parameters.bendingStiffness;
  j["min_dist_validity"] = options.parameters.minDistValidity;
  j["area_weights"] = std::string(forcefields::toString(options.parameters.areaWeights));
  std::cout << j.dump() << '\n';
  std::cout.flush();
  if (!std::cout) throw Error("cannot write to standard output");
}

}  // namespace

void registerEvalCommand(CLI::App& app) {
  auto options = std::make_shared<EvalOptions>();
  CLI::App* cmd = app.add_subcommand(
      "eval",
      "Build FastTriangularBendingSprings on a rest mesh and print, as one JSON object, its "
      "energy and forces at the current positions");
  cmd->add_option("--rest", options->rest, "the rest mesh (.obj or .off): springs are built on it")
      ->required();
  cmd->add_option("--current", options->current,
                  "the current positions (.obj or .off): same vertices; same faces if it has any")
      ->required();
  cmd->add_option("--bending-stiffness", options->parameters.bendingStiffness,
                  "bendingStiffness k, finite and >= 0")
      ->capture_default_str();
  cmd->add_option("--min-dist-validity", options->parameters.minDistValidity,
                  "minDistValidity: hinges with a wing distance, edge length or height <= this "
                  "get no spring")
      ->capture_default_str();
  cmd->add_option("--area-weights", options->areaWeights, "unsigned (SOFA's weights) or signed")
      ->capture_default_str();
  cmd->callback([options] { runEval(*options); });
}

}  // namespace cutsim::cli
