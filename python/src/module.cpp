// The compiled part of the Python module `cutsim` (cutsim/_cutsim): a running scene (SceneRunner)
// with zero-copy numpy views of its state, topology operations, topology-event and step
// callbacks, outputs, and the project's errors as Python exceptions. The pure-Python part
// (python/cutsim/__init__.py) adds the dict-based entry points and the documentation; the API is
// described in docs/python.md.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/contact_step.hpp"
#include "cutsim/core/output.hpp"
#include "cutsim/core/scene.hpp"
#include "cutsim/core/sofa_scene.hpp"
#include "cutsim/core/timeline.hpp"
#include "cutsim/core/version.hpp"
#include "cutsim/forcefields/contact.hpp"
#include "cutsim/view/player.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace cutsim::python {
namespace {

using core::PointId;
using topology::Index;

// ---------------------------------------------------------------------------------------------
// Errors

PyObject* gError = nullptr;          // cutsim.Error(Exception)
PyObject* gInvalidInput = nullptr;   // cutsim.InvalidInputError(Error, ValueError)
PyObject* gTopologyError = nullptr;  // cutsim.TopologyError(Error, ValueError)
PyObject* gSolverError = nullptr;    // cutsim.SolverError(Error, RuntimeError)
PyObject* gStaleView = nullptr;      // cutsim.StaleViewError(Error, RuntimeError)
PyObject* gUsageError = nullptr;     // cutsim.UsageError(Error, RuntimeError)
PyObject* gSolverWarning = nullptr;  // cutsim.SolverWarning(UserWarning)

/// A view used after the layout it was made for went away.
struct StaleView : std::runtime_error {
  using std::runtime_error::runtime_error;
};
/// A call the simulation cannot take now (re-entrant stepping, a change from an event callback).
struct Usage : std::runtime_error {
  using std::runtime_error::runtime_error;
};

PyObject* makeException(py::module_& m, const char* name, const char* doc, py::tuple bases) {
  const std::string full = std::string("cutsim.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(full.c_str(), doc, bases.ptr(), nullptr);
  if (!type) throw py::error_already_set();
  m.add_object(name, py::handle(type));
  return type;
}

// ---------------------------------------------------------------------------------------------
// numpy helpers

/// A (rows x cols) array over `data`, kept alive by `owner` (shared ownership of the buffer).
py::array_t<double> viewOf(double* data, std::size_t rows, std::size_t cols,
                           std::shared_ptr<const void> owner, bool writable) {
  auto* holder = new std::shared_ptr<const void>(std::move(owner));
  py::capsule base(holder, [](void* p) { delete static_cast<std::shared_ptr<const void>*>(p); });
  py::array_t<double> a({rows, cols}, {cols * sizeof(double), sizeof(double)}, data, base);
  if (!writable) a.attr("setflags")("write"_a = false);
  return a;
}

/// Index ids as int64 (kInvalidIndex as -1).
template <class Id>
py::array_t<std::int64_t> idArray(std::span<const Id> ids) {
  py::array_t<std::int64_t> a(py::ssize_t(ids.size()));
  auto r = a.mutable_unchecked<1>();
  for (std::size_t i = 0; i < ids.size(); ++i)
    r(py::ssize_t(i)) = Index(ids[i]) == topology::kInvalidIndex ? -1 : std::int64_t(Index(ids[i]));
  return a;
}
template <class Id>
py::array_t<std::int64_t> idArray(const std::vector<Id>& ids) {
  return idArray(std::span<const Id>(ids));
}

template <class Row>
py::array_t<std::int64_t> rowArray(std::span<const Row> rows) {
  constexpr std::size_t W = std::tuple_size_v<Row>;
  py::array_t<std::int64_t> a({rows.size(), W});
  auto r = a.mutable_unchecked<2>();
  for (std::size_t i = 0; i < rows.size(); ++i)
    for (std::size_t c = 0; c < W; ++c) {
      const Index v = Index(rows[i][c]);
      r(py::ssize_t(i), py::ssize_t(c)) = v == topology::kInvalidIndex ? -1 : std::int64_t(v);
    }
  return a;
}

/// Reads an (n, 3) float array (any float layout) into a flat vector; n must be `rows`.
/// The array of `obj` as float64 (an empty handle if it is not numbers).
py::array_t<double, py::array::c_style | py::array::forcecast> floats(const py::handle& obj) {
  try {
    return py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
  } catch (const py::error_already_set&) {
    return {};
  }
}

std::vector<double> readPoints(const py::handle& obj, std::size_t rows, const char* what) {
  auto a = floats(obj);
  if (!a || a.ndim() != 2 || a.shape(1) != 3 || std::size_t(a.shape(0)) != rows)
    throw py::value_error(std::string(what) + ": expected an array of shape (" +
                          std::to_string(rows) + ", 3), one row per point slot");
  std::vector<double> out(a.data(), a.data() + a.size());
  for (std::size_t i = 0; i < out.size(); ++i)
    if (!std::isfinite(out[i]))
      throw py::value_error(std::string(what) + ": non-finite value at point slot " +
                            std::to_string(i / 3));
  return out;
}

std::vector<core::Vec3> readVec3List(const py::handle& obj, const char* what) {
  auto a = floats(obj);
  if (!a || a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error(std::string(what) + ": expected a list of [x, y, z] points");
  std::vector<core::Vec3> out(std::size_t(a.shape(0)));
  for (std::size_t i = 0; i < out.size(); ++i)
    for (std::size_t c = 0; c < 3; ++c) {
      out[i][c] = a.at(py::ssize_t(i), py::ssize_t(c));
      if (!std::isfinite(out[i][c]))
        throw py::value_error(std::string(what) + "[" + std::to_string(i) +
                              "]: non-finite coordinate");
    }
  return out;
}

core::Vec3 readVec3(const py::handle& obj, const char* what) {
  py::array_t<double, py::array::c_style | py::array::forcecast> a;
  try {
    a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
  } catch (const py::error_already_set&) {
  }
  if (!a || a.size() != 3 || a.ndim() > 2)
    throw py::value_error(std::string(what) + ": expected three numbers [x, y, z]");
  core::Vec3 v{a.data()[0], a.data()[1], a.data()[2]};
  for (double c : v)
    if (!std::isfinite(c)) throw py::value_error(std::string(what) + ": non-finite coordinate");
  return v;
}

py::dict statsDict(const core::StepStats& s) {
  return py::dict("iterations"_a = s.iterations, "residual"_a = s.residual,
                  "worst_residual"_a = s.worstResidual, "solves"_a = s.solves,
                  "newton_iterations"_a = s.newtonIterations,
                  "newton_residual"_a = s.newtonResidual, "analysed"_a = s.analysed,
                  "clamped"_a = s.clamped, "splits"_a = s.splits, "substeps"_a = s.substeps,
                  "flags"_a = s.flagText());
}

py::dict incisionDict(const topology::IncisionResult& r) {
  return py::dict(
      "path"_a = idArray(r.path), "copies"_a = idArray(r.copies),
      "copied_from"_a = idArray(r.copiedFrom), "inserted"_a = idArray(r.insertedPoints),
      "flips"_a = r.repair.flips, "collapses"_a = r.repair.collapses,
      "relocations"_a = r.repair.relocations, "splits"_a = r.repair.splits,
      "insertions"_a = r.repair.insertions, "min_angle_before"_a = r.repair.minAngleBefore,
      "min_angle_after"_a = r.repair.minAngleAfter, "budget_spent"_a = r.repair.budgetSpent);
}

// ---------------------------------------------------------------------------------------------
// Topology events as Python objects

struct Event {
  explicit Event(std::string k) : kind(std::move(k)) {}
  std::string kind;  // "points_created", ...
  py::object ids = py::none(), vertices = py::none(), edges = py::none();
  py::object offsets = py::none(), ancestors = py::none(), weights = py::none();
  py::object oldToNew = py::none();
  long newSize = 0;
  std::string operation;
  py::object summary = py::none();
};

class Simulation;

/// Forwards every topology event to the Python callbacks (with the GIL), and stamps the layout.
class EventBridge final : public topology::TopologyObserver {
 public:
  explicit EventBridge(Simulation& s) : sim_(s) {}
  void onTrianglesDestroyed(const topology::Topology&,
                            const topology::TrianglesDestroyed& e) override {
    if (!wanted()) return;
    emit([&] {
      Event ev{"triangles_destroyed"};
      ev.ids = idArray(e.triangles);
      ev.vertices = rowArray(e.vertices);
      ev.edges = rowArray(e.edges);
      return ev;
    });
  }
  void onEdgesDestroyed(const topology::Topology&, const topology::EdgesDestroyed& e) override {
    if (!wanted()) return;
    emit([&] {
      Event ev{"edges_destroyed"};
      ev.ids = idArray(e.edges);
      ev.vertices = rowArray(e.vertices);
      return ev;
    });
  }
  void onPointsDestroyed(const topology::Topology&, const topology::PointsDestroyed& e) override {
    if (!wanted()) return;
    emit([&] {
      Event ev{"points_destroyed"};
      ev.ids = idArray(e.points);
      return ev;
    });
  }
  void onPointsCreated(const topology::Topology&, const topology::PointsCreated& e) override {
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
  void onEdgesCreated(const topology::Topology&, const topology::EdgesCreated& e) override {
    if (!wanted()) return;
    emit([&] {
      Event ev{"edges_created"};
      ev.ids = idArray(e.edges);
      ev.vertices = rowArray(e.vertices);
      return ev;
    });
  }
  void onTrianglesCreated(const topology::Topology&, const topology::TrianglesCreated& e) override {
    if (!wanted()) return;
    emit([&] {
      Event ev{"triangles_created"};
      ev.ids = idArray(e.triangles);
      ev.vertices = rowArray(e.vertices);
      ev.edges = rowArray(e.edges);
      return ev;
    });
  }
  void onPointsRenumbered(const topology::Topology&, const topology::Renumbering& r) override {
    renumbered("points_renumbered", r);
  }
  void onEdgesRenumbered(const topology::Topology&, const topology::Renumbering& r) override {
    renumbered("edges_renumbered", r);
  }
  void onTrianglesRenumbered(const topology::Topology&, const topology::Renumbering& r) override {
    renumbered("triangles_renumbered", r);
  }
  void onTransactionEnd(const topology::Topology&, const topology::TransactionSummary& s) override;
  std::string observerName() const override { return "Python event callbacks"; }

  bool wanted() const;

 private:
  void renumbered(const char* kind, const topology::Renumbering& r) {
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
  template <class Make>
  void emit(Make&& make);

  Simulation& sim_;
};

/// A plain C++ observer that writes each event as one line of text, independently of the Python
/// events: the tests compare the events Python callbacks receive with it (Simulation._cpp_events).
class EventLog final : public topology::TopologyObserver {
 public:
  std::vector<std::string> lines;
  void onTrianglesDestroyed(const topology::Topology&,
                            const topology::TrianglesDestroyed& e) override {
    lines.push_back("triangles_destroyed:" + join(e.triangles) + "|" + rows(e.vertices));
  }
  void onEdgesDestroyed(const topology::Topology&, const topology::EdgesDestroyed& e) override {
    lines.push_back("edges_destroyed:" + join(e.edges) + "|" + rows(e.vertices));
  }
  void onPointsDestroyed(const topology::Topology&, const topology::PointsDestroyed& e) override {
    lines.push_back("points_destroyed:" + join(e.points));
  }
  void onPointsCreated(const topology::Topology&, const topology::PointsCreated& e) override {
    std::string w;
    for (std::size_t i = 0; i < e.weights.size(); ++i) {
      char buf[40];
      std::snprintf(buf, sizeof buf, "%.17g", e.weights[i]);
      w += (i ? "," : "") + std::string(buf);
    }
    lines.push_back("points_created:" + join(e.points) + "|" + join(e.offsets) + "|" +
                    join(e.ancestors) + "|" + w);
  }
  void onEdgesCreated(const topology::Topology&, const topology::EdgesCreated& e) override {
    lines.push_back("edges_created:" + join(e.edges) + "|" + rows(e.vertices));
  }
  void onTrianglesCreated(const topology::Topology&, const topology::TrianglesCreated& e) override {
    lines.push_back("triangles_created:" + join(e.triangles) + "|" + rows(e.vertices) + "|" +
                    rows(e.edges));
  }
  void onPointsRenumbered(const topology::Topology&, const topology::Renumbering& r) override {
    renumbered("points", r);
  }
  void onEdgesRenumbered(const topology::Topology&, const topology::Renumbering& r) override {
    renumbered("edges", r);
  }
  void onTrianglesRenumbered(const topology::Topology&, const topology::Renumbering& r) override {
    renumbered("triangles", r);
  }
  void onTransactionEnd(const topology::Topology&, const topology::TransactionSummary& s) override {
    std::ostringstream o;
    o << "transaction_end:" << s.operation << "|" << s.pointsCreated << "," << s.pointsDestroyed
      << "," << s.edgesCreated << "," << s.edgesDestroyed << "," << s.trianglesCreated << ","
      << s.trianglesDestroyed << "," << (s.renumbered ? 1 : 0);
    lines.push_back(o.str());
  }
  std::string observerName() const override { return "event log"; }

 private:
  static std::string number(Index v) {
    return v == topology::kInvalidIndex ? "-1" : std::to_string(v);
  }
  template <class Ids>
  static std::string join(const Ids& ids) {
    std::string out;
    for (std::size_t i = 0; i < ids.size(); ++i) {
      if (i) out += ',';
      out += number(Index(ids[i]));
    }
    return out;
  }
  template <class Rows>
  static std::string rows(const Rows& r) {
    std::string out;
    for (std::size_t i = 0; i < r.size(); ++i) {
      if (i) out += ';';
      out += join(r[i]);
    }
    return out;
  }
  void renumbered(const char* kind, const topology::Renumbering& r) {
    lines.push_back(std::string(kind) + "_renumbered:" + std::to_string(r.newSize) + "|" +
                    join(r.oldToNew));
  }
};

// ---------------------------------------------------------------------------------------------
// The simulation

class Simulation {
 public:
  explicit Simulation(const core::Scene& scene)
      : runner_(std::make_unique<core::SceneRunner>(scene)) {
    bridge_ = std::make_unique<EventBridge>(*this);
    subscription_ = runner_->simulation().topology().subscribe(*bridge_);
  }
  ~Simulation() {
    subscription_.reset();
    eventLogSubscription_.reset();
    if (writer_) {
      try {
        writer_->finish();
      } catch (...) {
      }
    }
  }

  core::SceneRunner& runner() { return *runner_; }
  core::Simulation& sim() { return runner_->simulation(); }
  const core::Scene& scene() const { return runner_->scene(); }

  // ---- guards ----
  /// Throws unless the simulation may be changed now.
  void requireMutable(const char* what) const {
    if (inEvent_ && std::this_thread::get_id() == eventThread_)
      throw Usage(
          std::string(what) +
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
  /// Forces and energies are read between operations, or at an operation's transaction_end: before
  /// it, the force fields have not all followed the operation yet.
  void requireSettled(const char* what) const {
    requireReadable(what);
    if (inEvent_ && eventKind_ != "transaction_end")
      throw Usage(std::string(what) +
                  ": in a topology event callback, forces and energies are read at the "
                  "transaction_end event, when every table has followed the operation");
  }
  void requireReadable(const char* what) const {
    if (stepping_ && !(inEvent_ && std::this_thread::get_id() == eventThread_))
      throw Usage(std::string(what) + ": the simulation is stepping in another thread");
  }

  // ---- stepping ----
  py::object step(long n) {
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
      w << flagged << " of " << n
        << " steps were flagged by their solves (last: " << stats.flagText()
        << ", worst relative residual " << stats.worstResidual
        << "); see last_stats and solve_summary";
      if (PyErr_WarnEx(gSolverWarning, w.str().c_str(), 2) != 0) throw py::error_already_set();
    }
    return any ? py::object(statsDict(stats)) : py::object(py::none());
  }
  py::object runUntil(double t) {
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
  py::object run() { return step(std::max(0L, runner_->numSteps() - runner_->currentStep())); }

  // ---- views ----
  std::uint64_t layout() const { return runner_->simulation().topology().revision(); }
  std::size_t slots() { return sim().state().numSlots(); }
  py::array_t<double> x(bool writable = false) {
    requireReadable("x");
    auto& s = sim().state();
    return viewOf(s.x().data(), s.numSlots(), 3, s.xBuffer(), writable);
  }
  py::array_t<double> v(bool writable = false) {
    requireReadable("v");
    auto& s = sim().state();
    return viewOf(s.v().data(), s.numSlots(), 3, s.vBuffer(), writable);
  }
  py::array_t<double> rest() {
    requireReadable("rest");
    auto& s = sim().state();
    return viewOf(const_cast<double*>(s.rest().data()), s.numSlots(), 3, s.restBuffer(), false);
  }
  py::array_t<bool> alive() {
    requireReadable("alive");
    const auto& topo = sim().topology();
    auto a = py::array_t<bool>(static_cast<py::ssize_t>(slots()));
    for (std::size_t p = 0; p < slots(); ++p)
      a.mutable_at(py::ssize_t(p)) = topo.isPointAlive(PointId(p));
    return a;
  }
  py::array_t<std::int64_t> triangles() {
    requireReadable("triangles");
    const auto& topo = sim().topology();
    std::vector<topology::TriangleVertices> rows;
    for (auto t : topo.triangles()) rows.push_back(topo.triangleVertices(t));
    return rowArray(std::span<const topology::TriangleVertices>(rows));
  }
  py::array_t<std::int64_t> triangleIds() {
    requireReadable("triangle_ids");
    return idArray(sim().topology().triangles());
  }
  py::array_t<std::int64_t> edgeIds() {
    requireReadable("edge_ids");
    return idArray(sim().topology().edges());
  }
  py::array_t<std::int64_t> edges() {
    requireReadable("edges");
    const auto& topo = sim().topology();
    std::vector<topology::EdgeVertices> rows;
    for (auto e : topo.edges()) rows.push_back(topo.edgeVertices(e));
    return rowArray(std::span<const topology::EdgeVertices>(rows));
  }

  // ---- topology operations ----
  py::dict cut(const py::handle& polyline, double snapTolerance, double minAngle) {
    requireMutable("cut");
    const auto points = readVec3List(polyline, "cut: polyline");
    if (points.size() < 2) throw py::value_error("cut: a polyline needs at least two points");
    if (!(minAngle >= 0 && minAngle < 60))
      throw py::value_error("cut: min_angle must be in [0, 60) degrees");
    topology::CutOptions o;
    o.snapTolerance = snapTolerance;
    o.repair = core::repairOptions(sim(), minAngle);
    const auto result = operate([&] { return sim().topology().cutPolyline(points, o); });
    return incisionDict(result);
  }
  py::dict tear(long edge, double minAngle) {
    requireMutable("tear");
    if (!(minAngle >= 0 && minAngle < 60))
      throw py::value_error("tear: min_angle must be in [0, 60) degrees");
    auto& topo = sim().topology();
    if (edge < 0 || edge >= long(topo.edgeCapacity()) ||
        !topo.isEdgeAlive(topology::EdgeId(Index(edge))))
      throw TopologyError("tear: edge " + std::to_string(edge) + " does not exist");
    const auto result = operate([&] {
      return topo.tear(topology::EdgeId(Index(edge)), core::repairOptions(sim(), minAngle));
    });
    return incisionDict(result);
  }
  long findEdge(long a, long b) {
    requireReadable("find_edge");
    const auto& topo = sim().topology();
    if (a < 0 || b < 0 || a >= long(topo.pointCapacity()) || b >= long(topo.pointCapacity()))
      return -1;
    const auto e = topo.findEdge(PointId(Index(a)), PointId(Index(b)));
    return e == topology::kInvalidIndex ? -1 : long(Index(e));
  }
  void compact() {
    requireMutable("compact");
    operate([&] {
      sim().topology().compact();
      return 0;
    });
  }
  void act(const std::string& text, const std::string& source) {
    requireMutable(source.c_str());
    auto spec = core::parseActionEntry(text, source, runner_->time());
    struct Last {
      Simulation& s;
      ~Last() { s.keepBridgeLast(); }
    } last{*this};
    operate([&] {
      runner_->schedule(std::move(spec));
      return 0;
    });
  }
  void replaceField(std::size_t i, const std::string& text, const std::string& source) {
    requireMutable("set_parameters");
    const auto spec = core::parseForceFieldEntry(text, source);
    runner_->replaceForceField(i, spec);
    keepBridgeLast();
  }
  void constrain(const std::string& text, const std::string& source) {
    requireMutable("fix");
    const auto spec = core::parseConstraintEntry(text, source);
    runner_->applyConstraint(spec);
    keepBridgeLast();
  }
  void unfix(const std::vector<long>& points) {
    requireMutable("unfix");
    for (long p : points) {
      if (p < 0 || p >= long(slots()) || !sim().fixed().contains(PointId(Index(p))))
        throw InvalidInput("unfix", "point " + std::to_string(p) + " is not fixed");
    }
    for (long p : points) {
      sim().fixed().remove(PointId(Index(p)));
    }
  }
  void move(const std::string& name, const py::handle& delta, double duration) {
    requireMutable("move");
    core::Grasp* g = sim().findGrasp(name);
    if (!g) throw InvalidInput("move", "no grasp named \"" + name + "\" is active");
    g->moveBy(runner_->time(), readVec3(delta, "move: delta"), duration);
  }
  void moveObstacle(const std::string& name, const py::handle& delta, double duration) {
    requireMutable("move_obstacle");
    forcefields::Contact* c = core::findContact(sim());
    if (!c)
      throw InvalidInput("move_obstacle", "the scene has no contact section (and so no obstacles)");
    const auto& obstacles = c->obstacles();
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
  void release(const std::string& name) {
    requireMutable("release");
    if (!sim().findGrasp(name))
      throw InvalidInput("release", "no grasp named \"" + name + "\" is active");
    sim().releaseGrasp(name);
  }

  // ---- queries ----
  py::dict energies() {
    requireSettled("energies");
    py::dict d;
    d["kinetic"] = sim().kineticEnergy();
    d["gravity"] = sim().gravityEnergy();
    for (std::size_t i = 0; i < sim().numForceFields(); ++i)
      d[py::str(sim().forceFieldLabel(i))] = sim().potentialEnergy(i);
    return d;
  }
  py::array_t<double> forces() {
    requireSettled("forces");
    const auto f = sim().totalForce();
    py::array_t<double> a({f.size() / 3, std::size_t(3)});
    std::copy(f.begin(), f.end(), a.mutable_data());
    return a;
  }
  std::size_t fieldIndex(const std::string& label) {
    for (std::size_t i = 0; i < sim().numForceFields(); ++i)
      if (sim().forceFieldLabel(i) == label) return i;
    std::string known;
    for (std::size_t i = 0; i < sim().numForceFields(); ++i)
      known += (i ? ", " : "") + sim().forceFieldLabel(i);
    throw InvalidInput("field",
                       "no force field labelled \"" + label + "\" (the scene has: " + known + ")");
  }
  py::tuple fieldEval(const std::string& label, const py::object& xObj, const py::object& vObj) {
    requireSettled("eval");
    const std::size_t i = fieldIndex(label);
    const std::size_t n = slots();
    std::vector<double> x =
        xObj.is_none() ? std::vector<double>(sim().state().x().begin(), sim().state().x().end())
                       : readPoints(xObj, n, "eval: x");
    std::vector<double> v =
        vObj.is_none() ? std::vector<double>(3 * n, 0.0) : readPoints(vObj, n, "eval: v");
    // Dead slots are not part of the surface: their entries are ignored, as the state's are.
    const auto& field = sim().forceField(i);
    py::array_t<double> f({n, std::size_t(3)});
    std::fill(f.mutable_data(), f.mutable_data() + 3 * n, 0.0);
    // With the GIL held: no other thread can change the field's tables meanwhile.
    field.addForce(x, v, std::span<double>(f.mutable_data(), 3 * n));
    const double energy = field.potentialEnergy(x);
    return py::make_tuple(energy, f);
  }
  std::vector<std::string> fieldLabels() {
    std::vector<std::string> out;
    for (std::size_t i = 0; i < sim().numForceFields(); ++i)
      out.push_back(sim().forceFieldLabel(i));
    return out;
  }
  py::dict graspForces() {
    requireReadable("grasp_forces");
    py::dict d;
    for (std::size_t i = 0; i < sim().numGrasps(); ++i) {
      const auto& g = sim().grasp(i);
      const auto& r = g.reaction();
      d[py::str(g.name())] = py::array_t<double>(3, r.data());
    }
    return d;
  }
  py::array_t<std::int64_t> graspPoints(const std::string& name) {
    requireReadable("grasp_points");
    core::Grasp* g = sim().findGrasp(name);
    if (!g) throw InvalidInput("grasp_points", "no grasp named \"" + name + "\" is active");
    return idArray(g->points().points());
  }
  py::array_t<std::int64_t> fixedPoints() {
    requireReadable("fixed_points");
    return idArray(sim().fixed().points());
  }
  std::vector<std::string> fieldTypes() {
    std::vector<std::string> out;
    for (std::size_t i = 0; i < sim().numForceFields(); ++i)
      out.push_back(sim().forceField(i).typeName());
    return out;
  }
  py::dict summary() {
    requireReadable("solve_summary");
    const auto& s = sim().solveSummary();
    return py::dict("flagged_steps"_a = s.flaggedSteps, "missed_tolerance"_a = s.missedTolerance,
                    "indefinite"_a = s.indefinite, "fell_back"_a = s.fellBack,
                    "newton_not_converged"_a = s.newtonNotConverged,
                    "worst_residual"_a = s.worstResidual, "worst_step"_a = s.worstStep);
  }
  /// The contact's settings, obstacles and last step's figures; None without contact.
  py::object contact() {
    requireReadable("contact");
    const forcefields::Contact* c = core::findContact(sim());
    if (!c) return py::none();
    const auto& p = c->parameters();
    py::list obstacles;
    for (const auto& o : c->obstacles()) {
      const auto off = o.offsetAt(runner_->time());
      obstacles.append(
          py::dict("name"_a = o.name, "shape"_a = o.shapeName(), "friction"_a = o.friction,
                   "offset"_a = py::array_t<double>(3, off.data()), "moving"_a = o.moving()));
    }
    const auto& m = c->lastStep();
    py::dict normal, friction;
    for (std::size_t i = 0; i < c->obstacles().size(); ++i) {
      normal[py::str(c->obstacles()[i].name)] =
          i < m.obstacleNormal.size() ? m.obstacleNormal[i] : 0.0;
      friction[py::str(c->obstacles()[i].name)] =
          i < m.obstacleFriction.size() ? m.obstacleFriction[i] : 0.0;
    }
    return py::dict("thickness"_a = p.thickness, "stiffness"_a = p.stiffness,
                    "friction"_a = p.friction, "self_contact"_a = p.selfContact,
                    "obstacles"_a = obstacles, "candidates"_a = m.candidates, "active"_a = m.active,
                    "excluded"_a = m.excluded, "self_normal_force"_a = m.selfNormal,
                    "self_friction_force"_a = m.selfFriction, "obstacle_normal_force"_a = normal,
                    "obstacle_friction_force"_a = friction);
  }
  /// Triangles that intersect each other or an obstacle at the current positions (the start check
  /// of a scene): (description, distance), at most `limit`.
  std::vector<std::pair<std::string, double>> intersections(std::size_t limit) {
    requireReadable("intersections");
    const forcefields::Contact* c = core::findContact(sim());
    if (!c) throw InvalidInput("intersections", "the scene has no contact section");
    std::vector<std::pair<std::string, double>> out;
    for (const auto& p : c->intersections(sim().state().x(), limit))
      out.emplace_back(p.what, p.distance);
    return out;
  }
  std::vector<std::string> validate() {
    requireReadable("validate");
    return sim().topology().validate().problems;
  }

  // ---- outputs ----
  void record(const std::filesystem::path& dir, const std::vector<std::string>& extraGrasps) {
    requireMutable("record");
    if (writer_)
      throw Usage("record: already recording to " + writer_->dir().string() +
                  " (finish_recording() first)");
    std::vector<std::string> obstacles;
    for (const auto& o : scene().obstacles) obstacles.push_back(o.name);
    std::vector<std::string> grasps = scene().graspNames();
    std::vector<std::string> more = extraGrasps;
    for (std::size_t i = 0; i < sim().numGrasps(); ++i)
      more.push_back(sim().grasp(i).name());  // active now
    for (const auto& g : more) {
      if (g.empty() || g.find_first_of(",\"\n\r") != std::string::npos)
        throw InvalidInput("record", "grasp name \"" + g + "\" cannot name CSV columns");
      if (std::find(grasps.begin(), grasps.end(), g) == grasps.end()) grasps.push_back(g);
    }
    runner_->start();  // the scene's actions due at time 0, if they have not run yet
    keepBridgeLast();
    writer_ = std::make_unique<core::OutputWriter>(dir, scene().output, scene().forceFieldLabels(),
                                                   grasps, scene().contact.has_value(), obstacles);
    if (scene().output.vtk) core::writeRunInfo(dir, scene());
    writer_->record(sim(), {runner_->currentStep(), runner_->time(), runner_->lastStats()},
                    runner_->currentStep() == runner_->numSteps());
    raisePendingCallbackError();  // from the actions at time 0: the recording has started
  }
  py::object finishRecording() {
    requireMutable("finish_recording");
    if (!writer_) return py::none();
    const std::filesystem::path dir = writer_->dir();
    auto w = std::move(writer_);
    w->frame(sim(), {runner_->currentStep(), runner_->time(), runner_->lastStats()});
    w->finish();
    return py::cast(dir);
  }
  void dumpFinal(const std::filesystem::path& dir) {
    requireReadable("dump_final");
    core::dumpFinal(dir, sim(), runner_->bendingField());
  }

  // ---- callbacks ----
  void addController(py::object c) {
    if (!py::hasattr(c, "on_step_begin") && !py::hasattr(c, "on_step_end") &&
        !py::hasattr(c, "onAnimateBeginEvent") && !py::hasattr(c, "onAnimateEndEvent"))
      throw py::type_error(
          "add_controller: the controller has none of on_step_begin, on_step_end, "
          "onAnimateBeginEvent, onAnimateEndEvent");
    controllers_.push_back(std::move(c));
  }
  void removeController(const py::object& c) {
    for (auto it = controllers_.begin(); it != controllers_.end(); ++it)
      if (it->is(c)) {
        controllers_.erase(it);
        return;
      }
    throw py::value_error("remove_controller: not a controller of this simulation");
  }
  void onTopologyEvent(py::function f) { eventCallbacks_.push_back(std::move(f)); }
  /// Starts (or restarts) the C++ event log; returns and clears its lines.
  void startEventLog() {
    eventLogSubscription_.reset();
    eventLog_ = std::make_unique<EventLog>();
    eventLogSubscription_ = sim().topology().subscribe(*eventLog_);
  }
  std::vector<std::string> takeEventLog() {
    if (!eventLog_) throw Usage("_cpp_events: the event log was not started");
    return std::exchange(eventLog_->lines, {});
  }
  void removeTopologyCallback(const py::function& f) {
    for (auto it = eventCallbacks_.begin(); it != eventCallbacks_.end(); ++it)
      if (it->is(f)) {
        eventCallbacks_.erase(it);
        return;
      }
    throw py::value_error("remove_topology_callback: not a callback of this simulation");
  }

  /// Keeps the Python callbacks the topology's last observers (and the event log after them), so
  /// that when a callback runs every table of the simulation has followed the event. Called after
  /// whatever may subscribe new observers (actions that start grasps, rebuilt force fields).
  void keepBridgeLast() {
    auto& topo = sim().topology();
    subscription_.reset();
    subscription_ = topo.subscribe(*bridge_);
    if (eventLog_) {
      eventLogSubscription_.reset();
      eventLogSubscription_ = topo.subscribe(*eventLog_);
    }
  }

  // ---- the garbage collector's view ----
  int traverse(visitproc visit, void* arg) {
    for (const auto& c : controllers_) Py_VISIT(c.ptr());
    for (const auto& f : eventCallbacks_) Py_VISIT(f.ptr());
    return 0;
  }
  void clearReferences() {
    controllers_.clear();
    eventCallbacks_.clear();
  }

  // ---- edits ----
  void beginEdit() {
    requireMutable("edit");
    editing_ = true;
  }
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
  void callControllers(const char* method) {
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
  py::object self() { return py::cast(this, py::return_value_policy::reference); }
  void warnPendingCallbackError() {
    if (!pendingError_) return;
    auto e = std::move(pendingError_);
    const std::string message = std::string("a topology event callback raised too: ") + e->what();
    if (PyErr_WarnEx(PyExc_RuntimeWarning, message.c_str(), 2) != 0) throw py::error_already_set();
  }
  void raisePendingCallbackError() {
    if (!pendingError_) return;
    auto e = std::move(pendingError_);
    e->restore();
    throw py::error_already_set();
  }
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
  topology::Subscription subscription_;
  std::unique_ptr<core::OutputWriter> writer_;
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

/// A handle on the state's layout at one moment: its arrays, or StaleViewError once the topology
/// has changed since.
/// The simulation a view or an edit refers to, through a weak reference (a view kept by a
/// controller of its own simulation makes no cycle): StaleViewError once it is gone.
Simulation& target(const py::weakref& ref, const char* what) {
  py::object o = ref();
  if (o.is_none()) throw StaleView(std::string(what) + ": its simulation has been deleted");
  return o.cast<Simulation&>();
}

class StateView {
 public:
  StateView(Simulation& s, const py::object& owner) : ref_(owner), layout_(s.layout()) {}
  void check(const char* what) const {
    if (sim().layout() != layout_)
      throw StaleView(
          std::string("StateView.") + what +
          ": the topology has changed since this view was made (the state's slots may have moved, "
          "grown or been renumbered): take a new view");
  }
  bool valid() const {
    py::object o = ref_();
    return !o.is_none() && o.cast<Simulation&>().layout() == layout_;
  }
  Simulation& sim() const { return target(ref_, "StateView"); }
  std::uint64_t revision() const { return layout_; }

 private:
  py::weakref ref_;
  std::uint64_t layout_;
};

/// The writable arrays of an edit (Simulation.edit()): copies of the positions and velocities,
/// written back when the block ends if every value is sound (nothing written otherwise), then
/// read-only. Arrays derived from them inside the block stay copies: nothing escapes to the state.
class Editor {
 public:
  explicit Editor(const py::object& owner) : ref_(owner) {}
  py::object enter() {
    if (open_ || used_) throw Usage("edit: a with-block of sim.edit() is entered once");
    Simulation* sim_ = &target(ref_, "edit");
    sim_->beginEdit();
    open_ = used_ = true;
    revision_ = sim_->layout();
    x_ = copyOf(sim_->sim().state().x());
    v_ = copyOf(sim_->sim().state().v());
    return py::cast(this, py::return_value_policy::reference);
  }
  bool exit(const py::object& type, const py::object&, const py::object&) {
    if (!open_) return false;  // not this edit's block
    open_ = false;
    py::object owner = ref_();
    if (owner.is_none()) return false;  // the simulation is gone: nothing to write into
    Simulation* sim_ = &owner.cast<Simulation&>();
    sim_->endEdit();
    for (py::object* a : {&x_, &v_})
      if (py::isinstance<py::array>(*a)) a->attr("setflags")("write"_a = false);
    if (!type.is_none()) return false;  // the block raised: nothing of it is kept
    auto& st = sim_->sim().state();
    const auto& topo = sim_->sim().topology();
    if (sim_->layout() != revision_)
      throw Usage("edit: the topology changed during the edit; nothing was written");
    // The arrays must still be what the edit handed out: (slots, 3) float64, C order.
    auto sound = [&](const py::object& a) {
      if (!py::isinstance<py::array_t<double>>(a)) return false;
      auto arr = a.cast<py::array>();
      return arr.ndim() == 2 && std::size_t(arr.shape(0)) == st.numSlots() && arr.shape(1) == 3 &&
             (arr.flags() & py::array::c_style) != 0;
    };
    if (!sound(x_) || !sound(v_))
      throw Usage("edit: e.x or e.v was resized or replaced during the edit; nothing was written");
    const auto xs = x_.cast<py::array_t<double>>(), vs = v_.cast<py::array_t<double>>();
    for (const auto& [values, name] : {std::pair{xs.data(), "x"}, std::pair{vs.data(), "v"}}) {
      for (std::size_t i = 0; i < st.x().size(); ++i) {
        const bool dead = !topo.isPointAlive(PointId(Index(i / 3)));
        if (!std::isfinite(values[i]) || (dead && values[i] != 0.0))
          throw InvalidInput("edit", std::string(name) + "[" + std::to_string(i / 3) + ", " +
                                         std::to_string(i % 3) + "]: " +
                                         (dead ? "the slot is dead (not a point of the surface)"
                                               : "non-finite value") +
                                         "; nothing of the edit was written");
      }
    }
    std::copy(xs.data(), xs.data() + xs.size(), st.x().begin());
    std::copy(vs.data(), vs.data() + vs.size(), st.v().begin());
    return false;
  }
  py::object x() const { return x_; }
  py::object v() const { return v_; }

 private:
  static py::array_t<double> copyOf(std::span<const double> values) {
    py::array_t<double> a({values.size() / 3, std::size_t(3)});
    std::copy(values.begin(), values.end(), a.mutable_data());
    return a;
  }
  py::weakref ref_;
  bool open_ = false, used_ = false;
  std::uint64_t revision_ = 0;
  py::object x_ = py::none(), v_ = py::none();
};

/// Lets Python's garbage collector see the callbacks and controllers a simulation holds (a
/// closure that refers to the simulation makes a cycle).
int traverseSimulation(PyObject* self, visitproc visit, void* arg);
int clearSimulation(PyObject* self);

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

}  // namespace

PYBIND11_MODULE(_cutsim, m) {
  m.doc() = "cutsim: thin deformable surfaces cut, torn and carved while they run (compiled part)";
  m.attr("__version__") = core::version();

  py::tuple errorBases = py::make_tuple(py::handle(PyExc_Exception));
  gError = makeException(m, "Error", "Base of every error cutsim raises on purpose.", errorBases);
  py::handle error(gError);
  gInvalidInput =
      makeException(m, "InvalidInputError",
                    "Bad input: a scene, a parameter, an array (\"FILE:LINE: /pointer: message\").",
                    py::make_tuple(error, py::handle(PyExc_ValueError)));
  gTopologyError = makeException(
      m, "TopologyError", "A topology operation that cannot be carried out; nothing was changed.",
      py::make_tuple(error, py::handle(PyExc_ValueError)));
  gSolverError = makeException(m, "SolverError",
                               "A numerical failure of a step; the state is as before the step.",
                               py::make_tuple(error, py::handle(PyExc_RuntimeError)));
  gStaleView = makeException(m, "StaleViewError", "A StateView used after the topology changed.",
                             py::make_tuple(error, py::handle(PyExc_RuntimeError)));
  gUsageError = makeException(
      m, "UsageError",
      "A call the simulation cannot take now (re-entrant stepping, a change from an event "
      "callback or inside edit()).",
      py::make_tuple(error, py::handle(PyExc_RuntimeError)));
  gSolverWarning = PyErr_NewExceptionWithDoc("cutsim.SolverWarning",
                                             "Steps whose solves missed their tolerance.",
                                             PyExc_UserWarning, nullptr);
  m.add_object("SolverWarning", py::handle(gSolverWarning));

  py::register_exception_translator([](std::exception_ptr p) {
    // Messages may quote bytes of a file that are not UTF-8: decoded with replacement characters.
    auto set = [](PyObject* type, const char* what) {
      PyObject* text = PyUnicode_DecodeUTF8(what, Py_ssize_t(std::strlen(what)), "replace");
      if (!text) return;
      PyErr_SetObject(type, text);
      Py_DECREF(text);
    };
    try {
      if (p) std::rethrow_exception(p);
    } catch (const TopologyError& e) {
      set(gTopologyError, e.what());
    } catch (const InvalidInput& e) {
      set(gInvalidInput, e.what());
    } catch (const SolverError& e) {
      set(gSolverError, e.what());
    } catch (const Error& e) {
      set(gError, e.what());
    } catch (const StaleView& e) {
      set(gStaleView, e.what());
    } catch (const Usage& e) {
      set(gUsageError, e.what());
    }
  });

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

  py::class_<Simulation>(m, "_Simulation", py::custom_type_setup([](PyHeapTypeObject* heapType) {
                           auto* type = &heapType->ht_type;
                           type->tp_flags |= Py_TPFLAGS_HAVE_GC;
                           type->tp_traverse = traverseSimulation;
                           type->tp_clear = clearSimulation;
                         }))
      // A scene file (text = its path, source = ""), or a scene's JSON text named `source` whose
      // relative paths are resolved against `base`.
      .def(py::init([](const std::string& text, const std::string& source,
                       const std::filesystem::path& base) {
             const core::Scene scene =
                 source.empty() ? core::loadScene(text) : core::parseScene(text, source, base);
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
      .def_property(
          "gravity",
          [](Simulation& s) {
            s.requireReadable("gravity");
            return py::array_t<double>(3, s.sim().gravity().data());
          },
          [](Simulation& s, const py::object& g) {
            s.requireMutable("gravity");
            s.sim().setGravity(readVec3(g, "gravity"));
          })
      .def_property_readonly("x", [](Simulation& s) { return s.x(false); })
      .def_property_readonly("v", [](Simulation& s) { return s.v(false); })
      .def_property_readonly("rest", &Simulation::rest)
      .def_property_readonly("alive", &Simulation::alive)
      .def_property_readonly("revision",
                             [](Simulation& s) {
                               s.requireReadable("revision");
                               return s.layout();
                             })
      .def("triangles", &Simulation::triangles)
      .def("edges", &Simulation::edges)
      .def("triangle_ids", &Simulation::triangleIds)
      .def("edge_ids", &Simulation::edgeIds)
      .def_property_readonly("num_points",
                             [](Simulation& s) {
                               s.requireReadable("num_points");
                               return s.sim().topology().numPoints();
                             })
      .def_property_readonly("num_edges",
                             [](Simulation& s) {
                               s.requireReadable("num_edges");
                               return s.sim().topology().numEdges();
                             })
      .def_property_readonly("num_triangles",
                             [](Simulation& s) {
                               s.requireReadable("num_triangles");
                               return s.sim().topology().numTriangles();
                             })
      .def_property_readonly("num_slots",
                             [](Simulation& s) {
                               s.requireReadable("num_slots");
                               return s.slots();
                             })
      .def("_cut", &Simulation::cut)
      .def("_tear", &Simulation::tear)
      .def("find_edge", &Simulation::findEdge, "a"_a, "b"_a)
      .def("compact", &Simulation::compact)
      .def("_act", &Simulation::act)
      .def("_constrain", &Simulation::constrain)
      .def("_replace_field", &Simulation::replaceField)
      .def("unfix", &Simulation::unfix, "points"_a)
      .def("move", &Simulation::move, "name"_a, "delta"_a, "duration"_a = 0.0)
      .def("release", &Simulation::release, "name"_a)
      .def("move_obstacle", &Simulation::moveObstacle, "name"_a, "delta"_a, "duration"_a)
      .def("energies", &Simulation::energies)
      .def("forces", &Simulation::forces)
      .def("_eval", &Simulation::fieldEval)
      .def_property_readonly("field_labels", &Simulation::fieldLabels)
      .def_property_readonly("field_types", &Simulation::fieldTypes)
      .def("grasp_forces", &Simulation::graspForces)
      .def("grasp_points", &Simulation::graspPoints, "name"_a)
      .def("fixed_points", &Simulation::fixedPoints)
      .def_property_readonly("last_stats",
                             [](Simulation& s) {
                               s.requireReadable("last_stats");
                               return statsDict(s.runner().lastStats());
                             })
      .def_property_readonly("solve_summary", &Simulation::summary)
      .def_property_readonly("torn_edges", [](Simulation& s) { return s.runner().tornEdges(); })
      .def_property_readonly("cuts_done", [](Simulation& s) { return s.runner().cutsDone(); })
      .def("validate", &Simulation::validate)
      .def("contact", &Simulation::contact)
      .def("intersections", &Simulation::intersections, "limit"_a = 5)
      .def("_record", &Simulation::record, "dir"_a, "grasps"_a)
      .def("finish_recording", &Simulation::finishRecording)
      .def("dump_final", &Simulation::dumpFinal, "dir"_a)
      .def("add_controller", &Simulation::addController, "controller"_a)
      .def("remove_controller", &Simulation::removeController, "controller"_a)
      .def("on_topology_event", &Simulation::onTopologyEvent, "callback"_a)
      .def("remove_topology_callback", &Simulation::removeTopologyCallback, "callback"_a)
      .def("_start_cpp_events", &Simulation::startEventLog)
      .def("_cpp_events", &Simulation::takeEventLog)
      .def("view",
           [](py::object self) {
             auto& s = self.cast<Simulation&>();
             return StateView(s, self);
           })
      .def("edit", [](py::object self) { return Editor(self); });

  py::class_<StateView>(
      m, "StateView",
      "Read-only, zero-copy arrays of the state at one layout; StaleViewError once the topology "
      "has changed.")
      .def_property_readonly("x",
                             [](const StateView& v) {
                               v.check("x");
                               return v.sim().x(false);
                             })
      .def_property_readonly("v",
                             [](const StateView& v) {
                               v.check("v");
                               return v.sim().v(false);
                             })
      .def_property_readonly("rest",
                             [](const StateView& v) {
                               v.check("rest");
                               return v.sim().rest();
                             })
      .def_property_readonly("alive",
                             [](const StateView& v) {
                               v.check("alive");
                               return v.sim().alive();
                             })
      .def_property_readonly("triangles",
                             [](const StateView& v) {
                               v.check("triangles");
                               return v.sim().triangles();
                             })
      .def_property_readonly("valid", &StateView::valid)
      .def_property_readonly("revision", &StateView::revision);

  py::class_<Editor>(m, "Editor",
                     "Writable positions and velocities inside `with sim.edit() as e:`")
      .def("__enter__", &Editor::enter)
      .def("__exit__", &Editor::exit)
      .def_property_readonly("x", &Editor::x)
      .def_property_readonly("v", &Editor::v);
}

}  // namespace cutsim::python
