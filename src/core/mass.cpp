#include "cutsim/core/mass.hpp"

#include <cmath>
#include <numeric>

#include "cutsim/forcefields/parameters.hpp"
#include "cutsim/topology/errors.hpp"

namespace cutsim::core {

double LumpedMass::triangleArea(const topology::Topology& t, topology::TriangleId f) {
  auto v = t.triangleVertices(f);
  auto a = t.restPosition(v[0]), b = t.restPosition(v[1]), c = t.restPosition(v[2]);
  double u[3], w[3];
  for (int k = 0; k < 3; ++k) {
    u[k] = b[k] - a[k];
    w[k] = c[k] - a[k];
  }
  double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
  return 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

double LumpedMass::densityForTotal(const topology::Topology& t, double totalMass) {
  forcefields::requireFinitePositive("mass.total", totalMass);
  double area = 0;
  for (auto f : t.triangles()) area += triangleArea(t, f);
  if (!(area > 0)) throw InvalidInput("mass.total", "the mesh has no area to spread a total mass over");
  return totalMass / area;
}

LumpedMass::LumpedMass(topology::Topology& t, double density) : density_(density) {
  forcefields::requireFinitePositive("mass.density", density);
  mass_.reserve(std::size_t(t.pointCapacity()) * 5 / 4 + 16);
  triangleArea_.reserve(std::size_t(t.triangleCapacity()) * 5 / 4 + 16);
  mass_.assign(t.pointCapacity(), 0.0);
  triangleArea_.assign(t.triangleCapacity(), 0.0);
  for (auto f : t.triangles()) {
    double a = triangleArea(t, f);
    triangleArea_[f] = a;
    for (auto p : t.triangleVertices(f)) mass_[p] += density_ * a / 3.0;
  }
  subscription_ = t.subscribe(*this);
}

double LumpedMass::total() const { return std::accumulate(mass_.begin(), mass_.end(), 0.0); }
double LumpedMass::restArea() const {
  return std::accumulate(triangleArea_.begin(), triangleArea_.end(), 0.0);
}

void LumpedMass::onTrianglesDestroyed(const topology::Topology&, const topology::TrianglesDestroyed& e) {
  for (std::size_t i = 0; i < e.triangles.size(); ++i) {
    double a = triangleArea_[e.triangles[i]];
    triangleArea_[e.triangles[i]] = 0.0;
    for (auto p : e.vertices[i]) mass_[p] = std::max(0.0, mass_[p] - density_ * a / 3.0);
  }
}

void LumpedMass::onTrianglesCreated(const topology::Topology& t, const topology::TrianglesCreated& e) {
  if (triangleArea_.size() < t.triangleCapacity()) triangleArea_.resize(t.triangleCapacity(), 0.0);
  if (mass_.size() < t.pointCapacity()) mass_.resize(t.pointCapacity(), 0.0);
  for (std::size_t i = 0; i < e.triangles.size(); ++i) {
    double a = triangleArea(t, e.triangles[i]);
    triangleArea_[e.triangles[i]] = a;
    for (auto p : e.vertices[i]) mass_[p] += density_ * a / 3.0;
  }
}

void LumpedMass::onPointsCreated(const topology::Topology& t, const topology::PointsCreated&) {
  if (mass_.size() < t.pointCapacity()) mass_.resize(t.pointCapacity(), 0.0);
}

void LumpedMass::onPointsDestroyed(const topology::Topology&, const topology::PointsDestroyed& e) {
  for (auto p : e.points) mass_[p] = 0.0;
}

void LumpedMass::onPointsRenumbered(const topology::Topology&, const topology::Renumbering& r) {
  std::vector<double> m(r.newSize, 0.0);
  for (std::size_t o = 0; o < r.oldToNew.size() && o < mass_.size(); ++o)
    if (r.oldToNew[o] != topology::kInvalidIndex) m[r.oldToNew[o]] = mass_[o];
  mass_.swap(m);
}

void LumpedMass::onTrianglesRenumbered(const topology::Topology&, const topology::Renumbering& r) {
  std::vector<double> a(r.newSize, 0.0);
  for (std::size_t o = 0; o < r.oldToNew.size() && o < triangleArea_.size(); ++o)
    if (r.oldToNew[o] != topology::kInvalidIndex) a[r.oldToNew[o]] = triangleArea_[o];
  triangleArea_.swap(a);
}

void LumpedMass::validate(const topology::Topology& t, std::vector<std::string>& problems) const {
  std::vector<double> expected(t.pointCapacity(), 0.0);
  for (auto f : t.triangles())
    for (auto p : t.triangleVertices(f)) expected[p] += density_ * triangleArea(t, f) / 3.0;
  if (mass_.size() != expected.size()) {
    problems.push_back("mass table size differs from the point capacity");
    return;
  }
  double scale = 0;
  for (double m : expected) scale = std::max(scale, m);
  for (std::size_t p = 0; p < expected.size(); ++p)
    if (std::abs(mass_[p] - expected[p]) > 1e-9 * scale)
      problems.push_back("point " + std::to_string(p) + ": mass " + std::to_string(mass_[p]) +
                         " != rebuilt " + std::to_string(expected[p]));
}

}  // namespace cutsim::core
