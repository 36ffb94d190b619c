// Views of the state: zero-copy numpy arrays of positions, velocities and the rest shape, the
// mesh's arrays, StateView (a layout's arrays, stale once the topology changes) and Editor
// (`with sim.edit()`: writable copies written back when sound).
#include "simulation.hpp"

namespace cutsim::python {

/// A (rows x cols) array over `data`, kept alive by `owner` (shared ownership of the buffer).
py::array_t<double> viewOf(double* data, std::size_t rows, std::size_t cols,
                           std::shared_ptr<const void> owner, bool writable) {
  auto* holder = new std::shared_ptr<const void>(std::move(owner));
  py::capsule base(holder, [](void* p) { delete static_cast<std::shared_ptr<const void>*>(p); });
  py::array_t<double> a({rows, cols}, {cols * sizeof(double), sizeof(double)}, data, base);
  if (!writable) a.attr("setflags")("write"_a = false);
  return a;
}

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

py::array_t<double> Simulation::x(bool writable) {
  requireReadable("x");
  auto& s = sim().state();
  return viewOf(s.x().data(), s.numSlots(), 3, s.xBuffer(), writable);
}

py::array_t<double> Simulation::v(bool writable) {
  requireReadable("v");
  auto& s = sim().state();
  return viewOf(s.v().data(), s.numSlots(), 3, s.vBuffer(), writable);
}

py::array_t<double> Simulation::rest() {
  requireReadable("rest");
  auto& s = sim().state();
  return viewOf(const_cast<double*>(s.rest().data()), s.numSlots(), 3, s.restBuffer(), false);
}

py::array_t<bool> Simulation::alive() {
  requireReadable("alive");
  const auto& topo = sim().topology();
  auto a = py::array_t<bool>(static_cast<py::ssize_t>(slots()));
  for (std::size_t p = 0; p < slots(); ++p)
    a.mutable_at(py::ssize_t(p)) = topo.isPointAlive(PointId(p));
  return a;
}

py::array_t<std::int64_t> Simulation::triangles() {
  requireReadable("triangles");
  const auto& topo = sim().topology();
  std::vector<topology::TriangleVertices> rows;
  for (auto t : topo.triangles()) rows.push_back(topo.triangleVertices(t));
  return rowArray(std::span<const topology::TriangleVertices>(rows));
}

py::array_t<std::int64_t> Simulation::triangleIds() {
  requireReadable("triangle_ids");
  return idArray(sim().topology().triangles());
}

py::array_t<std::int64_t> Simulation::edgeIds() {
  requireReadable("edge_ids");
  return idArray(sim().topology().edges());
}

py::array_t<std::int64_t> Simulation::edges() {
  requireReadable("edges");
  const auto& topo = sim().topology();
  std::vector<topology::EdgeVertices> rows;
  for (auto e : topo.edges()) rows.push_back(topo.edgeVertices(e));
  return rowArray(std::span<const topology::EdgeVertices>(rows));
}

/// The simulation a view or an edit refers to, through a weak reference (a view kept by a
/// controller of its own simulation makes no cycle): StaleViewError once it is gone.
Simulation& target(const py::weakref& ref, const char* what) {
  py::object o = ref();
  if (o.is_none()) throw StaleView(std::string(what) + ": its simulation has been deleted");
  return o.cast<Simulation&>();
}

namespace {

/// A handle on the state's layout at one moment: its arrays, or StaleViewError once the topology
/// has changed since.
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

}  // namespace

void bindViews(py::module_& m, SimulationClass& cls) {
  cls.def_property_readonly("x", [](Simulation& s) { return s.x(false); })
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
      .def_property_readonly("num_slots",
                             [](Simulation& s) {
                               s.requireReadable("num_slots");
                               return s.slots();
                             })
      .def("view",
           [](py::object self) {
             auto& s = self.cast<Simulation&>();
             return StateView(s, self);
           })
      .def("edit", [](py::object self) { return Editor(self); });

  ;

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
