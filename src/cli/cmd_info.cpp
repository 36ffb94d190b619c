// `cutsim info MESH [--json]`: reads a mesh, checks that it is a manifold surface and prints its
// counts, for a person (aligned "label: value" lines) or as one JSON object.
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/core/mesh_info.hpp"
#include "cutsim/topology/mesh_io.hpp"

namespace cutsim::cli {
namespace {

constexpr int kLabelWidth = 19;  // "isolated vertices:" and one space

struct InfoOptions {
  std::string mesh;
  bool json = false;
};

void runInfo(const InfoOptions& options) {
  const topology::MeshData mesh = topology::readMesh(options.mesh);
  topology::checkManifold(mesh);
  const core::MeshInfo info = core::computeMeshInfo(mesh);

  if (options.json) {
    nlohmann::ordered_json j;
    j["vertices"] = info.vertices;
    j["edges"] = info.edges;
    j["triangles"] = info.triangles;
    j["boundary_edges"] = info.boundary_edges;
    j["components"] = info.components;
    j["isolated_vertices"] = info.isolated_vertices;
    std::cout << j.dump() << '\n';
  } else {
    const std::vector<std::pair<const char*, std::size_t>> rows = {
        {"vertices", info.vertices},     {"edges", info.edges},
        {"triangles", info.triangles},   {"boundary edges", info.boundary_edges},
        {"components", info.components}, {"isolated vertices", info.isolated_vertices},
    };
    std::cout << std::left << std::setw(kLabelWidth) << "mesh:" << mesh.source << '\n';
    for (const auto& [label, value] : rows) {
      std::cout << std::setw(kLabelWidth) << std::string(label) + ":" << value << '\n';
    }
  }
  std::cout.flush();
  if (!std::cout) throw Error("cannot write to standard output");
}

}  // namespace

void registerInfoCommand(CLI::App& app) {
  auto options = std::make_shared<InfoOptions>();
  CLI::App* cmd = app.add_subcommand(
      "info", "Read a mesh (.obj or .off), check that it is a manifold surface, print its counts");
  // No CLI::ExistingFile check: readMesh reports a missing file as "PATH: cannot open: ...".
  cmd->add_option("MESH", options->mesh, "the mesh file (.obj or .off)")->required();
  cmd->add_flag("--json", options->json,
                "print one JSON object with the keys vertices, edges, triangles, boundary_edges, "
                "components, isolated_vertices");
  cmd->callback([options] { runInfo(*options); });
}

}  // namespace cutsim::cli
