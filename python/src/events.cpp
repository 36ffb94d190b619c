// Topology events delivered to Python callbacks (EventBridge) and the C++ event log of the tests.
#include "simulation.hpp"

namespace cutsim::python {

void EventBridge::onTrianglesDestroyed(const topology::Topology&,
                                       const topology::TrianglesDestroyed& e) {
  if (!wanted()) return;
  emit([&] {
    Event ev{"triangles_destroyed"};
    ev.ids = idArray(e.triangles);
    ev.vertices = rowArray(e.vertices);
    ev.edges = rowArray(e.edges);
    return ev;
  });
}

void EventBridge::onEdgesDestroyed(const topology::Topology&, const topology::EdgesDestroyed& e) {
  if (!wanted()) return;
  emit([&] {
    Event ev{"edges_destroyed"};
    ev.ids = idArray(e.edges);
    ev.vertices = rowArray(e.vertices);
    return ev;
  });
}

void EventBridge::onPointsDestroyed(const topology::Topology&, const topology::PointsDestroyed& e) {
  if (!wanted()) return;
  emit([&] {
    Event ev{"points_destroyed"};
    ev.ids = idArray(e.points);
    return ev;
  });
}

void EventBridge::onPointsCreated(const topology::Topology&, const topology::PointsCreated& e) {
  if (!wanted()) return;
  emit([&] {
    Event ev{"points_created"};
    ev.ids = idArray(e.points);
    py::array_t<std::int64_t> off(py::ssize_t(e.offsets.size()));
    for (std::size_t i = 0; i < e.offsets.size(); ++i)
      off.mutable_at(py::ssize_t(i)) = e.offsets[i];
    ev.offsets = off;
    ev.ancestors = idArray(e.ancestors);
    ev.weights = py::array_t<double>(py::ssize_t(e.weights.size()), e.weights.data());
    return ev;
  });
}

void EventBridge::onEdgesCreated(const topology::Topology&, const topology::EdgesCreated& e) {
  if (!wanted()) return;
  emit([&] {
    Event ev{"edges_created"};
    ev.ids = idArray(e.edges);
    ev.vertices = rowArray(e.vertices);
    return ev;
  });
}

void EventBridge::onTrianglesCreated(const topology::Topology&,
                                     const topology::TrianglesCreated& e) {
  if (!wanted()) return;
  emit([&] {
    Event ev{"triangles_created"};
    ev.ids = idArray(e.triangles);
    ev.vertices = rowArray(e.vertices);
    ev.edges = rowArray(e.edges);
    return ev;
  });
}

void EventBridge::onPointsRenumbered(const topology::Topology&, const topology::Renumbering& r) {
  renumbered("points_renumbered", r);
}

void EventBridge::onEdgesRenumbered(const topology::Topology&, const topology::Renumbering& r) {
  renumbered("edges_renumbered", r);
}

void EventBridge::onTrianglesRenumbered(const topology::Topology&, const topology::Renumbering& r) {
  renumbered("triangles_renumbered", r);
}

void EventBridge::renumbered(const char* kind, const topology::Renumbering& r) {
  if (!wanted()) return;
  emit([&] {
    Event ev{kind};
    py::array_t<std::int64_t> map(py::ssize_t(r.oldToNew.size()));
    for (std::size_t i = 0; i < r.oldToNew.size(); ++i)
      map.mutable_at(py::ssize_t(i)) =
          r.oldToNew[i] == topology::kInvalidIndex ? -1 : std::int64_t(r.oldToNew[i]);
    ev.oldToNew = map;
    ev.newSize = long(r.newSize);
    return ev;
  });
}

bool EventBridge::wanted() const {
  return sim_.hasEventCallbacks();
}

template <class Make>
void EventBridge::emit(Make&& make) {
  sim_.deliver(std::forward<Make>(make));
}

void EventBridge::onTransactionEnd(const topology::Topology&,
                                   const topology::TransactionSummary& s) {
  if (!wanted()) return;
  emit([&] {
    Event ev{"transaction_end"};
    ev.operation = std::string(s.operation);
    ev.summary =
        py::dict("points_created"_a = s.pointsCreated, "points_destroyed"_a = s.pointsDestroyed,
                 "edges_created"_a = s.edgesCreated, "edges_destroyed"_a = s.edgesDestroyed,
                 "triangles_created"_a = s.trianglesCreated,
                 "triangles_destroyed"_a = s.trianglesDestroyed, "renumbered"_a = s.renumbered);
    return ev;
  });
}

void Simulation::startEventLog() {
  eventLogSubscription_.reset();
  eventLog_ = std::make_unique<EventLog>();
  eventLogSubscription_ = sim().topology().subscribe(*eventLog_);
}

std::vector<std::string> Simulation::takeEventLog() {
  if (!eventLog_) throw Usage("_cpp_events: the event log was not started");
  return std::exchange(eventLog_->lines, {});
}

void Simulation::removeTopologyCallback(const py::function& f) {
  for (auto it = eventCallbacks_.begin(); it != eventCallbacks_.end(); ++it)
    if (it->is(f)) {
      eventCallbacks_.erase(it);
      return;
    }
  throw py::value_error("remove_topology_callback: not a callback of this simulation");
}

void bindEvents(py::module_& m, SimulationClass& cls) {
  py::class_<Event>(
      m, "TopologyEvent",
      "One topology event, as the C++ observers get it (docs/topology-events.md). Arrays are "
      "copies; ids are slots (-1: none).")
      .def_readonly("kind", &Event::kind)
      .def_readonly("ids", &Event::ids)
      .def_readonly("vertices", &Event::vertices)
      .def_readonly("edges", &Event::edges)
      .def_readonly("offsets", &Event::offsets)
      .def_readonly("ancestors", &Event::ancestors)
      .def_readonly("weights", &Event::weights)
      .def_readonly("old_to_new", &Event::oldToNew)
      .def_readonly("new_size", &Event::newSize)
      .def_readonly("operation", &Event::operation)
      .def_readonly("summary", &Event::summary)
      .def("__repr__", [](const Event& e) {
        std::string s = "<TopologyEvent " + e.kind;
        if (!e.ids.is_none()) s += " " + std::to_string(py::len(e.ids));
        if (!e.operation.empty()) s += " " + e.operation;
        return s + ">";
      });

  cls.def("on_topology_event", &Simulation::onTopologyEvent, "callback"_a)
      .def("remove_topology_callback", &Simulation::removeTopologyCallback, "callback"_a)
      .def("_start_cpp_events", &Simulation::startEventLog)
      .def("_cpp_events", &Simulation::takeEventLog);
}

}  // namespace cutsim::python
