// Model: topology, state, mass, force fields, gravity and constraints (model.hpp).
#include "cutsim/core/model.hpp"

#include <algorithm>
#include <cmath>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"

namespace cutsim::core {

void requireFinite(std::span<const double> a, const char* what, const std::string& component) {
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!std::isfinite(a[i])) throw NonFiniteValue{what, component, i / 3};
}

Model::Model(std::unique_ptr<topology::Topology> topology, double density)
    : Model(std::move(topology), MassLaw::areaDensity(density)) {}

Model::Model(std::unique_ptr<topology::Topology> topology, MassLaw mass)
    : topology_(std::move(topology)) {
  if (!topology_) throw InvalidInput("mesh", "no topology");
  state_ = std::make_unique<MechanicalState>(*topology_);
  if (mass.value > 0) mass_ = std::make_unique<LumpedMass>(*topology_, mass);
  fixed_ = std::make_unique<PointSet>(*topology_, "fixed");
}

Model::~Model() {
  // Fields and constraints unsubscribe before the topology goes.
  fieldPointers_.clear();
  fields_.clear();
  grasps_.clear();
  fixed_.reset();
  mass_.reset();
  state_.reset();
}

forcefields::ForceField& Model::addForceField(std::unique_ptr<forcefields::ForceField> field,
                                              std::string label) {
  if (!field) throw InvalidInput("forceFields", "no force field");
  if (label.empty()) label = field->typeName();
  fields_.push_back(std::move(field));
  fieldPointers_.push_back(fields_.back().get());
  labels_.push_back(std::move(label));
  return *fields_.back();
}

void Model::replaceForceField(std::size_t i, std::unique_ptr<forcefields::ForceField> field) {
  if (i >= fields_.size()) throw InvalidInput("forceFields", "no force field " + std::to_string(i));
  if (!field) throw InvalidInput(labels_[i], "no force field");
  if (!fields_[i]->replaceable())
    throw InvalidInput(
        labels_[i], "a " + fields_[i]->typeName() + " cannot be replaced (a step hook holds it)");
  if (field->typeName() != fields_[i]->typeName())
    throw InvalidInput(labels_[i], "a " + fields_[i]->typeName() +
                                       " can only be replaced by another (got a " +
                                       field->typeName() + ")");
  field->continueFrom(*fields_[i]);
  fields_[i] = std::move(field);
  fieldPointers_[i] = fields_[i].get();
}

Grasp& Model::addGrasp(const std::string& name, std::span<const PointId> points,
                       DisplacementPath path, double now) {
  if (findGrasp(name))
    throw InvalidInput("grasp '" + name + "'", "a grasp of that name is already active");
  auto g = std::make_unique<Grasp>(*topology_, name, now, std::move(path));
  auto x = state_->x();
  for (PointId p : points) {
    if (!topology_->isPointAlive(p))
      throw InvalidInput("grasp '" + name + "'",
                         "point " + std::to_string(p.idx()) + " does not exist");
    g->add(p, {x[3 * p.idx()], x[3 * p.idx() + 1], x[3 * p.idx() + 2]});
  }
  grasps_.push_back(std::move(g));
  return *grasps_.back();
}

void Model::releaseGrasp(const std::string& name) {
  auto it =
      std::find_if(grasps_.begin(), grasps_.end(), [&](auto& g) { return g->name() == name; });
  if (it == grasps_.end())
    throw InvalidInput("grasp '" + name + "'", "no active grasp of that name to release");
  grasps_.erase(it);
}

Grasp* Model::findGrasp(const std::string& name) {
  for (auto& g : grasps_)
    if (g->name() == name) return g.get();
  return nullptr;
}

void Model::addForce(std::span<const double> x, std::span<const double> v,
                     std::span<double> f) const {
  for (std::size_t i = 0; i < fields_.size(); ++i) {
    fields_[i]->addForce(x, v, f);
    requireFinite(f, "force", labels_[i]);
  }
  if (mass_) {
    auto m = mass_->perPoint();
    for (std::size_t p = 0; p < m.size(); ++p)
      for (int c = 0; c < 3; ++c) f[3 * p + c] += m[p] * gravity_[c];
  }
}

void Model::addDForce(std::span<const double> x, std::span<const double> dx, std::span<double> df,
                      double kFactor, double bFactor) const {
  for (auto& fl : fields_) fl->addDForce(x, dx, df, kFactor, bFactor);
}

double Model::potentialEnergy(std::span<const double> x) const {
  double e = 0;
  for (auto& fl : fields_) e += fl->potentialEnergy(x);
  if (mass_) {
    auto m = mass_->perPoint();
    for (std::size_t p = 0; p < m.size(); ++p)
      e -=
          m[p] * (gravity_[0] * x[3 * p] + gravity_[1] * x[3 * p + 1] + gravity_[2] * x[3 * p + 2]);
  }
  return e;
}

StepConstraints Model::constraints(double tEnd) const {
  const std::size_t n = numSlots();
  StepConstraints c;
  c.constrained.assign(n, 0);
  auto x = state_->x();
  c.target.assign(x.begin(), x.end());
  const bool massless = !mass_;
  for (std::size_t p = 0; p < n; ++p)
    if (massless || !(mass_->perPoint()[p] > 0) || !topology_->isPointAlive(topology::PointId(p)) ||
        fixed_->contains(topology::PointId(p)))
      c.constrained[p] = 1;
  for (auto& g : grasps_)
    for (PointId p : g->points().points()) {
      c.constrained[p.idx()] = 1;
      const Vec3 t = g->target(p, tEnd);
      for (int k = 0; k < 3; ++k) c.target[3 * p.idx() + k] = t[k];
    }
  return c;
}

std::vector<std::string> Model::setExactStiffness(bool exact) {
  std::vector<std::string> without;
  for (std::size_t i = 0; i < fields_.size(); ++i)
    if (!fields_[i]->setExactStiffness(exact)) without.push_back(labels_[i]);
  return without;
}

double Model::kineticEnergy() const {
  return kineticEnergyOf(state_->v());
}

double Model::kineticEnergyOf(std::span<const double> v, std::size_t* overflowAt) const {
  const std::size_t n = v.size() / 3;
  if (overflowAt) *overflowAt = n;
  if (!mass_) return 0.0;
  auto m = mass_->perPoint();
  double e = 0;
  for (std::size_t p = 0; p < m.size() && p < n; ++p) {
    e += 0.5 * m[p] *
         (v[3 * p] * v[3 * p] + v[3 * p + 1] * v[3 * p + 1] + v[3 * p + 2] * v[3 * p + 2]);
    if (overflowAt && !std::isfinite(e)) {
      *overflowAt = p;
      break;
    }
  }
  return e;
}

double Model::gravityEnergy() const {
  return gravityEnergyOf(state_->x());
}

double Model::gravityEnergyOf(std::span<const double> x) const {
  if (!mass_) return 0.0;
  auto m = mass_->perPoint();
  double e = 0;
  for (std::size_t p = 0; p < m.size(); ++p)
    e -= m[p] * (gravity_[0] * x[3 * p] + gravity_[1] * x[3 * p + 1] + gravity_[2] * x[3 * p + 2]);
  return e;
}

double Model::fieldEnergy(std::size_t i) const {
  return fields_.at(i)->potentialEnergy(state_->x());
}

std::vector<double> Model::totalForce() const {
  std::vector<double> f(state_->x().size(), 0.0);
  for (auto& fl : fields_) fl->addForce(state_->x(), state_->v(), f);
  if (mass_) {
    auto m = mass_->perPoint();
    for (std::size_t p = 0; p < m.size(); ++p)
      for (int c = 0; c < 3; ++c) f[3 * p + c] += m[p] * gravity_[c];
  }
  return f;
}

std::vector<std::string> Model::notCheckpointable() const {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < fields_.size(); ++i)
    if (!fields_[i]->checkpointable())
      out.push_back(labels_[i] + " (" + fields_[i]->typeName() + ")");
  return out;
}

void Model::saveState(ArchiveWriter& out) const {
  out.begin("state");
  state_->saveState(out);
  out.begin("mass");
  out.boolean(mass_ != nullptr);
  if (mass_) mass_->saveState(out);
  out.begin("fixed");
  fixed_->saveState(out);
  out.begin("grasps");
  out.u64(grasps_.size());
  for (const auto& g : grasps_) {
    out.str(g->name());
    out.f64(g->startTime());
    out.f64s(g->path().times);
    out.u64(g->path().displacements.size());
    for (const Vec3& d : g->path().displacements) out.raw(d.data(), sizeof(double) * 3);
    out.u64(g->path().rotations.size());
    for (const Rotation& r : g->path().rotations) out.raw(r.data(), sizeof(double) * 4);
    out.raw(g->path().pivot.data(), sizeof(double) * 3);
    out.raw(g->reaction().data(), sizeof(double) * 3);
    g->points().saveState(out);
  }
  for (std::size_t i = 0; i < fields_.size(); ++i) {
    out.begin("field" + std::to_string(i));
    out.str(fields_[i]->typeName());
    fields_[i]->saveState(out);
  }
}

void Model::loadState(ArchiveReader& in) {
  std::vector<std::string> problems;
  auto check = [&](const char* what) {
    if (!problems.empty()) in.fail(std::string(what) + ": " + problems.front());
  };
  in.open("state");
  state_->loadState(in);
  in.close();
  for (double v : state_->x())
    if (!std::isfinite(v)) in.fail("a position is not finite");
  for (double v : state_->v())
    if (!std::isfinite(v)) in.fail("a velocity is not finite");
  in.open("mass");
  if (in.boolean() != (mass_ != nullptr))
    in.fail("the saved simulation and the scene differ in having a mass");
  if (mass_) mass_->loadState(in);
  in.close();
  if (mass_) mass_->validate(*topology_, problems);
  check("mass");
  in.open("fixed");
  fixed_->loadState(in);
  in.close();
  fixed_->validate(*topology_, problems);
  check("fixed points");
  in.open("grasps");
  grasps_.clear();
  const std::uint64_t n = in.u64();
  if (n > in.remaining()) in.fail("grasps: a count of " + std::to_string(n));
  for (std::uint64_t k = 0; k < n; ++k) {
    const std::string name = in.str();
    const double start = in.f64();
    DisplacementPath path;
    path.times = in.f64s();
    const std::uint64_t m = in.u64();
    if (m != path.times.size())
      in.fail("grasp '" + name + "': its path's times and displacements differ in number");
    path.displacements.resize(m);
    for (Vec3& d : path.displacements) in.raw(d.data(), sizeof(double) * 3);
    const std::uint64_t turns = in.u64();
    if (turns != 0 && turns != m)
      in.fail("grasp '" + name + "': its path's times and rotations differ in number");
    path.rotations.resize(turns);
    for (Rotation& r : path.rotations) in.raw(r.data(), sizeof(double) * 4);
    in.raw(path.pivot.data(), sizeof(double) * 3);
    Vec3 reaction;
    in.raw(reaction.data(), sizeof(double) * 3);
    try {
      grasps_.push_back(std::make_unique<Grasp>(*topology_, name, start, std::move(path)));
    } catch (const InvalidInput& e) {
      in.fail(e.what());
    }
    grasps_.back()->setReaction(reaction);
    grasps_.back()->points().loadState(in);
    grasps_.back()->points().validate(*topology_, problems);
    check("grasps");
  }
  in.close();
  for (std::size_t i = 0; i < fields_.size(); ++i) {
    in.open("field" + std::to_string(i));
    const std::string type = in.str();
    if (type != fields_[i]->typeName())
      in.fail("force field " + std::to_string(i) + " was a " + type + ", the scene's is a " +
              fields_[i]->typeName());
    fields_[i]->loadState(in);
    in.close();
  }
}

}  // namespace cutsim::core
