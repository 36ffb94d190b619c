// `cutsim regress LIST [--refs DIR] [--write]`: SOFA's regression tests of state
// (cutsim/core/sofa_regression.hpp): runs each scene of the list for its steps and compares its
// frames with SOFA's references (or writes them). Exit code 1 when a scene is above its threshold.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "commands.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/core/sofa_regression.hpp"

namespace cutsim::cli {
namespace {

struct RegressOptions {
  std::string list, refs;
  bool write = false;
};

void regress(const RegressOptions& options) {
  const std::filesystem::path list(options.list);
  const std::vector<core::RegressionEntry> entries = core::readRegressionList(list);
  const std::filesystem::path base = list.parent_path();
  const std::filesystem::path refs =
      options.refs.empty() ? base / "references" : std::filesystem::path(options.refs);
  int failed = 0, errors = 0;
  for (const core::RegressionEntry& e : entries) {
    // A scene that cannot run or be compared is reported, and the others still run.
    try {
      if (e.mechanicalInMapping)
        std::cerr << list.string() << ":" << e.line
                  << ": note: mecaInMapping 1: cutsim's scenes have no mapped states\n";
      const std::filesystem::path scene = base / e.scene;
      std::cerr << "running " << e.scene.string() << " (" << e.steps << " steps"
                << (e.onlyLastStep ? ", last step only" : "") << ")\n";
      std::string name;
      std::vector<std::string> notes;
      long flagged = 0;
      const std::vector<core::StateFrame> frames =
          core::runForRegression(scene, e, name, notes, flagged);
      for (const std::string& n : notes) std::cerr << n << "\n";
      if (flagged > 0)
        std::cerr << "note: " << flagged << " of " << (e.steps - 1)
                  << " steps ended their linear solve above its tolerance (at its iteration cap or "
                     "its threshold, as SOFA's "
                     "CGLinearSolver does)\n";
      const std::filesystem::path ref = core::referencePath(refs, e, 0, name);
      if (options.write) {
        core::writeReference(ref, frames);
        std::cout << e.scene.string() << ": wrote " << ref.string() << " (" << frames.size()
                  << " frames, " << frames.front().x.size() / 3 << " points)\n";
        continue;
      }
      std::error_code ec;
      if (!std::filesystem::is_regular_file(ref, ec))
        throw InvalidInput(list.string() + ":" + std::to_string(e.line),
                           "no reference " + ref.string() + " (write one with --write)");
      const std::vector<core::StateFrame> reference = core::readReference(ref);
      const double dt = frames.size() > 1 ? (frames[1].time - frames[0].time) /
                                                double(e.onlyLastStep ? e.steps - 1 : 1)
                                          : 1.0;
      const core::RegressionComparison c =
          core::compareWithReference(reference, frames, dt, ref.string());
      const bool pass = c.legacy <= e.epsilon;
      if (!pass) ++failed;
      char line[512];
      std::snprintf(line, sizeof line,
                    "%s: %s  legacy %.3e (threshold %.1e), positions-only %.3e, largest point "
                    "difference %.3g "
                    "(point %zu at T = %g; %.3g with the run printed to the reference's 6 digits), "
                    "%zu frames",
                    e.scene.string().c_str(), pass ? "pass" : "FAIL", c.legacy, e.epsilon,
                    c.positions, c.largestDistance, c.worstPoint, c.worstTime,
                    c.largestPrintedDifference, c.frames);
      std::cout << line << "\n";
    } catch (const Error& err) {
      ++errors;
      std::cout << e.scene.string() << ": ERROR (below)\n";
      std::cerr << "cutsim: error: " << err.what() << "\n";
    }
  }
  std::cout.flush();
  const std::string counts = std::to_string(entries.size()) + " scenes";
  if (errors > 0)
    throw InvalidInput(
        list.string(),
        std::to_string(errors) + " of " + counts + " could not be " +
            (options.write ? "written" : "compared") +
            (failed ? " and " + std::to_string(failed) + " were above their threshold" : ""));
  if (failed > 0) throw Error(std::to_string(failed) + " of " + counts + " above their threshold");
}

}  // namespace

void registerRegressCommand(CLI::App& app) {
  auto options = std::make_shared<RegressOptions>();
  CLI::App* cmd = app.add_subcommand("regress",
                                     "Run SOFA's regression tests of state: each scene of a "
                                     ".regression-tests list, against SOFA's references");
  cmd->add_option("list", options->list, "the list (SOFA's .regression-tests format)")->required();
  cmd->add_option("--refs", options->refs,
                  "the references' folder (default: references/ beside the list)");
  cmd->add_flag("--write", options->write, "write the references instead of comparing");
  cmd->callback([options] { regress(*options); });
}

}  // namespace cutsim::cli
