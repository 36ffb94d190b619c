// The project's errors as Python exceptions (cutsim.Error and its kinds) and their translation.
#include "bindings.hpp"

namespace cutsim::python {

PyObject* gError = nullptr;          // cutsim.Error(Exception)
PyObject* gInvalidInput = nullptr;   // cutsim.InvalidInputError(Error, ValueError)
PyObject* gTopologyError = nullptr;  // cutsim.TopologyError(Error, ValueError)
PyObject* gSolverError = nullptr;    // cutsim.SolverError(Error, RuntimeError)
PyObject* gStaleView = nullptr;      // cutsim.StaleViewError(Error, RuntimeError)
PyObject* gUsageError = nullptr;     // cutsim.UsageError(Error, RuntimeError)
PyObject* gSolverWarning = nullptr;  // cutsim.SolverWarning(UserWarning)

namespace {

PyObject* makeException(py::module_& m, const char* name, const char* doc, py::tuple bases) {
  const std::string full = std::string("cutsim.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(full.c_str(), doc, bases.ptr(), nullptr);
  if (!type) throw py::error_already_set();
  m.add_object(name, py::handle(type));
  return type;
}

}  // namespace

void bindExceptions(py::module_& m) {
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
}

}  // namespace cutsim::python
