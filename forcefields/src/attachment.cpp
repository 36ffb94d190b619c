#include "cutsim/forcefields/attachment.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/forcefields/registry.hpp"

namespace cutsim::forcefields {
namespace {

using topology::Topology;

double restArea(const Topology& t, TriangleId tri) {
  const topology::TriangleVertices v = t.triangleVertices(tri);
  const Vec3 a = t.restPosition(v[0]), b = t.restPosition(v[1]), c = t.restPosition(v[2]);
  const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                       e1[0] * e2[1] - e1[1] * e2[0]};
  return 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

/// A third of the rest areas of the live triangles around p, summed in ascending triangle order.
double pointArea(const Topology& t, PointId p) {
  std::vector<TriangleId> tris = t.trianglesAroundPoint(p);
  std::sort(tris.begin(), tris.end());
  double a = 0.0;
  for (TriangleId tri : tris) a += restArea(t, tri);
  return a / 3.0;
}

double distanceToSegment(const Vec3& p, const Vec3& a, const Vec3& b) {
  double ab[3], ap[3], len2 = 0.0, dot = 0.0;
  for (int k = 0; k < 3; ++k) {
    ab[k] = b[k] - a[k];
    ap[k] = p[k] - a[k];
    len2 += ab[k] * ab[k];
    dot += ab[k] * ap[k];
  }
  const double s = len2 > 0.0 ? std::clamp(dot / len2, 0.0, 1.0) : 0.0;
  double d2 = 0.0;
  for (int k = 0; k < 3; ++k) d2 += (ap[k] - s * ab[k]) * (ap[k] - s * ab[k]);
  return std::sqrt(d2);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Parameters

bool AttachmentParameters::contains(const Vec3& p) const {
  switch (region) {
    case Region::All:
      return true;
    case Region::Box:
      for (int k = 0; k < 3; ++k) {
        if (p[k] < boxMin[k] || p[k] > boxMax[k]) return false;
      }
      return true;
    case Region::Sphere: {
      double d2 = 0.0;
      for (int k = 0; k < 3; ++k) d2 += (p[k] - center[k]) * (p[k] - center[k]);
      return d2 <= radius * radius;
    }
  }
  return false;
}

void AttachmentParameters::validate() const {
  requireFiniteNonNegative("stiffness", stiffness);
  requireFiniteNonNegative("damping", damping);
  if (region == Region::Sphere) requireFinitePositive("sphere", radius);
  if (region == Region::Box) {
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(boxMin[k]) || !std::isfinite(boxMax[k]) || boxMin[k] > boxMax[k])
        throw InvalidInput("box",
                           "must be [[xmin, ymin, zmin], [xmax, ymax, zmax]] with finite "
                           "min <= max");
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Construction

Attachment::Attachment(Topology& topology, AttachmentParameters parameters)
    : topology_(&topology),
      params_(parameters),
      weight_(topology, "Attachment.weight", 0.0, topology::NewSlots::Interpolate),
      area_(topology, "Attachment.area", 0.0),
      target_(topology, "Attachment.target", 0.0) {
  params_.validate();
  for (PointId p : topology.points()) {
    const Vec3 x = topology.restPosition(p);
    weight_[p] = params_.contains(x) ? 1.0 : 0.0;
    recomputePoint(p);
  }
  subscription_ = topology.subscribe(*this);
}

Attachment::~Attachment() = default;

void Attachment::continueFrom(const ForceField& previous) {
  const auto* old = dynamic_cast<const Attachment*>(&previous);
  if (!old || old->topology_ != topology_) return;
  for (PointId p : topology_->points()) {
    const Vec3 x = topology_->restPosition(p);
    if (!params_.contains(x)) continue;  // outside the new region: 0 already
    if (old->params_.contains(x)) weight_[p] = old->weight_[p];
  }
}

void Attachment::recomputePoint(PointId p) {
  if (!topology_->isPointAlive(p)) {
    area_[p] = 0.0;
    for (double& c : target_.at(p)) c = 0.0;
    return;
  }
  area_[p] = pointArea(*topology_, p);
  const Vec3 x = topology_->restPosition(p);
  std::copy(x.begin(), x.end(), target_.at(p).begin());
}

std::size_t Attachment::numAttached() const {
  std::size_t n = 0;
  for (PointId p : topology_->points()) n += weight_[p] > 0.0 ? 1 : 0;
  return n;
}

std::size_t Attachment::release(const std::function<bool(const Vec3&)>& inside) {
  return releasePoints([&](PointId p) { return inside(topology_->restPosition(p)); });
}

std::size_t Attachment::releasePoints(const std::function<bool(PointId)>& inside) {
  std::size_t released = 0;
  for (PointId p : topology_->points()) {
    if (!inside(p)) continue;
    released += weight_[p] > 0.0 ? 1 : 0;
    weight_[p] = 0.0;
  }
  return released;
}

// ---------------------------------------------------------------------------------------------
// Forces

void Attachment::checkSize(std::span<const double> a, const char* name, const char* what) const {
  const std::size_t need = 3 * static_cast<std::size_t>(topology_->pointCapacity());
  if (a.size() < need) {
    throw std::invalid_argument(std::string("Attachment::") + what + ": " + name +
                                " must hold 3 * pointCapacity = " + std::to_string(need) +
                                " doubles, got " + std::to_string(a.size()));
  }
}

void Attachment::addForce(std::span<const double> x, std::span<const double> v,
                          std::span<double> f) const {
  checkSize(x, "x", "addForce");
  checkSize(f, "f", "addForce");
  if (!v.empty()) checkSize(v, "v", "addForce");  // empty: at rest
  const bool damped = params_.damping > 0.0 && !v.empty();
  const std::span<const double> w = weight_.values(), a = area_.values(), t = target_.values();
  for (std::size_t p = 0; p < w.size(); ++p) {
    const double wa = w[p] * a[p];
    if (wa == 0.0) continue;
    const double k = params_.stiffness * wa;
    for (int c = 0; c < 3; ++c) {
      const std::size_t i = 3 * p + c;
      f[i] -= k * (x[i] - t[i]);
      if (damped) f[i] -= params_.damping * wa * v[i];
    }
  }
}

void Attachment::addDForce(std::span<const double> x, std::span<const double> dx,
                           std::span<double> df, double kFactor, double bFactor) const {
  checkSize(x, "x", "addDForce");
  checkSize(dx, "dx", "addDForce");
  checkSize(df, "df", "addDForce");
  const double s = kFactor * params_.stiffness + bFactor * params_.damping;
  if (s == 0.0) return;
  const std::span<const double> w = weight_.values(), a = area_.values();
  for (std::size_t p = 0; p < w.size(); ++p) {
    const double wa = w[p] * a[p];
    if (wa == 0.0) continue;
    for (int c = 0; c < 3; ++c) df[3 * p + c] -= s * wa * dx[3 * p + c];
  }
}

double Attachment::potentialEnergy(std::span<const double> x) const {
  checkSize(x, "x", "potentialEnergy");
  const std::span<const double> w = weight_.values(), a = area_.values(), t = target_.values();
  double energy = 0.0;
  for (std::size_t p = 0; p < w.size(); ++p) {
    const double wa = w[p] * a[p];
    if (wa == 0.0) continue;
    double d2 = 0.0;
    for (int c = 0; c < 3; ++c) d2 += (x[3 * p + c] - t[3 * p + c]) * (x[3 * p + c] - t[3 * p + c]);
    energy += 0.5 * params_.stiffness * wa * d2;
  }
  return energy;
}

void Attachment::addKToMatrix(std::span<const double> x, MatrixAccumulator& m,
                              double kFactor) const {
  checkSize(x, "x", "addKToMatrix");
  addDiagonal(m, -kFactor * params_.stiffness);
}

void Attachment::addBToMatrix(std::span<const double> x, MatrixAccumulator& m,
                              double bFactor) const {
  checkSize(x, "x", "addBToMatrix");
  addDiagonal(m, -bFactor * params_.damping);
}

void Attachment::addDiagonal(MatrixAccumulator& m, double perArea) const {
  const std::span<const double> w = weight_.values(), a = area_.values();
  for (std::size_t p = 0; p < a.size(); ++p) {  // dead slots have no area
    if (a[p] != 0.0) m.addScaledIdentity(PointId(p), PointId(p), perArea * w[p] * a[p]);
  }
}

// ---------------------------------------------------------------------------------------------
// Topology events: new points take their ancestors' attached fraction (SlotData interpolates);
// the areas of the points around created and destroyed triangles, and the targets of new
// points, are recomputed when the transaction ends (the rest positions are final then).

void Attachment::onPointsCreated(const Topology&, const topology::PointsCreated& e) {
  // The interpolated fraction, kept in [0, 1] against rounding (weights 0.3 and 0.7 of two
  // attached points sum to 1 + 2^-52).
  for (PointId p : e.points) weight_[p] = std::clamp(weight_[p], 0.0, 1.0);
  touched_.insert(touched_.end(), e.points.begin(), e.points.end());
}

void Attachment::onTrianglesCreated(const Topology&, const topology::TrianglesCreated& e) {
  for (const topology::TriangleVertices& v : e.vertices)
    touched_.insert(touched_.end(), v.begin(), v.end());
}

void Attachment::onTrianglesDestroyed(const Topology&, const topology::TrianglesDestroyed& e) {
  for (const topology::TriangleVertices& v : e.vertices)
    touched_.insert(touched_.end(), v.begin(), v.end());
}

void Attachment::onTransactionEnd(const Topology& t, const topology::TransactionSummary&) {
  std::sort(touched_.begin(), touched_.end());
  touched_.erase(std::unique(touched_.begin(), touched_.end()), touched_.end());
  for (PointId p : touched_) {
    if (p.idx() < t.pointCapacity()) recomputePoint(p);
  }
  touched_.clear();
}

void Attachment::validate(const Topology& topology, std::vector<std::string>& problems) const {
  if (weight_.numSlots() != topology.pointCapacity()) {
    problems.push_back("Attachment: " + std::to_string(weight_.numSlots()) +
                       " point slots, the topology has " +
                       std::to_string(topology.pointCapacity()));
    return;
  }
  for (PointId p{0}; p.idx() < topology.pointCapacity(); ++p) {
    const std::string name = "point " + std::to_string(p.idx());
    if (!topology.isPointAlive(p)) {
      if (area_[p] != 0.0 || weight_[p] != 0.0)
        problems.push_back(name + " is dead but has an area or an attached fraction");
      continue;
    }
    const double w = weight_[p];
    if (!(w >= 0.0 && w <= 1.0))
      problems.push_back(name + ": attached fraction " + std::to_string(w) + " not in [0, 1]");
    const double ref = pointArea(topology, p);
    if (std::fabs(area_[p] - ref) > 1e-12 * std::max(ref, 1e-300))
      problems.push_back(name + ": area " + std::to_string(area_[p]) + ", a rebuild gives " +
                         std::to_string(ref));
    const Vec3 x = topology.restPosition(p);
    for (int c = 0; c < 3; ++c) {
      if (target_.at(p)[c] != x[c]) {
        problems.push_back(name + ": target differs from the rest position");
        break;
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Checkpoints: the attached fractions (the areas and targets follow from the topology).

void Attachment::saveState(ArchiveWriter& out) const {
  fields(out, slots(weight_.values(), "Attachment: attached fractions"));
}

void Attachment::loadState(ArchiveReader& in) {
  fields(in, slots(weight_.values(), "Attachment: attached fractions"));
  std::vector<std::string> problems;
  validate(*topology_, problems);
  if (!problems.empty()) in.fail(problems.front());
}

std::function<bool(const Vec3&)> nearPolyline(std::vector<Vec3> polyline, double halfWidth) {
  return [polyline = std::move(polyline), halfWidth](const Vec3& p) {
    if (polyline.size() == 1) return distanceToSegment(p, polyline[0], polyline[0]) <= halfWidth;
    for (std::size_t i = 0; i + 1 < polyline.size(); ++i) {
      if (distanceToSegment(p, polyline[i], polyline[i + 1]) <= halfWidth) return true;
    }
    return false;
  };
}

// ---- the component's registration ----

namespace {
const bool registered = ForceFieldRegistry::instance().add(
    {"Attachment",
     "ties each point to its rest position with a zero-length spring per unit area: the tissue "
     "beneath (SOFA's RestShapeSpringsForceField); released by the \"dissect\" action",
     {{"stiffness", KeyType::Number, "N/m per m^2 of surface, >= 0", {}, true},
      {"damping", KeyType::Number, "N s/m per m^2 of surface, >= 0 (default 0)"},
      {"box", KeyType::Box,
       "[[xmin, ymin, zmin], [xmax, ymax, zmax]]: only the points whose rest position lies in "
       "it (default: every point)"},
      {"sphere",
       KeyType::Object,
       "{\"center\": [x, y, z], \"radius\": r}: only the points whose rest position lies in it",
       {R"({"center": [0.25, 0.25, 0], "radius": 0.2})"}}},
     {},
     [](const ParameterSource& s) -> std::any {
       AttachmentParameters p;
       s.require("stiffness");
       p.stiffness = s.nonNegative("stiffness", 0.0);
       p.damping = s.nonNegative("damping", 0.0);
       if (s.has("box") && s.has("sphere")) s.fail("sphere", "give a box or a sphere, not both");
       if (s.has("box")) {
         p.region = AttachmentParameters::Region::Box;
         std::tie(p.boxMin, p.boxMax) = s.box("box");
       } else if (s.has("sphere")) {
         const auto sphere = s.object("sphere", {"center", "radius"});
         sphere->require("center");
         sphere->require("radius");
         p.region = AttachmentParameters::Region::Sphere;
         p.center = sphere->vec3("center");
         p.radius = sphere->positive("radius", 0.0);
       }
       s.check([&] { p.validate(); });
       return p;
     },
     [](const std::any& p, topology::Topology& t) -> std::unique_ptr<ForceField> {
       return std::make_unique<Attachment>(t, std::any_cast<const AttachmentParameters&>(p));
     }});
}  // namespace

}  // namespace cutsim::forcefields
