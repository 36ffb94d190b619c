// Scene files: what a run will need in memory, against what the machine has, at the check.
//
// Measured on hanging cloths (grids of 200 x 200 and 400 x 400 points, implicit Euler, the
// process's peak resident size): a run without a direct solve needs 1.0-1.25 KB a point beyond
// some 10 MB (the mesh, the springs' tables, the solver's vectors, the outputs' buffers); the
// estimate takes 1.28 KB and 16 MB. CHOLMOD's factor of the 3N x 3N system adds 152-156 bytes
// times 3N times log2(3N) (nested dissection of a surface mesh: n log n fill), 309 MB and 1.4 GB
// there; the estimate takes 160 B (10.3 GB for 1000 x 1000). The estimates leave out contact's
// search and the outputs' pages, which grow with the pairs and the frames, not the points.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <optional>
#include <sstream>
#include <string>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/integrator.hpp"
#include "cutsim/core/integrators/newton.hpp"
#include "scene/scene_internal.hpp"
#include "scene/scene_json.hpp"

namespace cutsim::core::detail {
namespace {

constexpr double kBytesPerPoint = 1280, kFixedBytes = 16e6, kFactorBytes = 160;

/// MemTotal and MemAvailable of /proc/meminfo in bytes ("MemAvailable:  123 kB"), as far as the
/// file has them, read once.
struct MemInfo {
  std::optional<double> total, available;
};
MemInfo memInfo() {
  MemInfo m;
  std::ifstream in("/proc/meminfo");
  std::string line;
  while (std::getline(in, line) && !(m.total && m.available)) {
    const std::size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = line.substr(0, colon);
    std::optional<double>* into = key == "MemTotal"       ? &m.total
                                  : key == "MemAvailable" ? &m.available
                                                          : nullptr;
    if (!into) continue;
    std::istringstream fields(line.substr(colon + 1));
    double kb = 0;
    if (fields >> kb) *into = kb * 1024;
  }
  return m;
}

/// The first word of a file as a number of bytes ("max", missing, unreadable: none).
std::optional<double> fileValue(const std::string& file) {
  std::ifstream in(file);
  std::string word;
  if (!(in >> word)) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(word.c_str(), &end);
  if (end == word.c_str() || *end != '\0' || !std::isfinite(v) || v < 0) return std::nullopt;
  return v;
}

/// A key's value in a cgroup's memory.stat ("inactive_file 123").
std::optional<double> statValue(const std::string& file, const std::string& key) {
  std::ifstream in(file);
  std::string k;
  double v = 0;
  while (in >> k >> v)
    if (k == key) return v;
  return std::nullopt;
}

/// The cgroups' limits on this process: each level's limit, and what it leaves (the limit less
/// the level's working set: its usage less the inactive file cache, which the kernel reclaims
/// first, as container runtimes count it), the smallest of each. cgroup v2: the process's own
/// group (/proc/self/cgroup's "0::PATH") and its ancestors; v1: the memory controller's group.
void cgroupLimits(std::optional<double>& limit, std::optional<double>& left) {
  auto take = [&](std::optional<double> max, std::optional<double> used,
                  std::optional<double> inactive) {
    if (!max || *max >= 1e18) return;  // (v1 writes "no limit" as a huge number)
    limit = limit ? std::min(*limit, *max) : *max;
    if (!used) return;
    const double rest = std::max(0.0, *max - std::max(0.0, *used - inactive.value_or(0.0)));
    left = left ? std::min(*left, rest) : rest;
  };
  std::ifstream self("/proc/self/cgroup");
  std::string line;
  while (std::getline(self, line)) {
    const std::size_t a = line.find(':'), b = a == std::string::npos ? a : line.find(':', a + 1);
    if (b == std::string::npos) continue;
    const std::string controllers = line.substr(a + 1, b - a - 1);
    std::string path = line.substr(b + 1);
    if (controllers.empty()) {  // v2: the group and each ancestor
      while (true) {
        const std::string dir = "/sys/fs/cgroup" + (path == "/" ? std::string() : path);
        take(fileValue(dir + "/memory.max"), fileValue(dir + "/memory.current"),
             statValue(dir + "/memory.stat", "inactive_file"));
        if (path.empty() || path == "/") break;
        path = path.substr(0, path.rfind('/'));
      }
    } else if (("," + controllers + ",").find(",memory,") != std::string::npos) {
      const std::string dir = "/sys/fs/cgroup/memory";  // (a namespace's own group is its root)
      take(fileValue(dir + "/memory.limit_in_bytes"), fileValue(dir + "/memory.usage_in_bytes"),
           statValue(dir + "/memory.stat", "total_inactive_file"));
    }
  }
}

std::string gigabytes(double bytes) {
  const double g = bytes / 1e9;
  std::ostringstream s;
  if (g < 0.1)
    return (s << std::setprecision(2) << bytes / 1e6 << " MB", s.str());  // 16 MB, 0.075 MB
  if (g < 1)
    s << std::setprecision(2) << g;  // 0.016
  else
    s << std::fixed << std::setprecision(g < 10 ? 2 : g < 100 ? 1 : 0) << g;  // 1.45, 23.4, 1000
  s << " GB";
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

std::optional<MachineMemory> machineMemory() {
  if (const char* given = std::getenv("CUTSIM_MEMORY"); given && *given) {
    const std::string text = given;
    if (text == "off") return std::nullopt;
    auto number = [&](const std::string& word) {
      char* end = nullptr;
      const double v = std::strtod(word.c_str(), &end);
      // (finite first: comparing a NaN traps where floating-point exceptions are enabled)
      if (word.empty() || end != word.c_str() + word.size() || !std::isfinite(v) || v <= 0)
        throw InvalidInput("CUTSIM_MEMORY",
                           "expected \"off\", a number of bytes (the machine's memory) or two "
                           "separated by a comma (its memory, then what is available now), got \"" +
                               text + "\"");
      return v;
    };
    const std::size_t comma = text.find(',');
    MachineMemory m;
    m.total = number(text.substr(0, comma));
    m.available = comma == std::string::npos ? m.total : number(text.substr(comma + 1));
    return m;
  }
  const MemInfo info = memInfo();
  if (!info.total) return std::nullopt;
  MachineMemory m{*info.total, info.available.value_or(*info.total)};
  std::optional<double> limit, left;
  cgroupLimits(limit, left);
  if (limit) m.total = std::min(m.total, *limit);
  if (left) m.available = std::min(m.available, *left);
  m.available = std::min(m.available, m.total);
  return m;
}

void checkMemory(const Reader& r, const std::string& meshPointer, Scene& s, std::size_t points) {
  std::optional<MachineMemory> machine;
  try {
    machine = machineMemory();
  } catch (const InvalidInput& e) {
    r.fail(meshPointer, std::string("the memory check: ") + e.what());
  }
  if (!machine) return;
  const double base = runBytes(points), factor = directFactorBytes(points);
  const std::string total = gigabytes(machine->total), now = gigabytes(machine->available);
  std::ostringstream perPointText;
  perPointText << kBytesPerPoint / 1000 << " KB";
  const std::string perPoint = perPointText.str();
  const std::string pointsText = std::to_string(points) + " points",
                    mesh = "a mesh of " + pointsText;
  if (base > machine->total)
    r.fail(meshPointer, mesh + " needs about " + gigabytes(base) + " to run (" + perPoint +
                            " a point), " + "more than this machine's " + total +
                            ": a coarser mesh");
  const bool direct = s.linearSolver && s.linearSolver->type == "cholmod";
  if (direct && base + factor > machine->total)
    r.fail(s.linearSolver->location.pointer + "/type",
           "CHOLMOD's factor of " + pointsText + " needs about " + gigabytes(factor) +
               " beside the run's " + gigabytes(base) + ", more than this machine's " + total +
               ": \"cg\" (iterative, no factor) or a coarser mesh");
  const std::string where =
      s.integrator.location.pointer.empty() ? meshPointer : s.integrator.location.pointer;
  const double need = base + (direct ? factor : 0.0);
  if (need > machine->available) {
    s.warnings.push_back(r.located(
        direct ? s.linearSolver->location.pointer + "/type" : meshPointer,
        "the run needs about " + gigabytes(need) + ", more than the " + now +
            " available now (of " + total + "): it may swap or be stopped by the system"));
    return;
  }
  const ImplicitSettings* implicit = std::any_cast<ImplicitSettings>(&s.integrator.parameters);
  if (const auto* newton = std::any_cast<NewtonParameters>(&s.integrator.parameters))
    implicit = &newton->implicit;
  if (!direct && s.linearSolver && implicit &&
      implicit->onSolveFailure == SolveFailurePolicy::Fallback &&
      implicit->fallbackSolver == "cholmod" && base + factor > machine->available)
    s.warnings.push_back(r.located(
        where, "a solve that misses its tolerance falls back to CHOLMOD, whose factor of " +
                   pointsText + " needs about " + gigabytes(factor) + " beside the run's " +
                   gigabytes(base) + ", more than the " + now + " available now (of " + total +
                   "): such a step would exhaust the memory (\"onSolveFailure\": \"warn\" keeps "
                   "CG's answer, flagged)"));
}

}  // namespace cutsim::core::detail
