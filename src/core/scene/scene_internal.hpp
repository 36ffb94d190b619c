#pragma once
// Private to cutsim::core: what the scene's schema and dry run share.
#include <optional>

#include "cutsim/core/scene.hpp"

namespace cutsim::core::detail {

class Reader;

/// Checks every constraint and action of the scene, in order, on a copy of the rest mesh (each
/// one's dryRun). Fails through r.
void dryRun(const Reader& r, const Scene& scene, const topology::MeshData& mesh);

/// The memory a run of a mesh of `points` points needs (bytes, an estimate from measured runs:
/// scene_memory.cpp), without and with a direct solve's factor (CHOLMOD).
double runBytes(std::size_t points);
double directFactorBytes(std::size_t points);
/// The memory of this machine for this process (bytes): the total (/proc/meminfo's MemTotal, or
/// a smaller cgroup limit) and what is available now (MemAvailable, or less if a cgroup's limit
/// leaves less beside its working set).
struct MachineMemory {
  double total = 0, available = 0;
};
/// The environment's CUTSIM_MEMORY stands for it: "off" (no check: none), "TOTAL" or
/// "TOTAL,AVAILABLE" in bytes (anything else: InvalidInput). None when unknown (no check).
std::optional<MachineMemory> machineMemory();
/// Refuses a scene whose run cannot fit in the machine's memory (the mesh at meshPointer, or a
/// direct solve's factor at the linear solver's type); adds a warning to the scene when the run,
/// or a fallback to CHOLMOD, needs more than is available now.
void checkMemory(const Reader& r, const std::string& meshPointer, Scene& s, std::size_t points);

/// The mean rest length of the topology's edges (0 without edges).
double meanRestEdge(const topology::Topology& topology);

}  // namespace cutsim::core::detail

// ---- sections a component's own file reads ----

#include <filesystem>
#include <functional>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

namespace cutsim::core::detail {

/// A top-level section of scene files that a component reads in its own file (the scene reader
/// names none of them): contact's "contact" and "obstacles" (scene_contact.cpp). Sections are
/// read after the force fields, in the order they were added, a section naming `after` once that
/// one is read; check() runs once the whole scene is read and dry run.
struct SceneSection {
  std::string name;
  std::string after;  ///< a section read before this one ("" : none)
  std::function<void(const Reader& r, const nlohmann::json& value, const std::string& pointer,
                     const std::filesystem::path& baseDir, Scene& scene)>
      read;
  /// Optional: a check of the read scene (when the section was given).
  std::function<void(const Reader& r, const Scene& scene, const topology::MeshData& mesh)> check;
};

class SceneSections {
 public:
  static SceneSections& instance();
  /// Adds a section (its name once); returns true, for a namespace-scope registration.
  bool add(SceneSection section);
  /// In reading order: those with no `after` first, in the order added, then the others.
  std::vector<const SceneSection*> inOrder() const;

 private:
  std::vector<SceneSection> sections_;
};

}  // namespace cutsim::core::detail
