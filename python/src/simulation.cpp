// The Python simulation's core: construction, the guards, the callbacks' plumbing, the garbage
// collector's view (simulation.hpp).
#include "simulation.hpp"

#include "cutsim/forcefields/surface_query.hpp"

namespace cutsim::python {

Simulation::Simulation(const core::Scene& scene)
    : runner_(std::make_unique<core::SceneRunner>(scene)) {
  bridge_ = std::make_unique<EventBridge>(*this);
  subscription_ = runner_->simulation().topology().subscribe(*bridge_);
}

Simulation::~Simulation() {
  subscription_.reset();
  eventLogSubscription_.reset();
  if (writer_) {
    // Abandoned (the script raised, or dropped the simulation without finish_recording()): the
    // outputs so far are written whole under partial names, never as a finished run's.
    try {
      writer_->frame(sim(), {runner_->currentStep(), runner_->time(), runner_->lastStats()});
    } catch (...) {
    }
    try {
      writer_->finishPartial();
    } catch (...) {
    }
  }
}

void Simulation::requireMutable(const char* what) const {
  if (inEvent_ && std::this_thread::get_id() == eventThread_)
    throw Usage(std::string(what) +
                ": a topology event callback may read the simulation but not change it (the event "
                "contract: events arrive while the operation is finishing)");
  if (stepping_ || inEvent_)
    throw Usage(std::string(what) +
                ": the simulation is busy (stepping or changing) in another thread");
  if (editing_)
    throw Usage(std::string(what) +
                ": called inside a `with sim.edit()` block, which allows no step or topology "
                "change: leave the block first");
}

void Simulation::requireSettled(const char* what) const {
  requireReadable(what);
  if (inEvent_ && eventKind_ != "transaction_end")
    throw Usage(std::string(what) +
                ": in a topology event callback, forces and energies are read at the "
                "transaction_end event, when every table has followed the operation");
}

void Simulation::requireReadable(const char* what) const {
  if (stepping_ && !(inEvent_ && std::this_thread::get_id() == eventThread_))
    throw Usage(std::string(what) + ": the simulation is stepping in another thread");
}

void Simulation::keepBridgeLast() {
  auto& topo = sim().topology();
  subscription_.reset();
  subscription_ = topo.subscribe(*bridge_);
  if (eventLog_) {
    eventLogSubscription_.reset();
    eventLogSubscription_ = topo.subscribe(*eventLog_);
  }
}

int Simulation::traverse(visitproc visit, void* arg) {
  for (const auto& c : controllers_) Py_VISIT(c.ptr());
  for (const auto& f : eventCallbacks_) Py_VISIT(f.ptr());
  return 0;
}

void Simulation::clearReferences() {
  controllers_.clear();
  eventCallbacks_.clear();
}

void Simulation::beginEdit() {
  requireMutable("edit");
  editing_ = true;
}

void Simulation::callControllers(const char* method) {
  const bool begin = std::string(method) == "on_step_begin";
  const char* sofa = begin ? "onAnimateBeginEvent" : "onAnimateEndEvent";
  for (const auto& c : std::vector<py::object>(controllers_)) {
    if (py::hasattr(c, sofa)) {
      c.attr(sofa)(
          py::dict("dt"_a = runner_->timeStep(), "time"_a = runner_->time(), "sim"_a = self()));
    } else if (py::hasattr(c, method)) {
      c.attr(method)(self());
    }
  }
}

void Simulation::warnPendingCallbackError() {
  if (!pendingError_) return;
  auto e = std::move(pendingError_);
  const std::string message = std::string("a topology event callback raised too: ") + e->what();
  if (PyErr_WarnEx(PyExc_RuntimeWarning, message.c_str(), 2) != 0) throw py::error_already_set();
}

void Simulation::raisePendingCallbackError() {
  if (!pendingError_) return;
  auto e = std::move(pendingError_);
  e->restore();
  throw py::error_already_set();
}

int traverseSimulation(PyObject* self, visitproc visit, void* arg) {
#if PY_VERSION_HEX >= 0x03090000
  Py_VISIT(Py_TYPE(self));
#endif
  auto* inst = reinterpret_cast<py::detail::instance*>(self);
  if (!inst->get_value_and_holder().holder_constructed()) return 0;
  return py::handle(self).cast<Simulation&>().traverse(visit, arg);
}

int clearSimulation(PyObject* self) {
  auto* inst = reinterpret_cast<py::detail::instance*>(self);
  if (inst->get_value_and_holder().holder_constructed())
    py::handle(self).cast<Simulation&>().clearReferences();
  return 0;
}

}  // namespace cutsim::python
