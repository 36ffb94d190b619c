// SOFA's TriangularBendingSprings on FastTriangularBendingSprings' hinges
// (triangular_bending_springs.hpp has the formulas).
#include "cutsim/forcefields/triangular_bending_springs.hpp"

#include <Eigen/Dense>
#include <cmath>

#include "cutsim/base/numbers.hpp"
#include "cutsim/forcefields/registry.hpp"

namespace cutsim::forcefields {
namespace {

constexpr double kShortest = 1e-4;  // SOFA: a spring shorter than this gives no force

struct Spring {
  double u[3], l;
  bool live;
};

Spring springAt(const double* x, std::uint32_t a, std::uint32_t b) {
  Spring s{};
  for (int k = 0; k < 3; ++k) s.u[k] = x[3 * b + std::uint32_t(k)] - x[3 * a + std::uint32_t(k)];
  s.l = std::sqrt(s.u[0] * s.u[0] + s.u[1] * s.u[1] + s.u[2] * s.u[2]);
  s.live = s.l > kShortest;
  if (s.live)
    for (double& c : s.u) c /= s.l;
  return s;
}

BendingParameters hingeParameters() {
  BendingParameters p;  // the hinge table's own validity thresholds (its stiffness is not used)
  return p;
}

}  // namespace

void TriangularBendingSpringsParameters::validate() const {
  requireFiniteNonNegative("stiffness", stiffness);
  requireFiniteNonNegative("damping", damping);
}

TriangularBendingSprings::TriangularBendingSprings(topology::Topology& topology,
                                                   TriangularBendingSpringsParameters p)
    : FastTriangularBendingSprings(topology, hingeParameters()), topo_(&topology), sp_(p) {
  sp_.validate();
}

double TriangularBendingSprings::restLength(const BendingSpring& s) const {
  const auto a = topo_->restPosition(topology::PointId(s.v[0])),
             b = topo_->restPosition(topology::PointId(s.v[1]));
  const double d0 = b[0] - a[0], d1 = b[1] - a[1], d2 = b[2] - a[2];
  return std::sqrt(d0 * d0 + d1 * d1 + d2 * d2);
}

void TriangularBendingSprings::addForce(std::span<const double> x, std::span<const double> v,
                                        std::span<double> f) const {
  const bool damped = sp_.damping != 0.0;
  for (const BendingSpring& bs : activeSprings()) {
    const Spring s = springAt(x.data(), bs.v[0], bs.v[1]);
    if (!s.live) continue;
    double intensity = sp_.stiffness * (s.l - restLength(bs));
    if (damped) {
      double rel = 0;
      for (int k = 0; k < 3; ++k)
        rel += (v[3 * bs.v[1] + std::uint32_t(k)] - v[3 * bs.v[0] + std::uint32_t(k)]) * s.u[k];
      intensity += sp_.damping * rel;
    }
    for (int k = 0; k < 3; ++k) {
      f[3 * bs.v[0] + std::uint32_t(k)] += intensity * s.u[k];
      f[3 * bs.v[1] + std::uint32_t(k)] -= intensity * s.u[k];
    }
  }
}

void TriangularBendingSprings::addDForce(std::span<const double> x, std::span<const double> dx,
                                         std::span<double> df, double kFactor, double) const {
  if (kFactor == 0.0) return;
  for (const BendingSpring& bs : activeSprings()) {
    const Spring s = springAt(x.data(), bs.v[0], bs.v[1]);
    if (!s.live) continue;
    const double t = sp_.stiffness * (s.l - restLength(bs)) / s.l;
    double w[3], uw = 0;
    for (int k = 0; k < 3; ++k) {
      w[k] = dx[3 * bs.v[1] + std::uint32_t(k)] - dx[3 * bs.v[0] + std::uint32_t(k)];
      uw += s.u[k] * w[k];
    }
    for (int k = 0; k < 3; ++k) {
      const double g = kFactor * ((sp_.stiffness - t) * uw * s.u[k] + t * w[k]);
      df[3 * bs.v[0] + std::uint32_t(k)] += g;
      df[3 * bs.v[1] + std::uint32_t(k)] -= g;
    }
  }
}

double TriangularBendingSprings::potentialEnergy(std::span<const double> x) const {
  double e = 0;
  for (const BendingSpring& bs : activeSprings()) {
    const Spring s = springAt(x.data(), bs.v[0], bs.v[1]);
    if (!s.live) continue;
    const double stretch = s.l - restLength(bs);
    e += stretch * stretch;
  }
  return 0.5 * sp_.stiffness * e;
}

void TriangularBendingSprings::addKToMatrix(std::span<const double> x, MatrixAccumulator& m,
                                            double kFactor) const {
  for (const BendingSpring& bs : activeSprings()) {
    const Spring s = springAt(x.data(), bs.v[0], bs.v[1]);
    Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
    if (s.live) {
      const double t = sp_.stiffness * (s.l - restLength(bs)) / s.l;
      const Eigen::Vector3d u(s.u[0], s.u[1], s.u[2]);
      block =
          kFactor * ((sp_.stiffness - t) * (u * u.transpose()) + t * Eigen::Matrix3d::Identity());
    }
    const PointId a(bs.v[0]), b(bs.v[1]);
    m.addBlock(a, b, block);
    m.addBlock(b, a, block);
    m.addBlock(a, a, -block);
    m.addBlock(b, b, -block);
  }
}

void TriangularBendingSprings::addBToMatrix(std::span<const double>, MatrixAccumulator&,
                                            double) const {}

namespace {
const bool registered = ForceFieldRegistry::instance().add(
    {"TriangularBendingSprings",
     "SOFA's TriangularBendingSprings: a linear spring between the two wings of each interior edge",
     {{"stiffness", KeyType::Number, "ks, >= 0 (default 100000, SOFA's)"},
      {"damping", KeyType::Number, "kd, >= 0 (default 1, SOFA's; explicit, as SOFA's)"}},
     {},
     [](const ParameterSource& s) -> std::any {
       TriangularBendingSpringsParameters p;
       p.stiffness = s.nonNegative("stiffness", p.stiffness);
       p.damping = s.nonNegative("damping", p.damping);
       s.check([&] { p.validate(); });
       return p;
     },
     [](const std::any& p, topology::Topology& t) -> std::unique_ptr<ForceField> {
       return std::make_unique<TriangularBendingSprings>(
           t, std::any_cast<const TriangularBendingSpringsParameters&>(p));
     }});
}  // namespace

}  // namespace cutsim::forcefields
