// SOFA's regression lists, reference files and metrics (sofa_regression.hpp).
#include "cutsim/core/sofa_regression.hpp"

#include <zlib.h>

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/scene.hpp"
#include "cutsim/core/sofa_scene.hpp"
#include "sofa/sofa_text.hpp"

namespace cutsim::core {
namespace {

using detail::parseSofaNumber;

std::vector<std::string> splitWords(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

/// A value as SOFA's comparison sees the run's state: printed with 6 significant digits.
double printed(double v) {
  std::ostringstream o;
  o << v;
  return std::stod(o.str());
}

}  // namespace

std::vector<RegressionEntry> readRegressionList(const std::filesystem::path& list) {
  std::ifstream in(list);
  if (!in) throw InvalidInput(list.string(), "cannot open the regression list");
  std::vector<RegressionEntry> out;
  std::string line;
  std::size_t n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (const std::size_t hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    const auto w = splitWords(line);
    if (w.empty()) continue;
    const std::string where = list.string() + ":" + std::to_string(n);
    if (w.size() > 5)
      throw InvalidInput(
          where, "expected 'SCENE STEPS EPSILON MECA_IN_MAPPING DUMP_ONLY_LAST_STEP', got " +
                     std::to_string(w.size()) + " fields");
    RegressionEntry e;
    e.scene = w[0];
    e.line = n;
    if (w.size() > 1) {
      const auto s = parseSofaNumber(w[1]);
      if (!s || *s < 1 || *s != std::floor(*s) || *s > 1e9)
        throw InvalidInput(where, "steps: expected a whole number >= 1, got \"" + w[1] + "\"");
      e.steps = long(*s);
    }
    if (w.size() > 2) {
      const auto s = parseSofaNumber(w[2]);
      if (!s || !(*s >= 0) || !std::isfinite(*s))
        throw InvalidInput(where, "epsilon: expected a number >= 0, got \"" + w[2] + "\"");
      e.epsilon = *s;
    }
    for (std::size_t k = 3; k < w.size(); ++k) {
      if (w[k] != "0" && w[k] != "1")
        throw InvalidInput(where, std::string(k == 3 ? "mecaInMapping" : "dumpOnlyLastStep") +
                                      ": expected 0 or 1, got \"" + w[k] + "\"");
      (k == 3 ? e.mechanicalInMapping : e.onlyLastStep) = w[k] == "1";
    }
    out.push_back(e);
  }
  if (out.empty()) throw InvalidInput(list.string(), "the regression list names no scene");
  return out;
}

std::string formatReference(const std::vector<StateFrame>& frames) {
  std::ostringstream o;  // default precision: 6 significant digits, as SOFA's streams
  for (const StateFrame& f : frames) {
    o << "T= " << f.time << "\n  X= ";
    for (std::size_t i = 0; i < f.x.size(); ++i) o << (i ? " " : "") << f.x[i];
    o << "\n  V= ";
    for (std::size_t i = 0; i < f.v.size(); ++i) o << (i ? " " : "") << f.v[i];
    o << "\n";
  }
  return o.str();
}

void writeReference(const std::filesystem::path& file, const std::vector<StateFrame>& frames) {
  const std::string text = formatReference(frames);
  std::error_code ec;
  if (!file.parent_path().empty()) std::filesystem::create_directories(file.parent_path(), ec);
  const std::filesystem::path tmp = file.string() + ".tmp";
  gzFile gz = gzopen(tmp.c_str(), "wb9");
  if (!gz) throw Error(tmp.string() + ": cannot write");
  const bool ok = gzwrite(gz, text.data(), unsigned(text.size())) == int(text.size());
  if (gzclose(gz) != Z_OK || !ok) {
    std::filesystem::remove(tmp, ec);
    throw Error(tmp.string() + ": write error");
  }
  std::filesystem::rename(tmp, file, ec);
  if (ec) throw Error(file.string() + ": cannot write: " + ec.message());
}

std::vector<StateFrame> readReference(const std::filesystem::path& file) {
  gzFile gz = gzopen(file.c_str(), "rb");
  if (!gz) throw InvalidInput(file.string(), "cannot open the reference");
  std::string text;
  char buf[1 << 16];
  int got = 0;
  while ((got = gzread(gz, buf, sizeof buf)) > 0) text.append(buf, std::size_t(got));
  int err = 0;
  const char* msg = gzerror(gz, &err);
  const std::string message = msg ? msg : "";
  gzclose(gz);
  if (got < 0 || (err != Z_OK && err != Z_STREAM_END))
    throw InvalidInput(file.string(), "corrupt gzip data: " + message);
  std::vector<StateFrame> frames;
  std::istringstream in(text);
  std::string line;
  std::size_t n = 0;
  while (std::getline(in, line)) {
    ++n;
    const auto w = splitWords(line);
    if (w.empty()) continue;
    const std::string where = file.string() + ":" + std::to_string(n);
    auto values = [&](std::vector<double>& out) {
      for (std::size_t k = 1; k < w.size(); ++k) {
        const auto d = parseSofaNumber(w[k]);
        if (!d || !std::isfinite(*d))
          throw InvalidInput(where, "malformed or non-finite number \"" + w[k] + "\"");
        out.push_back(*d);
      }
      if (out.size() % 3 != 0)
        throw InvalidInput(where, std::to_string(out.size()) + " values: not 3 per point");
    };
    if (w[0] == "T=") {
      if (w.size() != 2 || !parseSofaNumber(w[1]) || !std::isfinite(*parseSofaNumber(w[1])))
        throw InvalidInput(where, "expected 'T= time' (a finite number)");
      frames.push_back({*parseSofaNumber(w[1]), {}, {}});
    } else if (w[0] == "X=" || w[0] == "V=") {
      if (frames.empty()) throw InvalidInput(where, w[0] + " before the first 'T='");
      values(w[0] == "X=" ? frames.back().x : frames.back().v);
    } else {
      throw InvalidInput(where, "expected 'T=', 'X=' or 'V=', got \"" + w[0] + "\"");
    }
  }
  if (frames.empty()) throw InvalidInput(file.string(), "no frame ('T= ...') in the reference");
  return frames;
}

std::filesystem::path referencePath(const std::filesystem::path& refsDir,
                                    const RegressionEntry& entry, std::size_t index,
                                    const std::string& mechanicalObject) {
  return refsDir / (entry.scene.string() + ".reference_" + std::to_string(index) + "_" +
                    mechanicalObject + "_mstate.txt.gz");
}

RegressionComparison compareWithReference(const std::vector<StateFrame>& reference,
                                          const std::vector<StateFrame>& run, double dt,
                                          const std::string& what) {
  RegressionComparison c;
  for (const StateFrame& ref : reference) {
    const StateFrame* mine = nullptr;
    for (const StateFrame& f : run)
      if (std::abs(f.time - ref.time) < 0.5 * dt) mine = &f;
    if (!mine)
      throw InvalidInput(
          what, "the run wrote no frame at the reference's time " + std::to_string(ref.time));
    if (mine->x.size() != ref.x.size())
      throw InvalidInput(what, "the reference has " + std::to_string(ref.x.size() / 3) +
                                   " points at T = " + std::to_string(ref.time) + ", the run " +
                                   std::to_string(mine->x.size() / 3));
    const double points = double(ref.x.size() / 3);
    auto meanAbs = [&](const std::vector<double>& a, const std::vector<double>& b) {
      if (a.empty() || a.size() != b.size()) return 0.0;
      double s = 0;
      for (std::size_t i = 0; i < a.size(); ++i) s += std::abs(a[i] - printed(b[i]));
      return s / double(a.size());
    };
    c.legacy += meanAbs(ref.x, mine->x) / points;
    if (!ref.v.empty() && ref.v.size() == mine->v.size())
      c.legacy += meanAbs(ref.v, mine->v) / points;
    for (std::size_t i = 0; i < ref.x.size(); ++i)
      c.largestPrintedDifference =
          std::max(c.largestPrintedDifference, std::abs(ref.x[i] - printed(mine->x[i])));
    double norm2 = 0;
    for (std::size_t p = 0; 3 * p < ref.x.size(); ++p) {
      double d2 = 0;
      for (int k = 0; k < 3; ++k) {
        const double d = ref.x[3 * p + std::size_t(k)] - mine->x[3 * p + std::size_t(k)];
        d2 += d * d;
      }
      norm2 += d2;
      if (std::sqrt(d2) > c.largestDistance) {
        c.largestDistance = std::sqrt(d2);
        c.worstPoint = p;
        c.worstTime = ref.time;
      }
    }
    c.positions += std::sqrt(norm2) / double(ref.x.size());
    ++c.frames;
  }
  return c;
}

std::vector<StateFrame> runForRegression(const std::filesystem::path& scene,
                                         const RegressionEntry& entry,
                                         std::string& mechanicalObject,
                                         std::vector<std::string>& notes, long& flaggedSteps) {
  SofaImportOptions options;
  options.steps = entry.steps;
  const SofaSceneImport imported = importSofaScene(scene, options);
  mechanicalObject = imported.mechanicalObject;
  notes = imported.notes;
  const Scene s = sceneFromSofa(imported);
  SceneRunner runner(s);
  runner.start();
  std::vector<StateFrame> frames;
  auto record = [&]() {
    StateFrame f;
    f.time = runner.time();
    const auto& sim = runner.simulation();
    const auto x = sim.state().x(), v = sim.state().v();
    for (topology::PointId p : sim.topology().points()) {
      for (int k = 0; k < 3; ++k) {
        f.x.push_back(x[3 * p.idx() + std::size_t(k)]);
        f.v.push_back(v[3 * p.idx() + std::size_t(k)]);
      }
    }
    frames.push_back(std::move(f));
  };
  flaggedSteps = 0;
  for (long step = 0; step < entry.steps; ++step) {  // written at the start of each step
    if (!entry.onlyLastStep || step == 0 || step == entry.steps - 1) record();
    if (step + 1 < entry.steps) {
      const StepStats st = runner.stepOnce();
      if (st.flags) ++flaggedSteps;
    }
  }
  return frames;
}

}  // namespace cutsim::core
