// `cutsim run SCENE [--out DIR] [--dump-final DIR] [--quiet]`: loads and validates a scene, runs
// it, writes its frames and CSV (see cutsim/core/output.hpp) and prints a summary.
#include <unistd.h>

#include <csignal>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include "commands.hpp"
#include "cutsim/core/output.hpp"
#include "cutsim/core/scene.hpp"
#include "cutsim/core/sofa_scene.hpp"
#include "cutsim/topology/errors.hpp"
#include "cutsim/view/player.hpp"

namespace cutsim::cli {
namespace {

struct RunOptions {
  std::string scene;
  std::string out;
  std::string dumpFinal;
  bool quiet = false;
  bool allowLong = false;
  std::string html;  ///< also write the player page (cutsim view) here; "" none
  bool htmlAuto = false;  ///< --html without a file: OUT/player.html
  long steps = 0;         ///< a SOFA scene's number of steps (0: 100)
};

bool isSofaScene(const std::string& file) {
  std::string ext = std::filesystem::path(file).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".scn";
}

/// A progress bar on a terminal; plain lines every 10 % otherwise.
class Progress {
 public:
  Progress(long total, bool enabled)
      : total_(total), enabled_(enabled), tty_(enabled && isatty(fileno(stderr))) {}

  void update(long step, double time) {
    if (!enabled_ || total_ <= 0) return;
    const int percent = int(100 * step / total_);
    if (tty_) {
      if (percent == lastPercent_ && step != total_) return;
      lastPercent_ = percent;
      const int width = 40, filled = width * percent / 100;
      std::fprintf(stderr, "\r[%s%s] %3d%%  t = %-10.4g step %ld/%ld",
                   std::string(std::size_t(filled), '#').c_str(),
                   std::string(std::size_t(width - filled), ' ').c_str(), percent, time, step,
                   total_);
      if (step == total_) std::fputc('\n', stderr);
      std::fflush(stderr);
    } else {
      const int decile = percent / 10;
      if (decile == lastPercent_) return;
      lastPercent_ = decile;
      std::fprintf(stderr, "%3d%%  t = %g  step %ld/%ld\n", decile * 10, time, step, total_);
      std::fflush(stderr);
    }
  }

 private:
  long total_;
  bool enabled_, tty_;
  int lastPercent_ = -1;
};

// SIGINT and SIGTERM stop a run at the end of the step being made: the first signal sets this
// flag and gives both signals back their default action, so that a second one ends the program
// at once; the loop checks the flag after every step.
volatile std::sig_atomic_t gStopSignal = 0;
extern "C" void onStopSignal(int signal) {
  gStopSignal = signal;
  std::signal(SIGINT, SIG_DFL);  // (async-signal-safe)
  std::signal(SIGTERM, SIG_DFL);
}

/// Installs the handlers while it lives (the stepping loop), restores the earlier ones when
/// destroyed. A signal the program was started ignoring (a background job) stays ignored.
class StopSignals {
 public:
  StopSignals() {
    gStopSignal = 0;
    struct sigaction a {};
    a.sa_handler = onStopSignal;
    sigemptyset(&a.sa_mask);
    a.sa_flags = SA_RESTART;  // writes under way are not interrupted
    for (auto [signal, old] : {std::pair{SIGINT, &oldInt_}, std::pair{SIGTERM, &oldTerm_}}) {
      ::sigaction(signal, nullptr, old);
      if (old->sa_handler != SIG_IGN) ::sigaction(signal, &a, nullptr);
    }
  }
  ~StopSignals() {
    ::sigaction(SIGINT, &oldInt_, nullptr);
    ::sigaction(SIGTERM, &oldTerm_, nullptr);
  }
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;
  int received() const { return gStopSignal; }

 private:
  struct sigaction oldInt_ {}, oldTerm_ {};
};

std::size_t fieldIndex(const core::Simulation& sim, const forcefields::ForceField* field) {
  for (std::size_t i = 0; i < sim.numForceFields(); ++i)
    if (&sim.forceField(i) == field) return i;
  return 0;
}

void runScene(const RunOptions& options) {
  if (options.steps != 0 && !isSofaScene(options.scene))
    throw InvalidInput("--steps", "is for SOFA scenes (.scn); a JSON scene gives its duration");
  const core::Scene scene = [&] {
    if (!isSofaScene(options.scene)) return core::loadScene(options.scene);
    core::SofaImportOptions o;
    if (options.steps > 0) o.steps = options.steps;
    const core::SofaSceneImport imported = core::importSofaScene(options.scene, o);
    for (const std::string& n : imported.notes) std::cerr << n << "\n";
    return core::sceneFromSofa(imported);
  }();
  const std::filesystem::path outDir = options.out.empty()
                                           ? std::filesystem::path("out") / scene.name
                                           : std::filesystem::path(options.out);

  // What the run will make, checked before it starts: a scene that asks for days of work or
  // millions of files says so now, not after.
  const long steps = scene.numSteps();
  const long frames = (scene.output.vtk || scene.output.obj) ? steps / scene.output.every + 2 : 0;
  constexpr long kMaxSteps = 10'000'000, kMaxFrames = 100'000;
  if (!options.allowLong && (steps > kMaxSteps || frames > kMaxFrames))
    throw InvalidInput(options.scene, "the run would take " + std::to_string(steps) + " steps and write " +
                                          std::to_string(frames) + " frames, more than the limits (10^7 steps, 10^5 "
                                          "frames): raise output.every or the time step, or pass --allow-long");
  if ((options.htmlAuto || !options.html.empty()) && !scene.output.vtk)
    throw InvalidInput("--html", "the scene writes no frames (its output has \"vtk\": false): the player has nothing to "
                                 "show");
  if (!options.dumpFinal.empty()) {
    std::error_code ec;
    if (std::filesystem::exists(options.dumpFinal, ec) && !std::filesystem::is_directory(options.dumpFinal, ec))
      throw InvalidInput("--dump-final", options.dumpFinal + " is a file, not a folder");
  }
  if (!options.quiet)
    std::cerr << "running " << steps << " steps of " << scene.timeStep << " s"
              << (frames ? ", " + std::to_string(frames - 1) + " frames at most" : std::string()) << ", into "
              << outDir.string() << "\n";

  const auto start = std::chrono::steady_clock::now();
  core::SceneRunner runner(scene);
  std::vector<std::string> obstacleNames;
  for (const auto& o : scene.obstacles) obstacleNames.push_back(o.name);
  core::OutputWriter writer(outDir, scene.output, scene.forceFieldLabels(), scene.graspNames(),
                            scene.contact.has_value(), obstacleNames);
  if (writer.replacedFiles() > 0)
    std::cerr << "note: removed " << writer.replacedFiles() << " files of an earlier run from " << outDir.string()
              << "\n";
  // What the player (cutsim view) shows of the scene: its name, description and "up".
  if (scene.output.vtk) core::writeRunInfo(outDir, scene);
  Progress progress(runner.numSteps(), !options.quiet);

  runner.start();
  writer.record(runner.simulation(), {0, 0.0, {}}, runner.finished());
  progress.update(0, 0.0);
  core::StepRecord last{0, 0.0, {}};
  int signal = 0;
  {
    StopSignals signals;  // only while stepping: afterwards a signal ends the program at once
    while (!runner.finished() && !signals.received()) {
      const core::StepStats stats = runner.advance();
      last = {runner.currentStep(), runner.time(), stats};
      writer.record(runner.simulation(), last, runner.finished());
      progress.update(runner.currentStep(), runner.time());
    }
    signal = signals.received();
  }
  if (signal && !runner.finished()) {
    // Stopped cleanly between two steps: the step made last gets its frame, the outputs so far
    // are written whole under partial names, and the player (if asked for) shows them.
    writer.frame(runner.simulation(), last);
    writer.finishPartial();
    std::cerr << "cutsim: stopped by " << (signal == SIGINT ? "SIGINT" : "SIGTERM") << " after step "
              << runner.currentStep() << " of " << runner.numSteps() << " (t = " << runner.time()
              << " s): the outputs in " << outDir.string()
              << " are marked partial (steps.partial.csv, *.partial.pvd); the run cannot be resumed\n";
    if (options.htmlAuto || !options.html.empty()) {
      const std::filesystem::path html =
          options.html.empty() ? outDir / "player.html" : std::filesystem::path(options.html);
      const view::PlayerReport r = view::writePlayer(outDir, html);
      std::cerr << "player     " << html.string() << " (" << r.framesShown << " of " << r.framesInRun
                << " frames, partial)\n";
    }
    throw ExitStatus{128 + signal, signal};
  }
  writer.finish();
  if (!options.dumpFinal.empty()) {
    core::dumpFinal(options.dumpFinal, runner.simulation(), runner.bendingField());
  }
  const core::Simulation& sim = runner.simulation();
  const core::SolveSummary& solves = sim.solveSummary();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  const topology::Topology& topo = runner.simulation().topology();
  std::cout << "scene      " << scene.name << " (" << options.scene << ")\n"
            << "steps      " << runner.numSteps() << " of " << scene.timeStep
            << " s, t = " << runner.time() << " s\n"
            << "wall time  " << seconds << " s ("
            << (seconds > 0 ? double(runner.numSteps()) / seconds : 0.0) << " steps/s)\n"
            << "final      " << topo.numPoints() << " points, " << topo.numEdges() << " edges, "
            << topo.numTriangles() << " triangles";
  if (const auto* b = runner.bendingField()) {
    std::cout << ", " << b->numActiveSprings() << " bending springs";
  }
  std::cout << "\n"
            << "topology   " << runner.cutsDone() << " cuts, " << runner.tornEdges()
            << " torn edges\n"
            << "output     " << writer.framesWritten() << " frames in " << outDir.string() << "\n";
  std::cout << "solver     " << sim.integrator().name();
  if (const auto* ls = sim.integrator().linearSolver()) std::cout << " with " << ls->name();
  std::cout << ", " << solves.flaggedSteps << " flagged steps\n";
  if (solves.flaggedSteps > 0) {
    std::ostringstream w;
    w << "warning: " << solves.flaggedSteps << " of " << runner.numSteps()
      << " steps were flagged by their solves (" << solves.missedTolerance << " missed their tolerance, "
      << solves.indefinite << " indefinite, " << solves.fellBack << " fell back to CHOLMOD, "
      << solves.newtonNotConverged << " Newton unconverged); worst relative residual "
      << solves.worstResidual << " at step " << solves.worstStep
      << "; the steps are flagged in the solver_flags column of steps.csv";
    std::cerr << w.str() << "\n";
  }
  if (!options.dumpFinal.empty()) {
    if (const auto* b = runner.bendingField())
      std::cout << "final dump " << options.dumpFinal << " (forces of the FastTriangularBendingSprings field '"
                << sim.forceFieldLabel(fieldIndex(sim, b)) << "')\n";
    else
      std::cout << "final dump " << options.dumpFinal
                << " (meshes only: the scene has no FastTriangularBendingSprings field)\n";
  }
  if (options.htmlAuto || !options.html.empty()) {
    const std::filesystem::path html = options.html.empty() ? outDir / "player.html" : std::filesystem::path(options.html);
    const view::PlayerReport r = view::writePlayer(outDir, html);
    std::cout << "player     " << html.string() << " (" << r.framesShown << " of " << r.framesInRun << " frames, "
              << view::describeSize(r.bytes) << "; open it in a browser)\n";
  }
  std::cout.flush();
  if (!std::cout) throw Error("cannot write to standard output");
  if (signal) {
    // Received during the last step: the run is complete and its outputs final; the program
    // still ends as the signal asks.
    std::cerr << "cutsim: " << (signal == SIGINT ? "SIGINT" : "SIGTERM")
              << " received during the last step: the run is complete\n";
    throw ExitStatus{128 + signal, signal};
  }
}

}  // namespace

void registerRunCommand(CLI::App& app) {
  auto options = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand(
      "run", "Load a scene (JSON, or SOFA's .scn), check it, run it and write its frames and per-step CSV");
  cmd->add_option("scene", options->scene, "the scene file (.json, or a SOFA scene .scn)")->required();
  cmd->add_option("--steps", options->steps, "a SOFA scene's number of steps (default 100)")
      ->check(CLI::Range(1L, 1000000000L));
  cmd->add_option("--out", options->out, "output folder (default: out/<scene name>)");
  cmd->add_option("--dump-final", options->dumpFinal,
                  "also write final_rest.obj, final.obj and final_forces.json in this folder");
  cmd->add_flag("--quiet", options->quiet, "no progress display (the summary is still printed)");
  cmd->add_flag("--allow-long", options->allowLong,
                "run a scene of more than 10^7 steps or 10^5 frames (refused otherwise, before it starts)");
  cmd->add_option("--html", options->html,
                  "also write the run's player page (as cutsim view) to this file; --html alone: OUT/player.html")
      ->expected(0, 1);
  CLI::Option* html = cmd->get_option("--html");
  cmd->callback([options, html] {
    options->htmlAuto = html->count() > 0;
    if (options->htmlAuto) {
      // Checked before the run, not after it.
      if (!options->html.empty() && std::filesystem::is_directory(options->html))
        throw InvalidInput("--html", options->html + " is a folder, not a file");
    }
    runScene(*options);
  });
}

}  // namespace cutsim::cli
