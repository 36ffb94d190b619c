// `cutsim run SCENE [--out DIR] [--dump-final DIR] [--quiet] [--checkpoint-every N]`: loads and
// validates a scene, runs it, writes its frames, CSV and checkpoints (see cutsim/core/output.hpp)
// and prints a summary. `cutsim resume CHECKPOINT`: continues a run from its checkpoint.
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/base/threads.hpp"
#include "cutsim/core/output.hpp"
#include "cutsim/core/scene.hpp"
#include "cutsim/core/sofa_scene.hpp"
#include "cutsim/core/version.hpp"
#include "cutsim/view/player.hpp"

namespace cutsim::cli {
namespace {

struct RunOptions {
  std::string scene;
  std::string out;
  std::string dumpFinal;
  bool quiet = false;
  bool allowLong = false;
  std::string html;          ///< also write the player page (cutsim view) here; "" none
  bool htmlAuto = false;     ///< --html without a file: OUT/player.html
  long steps = 0;            ///< a SOFA scene's number of steps (0: 100)
  long checkpointEvery = 0;  ///< a checkpoint every N steps (0: only when stopped by a signal)
  long stopAfter = 0;        ///< stop after this step as a signal would (0: run to the end)
  bool force = false;        ///< --html may replace a file that is not a player page
  int threads = 0;           ///< --threads: the threads parallel loops may use (0: the scene's)
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
  struct sigaction oldInt_ {
  }, oldTerm_{};
};

std::size_t fieldIndex(const core::Simulation& sim, const forcefields::ForceField* field) {
  for (std::size_t i = 0; i < sim.numForceFields(); ++i)
    if (&sim.forceField(i) == field) return i;
  return 0;
}

/// What a checkpoint holds beyond the run's state: the scene (its text, so that a checkpoint
/// does not depend on the file staying as it was) and how the run was asked for.
struct RunSource {
  std::string
      sceneText;  ///< the JSON scene (a SOFA scene's translation, as cutsim import writes it)
  std::string sceneName;          ///< the scene file as given (for messages)
  std::filesystem::path baseDir;  ///< the scene's folder, absolute (its mesh files)
  long checkpointEvery = 0;
  // What the run was asked to write at its end (a resumed run does the same unless told).
  bool htmlAuto = false;
  std::string html, dumpFinal;  ///< absolute paths
  void remember(const RunOptions& o) {
    htmlAuto = o.htmlAuto;
    html = o.html.empty() ? "" : std::filesystem::absolute(o.html).string();
    dumpFinal = o.dumpFinal.empty() ? "" : std::filesystem::absolute(o.dumpFinal).string();
  }
};

/// The program's build, as a CRC-32 and size of its own executable: a checkpoint resumes, to the
/// bit, only with the build that wrote it.
std::string buildIdentity() {
  static const std::string id = [] {
    const std::filesystem::path exe = "/proc/self/exe";
    std::error_code ec;
    const std::uintmax_t size = std::filesystem::file_size(exe, ec);
    const std::optional<std::uint32_t> crc = fileCrc32(exe);
    if (ec || !crc) return std::string("unknown");
    char text[64];
    std::snprintf(text, sizeof text, "%08x-%ju", unsigned(*crc), size);
    return std::string(text);
  }();
  return id;
}

constexpr const char* kCheckpointName = "checkpoint.ckpt";

/// Writes OUT/checkpoint.ckpt atomically (the previous one stays whole until the new one is).
void writeCheckpoint(const std::filesystem::path& outDir, const RunSource& source,
                     const core::SceneRunner& runner, core::OutputWriter& writer) {
  ArchiveWriter w;
  w.begin("cutsim");
  w.str(core::version());
  w.str(source.sceneText);
  w.str(source.sceneName);
  w.str(source.baseDir.string());
  w.i64(source.checkpointEvery);
  w.str(buildIdentity());
  w.boolean(source.htmlAuto);
  w.str(source.html);
  w.str(source.dumpFinal);
  runner.save(w);
  writer.saveState(w);
  w.save(outDir / kCheckpointName);
}

/// Why a run cannot be checkpointed ("" if it can).
std::string whyNotCheckpointable(const core::SceneRunner& runner) {
  std::string list;
  for (const std::string& m : runner.notCheckpointable()) list += (list.empty() ? "" : ", ") + m;
  return list.empty() ? "" : "its " + list + " cannot be saved yet";
}

/// Steps a run to its end (or to a stop signal), writing its outputs and checkpoints, then prints
/// its summary. `resumed`: the runner and the writer continue a checkpoint.
void play(const RunOptions& options, const core::Scene& scene, const RunSource& source,
          core::SceneRunner& runner, core::OutputWriter& writer,
          const std::filesystem::path& outDir, bool resumed,
          std::chrono::steady_clock::time_point start) {
  const std::string notSaved = whyNotCheckpointable(runner);
  Progress progress(runner.numSteps(), !options.quiet);
  if (!resumed) {
    runner.start();
    writer.record(runner.simulation(), {0, 0.0, {}}, runner.finished());
  }
  progress.update(runner.currentStep(), runner.time());
  core::StepRecord last{runner.currentStep(), runner.time(), {}};
  const long every = source.checkpointEvery;
  const long firstStep = runner.currentStep();
  int signal = 0;
  {
    StopSignals signals;  // only while stepping: afterwards a signal ends the program at once
    const long stopAt =
        options.stopAfter > 0 ? options.stopAfter : std::numeric_limits<long>::max();
    try {
      while (!runner.finished() && !signals.received() && runner.currentStep() < stopAt) {
        const core::StepStats stats = runner.advance();
        last = {runner.currentStep(), runner.time(), stats};
        writer.record(runner.simulation(), last, runner.finished());
        progress.update(runner.currentStep(), runner.time());
        if (every > 0 && runner.currentStep() % every == 0 && !runner.finished())
          writeCheckpoint(outDir, source, runner, writer);
      }
    } catch (const Error&) {
      // The run ends with the error (printed by the caller); say where what it made lies: a
      // failed run leaves no file under a final name, so its rows and frames are easy to miss.
      std::cerr << "cutsim: the run stopped after step " << runner.currentStep() << " of "
                << runner.numSteps() << "; what it made so far is in " << outDir.string()
                << ": the CSV's rows in .steps.csv.tmp, the frames in its *_NNNNNN.vtp files "
                   "(listed in *.partial.pvd as of the last update)\n";
      throw;
    }
    signal = signals.received();
  }
  if ((signal || options.stopAfter > 0) && !runner.finished()) {
    // Stopped cleanly between two steps: a checkpoint of this point, then the step made last
    // gets its frame, the outputs so far are written whole under partial names, and the player
    // (if asked for) shows them.
    const bool saved = notSaved.empty();
    if (saved) writeCheckpoint(outDir, source, runner, writer);
    writer.frame(runner.simulation(), last);
    writer.finishPartial();
    const std::string by = signal == SIGINT    ? "by SIGINT"
                           : signal == SIGTERM ? "by SIGTERM"
                                               : "as asked (--stop-after)";
    std::cerr << "cutsim: stopped " << by << " after step " << runner.currentStep() << " of "
              << runner.numSteps() << " (t = " << runner.time() << " s): the outputs in "
              << outDir.string() << " are marked partial (steps.partial.csv, *.partial.pvd); "
              << (saved ? "resume with: cutsim resume " + (outDir / kCheckpointName).string()
                        : "the run cannot be resumed: " + notSaved)
              << "\n";
    if (options.htmlAuto || !options.html.empty()) {
      const std::filesystem::path html =
          options.html.empty() ? outDir / "player.html" : std::filesystem::path(options.html);
      const view::PlayerReport r = view::writePlayer(outDir, html);
      std::cerr << "player     " << html.string() << " (" << r.framesShown << " of "
                << r.framesInRun << " frames, partial)\n";
    }
    if (signal) throw ExitStatus{128 + signal, signal};
    return;
  }
  writer.finish();
  if (!options.dumpFinal.empty()) {
    core::dumpFinal(options.dumpFinal, runner.simulation(), runner.bendingField());
  }
  const core::Simulation& sim = runner.simulation();
  const core::SolveSummary& solves = sim.solveSummary();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const long stepsRun = runner.currentStep() - firstStep;

  const topology::Topology& topo = runner.simulation().topology();
  std::cout << "scene      " << scene.name << " (" << source.sceneName << ")\n"
            << "steps      " << runner.numSteps() << " of " << scene.timeStep
            << " s, t = " << runner.time() << " s"
            << (resumed ? " (resumed at step " + std::to_string(firstStep) + ")" : "") << "\n"
            << "wall time  " << seconds << " s ("
            << (seconds > 0 ? double(stepsRun) / seconds : 0.0) << " steps/s)\n"
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
  if (every > 0)
    std::cout << "checkpoint " << (outDir / kCheckpointName).string() << " (every " << every
              << " steps)\n";
  if (solves.flaggedSteps > 0) {
    std::ostringstream w;
    w << "warning: " << solves.flaggedSteps << " of " << runner.numSteps()
      << " steps were flagged by their solves (" << solves.missedTolerance
      << " missed their tolerance, " << solves.indefinite << " indefinite, " << solves.fellBack
      << " fell back to the fallback solver, " << solves.newtonNotConverged
      << " Newton unconverged, " << solves.residualEnergy
      << " with a residual of too much kinetic energy); worst relative residual "
      << solves.worstResidual << " at step " << solves.worstStep
      << "; the steps are flagged in the solver_flags column of steps.csv";
    if (solves.missedTolerance > 0)
      w << "; to meet the tolerance: a smaller time step, more iterations or a preconditioner "
           "for CG, a looser tolerance if the residual shown is acceptable, or the direct solver "
           "(cholmod)";
    if (solves.residualEnergy > 0)
      w << "; a solve whose residual could carry more than a hundredth of the motion's kinetic "
           "energy may be far from the system's answer (when it met its tolerance, forces that "
           "nearly cancel dominate the system: a damping or a stiffness very large against the "
           "masses): the direct solver (cholmod) solves it";
    std::cerr << w.str() << "\n";
  }
  if (!options.dumpFinal.empty()) {
    if (const auto* b = runner.bendingField())
      std::cout << "final dump " << options.dumpFinal
                << " (forces of the FastTriangularBendingSprings field '"
                << sim.forceFieldLabel(fieldIndex(sim, b)) << "')\n";
    else
      std::cout << "final dump " << options.dumpFinal
                << " (meshes only: the scene has no FastTriangularBendingSprings field)\n";
  }
  if (options.htmlAuto || !options.html.empty()) {
    const std::filesystem::path html =
        options.html.empty() ? outDir / "player.html" : std::filesystem::path(options.html);
    const view::PlayerReport r = view::writePlayer(outDir, html);
    std::cout << "player     " << html.string() << " (" << r.framesShown << " of " << r.framesInRun
              << " frames, " << view::describeSize(r.bytes) << "; open it in a browser)\n";
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

/// The checks of --html and --dump-final before a run into outDir.
void checkOutputOptions(const RunOptions& options, const core::Scene& scene,
                        const std::filesystem::path& outDir) {
  if (!options.html.empty()) {
    std::error_code ec;
    const std::filesystem::path page =
        std::filesystem::weakly_canonical(std::filesystem::absolute(options.html), ec);
    const std::filesystem::path dir =
        std::filesystem::weakly_canonical(std::filesystem::absolute(outDir), ec);
    const std::string name = page.filename().string();
    if (page.parent_path() == dir && name != "player.html" && core::OutputWriter::isRunOutput(name))
      throw InvalidInput("--html",
                         options.html + " is one of the run's own files: name the page otherwise");
  }
  if (!options.html.empty()) {
    std::vector<std::filesystem::path> inputs{scene.file, options.scene};
    if (scene.meshFile) inputs.push_back(*scene.meshFile);
    checkReplaceable(options.html, "--html", inputs, kPlayerMark, options.force);
  }
  if ((options.htmlAuto || !options.html.empty()) && !scene.output.vtk)
    throw InvalidInput(
        "--html",
        "the scene writes no frames (its output has \"vtk\": false): the player has nothing to "
        "show");
  if (!options.dumpFinal.empty()) {
    std::error_code ec;
    if (std::filesystem::exists(options.dumpFinal, ec) &&
        !std::filesystem::is_directory(options.dumpFinal, ec))
      throw InvalidInput("--dump-final", options.dumpFinal + " is a file, not a folder");
  }
}

std::vector<std::string> obstacleNamesOf(const core::Scene& scene) {
  std::vector<std::string> names;
  if (const auto* c = scene.contactSetup())
    for (const auto& o : c->obstacles) names.push_back(o.name);
  return names;
}

void runScene(const RunOptions& options) {
  if (options.threads > 0) overrideThreads(options.threads);
  if (options.steps != 0 && !isSofaScene(options.scene))
    throw InvalidInput("--steps", "is for SOFA scenes (.scn); a JSON scene gives its duration");
  RunSource source;
  source.sceneName = options.scene;
  source.checkpointEvery = options.checkpointEvery;
  source.remember(options);
  const core::Scene scene = [&] {
    if (!isSofaScene(options.scene)) {
      // Read once: the checkpoints hold the text the run was made from.
      source.sceneText = core::readSceneText(options.scene);
      source.baseDir =
          std::filesystem::absolute(std::filesystem::path(options.scene)).parent_path();
      return core::parseScene(source.sceneText, options.scene,
                              std::filesystem::path(options.scene).parent_path());
    }
    core::SofaImportOptions o;
    if (options.steps > 0) o.steps = options.steps;
    const core::SofaSceneImport imported = core::importSofaScene(options.scene, o);
    for (const std::string& n : imported.notes) std::cerr << n << "\n";
    // The checkpoints hold its JSON translation (what cutsim import writes: the same run).
    source.sceneText = imported.scene.dump(2) + "\n";
    source.baseDir = std::filesystem::absolute(imported.jsonDir.empty() ? std::filesystem::path(".")
                                                                        : imported.jsonDir);
    return core::sceneFromSofa(imported);
  }();
  for (const std::string& w : scene.warnings) std::cerr << "warning: " << w << "\n";
  const std::filesystem::path outDir = options.out.empty()
                                           ? std::filesystem::path("out") / scene.name
                                           : std::filesystem::path(options.out);

  // What the run will make, checked before it starts: a scene that asks for days of work or
  // millions of files says so now, not after.
  const long steps = scene.numSteps();
  const long frames = (scene.output.vtk || scene.output.obj) ? steps / scene.output.every + 2 : 0;
  constexpr long kMaxSteps = 10'000'000, kMaxFrames = 100'000;
  if (!options.allowLong && (steps > kMaxSteps || frames > kMaxFrames))
    throw InvalidInput(options.scene,
                       "the run would take " + std::to_string(steps) + " steps and write " +
                           std::to_string(frames) +
                           " frames, more than the limits (10^7 steps, 10^5 "
                           "frames): raise output.every or the time step, or pass --allow-long");
  checkOutputOptions(options, scene, outDir);
  if (!options.quiet)
    std::cerr << "running " << steps << " steps of " << scene.timeStep << " s"
              << (frames ? ", " + std::to_string(frames - 1) + " frames at most" : std::string())
              << ", into " << outDir.string() << "\n";

  const auto start = std::chrono::steady_clock::now();
  core::SceneRunner runner(scene);
  if (options.checkpointEvery > 0 || options.stopAfter > 0) {
    const std::string why = whyNotCheckpointable(runner);
    if (!why.empty())
      throw InvalidInput(options.checkpointEvery > 0 ? "--checkpoint-every" : "--stop-after",
                         "this run cannot be checkpointed: " + why);
  }
  core::OutputWriter writer(outDir, scene.output, scene.forceFieldLabels(), scene.graspNames(),
                            scene.contactSetup() != nullptr, obstacleNamesOf(scene));
  writer.setInstruments([&runner] { return runner.instrumentSegments(); });
  if (writer.replacedFiles() > 0)
    std::cerr << "note: removed " << writer.replacedFiles() << " files of an earlier run from "
              << outDir.string() << "\n";
  // What the player (cutsim view) shows of the scene: its name, description and "up".
  if (scene.output.vtk) core::writeRunInfo(outDir, scene);
  play(options, scene, source, runner, writer, outDir, false, start);
}

struct ResumeOptions {
  std::string checkpoint;
  RunOptions run;
  bool everyGiven = false, htmlGiven = false, dumpGiven = false;
  bool otherBuild = false;  ///< resume with another build of cutsim (its rounding may differ)
};

void resumeRun(const ResumeOptions& options) {
  if (options.run.threads > 0) overrideThreads(options.run.threads);
  const std::filesystem::path file(options.checkpoint);
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec))
    throw InvalidInput(file.string(), "is a folder: give its " + std::string(kCheckpointName));
  ArchiveReader in(file);
  in.open("cutsim");
  const std::string written = in.str();
  RunSource source;
  source.sceneText = in.str();
  source.sceneName = in.str();
  source.baseDir = in.str();
  source.checkpointEvery = long(in.i64());
  const std::string build = in.str();
  source.htmlAuto = in.boolean();
  source.html = in.str();
  source.dumpFinal = in.str();
  in.close();
  if (written != core::version())
    throw InvalidInput(
        file.string(),
        "written by cutsim " + written + ", this is cutsim " + core::version() +
            ": a run resumes with the program that began it (its outputs would differ)");
  if (build != buildIdentity() && !options.otherBuild)
    throw InvalidInput(
        file.string(),
        "written by another build of cutsim (" + build + ", this one is " + buildIdentity() +
            "): its rounding may differ from this one's, so the resumed run would not be "
            "the run made without a stop; pass --other-build to resume anyway");
  // What the run was asked for, unless given again.
  RunOptions run = options.run;
  if (options.everyGiven) source.checkpointEvery = run.checkpointEvery;
  if (!options.htmlGiven) {
    run.htmlAuto = source.htmlAuto;
    run.html = source.html;
  }
  if (!options.dumpGiven) run.dumpFinal = source.dumpFinal;
  source.remember(run);  // (the checkpoints this run writes remember what it was asked for)
  const core::Scene scene = core::parseScene(source.sceneText, source.sceneName, source.baseDir);
  for (const std::string& w : scene.warnings) std::cerr << "warning: " << w << "\n";
  const std::filesystem::path outDir =
      file.parent_path().empty() ? std::filesystem::path(".") : file.parent_path();
  checkOutputOptions(run, scene, outDir);
  const auto start = std::chrono::steady_clock::now();
  core::SceneRunner runner(scene, in);
  if (run.stopAfter > 0 && run.stopAfter <= runner.currentStep())
    throw InvalidInput("--stop-after", std::to_string(run.stopAfter) +
                                           " is not after the checkpoint's step " +
                                           std::to_string(runner.currentStep()));
  core::OutputWriter writer(outDir, scene.output, scene.forceFieldLabels(), scene.graspNames(),
                            scene.contactSetup() != nullptr, obstacleNamesOf(scene), in);
  writer.setInstruments([&runner] { return runner.instrumentSegments(); });
  if (!run.quiet)
    std::cerr << "resuming " << source.sceneName << " at step " << runner.currentStep() << " of "
              << runner.numSteps() << " (t = " << runner.time() << " s), into " << outDir.string()
              << "\n";
  if (scene.output.vtk) core::writeRunInfo(outDir, scene);
  play(run, scene, source, runner, writer, outDir, true, start);
}

}  // namespace

void registerRunCommand(CLI::App& app) {
  auto options = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand("run",
                                     "Load a scene (JSON, or SOFA's .scn), check it, run it and "
                                     "write its frames and per-step CSV");
  cmd->add_option("scene", options->scene, "the scene file (.json, or a SOFA scene .scn)")
      ->required();
  cmd->add_option("--steps", options->steps, "a SOFA scene's number of steps (default 100)")
      ->check(CLI::Range(1L, 1000000000L));
  cmd->add_option("--out", options->out, "output folder (default: out/<scene name>)");
  cmd->add_option("--dump-final", options->dumpFinal,
                  "also write final_rest.obj, final.obj and final_forces.json in this folder");
  cmd->add_flag("--quiet", options->quiet, "no progress display (the summary is still printed)");
  cmd->add_flag(
      "--allow-long", options->allowLong,
      "run a scene of more than 10^7 steps or 10^5 frames (refused otherwise, before it starts)");
  cmd->add_option("--html", options->html,
                  "also write the run's player page (as cutsim view) to this file; --html alone: "
                  "OUT/player.html")
      ->expected(0, 1);
  cmd->add_flag("--force", options->force,
                "let --html replace an existing file that is not a player page (never the scene "
                "or its mesh)");
  cmd->add_option(
         "--checkpoint-every", options->checkpointEvery,
         "write OUT/checkpoint.ckpt every N steps (a stop by SIGINT or SIGTERM writes one too); "
         "cutsim resume continues from it")
      ->check(CLI::Range(1L, 1000000000L));
  cmd->add_option("--stop-after", options->stopAfter,
                  "stop after this step as SIGINT would (a checkpoint, the outputs marked "
                  "partial), exit code 0: "
                  "a run made in parts")
      ->check(CLI::Range(1L, 1000000000L));
  cmd->add_option("--threads", options->threads,
                  "the threads parallel loops may use (default: the scene's \"threads\", else "
                  "CUTSIM_THREADS, else the machine's cores); the outputs do not depend on it")
      ->check(CLI::Range(1, 256));
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

void registerResumeCommand(CLI::App& app) {
  auto options = std::make_shared<ResumeOptions>();
  CLI::App* cmd = app.add_subcommand("resume",
                                     "Continue a run from its checkpoint (OUT/checkpoint.ckpt) "
                                     "into the same folder: the outputs are those "
                                     "of the run made without a stop");
  cmd->add_option("checkpoint", options->checkpoint, "the checkpoint file (OUT/checkpoint.ckpt)")
      ->required();
  cmd->add_option("--dump-final", options->run.dumpFinal,
                  "also write final_rest.obj, final.obj and final_forces.json in this folder");
  cmd->add_flag("--quiet", options->run.quiet,
                "no progress display (the summary is still printed)");
  cmd->add_option("--html", options->run.html,
                  "also write the run's player page (as cutsim view) to this file; --html alone: "
                  "OUT/player.html")
      ->expected(0, 1);
  cmd->add_flag("--force", options->run.force,
                "let --html replace an existing file that is not a player page (never the scene "
                "or its mesh)");
  CLI::Option* every = cmd->add_option("--checkpoint-every", options->run.checkpointEvery,
                                       "a checkpoint every N steps (default: as the run did)")
                           ->check(CLI::Range(1L, 1000000000L));
  cmd->add_option("--stop-after", options->run.stopAfter,
                  "stop after this step as SIGINT would (a checkpoint, the outputs marked "
                  "partial), exit code 0: "
                  "a run made in parts")
      ->check(CLI::Range(1L, 1000000000L));
  cmd->add_option("--threads", options->run.threads,
                  "the threads parallel loops may use (default: the scene's \"threads\", else "
                  "CUTSIM_THREADS, else the machine's cores); the outputs do not depend on it")
      ->check(CLI::Range(1, 256));
  CLI::Option* dump = cmd->get_option("--dump-final");
  cmd->add_flag("--other-build", options->otherBuild,
                "resume a checkpoint written by another build of cutsim (the outputs may then "
                "differ by rounding "
                "from the run made without a stop)");
  CLI::Option* html = cmd->get_option("--html");
  cmd->callback([options, html, every, dump] {
    options->run.htmlAuto = html->count() > 0;
    options->htmlGiven = html->count() > 0;
    options->dumpGiven = dump->count() > 0;
    options->everyGiven = every->count() > 0;
    if (options->run.htmlAuto && !options->run.html.empty() &&
        std::filesystem::is_directory(options->run.html))
      throw InvalidInput("--html", options->run.html + " is a folder, not a file");
    resumeRun(*options);
  });
}

}  // namespace cutsim::cli
