// What the model says at the current state: energies, forces, each force field's evaluation,
// grasps, fixed points, contact's figures and intersections, gravity.
#include "cutsim/core/contact_step.hpp"
#include "cutsim/forcefields/contact.hpp"
#include "simulation.hpp"

namespace cutsim::python {

py::dict Simulation::energies() {
  requireSettled("energies");
  py::dict d;
  d["kinetic"] = sim().kineticEnergy();
  d["gravity"] = sim().gravityEnergy();
  for (std::size_t i = 0; i < sim().numForceFields(); ++i)
    d[py::str(sim().forceFieldLabel(i))] = sim().potentialEnergy(i);
  return d;
}

py::object Simulation::energyAccount() {
  requireSettled("energy_account");
  const core::EnergyLedger* e = sim().energy();
  if (!e) return py::none();
  auto flows = [](const core::EnergyFlows& f) {
    py::dict d;
    d["work_gravity"] = f.gravity;
    d["work_constraints"] = f.constraints;
    d["work_contact"] = f.contact;
    d["dissipated_damping"] = f.damping;
    d["removed"] = f.removed;
    return d;
  };
  py::dict d = flows(e->total());
  d["stored"] = e->storedEnergy();
  d["balance"] = e->balance();
  d["drift"] = e->drift();
  py::dict step = flows(e->lastStep());
  step["drift"] = e->stepDrift();
  d["step"] = step;
  return d;
}

void Simulation::accountEnergy() {
  requireMutable("account_energy");
  sim().enableEnergyAccounting();
}

py::array_t<double> Simulation::forces() {
  requireSettled("forces");
  const auto f = sim().totalForce();
  py::array_t<double> a({f.size() / 3, std::size_t(3)});
  std::copy(f.begin(), f.end(), a.mutable_data());
  return a;
}

std::size_t Simulation::fieldIndex(const std::string& label) {
  for (std::size_t i = 0; i < sim().numForceFields(); ++i)
    if (sim().forceFieldLabel(i) == label) return i;
  std::string known;
  for (std::size_t i = 0; i < sim().numForceFields(); ++i)
    known += (i ? ", " : "") + sim().forceFieldLabel(i);
  throw InvalidInput("field",
                     "no force field labelled \"" + label + "\" (the scene has: " + known + ")");
}

py::tuple Simulation::fieldEval(const std::string& label, const py::object& xObj,
                                const py::object& vObj) {
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

std::vector<std::string> Simulation::fieldLabels() {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < sim().numForceFields(); ++i) out.push_back(sim().forceFieldLabel(i));
  return out;
}

py::dict Simulation::graspForces() {
  requireReadable("grasp_forces");
  py::dict d;
  for (std::size_t i = 0; i < sim().numGrasps(); ++i) {
    const auto& g = sim().grasp(i);
    const auto& r = g.reaction();
    d[py::str(g.name())] = py::array_t<double>(3, r.data());
  }
  return d;
}

py::array_t<std::int64_t> Simulation::graspPoints(const std::string& name) {
  requireReadable("grasp_points");
  core::Grasp* g = sim().findGrasp(name);
  if (!g) throw InvalidInput("grasp_points", "no grasp named \"" + name + "\" is active");
  return idArray(g->points().points());
}

py::array_t<std::int64_t> Simulation::fixedPoints() {
  requireReadable("fixed_points");
  return idArray(sim().fixed().points());
}

std::vector<std::string> Simulation::fieldTypes() {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < sim().numForceFields(); ++i)
    out.push_back(sim().forceField(i).typeName());
  return out;
}

py::dict Simulation::summary() {
  requireReadable("solve_summary");
  const auto& s = sim().solveSummary();
  return py::dict("flagged_steps"_a = s.flaggedSteps, "missed_tolerance"_a = s.missedTolerance,
                  "indefinite"_a = s.indefinite, "fell_back"_a = s.fellBack,
                  "newton_not_converged"_a = s.newtonNotConverged,
                  "residual_energy"_a = s.residualEnergy, "worst_residual"_a = s.worstResidual,
                  "worst_step"_a = s.worstStep);
}

py::object Simulation::contact() {
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

std::vector<std::pair<std::string, double>> Simulation::intersections(std::size_t limit) {
  requireReadable("intersections");
  forcefields::Contact* c = core::findContact(sim());
  if (!c) throw InvalidInput("intersections", "the scene has no contact section");
  std::vector<std::pair<std::string, double>> out;
  for (const auto& p : c->intersections(sim().state().x(), limit))
    out.emplace_back(p.what, p.distance);
  return out;
}

void bindModel(SimulationClass& cls) {
  cls.def_property(
         "gravity",
         [](Simulation& s) {
           s.requireReadable("gravity");
           return py::array_t<double>(3, s.sim().gravity().data());
         },
         [](Simulation& s, const py::object& g) {
           s.requireMutable("gravity");
           s.sim().setGravity(readVec3(g, "gravity"));
         })
      .def("energies", &Simulation::energies)
      .def("energy_account", &Simulation::energyAccount,
           "energy_account() -> dict or None: the energy accounts (docs/energy.md) since they were "
           "opened: stored, the cumulative work_gravity, work_constraints, work_contact, "
           "dissipated_damping and removed, balance and drift, and under 'step' the last step's "
           "flows and drift. None unless the scene's output has \"energy\": true or "
           "account_energy() was called.")
      .def("account_energy", &Simulation::accountEnergy,
           "account_energy(): opens the energy accounts at the current state (a new start).")
      .def("forces", &Simulation::forces)
      .def("_eval", &Simulation::fieldEval)
      .def_property_readonly("field_labels", &Simulation::fieldLabels)
      .def_property_readonly("field_types", &Simulation::fieldTypes)
      .def("grasp_forces", &Simulation::graspForces,
           "grasp_forces() -> {name: array of 3}: the force (N) each active grasp exerts on the "
           "surface over the last step, as the CSV's NAME_fx, NAME_fy, NAME_fz columns report it.")
      .def("grasp_points", &Simulation::graspPoints, "name"_a)
      .def("fixed_points", &Simulation::fixedPoints)
      .def("contact", &Simulation::contact)
      .def("intersections", &Simulation::intersections, "limit"_a = 5);
}

}  // namespace cutsim::python
