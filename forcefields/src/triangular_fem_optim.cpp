// SOFA's TriangularFEMForceFieldOptim formulation on TriangularFEM's table
// (triangular_fem_optim.hpp has the formulas).
#include "cutsim/forcefields/triangular_fem_optim.hpp"

#include <Eigen/Dense>
#include <cmath>

#include "cutsim/forcefields/registry.hpp"
#include "cutsim/topology/errors.hpp"

namespace cutsim::forcefields {
namespace {

using V3 = Eigen::Vector3d;

V3 point(const double* x, std::uint32_t p) { return V3(x[3 * p], x[3 * p + 1], x[3 * p + 2]); }
void scatter(double* f, std::uint32_t p, const V3& v) {
  f[3 * p] += v[0];
  f[3 * p + 1] += v[1];
  f[3 * p + 2] += v[2];
}

/// The rest shape's (bx, cx, cy) from the element's shape gradients
/// g = (1/bx, -cx/(bx cy), 0, 1/cy) (TriangularFEM::elementFromMesh).
struct RestShape {
  double bx, cx, cy, ss;  // ss = 1 / (4A) = 0.5 / (bx cy)
  explicit RestShape(const FemTriangle& e)
      : bx(1.0 / e.g[0]), cx(-e.g[1] / (e.g[0] * e.g[3])), cy(1.0 / e.g[3]), ss(0.5 / (bx * cy)) {}
};

/// The current frame: f0 along ab, f1 in the plane towards c. False when the triangle is
/// (nearly) flat at x: it has no frame, and gives no force.
bool frame(const double* x, const FemTriangle& e, V3& f0, V3& f1, V3& ab, V3& ac) {
  const V3 a = point(x, e.v[0]);
  ab = point(x, e.v[1]) - a;
  ac = point(x, e.v[2]) - a;
  const V3 n = ab.cross(ac);
  const V3 y = n.cross(ab);
  const double lab = ab.norm(), ly = y.norm();
  if (!(lab > 0) || !(ly > 1e-14 * lab * lab * lab)) return false;
  f0 = ab / lab;
  f1 = y / ly;
  return true;
}

}  // namespace

TriangularFEMOptim::TriangularFEMOptim(topology::Topology& topology, TriangularFEMParameters parameters)
    : TriangularFEM(topology, parameters) {
  if (parameters.exactHessian)
    throw InvalidInput("exactHessian", "TriangularFEMForceFieldOptim has no exact stiffness (SOFA's K holds the frame)");
  const double E = parameters.youngModulus * parameters.thickness, nu = parameters.poissonRatio;
  muPrime_ = E / (1 + nu);
  gamma_ = E * nu / (1 - nu * nu);
}

void TriangularFEMOptim::addForce(std::span<const double> x, std::span<const double>, std::span<double> f) const {
  checkSize(x, "x", "addForce");
  checkSize(f, "f", "addForce");
  for (const FemTriangle& e : elements()) {
    V3 f0, f1, ab, ac;
    if (!frame(x.data(), e, f0, f1, ab, ac)) continue;
    const RestShape r(e);
    const double dbx = r.bx - f0.dot(ab), dcx = r.cx - f0.dot(ac), dcy = r.cy - f1.dot(ac);
    const double e0 = r.cy * dbx, e1 = r.bx * dcy, e2 = r.bx * dcx - r.cx * dbx;
    const double gxy = gamma_ * (e0 + e1);
    const double s0 = (muPrime_ * e0 + gxy) * r.ss, s1 = (muPrime_ * e1 + gxy) * r.ss, s2 = (0.5 * muPrime_ * e2) * r.ss;
    const V3 fb = f0 * (r.cy * s0 - r.cx * s2) + f1 * (r.cy * s2 - r.cx * s1);
    const V3 fc = f0 * (r.bx * s2) + f1 * (r.bx * s1);
    scatter(f.data(), e.v[0], -fb - fc);
    scatter(f.data(), e.v[1], fb);
    scatter(f.data(), e.v[2], fc);
  }
}

void TriangularFEMOptim::addDForce(std::span<const double> x, std::span<const double> dx, std::span<double> df,
                                   double kFactor, double) const {
  checkSize(x, "x", "addDForce");
  checkSize(dx, "dx", "addDForce");
  checkSize(df, "df", "addDForce");
  if (kFactor == 0.0) return;
  for (const FemTriangle& e : elements()) {
    V3 f0, f1, ab, ac;
    if (!frame(x.data(), e, f0, f1, ab, ac)) continue;
    const RestShape r(e);
    const V3 da = point(dx.data(), e.v[0]);
    const V3 dab = point(dx.data(), e.v[1]) - da, dac = point(dx.data(), e.v[2]) - da;
    const double dbx = f0.dot(dab), dby = f1.dot(dab), dcx = f0.dot(dac), dcy = f1.dot(dac);
    const double e0 = r.cy * dbx, e1 = r.bx * dcy - r.cx * dby, e2 = r.bx * dcx - r.cx * dbx + r.cy * dby;
    const double gxy = gamma_ * (e0 + e1);
    const double k = r.ss * kFactor;
    const double s0 = (muPrime_ * e0 + gxy) * k, s1 = (muPrime_ * e1 + gxy) * k, s2 = (0.5 * muPrime_ * e2) * k;
    const V3 fb = f0 * (r.cy * s0 - r.cx * s2) + f1 * (r.cy * s2 - r.cx * s1);
    const V3 fc = f0 * (r.bx * s2) + f1 * (r.bx * s1);
    scatter(df.data(), e.v[0], fb + fc);
    scatter(df.data(), e.v[1], -fb);
    scatter(df.data(), e.v[2], -fc);
  }
}

double TriangularFEMOptim::potentialEnergy(std::span<const double> x) const {
  checkSize(x, "x", "potentialEnergy");
  double energy = 0.0;
  for (const FemTriangle& e : elements()) {
    V3 f0, f1, ab, ac;
    if (!frame(x.data(), e, f0, f1, ab, ac)) continue;
    const RestShape r(e);
    const double dbx = r.bx - f0.dot(ab), dcx = r.cx - f0.dot(ac), dcy = r.cy - f1.dot(ac);
    const double e0 = r.cy * dbx, e1 = r.bx * dcy, e2 = r.bx * dcx - r.cx * dbx;
    const double gxy = gamma_ * (e0 + e1);
    energy += 0.5 * r.ss * (e0 * (muPrime_ * e0 + gxy) + e1 * (muPrime_ * e1 + gxy) + 0.5 * muPrime_ * e2 * e2);
  }
  return energy;
}

void TriangularFEMOptim::addKToMatrix(std::span<const double> x, MatrixAccumulator& m, double kFactor) const {
  checkSize(x, "x", "addKToMatrix");
  using Mat23 = Eigen::Matrix<double, 2, 3>;
  using Mat36 = Eigen::Matrix<double, 3, 6>;
  for (const FemTriangle& e : elements()) {
    const std::array<PointId, 3> v{PointId(e.v[0]), PointId(e.v[1]), PointId(e.v[2])};
    V3 f0, f1, ab, ac;
    if (!frame(x.data(), e, f0, f1, ab, ac)) {  // the pattern stays: zero blocks
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) m.addBlock(v[std::size_t(i)], v[std::size_t(j)], Eigen::Matrix3d::Zero());
      continue;
    }
    const RestShape r(e);
    // The 2D strain-displacement matrix over (a, b, c) (times 2A) and the material matrix.
    Mat36 B;
    B << -r.cy, 0, r.cy, 0, 0, 0,                            //
        0, r.cx - r.bx, 0, -r.cx, 0, r.bx,                   //
        r.cx - r.bx, -r.cy, -r.cx, r.cy, r.bx, 0;            //
    Eigen::Matrix3d D;
    D << muPrime_ + gamma_, gamma_, 0, gamma_, muPrime_ + gamma_, 0, 0, 0, 0.5 * muPrime_;
    const Eigen::Matrix<double, 6, 6> K = (-kFactor * r.ss) * (B.transpose() * D * B);
    Mat23 F;
    F.row(0) = f0.transpose();
    F.row(1) = f1.transpose();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        m.addBlock(v[std::size_t(i)], v[std::size_t(j)], F.transpose() * K.block<2, 2>(2 * i, 2 * j) * F);
  }
}

namespace {
const bool registered = ForceFieldRegistry::instance().add({
    "TriangularFEMForceFieldOptim",
    "SOFA's TriangularFEMForceFieldOptim (method large), formula for formula: frame along the first edge, K with the frame held",
    {{"youngModulus", "E, >= 0 (default 1000)"},
     {"poissonRatio", "nu, in (-1, 0.5) (default 0.3)"},
     {"thickness", "h, >= 0 (default 1; SOFA's has none: 1)"},
     {"restScale", "> 0, scales every element's rest shape, as SOFA's restScale (default 1)"}},
    {},
    [](const ParameterSource& s) -> std::any {
      TriangularFEMParameters p;
      p.youngModulus = s.nonNegative("youngModulus", p.youngModulus);
      p.poissonRatio = s.number("poissonRatio", p.poissonRatio);
      p.thickness = s.nonNegative("thickness", p.thickness);
      p.restScale = s.positive("restScale", p.restScale);
      s.check([&] { p.validate(); });
      return p;
    },
    [](const std::any& p, topology::Topology& t) -> std::unique_ptr<ForceField> {
      return std::make_unique<TriangularFEMOptim>(t, std::any_cast<const TriangularFEMParameters&>(p));
    }});
}  // namespace

}  // namespace cutsim::forcefields
