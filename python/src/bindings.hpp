#pragma once
// What the files of the Python module's compiled part share: one file an area, each binding its
// part of `_Simulation` (exceptions.cpp, views.cpp, events.cpp, topology.cpp, model.cpp,
// running.cpp; simulation.cpp holds the class's core and module.cpp puts them together). The
// pure-Python part (python/cutsim/__init__.py) adds the dict-based entry points and the
// documentation; the API is described in docs/python.md.
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

namespace cutsim::python {

using namespace pybind11::literals;
using core::PointId;
using topology::Index;

class Simulation;
using SimulationClass = py::class_<Simulation>;

// ---- errors (exceptions.cpp) ----

extern PyObject* gError;          // cutsim.Error(Exception)
extern PyObject* gInvalidInput;   // cutsim.InvalidInputError(Error, ValueError)
extern PyObject* gTopologyError;  // cutsim.TopologyError(Error, ValueError)
extern PyObject* gSolverError;    // cutsim.SolverError(Error, RuntimeError)
extern PyObject* gStaleView;      // cutsim.StaleViewError(Error, RuntimeError)
extern PyObject* gUsageError;     // cutsim.UsageError(Error, RuntimeError)
extern PyObject* gSolverWarning;  // cutsim.SolverWarning(UserWarning)

/// A view used after the layout it was made for went away.
struct StaleView : std::runtime_error {
  using std::runtime_error::runtime_error;
};
/// A call the simulation cannot take now (re-entrant stepping, a change from an event callback).
struct Usage : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The project's errors as Python exceptions, and their translation.
void bindExceptions(py::module_& m);

// ---- arrays (views.cpp) ----

/// A (rows x cols) array over `data`, kept alive by `owner` (shared ownership of the buffer).
py::array_t<double> viewOf(double* data, std::size_t rows, std::size_t cols,
                           std::shared_ptr<const void> owner, bool writable);
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

/// The array of `obj` as float64 (an empty handle if it is not numbers).
py::array_t<double, py::array::c_style | py::array::forcecast> floats(const py::handle& obj);
/// Reads an (n, 3) float array (any float layout) into a flat vector; n must be `rows`.
std::vector<double> readPoints(const py::handle& obj, std::size_t rows, const char* what);
std::vector<core::Vec3> readVec3List(const py::handle& obj, const char* what);
core::Vec3 readVec3(const py::handle& obj, const char* what);

// ---- results as dicts ----

py::dict statsDict(const core::StepStats& s);              // running.cpp
py::dict incisionDict(const topology::IncisionResult& r);  // topology.cpp

// ---- each area's bindings ----

void bindRunning(py::module_& m, SimulationClass& cls);
void bindViews(py::module_& m, SimulationClass& cls);
void bindTopology(SimulationClass& cls);
void bindModel(SimulationClass& cls);
void bindEvents(py::module_& m, SimulationClass& cls);
void bindLocate(SimulationClass& cls);

/// Lets Python's garbage collector see the callbacks and controllers a simulation holds (a
/// closure that refers to the simulation makes a cycle): simulation.cpp.
int traverseSimulation(PyObject* self, visitproc visit, void* arg);
int clearSimulation(PyObject* self);

}  // namespace cutsim::python
