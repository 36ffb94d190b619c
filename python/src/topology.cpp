// Topology operations from Python: cuts, tears, edges, compaction, validation.
#include <nlohmann/json.hpp>

#include "simulation.hpp"

namespace cutsim::python {

py::dict incisionDict(const topology::IncisionResult& r) {
  return py::dict(
      "path"_a = idArray(r.path), "copies"_a = idArray(r.copies),
      "copied_from"_a = idArray(r.copiedFrom), "inserted"_a = idArray(r.insertedPoints),
      "flips"_a = r.repair.flips, "collapses"_a = r.repair.collapses,
      "relocations"_a = r.repair.relocations, "splits"_a = r.repair.splits,
      "insertions"_a = r.repair.insertions, "min_angle_before"_a = r.repair.minAngleBefore,
      "min_angle_after"_a = r.repair.minAngleAfter, "budget_spent"_a = r.repair.budgetSpent);
}

// A cut and a tear are timeline actions played now, as a scene's are (the same checks, the same
// counters in the CSV and the summary, the same messages); their incision is returned.
topology::IncisionResult Simulation::playIncision(const nlohmann::json& entry,
                                                  const std::string& source) {
  act(entry.dump(), source);
  std::vector<topology::IncisionResult> made = runner_->takeIncisions();
  if (made.empty()) throw Error(source + ": the action made no incision");
  return std::move(made.back());
}

py::dict Simulation::cut(const py::handle& polyline, double snapTolerance, double minAngle) {
  requireMutable("cut");
  const auto points = readVec3List(polyline, "cut: polyline");
  if (points.size() < 2) throw py::value_error("cut: a polyline needs at least two points");
  if (!(minAngle >= 0 && minAngle < 60))
    throw py::value_error("cut: min_angle must be in [0, 60) degrees");
  const nlohmann::json entry = {{"at", runner_->time()},
                                {"action", "cut"},
                                {"polyline", points},
                                {"snapTolerance", snapTolerance},
                                {"minAngle", minAngle}};
  return incisionDict(playIncision(entry, "<cut>"));
}

py::dict Simulation::tear(long edge, double minAngle) {
  requireMutable("tear");
  if (!(minAngle >= 0 && minAngle < 60))
    throw py::value_error("tear: min_angle must be in [0, 60) degrees");
  const auto& topo = sim().topology();
  if (edge < 0 || edge >= long(topo.edgeCapacity()) ||
      !topo.isEdgeAlive(topology::EdgeId(Index(edge))))
    throw TopologyError("tear: edge " + std::to_string(edge) + " does not exist");
  const auto v = topo.edgeVertices(topology::EdgeId(Index(edge)));
  const nlohmann::json entry = {{"at", runner_->time()},
                                {"action", "tear"},
                                {"points", {long(Index(v[0])), long(Index(v[1]))}},
                                {"minAngle", minAngle}};
  return incisionDict(playIncision(entry, "<tear>"));
}

long Simulation::findEdge(long a, long b) {
  requireReadable("find_edge");
  const auto& topo = sim().topology();
  if (a < 0 || b < 0 || a >= long(topo.pointCapacity()) || b >= long(topo.pointCapacity()))
    return -1;
  const auto e = topo.findEdge(PointId(Index(a)), PointId(Index(b)));
  return e.idx() == topology::kInvalidIndex ? -1 : long(Index(e));
}

void Simulation::compact() {
  requireMutable("compact");
  operate([&] {
    sim().topology().compact();
    return 0;
  });
}

std::vector<std::string> Simulation::validate() {
  requireReadable("validate");
  return sim().topology().validate().problems;
}

void bindTopology(SimulationClass& cls) {
  cls.def_property_readonly("num_points",
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
      .def("_cut", &Simulation::cut)
      .def("_tear", &Simulation::tear)
      .def("find_edge", &Simulation::findEdge, "a"_a, "b"_a)
      .def("compact", &Simulation::compact)
      .def("validate", &Simulation::validate);
}

}  // namespace cutsim::python
