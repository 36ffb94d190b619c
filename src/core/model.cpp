// Model: topology, state, mass, force fields, gravity and constraints (model.hpp).
#include "cutsim/core/model.hpp"

#include <algorithm>
#include <cmath>

#include "cutsim/forcefields/contact.hpp"
#include "cutsim/topology/errors.hpp"

namespace cutsim::core {

void requireFinite(std::span<const double> a, const char* what, const std::string& component) {
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!std::isfinite(a[i])) throw NonFiniteValue{what, component, i / 3};
}

Model::Model(std::unique_ptr<topology::Topology> topology, double density)
    : Model(std::move(topology), MassLaw::areaDensity(density)) {}

Model::Model(std::unique_ptr<topology::Topology> topology, MassLaw mass) : topology_(std::move(topology)) {
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
  if (fields_[i].get() == static_cast<forcefields::ForceField*>(contact_))
    throw InvalidInput(labels_[i], "the contact cannot be replaced");
  if (field->typeName() != fields_[i]->typeName())
    throw InvalidInput(labels_[i], "a " + fields_[i]->typeName() + " can only be replaced by another (got a " +
                                       field->typeName() + ")");
  fields_[i] = std::move(field);
  fieldPointers_[i] = fields_[i].get();
}

forcefields::Contact& Model::setContact(std::unique_ptr<forcefields::Contact> contact, std::string label) {
  if (!contact) throw InvalidInput("contact", "no contact");
  if (contact_) throw InvalidInput("contact", "the model has contact already");
  contact_ = contact.get();
  addForceField(std::move(contact), std::move(label));
  return *contact_;
}

Grasp& Model::addGrasp(const std::string& name, std::span<const PointId> points,
                       DisplacementPath path, double now) {
  if (findGrasp(name)) throw InvalidInput("grasp '" + name + "'", "a grasp of that name is already active");
  auto g = std::make_unique<Grasp>(*topology_, name, now, std::move(path));
  auto x = state_->x();
  for (PointId p : points) {
    if (!topology_->isPointAlive(p))
      throw InvalidInput("grasp '" + name + "'", "point " + std::to_string(p) + " does not exist");
    g->add(p, {x[3 * p], x[3 * p + 1], x[3 * p + 2]});
  }
  grasps_.push_back(std::move(g));
  return *grasps_.back();
}

void Model::releaseGrasp(const std::string& name) {
  auto it = std::find_if(grasps_.begin(), grasps_.end(), [&](auto& g) { return g->name() == name; });
  if (it == grasps_.end())
    throw InvalidInput("grasp '" + name + "'", "no active grasp of that name to release");
  grasps_.erase(it);
}

Grasp* Model::findGrasp(const std::string& name) {
  for (auto& g : grasps_)
    if (g->name() == name) return g.get();
  return nullptr;
}

void Model::addForce(std::span<const double> x, std::span<const double> v, std::span<double> f) const {
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
      e -= m[p] * (gravity_[0] * x[3 * p] + gravity_[1] * x[3 * p + 1] + gravity_[2] * x[3 * p + 2]);
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
      c.constrained[p] = 1;
      const Vec3 t = g->target(p, tEnd);
      for (int k = 0; k < 3; ++k) c.target[3 * p + k] = t[k];
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
  if (!mass_) return 0.0;
  auto m = mass_->perPoint();
  auto v = state_->v();
  double e = 0;
  for (std::size_t p = 0; p < m.size(); ++p)
    e += 0.5 * m[p] * (v[3 * p] * v[3 * p] + v[3 * p + 1] * v[3 * p + 1] + v[3 * p + 2] * v[3 * p + 2]);
  return e;
}

double Model::gravityEnergy() const {
  if (!mass_) return 0.0;
  auto m = mass_->perPoint();
  auto x = state_->x();
  double e = 0;
  for (std::size_t p = 0; p < m.size(); ++p)
    e -= m[p] * (gravity_[0] * x[3 * p] + gravity_[1] * x[3 * p + 1] + gravity_[2] * x[3 * p + 2]);
  return e;
}

double Model::fieldEnergy(std::size_t i) const { return fields_.at(i)->potentialEnergy(state_->x()); }

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

}  // namespace cutsim::core
