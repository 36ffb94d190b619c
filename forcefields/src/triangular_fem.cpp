#include "cutsim/forcefields/triangular_fem.hpp"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/forcefields/registry.hpp"

namespace cutsim::forcefields {
namespace {

using topology::kInvalidIndex;
using topology::Topology;

using TableStatus = detail::FemTableTraits::Status;

/// A triangle whose rest area is below this fraction of its longest edge squared has no element.
constexpr double kMinRestShape = 1e-12;
/// A current configuration whose area ratio det S is below this fraction of (tr S)^2 has no
/// rotation (cond(S) would exceed 1e12): no force, zero blocks.
constexpr double kMinCurrentShape = 1e-12;

using Mat32 = Eigen::Matrix<double, 3, 2>;

std::string triangleName(TriangleId t) {
  return "triangle " + std::to_string(t.idx());
}

/// What one element gives at x.
struct ElementState {
  Mat32 f = Mat32::Zero();                      // F
  Eigen::Matrix2d s = Eigen::Matrix2d::Zero();  // S = sqrt(F^T F)
  double detS = 0.0;
  bool hasRotation = false;
  Mat32 r = Mat32::Zero();  // R = F S^-1 (when hasRotation)
};

inline Eigen::Vector3d point(const double* x, std::uint32_t p) {
  const double* q = x + 3 * static_cast<std::size_t>(p);
  return {q[0], q[1], q[2]};
}

ElementState evaluate(const FemTriangle& e, const double* x) {
  ElementState st;
  const Eigen::Vector3d xa = point(x, e.v[0]);
  const Eigen::Vector3d db = point(x, e.v[1]) - xa;
  const Eigen::Vector3d dc = point(x, e.v[2]) - xa;
  st.f.col(0) = db * e.g[0] + dc * e.g[2];
  st.f.col(1) = db * e.g[1] + dc * e.g[3];
  const double c00 = st.f.col(0).squaredNorm();
  const double c11 = st.f.col(1).squaredNorm();
  const double c01 = st.f.col(0).dot(st.f.col(1));
  // sqrt of a symmetric positive semi-definite 2x2 matrix: (C + sqrt(det C) I) / sqrt(tr C +
  // 2 sqrt(det C)), with det S = sqrt(det C).
  const double s = std::sqrt(std::max(0.0, c00 * c11 - c01 * c01));
  const double t2 = c00 + c11 + 2.0 * s;
  if (!(t2 > 0.0)) return st;  // F = 0: S = 0
  const double inv = 1.0 / std::sqrt(t2);
  st.s << (c00 + s) * inv, c01 * inv, c01 * inv, (c11 + s) * inv;
  st.detS = s;
  if (s > kMinCurrentShape * t2) {
    Eigen::Matrix2d sInv;
    sInv << st.s(1, 1), -st.s(0, 1), -st.s(1, 0), st.s(0, 0);
    sInv /= s;
    st.r = st.f * sInv;
    st.hasRotation = true;
  }
  return st;
}

/// sigma = 2 mu eps + lambda tr(eps) I.
inline Eigen::Matrix2d stress(const Eigen::Matrix2d& eps, double mu, double lambda) {
  Eigen::Matrix2d sigma = 2.0 * mu * eps;
  const double tr = lambda * (eps(0, 0) + eps(1, 1));
  sigma(0, 0) += tr;
  sigma(1, 1) += tr;
  return sigma;
}

/// The exact derivative of P = R sigma(S - I) along dF, for an element with a rotation (see the
/// header): dP = 2 mu dF + (lambda tr(eps) - 2 mu) dR + lambda tr(dS) R, with dS the solution of
/// S dS + dS S = F^T dF + dF^T F and dR = (dF - R dS) S^-1.
Mat32 exactDP(const ElementState& st, const Mat32& dF, double mu, double lambda) {
  const Eigen::Matrix2d ftdf = st.f.transpose() * dF;
  const Eigen::Matrix2d c = ftdf + ftdf.transpose();
  // The 2x2 Sylvester equation S X + X S = C in closed form: with t = tr S, d = det S, the 2x2
  // identity S X + X S = t X + tr(X) S + (tr(S X) - t tr X) I gives tr(S X) = tr(C) / 2 and
  // tr X = (t tr C - tr(S C)) / (2 d), then X = (C - tr(X) S - (tr(S X) - t tr X) I) / t.
  const double t = st.s(0, 0) + st.s(1, 1), d = st.detS;
  const double trC = c(0, 0) + c(1, 1);
  const double trSC = st.s(0, 0) * c(0, 0) + 2.0 * st.s(0, 1) * c(0, 1) + st.s(1, 1) * c(1, 1);
  const double trX = (t * trC - trSC) / (2.0 * d);
  const double shift = 0.5 * trC - t * trX;
  Eigen::Matrix2d dS = c - trX * st.s;
  dS(0, 0) -= shift;
  dS(1, 1) -= shift;
  dS /= t;
  Eigen::Matrix2d sInv;
  sInv << st.s(1, 1), -st.s(0, 1), -st.s(1, 0), st.s(0, 0);
  sInv /= d;
  const Mat32 dR = (dF - st.r * dS) * sInv;
  const double trEps = t - 2.0;
  return 2.0 * mu * dF + (lambda * trEps - 2.0 * mu) * dR + (lambda * (dS(0, 0) + dS(1, 1))) * st.r;
}

/// The geometric stiffness of tension that the corotational K lacks (see "Stiffness" in the
/// header): the exact Hessian of the element's energy in F, written in the modes of F = U Sigma
/// V^T (Smith, de Goes and Kim 2019, for a 3 x 2 F), is the corotational K plus two kinds of
/// modes, each kept here only where its eigenvalue is positive (the projection to the nearest
/// positive semi-definite matrix, in closed form):
///  - the twist, dF = R J / sqrt 2 (J = [[0, 1], [-1, 0]]), eigenvalue
///    (Psi_1 + Psi_2) / (s_1 + s_2) = 2 (mu + lambda) (tr S - 2) / tr S;
///  - the two out-of-plane modes, dF = n v_i^T (n the element's normal, v_i the eigenvectors of
///    S), eigenvalues Psi_i / s_i = (2 mu (s_i - 1) + lambda (tr S - 2)) / s_i, gathered in the
///    2 x 2 matrix m = sum_i max(0, Psi_i / s_i) v_i v_i^T.
/// The scaling and flip modes are the corotational K's own (eigenvalues 2 mu + 2 lambda, 2 mu and
/// 2 mu, never negative: mu + lambda = E h / (2 (1 - nu)) > 0). In tension every eigenvalue is
/// positive and the projected K is the exact one; in compression the extra modes vanish and it is
/// the corotational K.
struct TensionModes {
  double twist = 0.0;  // max(0, twist eigenvalue)
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  Eigen::Matrix2d m = Eigen::Matrix2d::Zero();
};

TensionModes tensionModes(const ElementState& st, double mu, double lambda) {
  TensionModes t;
  const double trS = st.s(0, 0) + st.s(1, 1);
  const double trEps = trS - 2.0;
  t.twist = std::max(0.0, 2.0 * (mu + lambda) * trEps / trS);
  t.n = st.r.col(0).cross(st.r.col(1)).normalized();
  // Eigenvalues of S, m +- dev, and its spectral projectors (S - s_j I) / (s_i - s_j).
  const double mean = 0.5 * trS;
  const double half = 0.5 * (st.s(0, 0) - st.s(1, 1));
  const double dev = std::hypot(half, st.s(0, 1));
  const double s1 = mean + dev, s2 = mean - dev;
  // Divided by s_i, floored at 1e-3 tr S: a triangle nearly collapsed across while stretched
  // along would get an out-of-plane stiffness without bound (exact, but ruinous for a solver's
  // conditioning); there the projected K is below the exact one.
  const double floor = 1e-3 * trS;
  const double c1 = std::max(0.0, (2.0 * mu * (s1 - 1.0) + lambda * trEps) / std::max(s1, floor));
  const double c2 = std::max(0.0, (2.0 * mu * (s2 - 1.0) + lambda * trEps) / std::max(s2, floor));
  if (dev > 0.0) {
    Eigen::Matrix2d d;  // (S - mean I) / dev = P1 - P2, with P1 + P2 = I
    d << half / dev, st.s(0, 1) / dev, st.s(0, 1) / dev, -half / dev;
    t.m = 0.5 * (c1 + c2) * Eigen::Matrix2d::Identity() + 0.5 * (c1 - c2) * d;
  } else {
    t.m = c1 * Eigen::Matrix2d::Identity();
  }
  return t;
}

inline std::array<Eigen::Vector2d, 3> gradients(const FemTriangle& e) {
  const Eigen::Vector2d gb(e.g[0], e.g[1]), gc(e.g[2], e.g[3]);
  return {-gb - gc, gb, gc};
}

inline void scatter(double* out, std::uint32_t p, const Eigen::Vector3d& v) {
  double* q = out + 3 * static_cast<std::size_t>(p);
  q[0] += v[0];
  q[1] += v[1];
  q[2] += v[2];
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Parameters

void TriangularFEMParameters::validate() const {
  requireFiniteNonNegative("youngModulus", youngModulus);
  if (!std::isfinite(poissonRatio) || !(poissonRatio > -1.0) || !(poissonRatio < 0.5)) {
    throw InvalidInput("poissonRatio",
                       "must be a finite number in (-1, 0.5), got " + describeNumber(poissonRatio));
  }
  requireFiniteNonNegative("thickness", thickness);
  requireFinitePositive("restScale", restScale);
}

// ---------------------------------------------------------------------------------------------
// Construction and the table

TriangularFEM::TriangularFEM(Topology& topology, TriangularFEMParameters parameters)
    : topology_(&topology), params_(parameters) {
  params_.validate();
  const double nu = params_.poissonRatio;
  mu_ = params_.thickness * params_.youngModulus / (2.0 * (1.0 + nu));
  lambda_ = params_.thickness * params_.youngModulus * nu / (1.0 - nu * nu);
  const std::vector<FemRecord> records = buildFromScratch(topology, params_);
  table_.reset(topology.triangleCapacity(), records.size());
  for (const FemRecord& r : records) setTriangle(r.triangle, r);
  subscription_ = topology.subscribe(*this);
}

TriangularFEM::~TriangularFEM() = default;

FemRecord TriangularFEM::elementFromMesh(const Topology& t, TriangleId tri,
                                         const TriangularFEMParameters& parameters) {
  FemRecord r;
  r.triangle = tri;
  const topology::TriangleVertices v = t.triangleVertices(tri);
  const topology::Vec3 pa = t.restPosition(v[0]), pb = t.restPosition(v[1]),
                       pc = t.restPosition(v[2]);
  const Eigen::Vector3d xa(pa[0], pa[1], pa[2]), xb(pb[0], pb[1], pb[2]), xc(pc[0], pc[1], pc[2]);
  const Eigen::Vector3d e1 = xb - xa, e2 = xc - xa;
  const double lb = e1.norm();
  const double twiceArea = e1.cross(e2).norm();
  const double longest = std::max({lb, e2.norm(), (xc - xb).norm()});
  if (!(lb > 0.0) || !(twiceArea > kMinRestShape * longest * longest)) {
    r.degenerate = true;
    return r;
  }
  // Rest frame: x along ab, y in the plane towards c, the mesh triangle scaled by s = restScale
  // about a (the prestrain; the test above is scale-free, so s does not change which triangles
  // are degenerate): Pa = (0, 0), Pb = (bx, 0), Pc = (cx, cy).
  const double s = parameters.restScale;
  const double bx = s * lb;
  const double cx = s * (e2.dot(e1) / lb);
  const double cy = s * (twiceArea / lb);
  // Dm = [[bx, cx], [0, cy]]; Dm^-1 = [[1/bx, -cx/(bx cy)], [0, 1/cy]]; rows are g_b, g_c.
  r.vertices = {v[0], v[1], v[2]};
  r.g = {1.0 / bx, -cx / (bx * cy), 0.0, 1.0 / cy};
  r.area = 0.5 * twiceArea * (s * s);  // the scaled rest area (bit for bit the mesh's for s = 1)
  return r;
}

std::vector<FemRecord> TriangularFEM::buildFromScratch(const Topology& topology,
                                                       const TriangularFEMParameters& parameters) {
  std::vector<FemRecord> records;
  const std::vector<TriangleId> tris = topology.triangles();
  records.reserve(tris.size());
  for (TriangleId t : tris) records.push_back(elementFromMesh(topology, t, parameters));
  return records;
}

void TriangularFEM::clearTriangle(TriangleId t) {
  if (!table_.hasEntry(t) && table_.status(t) == TableStatus::Degenerate) --numDegenerate_;
  table_.setStatus(t, TableStatus::DeadTriangle);
}

void TriangularFEM::setTriangle(TriangleId t, const FemRecord& r) {
  clearTriangle(t);
  if (r.degenerate) {
    table_.setStatus(t, TableStatus::Degenerate);
    ++numDegenerate_;
    return;
  }
  table_.set(t, {{r.vertices[0].idx(), r.vertices[1].idx(), r.vertices[2].idx()}, 0, r.g, r.area});
}

FemRecord TriangularFEM::element(TriangleId t) const {
  FemRecord r;
  if (table_.isEmpty(t)) return r;
  r.triangle = t;
  const Index i = table_.find(t);
  if (i == table_.kNoEntry) {
    r.degenerate = true;
    return r;
  }
  const FemTriangle& e = table_.entry(i);
  r.vertices = {PointId(e.v[0]), PointId(e.v[1]), PointId(e.v[2])};
  r.g = e.g;
  r.area = e.area;
  return r;
}

// ---------------------------------------------------------------------------------------------
// Forces

void TriangularFEM::checkSize(std::span<const double> a, const char* name, const char* what) const {
  const std::size_t need = 3 * static_cast<std::size_t>(topology_->pointCapacity());
  if (a.size() < need) {
    throw std::invalid_argument(std::string("TriangularFEM::") + what + ": " + name +
                                " must hold 3 * pointCapacity = " + std::to_string(need) +
                                " doubles, got " + std::to_string(a.size()));
  }
}

void TriangularFEM::addForce(std::span<const double> x, std::span<const double> /*v*/,
                             std::span<double> f) const {
  checkSize(x, "x", "addForce");
  checkSize(f, "f", "addForce");
  for (const FemTriangle& e : table_.entries()) {
    const ElementState st = evaluate(e, x.data());
    if (!st.hasRotation) continue;
    const Eigen::Matrix2d sigma = stress(st.s - Eigen::Matrix2d::Identity(), mu_, lambda_);
    const Mat32 p = (-e.area) * (st.r * sigma);  // -A h P (h folded into mu, lambda)
    const Eigen::Vector3d fb = p * Eigen::Vector2d(e.g[0], e.g[1]);
    const Eigen::Vector3d fc = p * Eigen::Vector2d(e.g[2], e.g[3]);
    scatter(f.data(), e.v[1], fb);
    scatter(f.data(), e.v[2], fc);
    scatter(f.data(), e.v[0], -(fb + fc));
  }
}

void TriangularFEM::addDForce(std::span<const double> x, std::span<const double> dx,
                              std::span<double> df, double kFactor, double /*bFactor*/) const {
  checkSize(x, "x", "addDForce");
  checkSize(dx, "dx", "addDForce");
  checkSize(df, "df", "addDForce");
  if (kFactor == 0.0) return;
  for (const FemTriangle& e : table_.entries()) {
    const ElementState st = evaluate(e, x.data());
    if (!st.hasRotation) continue;
    const Eigen::Vector3d da = point(dx.data(), e.v[0]);
    const Eigen::Vector3d db = point(dx.data(), e.v[1]) - da;
    const Eigen::Vector3d dc = point(dx.data(), e.v[2]) - da;
    Mat32 dF;
    dF.col(0) = db * e.g[0] + dc * e.g[2];
    dF.col(1) = db * e.g[1] + dc * e.g[3];
    Mat32 dP;
    if (params_.exactHessian) {
      dP = (-kFactor * e.area) * exactDP(st, dF, mu_, lambda_);
    } else {
      const Eigen::Matrix2d local = st.r.transpose() * dF;
      const Eigen::Matrix2d dEps = 0.5 * (local + local.transpose());
      Mat32 h = st.r * stress(dEps, mu_, lambda_);
      if (params_.tangent == TriangularFEMParameters::Tangent::Projected) {
        const TensionModes t = tensionModes(st, mu_, lambda_);
        // twist: twist <Q, dF> Q with Q = R J / sqrt 2, <Q, dF> = (local01 - local10) / sqrt 2.
        const double w = 0.5 * t.twist * (local(0, 1) - local(1, 0));
        h.col(0) -= w * st.r.col(1);  // R J = [-r1, r0]
        h.col(1) += w * st.r.col(0);
        // out of plane: n (dF^T n)^T m.
        const Eigen::Vector2d dn = dF.transpose() * t.n;
        h += t.n * (t.m * dn).transpose();
      }
      dP = (-kFactor * e.area) * h;
    }
    const Eigen::Vector3d fb = dP * Eigen::Vector2d(e.g[0], e.g[1]);
    const Eigen::Vector3d fc = dP * Eigen::Vector2d(e.g[2], e.g[3]);
    scatter(df.data(), e.v[1], fb);
    scatter(df.data(), e.v[2], fc);
    scatter(df.data(), e.v[0], -(fb + fc));
  }
}

double TriangularFEM::potentialEnergy(std::span<const double> x) const {
  checkSize(x, "x", "potentialEnergy");
  double energy = 0.0;
  for (const FemTriangle& e : table_.entries()) {
    const ElementState st = evaluate(e, x.data());
    const Eigen::Matrix2d eps = st.s - Eigen::Matrix2d::Identity();
    const double tr = eps(0, 0) + eps(1, 1);
    const double epsEps =
        eps(0, 0) * eps(0, 0) + 2.0 * eps(0, 1) * eps(0, 1) + eps(1, 1) * eps(1, 1);
    energy += e.area * (mu_ * epsEps + 0.5 * lambda_ * tr * tr);
  }
  return energy;
}

void TriangularFEM::addKToMatrix(std::span<const double> x, MatrixAccumulator& m,
                                 double kFactor) const {
  checkSize(x, "x", "addKToMatrix");
  if (params_.exactHessian) {
    addExactKToMatrix(x, m, kFactor);
    return;
  }
  const bool projected = params_.tangent == TriangularFEMParameters::Tangent::Projected;
  for (const FemTriangle& e : table_.entries()) {
    const ElementState st = evaluate(e, x.data());
    const std::array<Eigen::Vector2d, 3> g = gradients(e);
    TensionModes t;
    std::array<Eigen::Vector3d, 3> rjg;  // R J g_k: the twist mode's force directions
    if (st.hasRotation && projected) {
      t = tensionModes(st, mu_, lambda_);
      for (int k = 0; k < 3; ++k) rjg[k] = st.r.col(0) * g[k][1] - st.r.col(1) * g[k][0];
    }
    for (int k = 0; k < 3; ++k) {
      for (int l = 0; l < 3; ++l) {
        Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
        if (st.hasRotation) {
          Eigen::Matrix2d mkl = (mu_ * g[k].dot(g[l])) * Eigen::Matrix2d::Identity();
          mkl += mu_ * (g[l] * g[k].transpose()) + lambda_ * (g[k] * g[l].transpose());
          Eigen::Matrix3d h = st.r * mkl * st.r.transpose();
          if (projected) {
            h += (0.5 * t.twist) * (rjg[k] * rjg[l].transpose());
            h += g[l].dot(t.m * g[k]) * (t.n * t.n.transpose());
          }
          block = (-kFactor * e.area) * h;
        }
        m.addBlock(PointId(e.v[k]), PointId(e.v[l]), block);
      }
    }
  }
}

void TriangularFEM::addExactKToMatrix(std::span<const double> x, MatrixAccumulator& m,
                                      double kFactor) const {
  using Mat9 = Eigen::Matrix<double, 9, 9>;
  for (const FemTriangle& e : table_.entries()) {
    const ElementState st = evaluate(e, x.data());
    const std::array<Eigen::Vector2d, 3> g = gradients(e);
    Mat9 ke = Mat9::Zero();
    if (st.hasRotation) {
      // Column (3 l + i): the force derivatives for dx = unit vector i at vertex l, dF = e_i g_l^T.
      for (int l = 0; l < 3; ++l) {
        for (int i = 0; i < 3; ++i) {
          Mat32 dF = Mat32::Zero();
          dF.row(i) = g[l].transpose();
          const Mat32 dP = (-kFactor * e.area) * exactDP(st, dF, mu_, lambda_);
          for (int k = 0; k < 3; ++k) ke.block<3, 1>(3 * k, 3 * l + i) = dP * g[k];
        }
      }
      ke = (0.5 * (ke + ke.transpose())).eval();  // symmetric up to rounding: make it exactly so
    }
    for (int k = 0; k < 3; ++k) {
      for (int l = 0; l < 3; ++l) {
        m.addBlock(PointId(e.v[k]), PointId(e.v[l]), ke.block<3, 3>(3 * k, 3 * l));
      }
    }
  }
}

bool TriangularFEM::setExactStiffness(bool exact) {
  params_.exactHessian = exact;
  return true;
}

void TriangularFEM::addBToMatrix(std::span<const double> /*x*/, MatrixAccumulator& /*m*/,
                                 double /*bFactor*/) const {}

void TriangularFEM::draw(std::vector<std::array<PointId, 2>>& segments) const {
  segments.reserve(segments.size() + 3 * table_.size());
  for (const FemTriangle& e : table_.entries()) {
    const PointId a(e.v[0]), b(e.v[1]), c(e.v[2]);
    segments.push_back({a, b});
    segments.push_back({b, c});
    segments.push_back({c, a});
  }
}

// ---------------------------------------------------------------------------------------------
// Topology events: only triangles carry elements. A triangle re-attached to other vertices (an
// incision) is destroyed and created anew, so a triangle's element never changes in place.

void TriangularFEM::onTrianglesDestroyed(const Topology&, const topology::TrianglesDestroyed& ev) {
  for (TriangleId t : ev.triangles) {
    if (table_.isEmpty(t)) {
      eventProblems_.push_back("triangles destroyed: " + triangleName(t) + " was not in the table");
      continue;
    }
    clearTriangle(t);
  }
}

void TriangularFEM::onTrianglesCreated(const Topology& t, const topology::TrianglesCreated& ev) {
  table_.grow(t);
  for (TriangleId tri : ev.triangles) {
    if (!table_.isEmpty(tri)) {
      eventProblems_.push_back("triangles created: " + triangleName(tri) +
                               " was already in the table");
    }
    setTriangle(tri, elementFromMesh(t, tri, params_));  // scaled by restScale, as at the start
  }
}

void TriangularFEM::onPointsRenumbered(const Topology&, const topology::Renumbering& ev) {
  table_.remapPoints(ev, eventProblems_);
}

void TriangularFEM::onTrianglesRenumbered(const Topology&, const topology::Renumbering& ev) {
  // The elements move with their triangles and are re-laid out in the new triangle order.
  table_.renumber(ev, eventProblems_);
}

// ---------------------------------------------------------------------------------------------
// Validation against a rebuild

namespace {

/// The same element up to the labelling of its vertices (a rotation of the triangle's): the same
/// rest area, and the same Gram matrix of the shape gradients per pair of vertex ids (which
/// determines the element's stiffness and is independent of the rest frame).
bool sameElement(const FemRecord& a, const FemRecord& b) {
  if (a.degenerate != b.degenerate) return false;
  if (a.degenerate) return true;
  const auto tol = [](double x, double y, double scale) {
    return std::fabs(x - y) <= 1e-10 * scale;
  };
  if (!tol(a.area, b.area, std::max(std::fabs(b.area), 1e-300))) return false;
  auto grads = [](const FemRecord& r) {
    std::map<PointId, Eigen::Vector2d> m;
    const Eigen::Vector2d gb(r.g[0], r.g[1]), gc(r.g[2], r.g[3]);
    m[r.vertices[0]] = -gb - gc;
    m[r.vertices[1]] = gb;
    m[r.vertices[2]] = gc;
    return m;
  };
  const auto ga = grads(a), gb = grads(b);
  if (ga.size() != 3 || gb.size() != 3) return false;
  // Same cyclic order (orientation) of the vertices.
  int shift = -1;
  for (int s = 0; s < 3; ++s) {
    if (a.vertices[0] == b.vertices[s]) shift = s;
  }
  if (shift < 0 || a.vertices[1] != b.vertices[(shift + 1) % 3] ||
      a.vertices[2] != b.vertices[(shift + 2) % 3]) {
    return false;
  }
  double scale = 0.0;
  for (const auto& [p, g] : gb) scale = std::max(scale, g.squaredNorm());
  for (const auto& [p, g] : ga) {
    const auto it = gb.find(p);
    if (it == gb.end()) return false;
    for (const auto& [q, h] : ga) {
      if (!tol(g.dot(h), it->second.dot(gb.at(q)), scale)) return false;
    }
  }
  return true;
}

std::string describeRecord(const FemRecord& r) {
  std::ostringstream os;
  os.precision(17);
  os << triangleName(r.triangle);
  if (r.degenerate) {
    os << " [degenerate]";
  } else {
    os << " [" << r.vertices[0] << " " << r.vertices[1] << " " << r.vertices[2] << ", area "
       << r.area << "]";
  }
  return os.str();
}

}  // namespace

void TriangularFEM::validate(const Topology& topology, std::vector<std::string>& problems) const {
  for (const std::string& p : eventProblems_) problems.push_back(p);
  // The table's own consistency, live triangles against its slots, elements on live points.
  table_.validate(topology, problems, "");
  std::size_t degenerate = 0;
  for (TriangleId t{0}; t.idx() < table_.numSlots(); ++t) {
    degenerate += !table_.hasEntry(t) && table_.status(t) == TableStatus::Degenerate ? 1 : 0;
  }
  if (degenerate != numDegenerate_) {
    problems.push_back("degenerate count " + std::to_string(numDegenerate_) + ", the table holds " +
                       std::to_string(degenerate));
  }
  const std::vector<FemRecord> ref = buildFromScratch(topology, params_);
  std::size_t refElements = 0;
  for (const FemRecord& r : ref) {
    refElements += r.degenerate ? 0 : 1;
    const FemRecord mine = element(r.triangle);
    if (mine.triangle.idx() == kInvalidIndex) {
      problems.push_back("no entry for " + triangleName(r.triangle) + ", a rebuild gives " +
                         describeRecord(r));
    } else if (!sameElement(mine, r)) {
      problems.push_back("table has " + describeRecord(mine) + ", a rebuild gives " +
                         describeRecord(r));
    }
  }
  if (refElements != table_.size()) {
    problems.push_back(std::to_string(table_.size()) + " elements, a rebuild has " +
                       std::to_string(refElements));
  }
}

}  // namespace cutsim::forcefields

// ---- the component's registration (scenes, and every other front end) ----

namespace cutsim::forcefields {
TriangularFEMParameters readTriangularFEMParameters(const ParameterSource& s,
                                                    bool withExactHessian) {
  TriangularFEMParameters p;
  p.youngModulus = s.nonNegative("youngModulus", p.youngModulus);
  p.poissonRatio = s.number("poissonRatio", p.poissonRatio);
  p.thickness = s.nonNegative("thickness", p.thickness);
  p.restScale = s.positive("restScale", p.restScale);
  if (withExactHessian) {
    p.exactHessian = s.boolean("exactHessian", p.exactHessian);
    p.tangent = s.choice("tangent", "projected", {"projected", "corotational"}) == "corotational"
                    ? TriangularFEMParameters::Tangent::Corotational
                    : TriangularFEMParameters::Tangent::Projected;
  }
  s.check([&] { p.validate(); });
  return p;
}

namespace {
const bool registered = ForceFieldRegistry::instance().add(
    {"TriangularFEM",
     "corotational linear membrane, one constant-strain triangle each (SOFA's "
     "TriangularFEMForceField)",
     {{"youngModulus", KeyType::Number, "E, >= 0 (default 1000)"},
      {"poissonRatio", KeyType::Number, "nu, in (-1, 0.5) (default 0.3)"},
      {"thickness", KeyType::Number, "h, >= 0 (default 1)"},
      {"restScale", KeyType::Number,
       "> 0, scales every element's rest shape (prestrain: < 1 puts a held sheet under "
       "tension, strain 1/restScale - 1) (default 1)"},
      {"tangent",
       KeyType::Choice,
       "the stiffness K of implicit steps: \"projected\", the exact Hessian projected to "
       "positive semi-definite per element (the corotational K plus the geometric stiffness of "
       "tension: a prestressed membrane stays still), or \"corotational\", R held constant",
       {"projected", "corotational"}},
      {"exactHessian", KeyType::Boolean,
       "K is the exact Hessian of the energy (indefinite in compression) instead of the "
       "tangent's (default false)"}},
     {},
     [](const ParameterSource& s) -> std::any { return readTriangularFEMParameters(s, true); },
     [](const std::any& p, topology::Topology& t) -> std::unique_ptr<ForceField> {
       return std::make_unique<TriangularFEM>(t, std::any_cast<const TriangularFEMParameters&>(p));
     }});
}  // namespace
void TriangularFEM::saveState(ArchiveWriter& out) const {
  fields(out, params_.exactHessian, numDegenerate_);
  table_.save(out);
}
void TriangularFEM::loadState(ArchiveReader& in) {
  fields(in, params_.exactHessian, numDegenerate_);
  table_.load(in);
  eventProblems_.clear();
  std::vector<std::string> problems;
  validate(*topology_, problems);
  if (!problems.empty()) in.fail(typeName() + ": " + problems.front());
}

}  // namespace cutsim::forcefields
