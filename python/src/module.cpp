// The compiled part of the Python module `cutsim` (cutsim/_cutsim): a running scene (SceneRunner)
// with zero-copy numpy views of its state, topology operations, topology-event and step
// callbacks, outputs, and the project's errors as Python exceptions, each area in its own file
// (bindings.hpp). The API is described in docs/python.md.
#include "cutsim/core/version.hpp"
#include "simulation.hpp"

namespace cutsim::python {

PYBIND11_MODULE(_cutsim, m) {
  m.doc() = "cutsim: thin deformable surfaces cut, torn and carved while they run (compiled part)";
  m.attr("__version__") = core::version();
  bindExceptions(m);
  SimulationClass cls(m, "_Simulation", py::custom_type_setup([](PyHeapTypeObject* heapType) {
                        auto* type = &heapType->ht_type;
                        type->tp_flags |= Py_TPFLAGS_HAVE_GC;
                        type->tp_traverse = traverseSimulation;
                        type->tp_clear = clearSimulation;
                      }));
  bindRunning(m, cls);
  bindViews(m, cls);
  bindTopology(cls);
  bindModel(cls);
  bindEvents(m, cls);
  bindLocate(cls);
}

}  // namespace cutsim::python
