// Scene files: the dry run. Before anything runs, every constraint and every action of the
// timeline is checked, in order, on a copy of the rest mesh that the earlier actions have changed
// (each action's own dryRun: cuts and removals carried out, selections resolved, grasps started
// and released by name), so that a scene that loads also runs.
#include <set>

#include "cutsim/core/timeline.hpp"
#include "scene/scene_internal.hpp"
#include "scene/scene_json.hpp"

namespace cutsim::core::detail {
namespace {

class SceneDryRun final : public DryRunContext {
 public:
  SceneDryRun(const Reader& r, const Scene& scene, const topology::MeshData& mesh)
      : r_(r), mesh_(mesh), topo_(mesh) {
    const std::vector<std::string> labels = scene.forceFieldLabels();  // as the run names them
    for (std::size_t i = 0; i < scene.forceFields.size(); ++i)
      fields_.emplace_back(scene.forceFields[i].type, labels[i]);
  }
  topology::Topology& topology() override { return topo_; }
  const topology::MeshData& restMesh() const override { return mesh_; }
  std::set<std::string>& activeGrasps() override { return grasps_; }
  const std::vector<std::pair<std::string, std::string>>* forceFields() const override {
    return &fields_;
  }
  [[noreturn]] void fail(std::string_view key, const std::string& message) const override {
    r_.fail(key.empty() ? pointer_ : pointer_ + "/" + std::string(key), message);
  }
  void at(const std::string& pointer) { pointer_ = pointer; }

 private:
  const Reader& r_;
  const topology::MeshData& mesh_;
  topology::Topology topo_;
  std::set<std::string> grasps_;
  std::vector<std::pair<std::string, std::string>> fields_;
  std::string pointer_;
};

}  // namespace

void dryRun(const Reader& r, const Scene& scene, const topology::MeshData& mesh) {
  SceneDryRun c(r, scene, mesh);
  for (const ConstraintSpec& spec : scene.constraints) {
    c.at(spec.location.pointer);
    ConstraintRegistry::instance().find(spec.type)->build(spec.parameters)->dryRun(c);
  }
  for (const ActionSpec& spec : scene.timeline) {
    c.at(spec.location.pointer);
    spec.build()->dryRun(c);
  }
}

}  // namespace cutsim::core::detail
