// Scene files: what a run will need in memory, against what the machine has, at the check.
//
// Measured on hanging cloths (grids of 200 x 200 and 400 x 400 points, implicit Euler, the
// process's peak resident size): a run without a direct solve needs 1.0-1.25 KB a point beyond
// a fixed 10 MB or so (the mesh, the springs' tables, the solver's vectors, the outputs' buffers);
// CHOLMOD's factor of the 3N x 3N system adds 152-156 bytes times 3N times log2(3N) (nested
// dissection of a surface mesh: n log n fill), 309 MB and 1.4 GB there, 10 GB for 1000 x 1000.
// The estimates leave out contact's search and the outputs' pages, which grow with the pairs and
// the frames, not only with the points.
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>

#include "cutsim/base/numbers.hpp"
#include "cutsim/core/integrator.hpp"
#include "cutsim/core/integrators/newton.hpp"
#include "scene/scene_internal.hpp"
#include "scene/scene_json.hpp"

namespace cutsim::core::detail {
namespace {

constexpr double kBytesPerPoint = 1280, kFixedBytes = 16e6, kFactorBytes = 160;

/// A value of /proc/meminfo in bytes ("MemAvailable:  123 kB"), if the file has it.
std::optional<double> memInfo(const std::string& key) {
  std::ifstream in("/proc/meminfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.compare(0, key.size() + 1, key + ":") != 0) continue;
    std::istringstream fields(line.substr(key.size() + 1));
    double kb = 0;
    if (fields >> kb) return kb * 1024;
  }
  return std::nullopt;
}

/// A number of bytes from a cgroup's file ("max" or unreadable: none).
std::optional<double> cgroupValue(const char* file) {
  std::ifstream in(file);
  std::string word;
  if (!(in >> word) || word == "max") return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(word.c_str(), &end);
  if (end == word.c_str() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::string gigabytes(double bytes) {
  std::ostringstream s;
  s.precision(bytes < 1e9 ? 2 : 3);
  s << bytes / 1e9 << " GB";
  return s.str();
}

}  // namespace

double runBytes(std::size_t points) {
  return kFixedBytes + kBytesPerPoint * double(points);
}

double directFactorBytes(std::size_t points) {
  const double dofs = 3.0 * double(points);
  return kFactorBytes * dofs * std::log2(std::max(2.0, dofs));
}

std::optional<double> availableMemory() {
  if (const char* given = std::getenv("CUTSIM_MEMORY_AVAILABLE"); given && *given) {
    char* end = nullptr;
    const double v = std::strtod(given, &end);
    if (end != given && *end == '\0' && v > 0 && std::isfinite(v)) return v;
    return std::nullopt;  // (unreadable: no check rather than a wrong one)
  }
  std::optional<double> available = memInfo("MemAvailable");
  const std::optional<double> limit = cgroupValue("/sys/fs/cgroup/memory.max");
  const std::optional<double> used = cgroupValue("/sys/fs/cgroup/memory.current");
  if (limit && used) {
    const double left = std::max(0.0, *limit - *used);
    if (!available || left < *available) available = left;
  }
  return available;
}

void checkMemory(const Reader& r, const std::string& meshPointer, const Scene& s,
                 std::size_t points) {
  const std::optional<double> available = availableMemory();
  if (!available) return;
  const double base = runBytes(points);
  const std::string have = gigabytes(*available) + " available";
  if (base > *available)
    r.fail(meshPointer, "a mesh of " + std::to_string(points) + " points needs about " +
                            gigabytes(base) + " to run (" + std::to_string(int(kBytesPerPoint)) +
                            " bytes a point), more than the " + have + ": a coarser mesh");
  const bool direct = s.linearSolver && s.linearSolver->type == "cholmod";
  const double factor = directFactorBytes(points);
  if (direct && base + factor > *available)
    r.fail(s.linearSolver->location.pointer + "/type",
           "CHOLMOD's factor of " + std::to_string(points) + " points needs about " +
               gigabytes(factor) + " beside the run's " + gigabytes(base) + ", more than the " +
               have + ": \"cg\" (iterative, no factor) or a coarser mesh");
  const ImplicitSettings* implicit = std::any_cast<ImplicitSettings>(&s.integrator.parameters);
  if (const auto* newton = std::any_cast<NewtonParameters>(&s.integrator.parameters))
    implicit = &newton->implicit;
  if (!direct && s.linearSolver && implicit &&
      implicit->onSolveFailure == SolveFailurePolicy::Fallback &&
      implicit->fallbackSolver == "cholmod" && base + factor > *available)
    s.warnings.push_back(r.located(
        s.integrator.location.pointer.empty() ? meshPointer : s.integrator.location.pointer,
        "a solve that misses its tolerance falls back to CHOLMOD, whose factor of " +
            std::to_string(points) + " points needs about " + gigabytes(factor) +
            " beside the run's " + gigabytes(base) + ", more than the " + have +
            ": such a step would exhaust the memory (\"onSolveFailure\": \"warn\" keeps CG's "
            "answer, flagged)"));
}

}  // namespace cutsim::core::detail
