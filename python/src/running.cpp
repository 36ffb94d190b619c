// Running a scene from Python: stepping (the GIL released), the timeline's actions, constraints
// and parameters between steps, grasps and obstacles moved, outputs, controllers; the SOFA
// importer and the player.
#include <algorithm>

#include "cutsim/core/contact_step.hpp"
#include "cutsim/core/sofa_scene.hpp"
#include "cutsim/forcefields/contact.hpp"
#include "cutsim/view/player.hpp"
#include "simulation.hpp"

namespace cutsim::python {

py::dict statsDict(const core::StepStats& s) {
  return py::dict("iterations"_a = s.iterations, "residual"_a = s.residual,
                  "worst_residual"_a = s.worstResidual, "solves"_a = s.solves,
                  "newton_iterations"_a = s.newtonIterations,
                  "newton_residual"_a = s.newtonResidual, "analysed"_a = s.analysed,
                  "clamped"_a = s.clamped, "splits"_a = s.splits, "substeps"_a = s.substeps,
                  "flags"_a = s.flagText());
}

py::object Simulation::step(long n) {
  if (n < 0) throw py::value_error("step: n must be >= 0");
  requireMutable("step");
  if (inStepLoop_)
    throw Usage(
        "step: a step loop is in progress (a controller or callback of a step cannot step)");
  inStepLoop_ = true;
  struct Reset {
    bool& b;
    ~Reset() { b = false; }
  } reset{inStepLoop_};
  core::StepStats stats;
  bool any = false;
  long flagged = 0;
  for (long i = 0; i < n; ++i) {
    callControllers("on_step_begin");
    const long before = runner_->currentStep();
    std::exception_ptr failure;
    stepping_ = true;
    {
      py::gil_scoped_release release;
      try {
        stats = runner_->stepOnce();
      } catch (...) {
        failure = std::current_exception();
      }
      // A step done, even if an action failed after it, is recorded as `cutsim run` would.
      if (writer_ && runner_->currentStep() > before) {
        try {
          const auto& st = failure ? runner_->lastStats() : stats;
          writer_->record(sim(), {runner_->currentStep(), runner_->time(), st},
                          runner_->currentStep() == runner_->numSteps());
        } catch (...) {
          if (!failure) failure = std::current_exception();
        }
      }
    }
    stepping_ = false;
    keepBridgeLast();
    if (writer_) recordingFailed_ = failure != nullptr;
    if (failure) {
      warnPendingCallbackError();  // the action's failure is raised; the callback's is a warning
      std::rethrow_exception(failure);
    }
    raisePendingCallbackError();
    any = true;
    if (stats.flagged()) ++flagged;
    callControllers("on_step_end");
    if (PyErr_CheckSignals() != 0) throw py::error_already_set();
  }
  if (flagged > 0) {
    std::ostringstream w;
    w << flagged << " of " << n << " steps were flagged by their solves (last: " << stats.flagText()
      << ", worst relative residual " << stats.worstResidual
      << "); see last_stats and solve_summary";
    if (PyErr_WarnEx(gSolverWarning, w.str().c_str(), 2) != 0) throw py::error_already_set();
  }
  return any ? py::object(statsDict(stats)) : py::object(py::none());
}

py::object Simulation::runUntil(double t) {
  if (!std::isfinite(t)) throw py::value_error("run_until: the time must be finite");
  const double eps = 1e-9 * runner_->timeStep();
  long n = 0;
  if (t > runner_->time() + eps) {
    const double steps = std::ceil((t - runner_->time()) / runner_->timeStep() - 1e-9);
    if (steps > 1e12)
      throw py::value_error("run_until: t = " + std::to_string(t) +
                            " is more than 1e12 steps of time_step away");
    n = long(steps);
  }
  return step(n);
}

void Simulation::act(const std::string& text, const std::string& source) {
  requireMutable(source.c_str());
  auto spec = core::parseActionEntry(text, source, runner_->time());
  // A recording's CSV has its columns from the start: a grasp it has none for is refused now,
  // not left out of the CSV without a word.
  if (writer_) {
    const std::string grasp = spec.build()->graspName();
    const auto& columns = writer_->graspColumns();
    if (!grasp.empty() && std::find(columns.begin(), columns.end(), grasp) == columns.end())
      throw Usage(source + ": the recording to " + writer_->dir().string() +
                  " has no CSV columns for the grasp \"" + grasp +
                  "\": name it when the recording starts, record(dir, grasps=[\"" + grasp +
                  "\"]), or start it before record()");
  }
  struct Last {
    Simulation& s;
    ~Last() { s.keepBridgeLast(); }
  } last{*this};
  operate([&] {
    runner_->schedule(std::move(spec));
    return 0;
  });
}

void Simulation::replaceField(std::size_t i, const std::string& text, const std::string& source) {
  requireMutable("set_parameters");
  const auto spec = core::parseForceFieldEntry(text, source);
  runner_->replaceForceField(i, spec);
  keepBridgeLast();
}

void Simulation::constrain(const std::string& text, const std::string& source) {
  requireMutable("fix");
  const auto spec = core::parseConstraintEntry(text, source);
  runner_->applyConstraint(spec);
  keepBridgeLast();
}

void Simulation::unfix(const std::vector<long>& points) {
  requireMutable("unfix");
  for (long p : points) {
    if (p < 0 || p >= long(slots()) || !sim().fixed().contains(PointId(Index(p))))
      throw InvalidInput("unfix", "point " + std::to_string(p) + " is not fixed");
  }
  for (long p : points) {
    sim().fixed().remove(PointId(Index(p)));
  }
}

void Simulation::move(const std::string& name, const py::handle& delta, double duration) {
  requireMutable("move");
  core::Grasp* g = sim().findGrasp(name);
  if (!g) throw InvalidInput("move", "no grasp named \"" + name + "\" is active");
  g->moveBy(runner_->time(), readVec3(delta, "move: delta"), duration);
}

void Simulation::moveObstacle(const std::string& name, const py::handle& delta, double duration) {
  requireMutable("move_obstacle");
  core::ContactStep* c = core::findContactStep(sim());
  if (!c)
    throw InvalidInput("move_obstacle", "the scene has no contact section (and so no obstacles)");
  const auto& obstacles = c->contact().obstacles();
  for (std::size_t k = 0; k < obstacles.size(); ++k)
    if (obstacles[k].name == name) {
      c->moveObstacle(k, runner_->time(), readVec3(delta, "move_obstacle: delta"), duration);
      return;
    }
  std::string known;
  for (const auto& o : obstacles) known += (known.empty() ? "" : ", ") + o.name;
  throw InvalidInput("move_obstacle",
                     "no obstacle named \"" + name + "\" (the scene has: " + known + ")");
}

void Simulation::release(const std::string& name) {
  requireMutable("release");
  if (!sim().findGrasp(name))
    throw InvalidInput("release", "no grasp named \"" + name + "\" is active");
  sim().releaseGrasp(name);
}

void Simulation::record(const std::filesystem::path& dir,
                        const std::vector<std::string>& extraGrasps) {
  requireMutable("record");
  if (writer_)
    throw Usage("record: already recording to " + writer_->dir().string() +
                " (finish_recording() first)");
  std::vector<std::string> obstacles;
  if (const auto* c = scene().contactSetup())
    for (const auto& o : c->obstacles) obstacles.push_back(o.name);
  std::vector<std::string> grasps = scene().graspNames();
  std::vector<std::string> more = extraGrasps;
  for (std::size_t i = 0; i < sim().numGrasps(); ++i)
    more.push_back(sim().grasp(i).name());  // active now
  for (const auto& g : more) {
    if (g.empty() || g.find_first_of(",\"\n\r") != std::string::npos)
      throw InvalidInput("record", "grasp name \"" + g + "\" cannot name CSV columns");
    if (std::find(grasps.begin(), grasps.end(), g) == grasps.end()) grasps.push_back(g);
  }
  recordingFailed_ = false;
  runner_->start();  // the scene's actions due at time 0, if they have not run yet
  keepBridgeLast();
  writer_ =
      std::make_unique<core::OutputWriter>(dir, scene().output, scene().forceFieldLabels(), grasps,
                                           scene().contactSetup() != nullptr, obstacles);
  writer_->setInstruments([this] { return runner_->instrumentSegments(); });
  if (scene().output.vtk) core::writeRunInfo(dir, scene());
  writer_->record(sim(), {runner_->currentStep(), runner_->time(), runner_->lastStats()},
                  runner_->currentStep() == runner_->numSteps());
  raisePendingCallbackError();  // from the actions at time 0: the recording has started
}

py::object Simulation::finishRecording() {
  requireMutable("finish_recording");
  if (!writer_) return py::none();
  const std::filesystem::path dir = writer_->dir();
  auto w = std::move(writer_);
  w->frame(sim(), {runner_->currentStep(), runner_->time(), runner_->lastStats()});
  if (recordingFailed_) {
    recordingFailed_ = false;
    w->finishPartial();
    if (PyErr_WarnEx(gSolverWarning,
                     ("finish_recording: the recording's last step failed: " + dir.string() +
                      " is written as a partial run (steps.partial.csv, *.partial.pvd)")
                         .c_str(),
                     2) != 0)
      throw py::error_already_set();
    return py::cast(dir);
  }
  w->finish();
  return py::cast(dir);
}

void Simulation::dumpFinal(const std::filesystem::path& dir) {
  requireReadable("dump_final");
  core::dumpFinal(dir, sim(), runner_->bendingField());
}

void Simulation::addController(py::object c) {
  if (!py::hasattr(c, "on_step_begin") && !py::hasattr(c, "on_step_end") &&
      !py::hasattr(c, "onAnimateBeginEvent") && !py::hasattr(c, "onAnimateEndEvent"))
    throw py::type_error(
        "add_controller: the controller has none of on_step_begin, on_step_end, "
        "onAnimateBeginEvent, onAnimateEndEvent");
  controllers_.push_back(std::move(c));
}

void Simulation::removeController(const py::object& c) {
  for (auto it = controllers_.begin(); it != controllers_.end(); ++it)
    if (it->is(c)) {
      controllers_.erase(it);
      return;
    }
  throw py::value_error("remove_controller: not a controller of this simulation");
}

void bindRunning(py::module_& m, SimulationClass& cls) {
  // A SOFA scene's translation into a JSON scene (docs/sofa.md), as text.
  m.def(
      "_sofa_scene_json",
      [](const std::filesystem::path& scn) { return core::importSofaScene(scn).scene.dump(); },
      "path"_a);

  m.def(
      "_write_player",
      [](const std::filesystem::path& run, const std::filesystem::path& html, double maxMb,
         const std::string& up) {
        if (!(maxMb >= 1.0 && maxMb <= 4096.0))
          throw InvalidInput("max_mb",
                             std::to_string(maxMb) + " is not a size between 1 and 4096 MB");
        view::PlayerOptions options;
        options.budgetBytes = std::size_t(maxMb * 1048576.0);
        options.up = up;
        view::PlayerReport r;
        {
          py::gil_scoped_release release;
          r = view::writePlayer(run, html, options);
        }
        py::dict d;
        d["path"] = html;
        d["frames_in_run"] = r.framesInRun;
        d["frames_shown"] = r.framesShown;
        d["bytes"] = r.bytes;
        d["partial"] = r.partial;
        return d;
      },
      py::arg("run"), py::arg("html"), py::arg("max_mb"), py::arg("up"));

  // A scene file (text = its path, source = ""), or a scene's JSON text named `source` whose
  // relative paths are resolved against `base`.
  cls.def(py::init([](const std::string& text, const std::string& source,
                      const std::filesystem::path& base) {
            const core::Scene scene =
                source.empty() ? core::loadScene(text) : core::parseScene(text, source, base);
            for (const std::string& w : scene.warnings)
              if (PyErr_WarnEx(PyExc_RuntimeWarning, w.c_str(), 2) != 0)
                throw py::error_already_set();  // (warnings made errors)
            return std::make_unique<Simulation>(scene);
          }),
          "text"_a, "source"_a, "base"_a)
      .def("step", &Simulation::step, "n"_a = 1)
      .def("run_until", &Simulation::runUntil, "t"_a)
      .def("run", &Simulation::run)
      .def_property_readonly("time", [](Simulation& s) { return s.runner().time(); })
      .def_property_readonly("step_count", [](Simulation& s) { return s.runner().currentStep(); })
      .def_property(
          "time_step", [](Simulation& s) { return s.runner().timeStep(); },
          [](Simulation& s, double dt) {
            s.requireMutable("time_step");
            s.runner().setTimeStep(dt);
          })
      .def_property_readonly("duration", [](Simulation& s) { return s.scene().duration; })
      .def_property_readonly("num_steps", [](Simulation& s) { return s.runner().numSteps(); })
      .def_property_readonly("finished", [](Simulation& s) { return s.runner().finished(); })
      .def_property_readonly("name", [](Simulation& s) { return s.scene().name; })
      .def_property_readonly("description", [](Simulation& s) { return s.scene().description; })
      .def_property_readonly("scene_file", [](Simulation& s) { return s.scene().file; })
      .def("_act", &Simulation::act)
      .def("_constrain", &Simulation::constrain)
      .def("_replace_field", &Simulation::replaceField)
      .def("unfix", &Simulation::unfix, "points"_a)
      .def("move", &Simulation::move, "name"_a, "delta"_a, "duration"_a = 0.0,
           "move(name, delta, duration=0): the active grasp `name` moves its points by `delta` "
           "([dx, dy, dz], m) more, over `duration` seconds from now (0: within the next step), "
           "then holds; the rest of its path is dropped. Raises InvalidInputError if no grasp "
           "of that name is active.")
      .def("release", &Simulation::release, "name"_a)
      .def("move_obstacle", &Simulation::moveObstacle, "name"_a, "delta"_a, "duration"_a)
      .def_property_readonly("last_stats",
                             [](Simulation& s) {
                               s.requireReadable("last_stats");
                               return statsDict(s.runner().lastStats());
                             })
      .def_property_readonly("solve_summary", &Simulation::summary)
      .def_property_readonly("torn_edges", [](Simulation& s) { return s.runner().tornEdges(); })
      .def_property_readonly("cuts_done", [](Simulation& s) { return s.runner().cutsDone(); })
      .def("_record", &Simulation::record, "dir"_a, "grasps"_a)
      .def("finish_recording", &Simulation::finishRecording)
      .def("dump_final", &Simulation::dumpFinal, "dir"_a)
      .def("add_controller", &Simulation::addController, "controller"_a)
      .def("remove_controller", &Simulation::removeController, "controller"_a);
}

}  // namespace cutsim::python
