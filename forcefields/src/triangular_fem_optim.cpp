// SOFA's TriangularFEMForceFieldOptim formulation on TriangularFEM's table
// (triangular_fem_optim.hpp has the formulas).
#include "cutsim/forcefields/triangular_fem_optim.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <limits>

#include "cutsim/base/errors.hpp"
#include "cutsim/forcefields/registry.hpp"

namespace cutsim::forcefields {
namespace {

// The arithmetic below is SOFA's, operation for operation and in its order (this file is compiled
// without contraction of multiply-adds, -ffp-contract=off, as SOFA's x86-64 builds are): a scene
// whose result depends on every rounding (docs/sofa.md) then gives SOFA's numbers.

struct V {
  double x, y, z;
};
inline V load(const double* a, std::uint32_t p) {
  return {a[3 * p], a[3 * p + 1], a[3 * p + 2]};
}
inline V sub(const V& a, const V& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline V mul(const V& a, double s) {
  return {a.x * s, a.y * s, a.z * s};
}
inline V add(const V& a, const V& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
inline double dot(const V& a, const V& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline V cross(const V& a, const V& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
/// SOFA's Vec::normalize: divided by its norm when the norm exceeds epsilon.
inline bool normalize(V& a) {
  const double n = std::sqrt(dot(a, a));
  if (!(n > std::numeric_limits<double>::epsilon())) return false;
  a.x /= n;
  a.y /= n;
  a.z /= n;
  return true;
}
inline void addTo(double* f, std::uint32_t p, const V& v) {
  f[3 * p] += v.x;
  f[3 * p + 1] += v.y;
  f[3 * p + 2] += v.z;
}
inline void subFrom(double* f, std::uint32_t p, const V& v) {
  f[3 * p] -= v.x;
  f[3 * p + 1] -= v.y;
  f[3 * p + 2] -= v.z;
}

/// SOFA's computeTriangleRotation: f0 along ab, f1 = (ab x ac) x ab; false when either has no
/// direction (a flat triangle: no frame, no force; SOFA would divide by zero).
bool frameOf(const V& ab, const V& ac, V& f0, V& f1) {
  f0 = ab;
  const V n = cross(ab, ac);
  f1 = cross(n, ab);
  return normalize(f0) && normalize(f1);
}

/// The element at x: its edges from a and its frame (SOFA's addForce prologue).
struct Current {
  V ab, ac, f0, f1;
};
bool current(const double* x, const FemTriangle& e, Current& c) {
  const V a = load(x, e.v[0]);
  c.ab = sub(load(x, e.v[1]), a);
  c.ac = sub(load(x, e.v[2]), a);
  return frameOf(c.ab, c.ac, c.f0, c.f1);
}

/// SOFA's strain (times 2A) of the displacement rest minus current, in the current frame.
struct Strain {
  double e0, e1, e2;
};
template <class Rest>
Strain strainOf(const Rest& r, const Current& c) {
  const double dbx = r.bx - dot(c.f0, c.ab), dcx = r.cx - dot(c.f0, c.ac),
               dcy = r.cy - dot(c.f1, c.ac);
  return {r.cy * dbx, r.bx * dcy, r.bx * dcx - r.cx * dbx};
}

/// SOFA's forces of a strain (times 2A), its stress scaled by `scale` (1 / 4A, times the kFactor
/// for a change of force): f_b, f_c, and f_a = -f_b - f_c.
struct Forces {
  V fa, fb, fc;
};
template <class Rest>
Forces forcesOf(const Rest& r, const V& f0, const V& f1, double e0, double e1, double e2, double mu,
                double gamma, double scale) {
  const double gxy = gamma * (e0 + e1);
  const double s0 = (mu * e0 + gxy) * scale, s1 = (mu * e1 + gxy) * scale,
               s2 = (0.5 * mu * e2) * scale;
  Forces out;
  out.fb = add(mul(f0, r.cy * s0 - r.cx * s2), mul(f1, r.cy * s2 - r.cx * s1));
  out.fc = add(mul(f0, r.bx * s2), mul(f1, r.bx * s1));
  out.fa = sub(mul(out.fb, -1.0), out.fc);
  return out;
}

}  // namespace

TriangularFEMOptim::RestFrame TriangularFEMOptim::restFrame(const FemTriangle& e) const {
  // SOFA's initTriangleInfo, on the rest positions (scaled by restScale when it is not 1).
  RestFrame r{};
  const auto pa = topo_->restPosition(topology::PointId(e.v[0]));
  const auto pb = topo_->restPosition(topology::PointId(e.v[1]));
  const auto pc = topo_->restPosition(topology::PointId(e.v[2]));
  const V a{pa[0], pa[1], pa[2]};
  V ab = sub(V{pb[0], pb[1], pb[2]}, a), ac = sub(V{pc[0], pc[1], pc[2]}, a);
  if (restScale_ != 1.0) {
    ab = mul(ab, restScale_);
    ac = mul(ac, restScale_);
  }
  V f0, f1;
  frameOf(ab, ac, f0, f1);
  r.bx = dot(f0, ab);
  r.cx = dot(f0, ac);
  r.cy = dot(f1, ac);
  r.ss = 0.5 / (r.bx * r.cy);
  return r;
}

TriangularFEMOptim::TriangularFEMOptim(topology::Topology& topology,
                                       TriangularFEMParameters parameters)
    : TriangularFEM(topology, parameters), topo_(&topology), restScale_(parameters.restScale) {
  if (parameters.exactHessian)
    throw InvalidInput(
        "exactHessian",
        "TriangularFEMForceFieldOptim has no exact stiffness (SOFA's K holds the frame)");
  // SOFA's computeMuGamma, with the thickness folded into E (SOFA's element has none: h = 1).
  const double E = parameters.thickness == 1.0 ? parameters.youngModulus
                                               : parameters.youngModulus * parameters.thickness;
  const double nu = parameters.poissonRatio;
  muPrime_ = E / (1 + nu);
  gamma_ = (E * nu) / (1 - nu * nu);
}

void TriangularFEMOptim::addForce(std::span<const double> x, std::span<const double>,
                                  std::span<double> f) const {
  checkSize(x, "x", "addForce");
  checkSize(f, "f", "addForce");
  for (const FemTriangle& e : elements()) {
    Current c;
    if (!current(x.data(), e, c)) continue;
    const RestFrame r = restFrame(e);
    const auto [e0, e1, e2] = strainOf(r, c);
    const Forces g = forcesOf(r, c.f0, c.f1, e0, e1, e2, muPrime_, gamma_, r.ss);
    addTo(f.data(), e.v[0], g.fa);
    addTo(f.data(), e.v[1], g.fb);
    addTo(f.data(), e.v[2], g.fc);
  }
}

void TriangularFEMOptim::addDForce(std::span<const double> x, std::span<const double> dx,
                                   std::span<double> df, double kFactor, double) const {
  checkSize(x, "x", "addDForce");
  checkSize(dx, "dx", "addDForce");
  checkSize(df, "df", "addDForce");
  if (kFactor == 0.0) return;
  for (const FemTriangle& e : elements()) {
    Current c;
    if (!current(x.data(), e, c)) continue;
    const RestFrame r = restFrame(e);
    const V &f0 = c.f0, &f1 = c.f1;
    const V da = load(dx.data(), e.v[0]);
    const V dab = sub(load(dx.data(), e.v[1]), da), dac = sub(load(dx.data(), e.v[2]), da);
    const double dbx = dot(f0, dab), dby = dot(f1, dab), dcx = dot(f0, dac), dcy = dot(f1, dac);
    const double e0 = r.cy * dbx, e1 = r.bx * dcy - r.cx * dby,
                 e2 = r.bx * dcx - r.cx * dbx + r.cy * dby;
    const Forces g = forcesOf(r, f0, f1, e0, e1, e2, muPrime_, gamma_, r.ss * kFactor);
    subFrom(df.data(), e.v[0], g.fa);  // SOFA: df -= dfa, dfb, dfc (its kFactor carries the sign)
    subFrom(df.data(), e.v[1], g.fb);
    subFrom(df.data(), e.v[2], g.fc);
  }
}

double TriangularFEMOptim::potentialEnergy(std::span<const double> x) const {
  checkSize(x, "x", "potentialEnergy");
  double energy = 0.0;
  for (const FemTriangle& e : elements()) {
    Current c;
    if (!current(x.data(), e, c)) continue;
    const RestFrame r = restFrame(e);
    const auto [e0, e1, e2] = strainOf(r, c);
    const double gxy = gamma_ * (e0 + e1);
    energy += 0.5 * r.ss *
              (e0 * (muPrime_ * e0 + gxy) + e1 * (muPrime_ * e1 + gxy) + 0.5 * muPrime_ * e2 * e2);
  }
  return energy;
}

void TriangularFEMOptim::addKToMatrix(std::span<const double> x, MatrixAccumulator& m,
                                      double kFactor) const {
  checkSize(x, "x", "addKToMatrix");
  using Mat23 = Eigen::Matrix<double, 2, 3>;
  using Mat36 = Eigen::Matrix<double, 3, 6>;
  for (const FemTriangle& e : elements()) {
    const std::array<PointId, 3> v{PointId(e.v[0]), PointId(e.v[1]), PointId(e.v[2])};
    Current c;
    if (!current(x.data(), e, c)) {  // the pattern stays: zero blocks
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          m.addBlock(v[std::size_t(i)], v[std::size_t(j)], Eigen::Matrix3d::Zero());
      continue;
    }
    const RestFrame r = restFrame(e);
    // The 2D strain-displacement matrix over (a, b, c) (times 2A) and the material matrix.
    Mat36 B;
    B << -r.cy, 0, r.cy, 0, 0, 0,                  //
        0, r.cx - r.bx, 0, -r.cx, 0, r.bx,         //
        r.cx - r.bx, -r.cy, -r.cx, r.cy, r.bx, 0;  //
    Eigen::Matrix3d D;
    D << muPrime_ + gamma_, gamma_, 0, gamma_, muPrime_ + gamma_, 0, 0, 0, 0.5 * muPrime_;
    const Eigen::Matrix<double, 6, 6> K = (-kFactor * r.ss) * (B.transpose() * D * B);
    Mat23 F;
    F << c.f0.x, c.f0.y, c.f0.z, c.f1.x, c.f1.y, c.f1.z;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        m.addBlock(v[std::size_t(i)], v[std::size_t(j)],
                   F.transpose() * K.block<2, 2>(2 * i, 2 * j) * F);
  }
}

namespace {
const bool registered = ForceFieldRegistry::instance().add(
    {"TriangularFEMForceFieldOptim",
     "SOFA's TriangularFEMForceFieldOptim (method large), formula for formula: frame along the "
     "first edge, K with the frame held",
     {{"youngModulus", KeyType::Number, "E, >= 0 (default 1000)"},
      {"poissonRatio", KeyType::Number, "nu, in (-1, 0.5) (default 0.3)"},
      {"thickness", KeyType::Number, "h, >= 0 (default 1; SOFA's has none: 1)"},
      {"restScale", KeyType::Number,
       "> 0, scales every element's rest shape, as SOFA's restScale (default 1)"}},
     {},
     [](const ParameterSource& s) -> std::any { return readTriangularFEMParameters(s, false); },
     [](const std::any& p, topology::Topology& t) -> std::unique_ptr<ForceField> {
       return std::make_unique<TriangularFEMOptim>(
           t, std::any_cast<const TriangularFEMParameters&>(p));
     }});
}  // namespace

}  // namespace cutsim::forcefields
