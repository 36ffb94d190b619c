#pragma once
// A running scene as Python sees it: the scene runner, the guards of what may be called when
// (stepping, event callbacks, edits), the outputs and callbacks. Its methods are defined by area:
// simulation.cpp (the guards, the callbacks' plumbing), running.cpp, views.cpp, topology.cpp,
// model.cpp, events.cpp.
#include <nlohmann/json_fwd.hpp>

#include "events.hpp"

namespace cutsim::forcefields {
class SurfaceQuery;
}

namespace cutsim::python {

class Simulation {
 public:
  explicit Simulation(const core::Scene& scene);
  ~Simulation();

  core::SceneRunner& runner() { return *runner_; }
  core::Simulation& sim() { return runner_->simulation(); }
  const core::Scene& scene() const { return runner_->scene(); }

  // ---- guards ----
  /// Throws unless the simulation may be changed now.
  void requireMutable(const char* what) const;
  /// Forces and energies are read between operations, or at an operation's transaction_end: before
  /// it, the force fields have not all followed the operation yet.
  void requireSettled(const char* what) const;
  void requireReadable(const char* what) const;

  // ---- stepping ----
  py::object step(long n);
  py::object runUntil(double t);
  py::object run() { return step(std::max(0L, runner_->numSteps() - runner_->currentStep())); }

  // ---- views ----
  std::uint64_t layout() const { return runner_->simulation().topology().revision(); }
  std::size_t slots() { return sim().state().numSlots(); }
  py::array_t<double> x(bool writable = false);
  py::array_t<double> v(bool writable = false);
  py::array_t<double> rest();
  py::array_t<bool> alive();
  py::array_t<std::int64_t> triangles();
  py::array_t<std::int64_t> triangleIds();
  py::array_t<std::int64_t> edgeIds();
  py::array_t<std::int64_t> edges();

  // ---- topology operations ----
  py::dict cut(const py::handle& polyline, double snapTolerance, double minAngle);
  py::dict tear(long edge, double minAngle);
  /// Plays a timeline entry (a cut, a tear) now and returns the incision it made.
  topology::IncisionResult playIncision(const nlohmann::json& entry, const std::string& source);
  long findEdge(long a, long b);
  void compact();
  void act(const std::string& text, const std::string& source);
  void replaceField(std::size_t i, const std::string& text, const std::string& source);
  void constrain(const std::string& text, const std::string& source);
  void unfix(const std::vector<long>& points);
  void move(const std::string& name, const py::handle& delta, double duration);
  void moveObstacle(const std::string& name, const py::handle& delta, double duration);
  void release(const std::string& name);

  // ---- queries ----
  py::dict energies();
  /// The energy accounts (docs/energy.md), None when the simulation does not keep them.
  py::object energyAccount();
  /// Opens the energy accounts now (again: a new start).
  void accountEnergy();
  py::array_t<double> forces();
  std::size_t fieldIndex(const std::string& label);
  py::tuple fieldEval(const std::string& label, const py::object& xObj, const py::object& vObj);
  std::vector<std::string> fieldLabels();
  py::dict graspForces();
  py::array_t<std::int64_t> graspPoints(const std::string& name);
  py::array_t<std::int64_t> fixedPoints();
  std::vector<std::string> fieldTypes();
  py::dict summary();
  /// The contact's settings, obstacles and last step's figures; None without contact.
  py::object contact();
  /// Triangles that intersect each other or an obstacle at the current positions (the start check
  /// of a scene): (description, distance), at most `limit`.
  std::vector<std::pair<std::string, double>> intersections(std::size_t limit);
  std::vector<std::string> validate();
  // ---- world and material (locate.cpp) ----
  /// The nearest surface point to each world point (within maxDistance).
  py::dict locate(const py::handle& points, double maxDistance);
  /// The first surface point each ray meets (within maxT along its unit direction).
  py::dict rayHits(const py::handle& origins, const py::handle& directions, double maxT);
  /// Every surface point the segment a-b crosses, by its fraction from a.
  py::dict segmentHits(const py::handle& a, const py::handle& b);
  /// Where material points (triangle ids, barycentric weights) are now, and at rest.
  py::array_t<double> worldOf(const py::handle& triangles, const py::handle& weights, bool rest);

  // ---- outputs ----
  void record(const std::filesystem::path& dir, const std::vector<std::string>& extraGrasps);
  py::object finishRecording();
  void dumpFinal(const std::filesystem::path& dir);

  // ---- callbacks ----
  void addController(py::object c);
  void removeController(const py::object& c);
  void onTopologyEvent(py::function f) { eventCallbacks_.push_back(std::move(f)); }
  /// Starts (or restarts) the C++ event log; returns and clears its lines.
  void startEventLog();
  std::vector<std::string> takeEventLog();
  void removeTopologyCallback(const py::function& f);

  /// Keeps the Python callbacks the topology's last observers (and the event log after them), so
  /// that when a callback runs every table of the simulation has followed the event. Called after
  /// whatever may subscribe new observers (actions that start grasps, rebuilt force fields).
  void keepBridgeLast();

  // ---- the garbage collector's view ----
  int traverse(visitproc visit, void* arg);
  void clearReferences();

  // ---- edits ----
  void beginEdit();
  void endEdit() { editing_ = false; }

  // ---- event delivery (EventBridge) ----
  bool hasEventCallbacks() const { return !eventCallbacks_.empty(); }
  template <class Make>
  void deliver(Make&& make) {
    py::gil_scoped_acquire gil;
    Event ev = make();
    eventKind_ = ev.kind;
    auto obj = py::cast(std::move(ev));
    eventThread_ = std::this_thread::get_id();
    inEvent_ = true;
    for (const auto& f : std::vector<py::function>(eventCallbacks_)) {
      try {
        f(obj);
      } catch (py::error_already_set& e) {
        // The transaction is finishing: nothing may unwind through the topology. The first error
        // is raised when the operation returns.
        if (!pendingError_) pendingError_ = std::make_unique<py::error_already_set>(std::move(e));
      }
    }
    inEvent_ = false;
  }

 private:
  /// Calls each controller's on_step_begin(sim) / on_step_end(sim), or SofaPython3's
  /// onAnimateBeginEvent(event) / onAnimateEndEvent(event) with an event dict (dt, time, sim).
  void callControllers(const char* method);
  py::object self() { return py::cast(this, py::return_value_policy::reference); }
  void warnPendingCallbackError();
  void raisePendingCallbackError();
  /// Runs a topology operation; a callback's error is raised after it.
  template <class F>
  std::invoke_result_t<F> operate(F&& f) {
    try {
      auto r = f();
      raisePendingCallbackError();
      return r;
    } catch (...) {
      pendingError_.reset();
      throw;
    }
  }

  std::unique_ptr<core::SceneRunner> runner_;
  std::unique_ptr<EventBridge> bridge_;
  /// The deformed surface's search structure for locate and the ray queries (made at the first,
  /// refitted or rebuilt at each); before runner_'s topology goes.
  std::unique_ptr<forcefields::SurfaceQuery> query_;
  forcefields::SurfaceQuery& surfaceQuery();
  topology::Subscription subscription_;
  std::unique_ptr<core::OutputWriter> writer_;
  /// The recording's last step failed (a SolverError, an action's failure): finishing it writes
  /// the outputs as partial, as `cutsim run` does for a run that did not reach its end.
  bool recordingFailed_ = false;
  std::unique_ptr<EventLog> eventLog_;
  topology::Subscription eventLogSubscription_;
  std::vector<py::object> controllers_;
  std::vector<py::function> eventCallbacks_;
  std::unique_ptr<py::error_already_set> pendingError_;
  std::atomic<bool> stepping_{false};
  bool inStepLoop_ = false, inEvent_ = false, editing_ = false;
  std::thread::id eventThread_;
  std::string eventKind_;
};

/// The simulation a view or an edit refers to, through a weak reference (a view kept by a
/// controller of its own simulation makes no cycle): StaleViewError once it is gone.
Simulation& target(const py::weakref& ref, const char* what);

}  // namespace cutsim::python
