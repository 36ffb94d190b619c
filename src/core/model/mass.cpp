#include "cutsim/core/mass.hpp"

#include <cmath>
#include <numeric>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"

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
  requireFinitePositive("mass.total", totalMass);
  double area = 0;
  for (auto f : t.triangles()) area += triangleArea(t, f);
  if (!(area > 0))
    throw InvalidInput("mass.total", "the mesh has no area to spread a total mass over");
  return totalMass / area;
}

LumpedMass::LumpedMass(topology::Topology& t, double density)
    : LumpedMass(t, MassLaw::areaDensity(density)) {}

LumpedMass::LumpedMass(topology::Topology& t, MassLaw law)
    : law_(law),
      density_(law.kind == MassLaw::Kind::AreaDensity ? law.value : 0.0),
      mass_(t, "mass per point"),
      triangleArea_(t, "mass: triangle rest areas") {
  requireFinitePositive(law.kind == MassLaw::Kind::AreaDensity ? "mass.density" : "mass.perPoint",
                        law.value);
  for (auto f : t.triangles()) {
    double a = triangleArea(t, f);
    triangleArea_[f] = a;
    for (auto p : t.triangleVertices(f)) mass_[p] += density_ * a / 3.0;
  }
  if (law.kind == MassLaw::Kind::PerPoint)
    for (auto p : t.points()) mass_[p] = law.value;
  subscription_ = t.subscribe(*this);
}

void LumpedMass::onPointsCreated(const topology::Topology&, const topology::PointsCreated& e) {
  if (law_.kind != MassLaw::Kind::PerPoint) return;
  for (auto p : e.points) mass_[p] = law_.value;
}

double LumpedMass::total() const {
  auto m = mass_.values();
  return std::accumulate(m.begin(), m.end(), 0.0);
}
double LumpedMass::restArea() const {
  auto a = triangleArea_.values();
  return std::accumulate(a.begin(), a.end(), 0.0);
}

void LumpedMass::onTrianglesDestroyed(const topology::Topology&,
                                      const topology::TrianglesDestroyed& e) {
  for (std::size_t i = 0; i < e.triangles.size(); ++i) {
    const double a =
        triangleArea_[e.triangles[i]];  // reset by the SlotData at the transaction's end
    for (auto p : e.vertices[i]) mass_[p] = std::max(0.0, mass_[p] - density_ * a / 3.0);
  }
}

void LumpedMass::onTrianglesCreated(const topology::Topology& t,
                                    const topology::TrianglesCreated& e) {
  for (std::size_t i = 0; i < e.triangles.size(); ++i) {
    double a = triangleArea(t, e.triangles[i]);
    triangleArea_[e.triangles[i]] = a;
    for (auto p : e.vertices[i]) mass_[p] += density_ * a / 3.0;
  }
}

void LumpedMass::validate(const topology::Topology& t, std::vector<std::string>& problems) const {
  std::vector<double> expected(t.pointCapacity(), 0.0);
  for (auto f : t.triangles())
    for (auto p : t.triangleVertices(f)) expected[p.idx()] += density_ * triangleArea(t, f) / 3.0;
  if (law_.kind == MassLaw::Kind::PerPoint)
    for (auto p : t.points()) expected[p.idx()] = law_.value;
  if (mass_.numSlots() != expected.size()) {
    problems.push_back("mass table size differs from the point capacity");
    return;
  }
  double scale = 0;
  for (double m : expected) scale = std::max(scale, m);
  for (topology::PointId p{0}; p.idx() < expected.size(); ++p)
    if (std::abs(mass_[p] - expected[p.idx()]) > 1e-9 * scale)
      problems.push_back("point " + std::to_string(p.idx()) + ": mass " + std::to_string(mass_[p]) +
                         " != rebuilt " + std::to_string(expected[p.idx()]));
}

template <class Archive, class Self>
void LumpedMass::members(Archive& a, Self& s) {
  fields(a, s.density_, slots(s.mass_.values(), "masses"),
         slots(s.triangleArea_.values(), "triangle areas"));
}
void LumpedMass::saveState(ArchiveWriter& out) const {
  members(out, *this);
}
void LumpedMass::loadState(ArchiveReader& in) {
  members(in, *this);
  if (!(density_ >= 0) || !std::isfinite(density_))
    in.fail("mass: a density of " + std::to_string(density_));
}

}  // namespace cutsim::core
