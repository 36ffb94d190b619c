#include "cutsim/forcefields/dihedral_bending.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>
#include <random>
#include <sstream>
#include <stdexcept>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/numbers.hpp"
#include "dual.hpp"
#include "hinge_table_impl.hpp"

namespace cutsim::forcefields {

template class detail::HingeTable<DihedralBending, detail::DihedralHingeTraits>;

namespace {

using detail::edgeName;
using topology::Topology;
using topology::Vec3;

constexpr double kPi = std::numbers::pi;

/// Rest wing heights at or below this fraction of the edge length make a sliver: no hinge.
constexpr double kRelativeRestHeight = 1e-8;
/// Current wing heights (and edge lengths) below this fraction of the hinge's size: no direction.
constexpr double kRelativeCurrentHeight2 = 1e-24;
/// Rest coordinates beyond this are not representable (squares of cross products would overflow).
constexpr double kMaxCoordinate = 1e60;
/// A hinge stiffer than this at rest (2 c / h^2) is refused (problemAtRest), as a spring is.
constexpr double kMaxHingeStiffness = 1e306;
/// Current l^2 at or beyond this (or not finite): the exact stiffness gives the hinge zero blocks
/// (its force overflows long before).
constexpr double kMaxLength2 = 1e300;

// The geometry is written once for a scalar type T: double (forces, the Gauss-Newton K), or a
// forward-mode dual (dual.hpp) whose derivatives give the exact Hessian of theta.
using detail::Dual;
using detail::value;

template <class T>
inline T dot(const T* a, const T* b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
/// dot(a, b) of the values (the same operations as dot for T = double).
template <class T>
inline double dotValue(const T* a, const T* b) {
  return value(a[0]) * value(b[0]) + value(a[1]) * value(b[1]) + value(a[2]) * value(b[2]);
}
template <class T>
inline void cross(const T* a, const T* b, T* c) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}

/// theta - theta0 wrapped to [-pi, pi].
inline double wrapped(double theta, double theta0) {
  double d = theta - theta0;
  if (d > kPi) d -= 2.0 * kPi;
  if (d < -kPi) d += 2.0 * kPi;
  return d;
}

/// The geometry of one hinge at x: its angle and, if it has a direction, the gradient of theta
/// (g[0..2] for A, g[3..5] for B, g[6..8] for C, g[9..11] for D). Returns false (theta still
/// set, g untouched) for a hinge that is degenerate at x. The angle and the tests of degeneracy
/// read values only, so a dual T takes the same branches as double (and only g is
/// differentiated: the derivative of theta is g).
template <class T>
inline bool hingeGeometry(const T* xa, const T* xb, const T* xc, const T* xd, double& theta, T* g) {
  using std::sqrt;
  const T e[3] = {xd[0] - xc[0], xd[1] - xc[1], xd[2] - xc[2]};
  const T ac[3] = {xa[0] - xc[0], xa[1] - xc[1], xa[2] - xc[2]};
  const T ad[3] = {xa[0] - xd[0], xa[1] - xd[1], xa[2] - xd[2]};
  const T bc[3] = {xb[0] - xc[0], xb[1] - xc[1], xb[2] - xc[2]};
  const T bd[3] = {xb[0] - xd[0], xb[1] - xd[1], xb[2] - xd[2]};
  T na[3], nb[3], nba[3];
  cross(ac, ad, na);
  cross(bd, bc, nb);
  cross(nb, na, nba);
  const T l2 = dot(e, e);
  const T na2 = dot(na, na), nb2 = dot(nb, nb);
  // atan2 of (NB x NA).e and (NA.NB) |e|: the angle's sine and cosine times |NA| |NB| |e|.
  const T l = sqrt(l2);
  const double s = dotValue(nba, e), c = dotValue(na, nb) * value(l);
  theta = (s == 0.0 && c == 0.0) ? 0.0 : std::atan2(s, c);
  const double size2 = value(l2) + std::max(dotValue(ac, ac), dotValue(bc, bc));
  if (!(value(l2) > kRelativeCurrentHeight2 * size2) || !(value(l2) > 1e-280) ||
      !(value(na2) > kRelativeCurrentHeight2 * value(l2) * size2) ||
      !(value(nb2) > kRelativeCurrentHeight2 * value(l2) * size2)) {
    return false;
  }
  const T invL = 1.0 / l;
  const T ia = 1.0 / na2, ib = 1.0 / nb2;
  const T pa = l * ia, pb = l * ib;
  const T ca = dot(ad, e) * invL * ia, cb = dot(bd, e) * invL * ib;
  const T da = -dot(ac, e) * invL * ia, db = -dot(bc, e) * invL * ib;
  for (int k = 0; k < 3; ++k) {
    g[k] = pa * na[k];
    g[3 + k] = pb * nb[k];
    g[6 + k] = ca * na[k] + cb * nb[k];
    g[9 + k] = da * na[k] + db * nb[k];
  }
  return true;
}

inline const double* at(const double* x, std::uint32_t v) {
  return x + 3 * static_cast<std::size_t>(v);
}
inline double* at(double* x, std::uint32_t v) {
  return x + 3 * static_cast<std::size_t>(v);
}

/// f += -2 c (theta - theta0) g for one hinge; returns false if degenerate at x.
inline bool hingeForce(const double* __restrict x, double* __restrict f,
                       const std::array<std::uint32_t, 4>& v, double coefficient,
                       double restAngle) {
  double theta, g[12];
  if (!hingeGeometry(at(x, v[0]), at(x, v[1]), at(x, v[2]), at(x, v[3]), theta, g)) return false;
  const double m = -2.0 * coefficient * wrapped(theta, restAngle);
  for (int i = 0; i < 4; ++i) {
    double* fi = at(f, v[i]);
    fi[0] += m * g[3 * i];
    fi[1] += m * g[3 * i + 1];
    fi[2] += m * g[3 * i + 2];
  }
  return true;
}

/// The hinge's points as duals, relative to C and scaled by a power of two sigma that brings its
/// current edge length into [1, 2): theta is unchanged, g(x) = sigma g(x'), d2theta/dx2 =
/// sigma^2 d2theta/dx'2, and the duals' intermediate terms (up to the 8th power of lengths) stay
/// far from overflow and underflow whatever the mesh's scale. Values only; derivatives unset.
/// Returns sigma, or 0 for an edge too short for hingeGeometry on x (degenerate at x).
template <int N>
inline double scaledHinge(const double* x, const DihedralHinge& h, Dual<N> (&p)[4][3]) {
  const double* xc = at(x, h.v[2]);
  const double* xd = at(x, h.v[3]);
  const double e[3] = {xd[0] - xc[0], xd[1] - xc[1], xd[2] - xc[2]};
  const double l2 = dot(e, e);
  if (!(l2 > 1e-280) || !(l2 < kMaxLength2)) return 0.0;
  const double sigma = std::ldexp(1.0, -std::ilogb(std::sqrt(l2)));
  for (int i = 0; i < 4; ++i) {
    const double* xi = at(x, h.v[i]);
    for (int k = 0; k < 3; ++k) p[i][k].v = (xi[k] - xc[k]) * sigma;
  }
  return sigma;
}

/// The exact stiffness of one hinge, matrix-free: df += (kFactor K + bFactor B) dx with
/// K = -2 c (g g^T + (theta - theta0) d2theta/dx2) and B = -2 c rayleighStiffness g g^T, where
/// gn = kFactor + bFactor rayleighStiffness. d2theta/dx2 dx is the derivative of g along dx,
/// from one pass of the geometry in Dual<1> seeded with dx. Nothing for a hinge degenerate at x.
inline void hingeExactDForce(const double* __restrict x, const double* __restrict dx,
                             double* __restrict df, const DihedralHinge& h, double kFactor,
                             double gn) {
  Dual<1> p[4][3];
  const double sigma = scaledHinge(x, h, p);
  if (sigma == 0.0) return;
  for (int i = 0; i < 4; ++i) {
    const double* dxi = at(dx, h.v[i]);
    for (int k = 0; k < 3; ++k) p[i][k].d[0] = dxi[k] * sigma;
  }
  double theta;
  Dual<1> g[12];
  if (!hingeGeometry(p[0], p[1], p[2], p[3], theta, g)) return;
  // g = sigma g', (d2theta/dx2) dx = sigma g'.d (the seeds carry the other sigma).
  double s = 0.0;
  for (int j = 0; j < 12; ++j) s += g[j].v * p[j / 3][j % 3].d[0];  // g' . (sigma dx) = g . dx
  const double mg = -2.0 * gn * h.coefficient * s * sigma;
  const double mh = -2.0 * kFactor * h.coefficient * wrapped(theta, h.restAngle) * sigma;
  for (int i = 0; i < 4; ++i) {
    double* fi = at(df, h.v[i]);
    for (int k = 0; k < 3; ++k) fi[k] += mg * g[3 * i + k].v + mh * g[3 * i + k].d[0];
  }
}

/// The exact 12 x 12 stiffness of one hinge times `factor` (zero for a hinge degenerate at x):
/// -2 c factor (g g^T + (theta - theta0) H), H = d2theta/dx2 from one pass of the geometry in
/// Dual<12> (the Jacobian of g), symmetrised (it is symmetric up to rounding).
inline Eigen::Matrix<double, 12, 12> hingeExactStiffness(const double* x, const DihedralHinge& h,
                                                         double factor) {
  Eigen::Matrix<double, 12, 12> kh = Eigen::Matrix<double, 12, 12>::Zero();
  Dual<12> p[4][3];
  const double sigma = scaledHinge(x, h, p);
  if (sigma == 0.0) return kh;
  for (int i = 0; i < 4; ++i) {
    for (int k = 0; k < 3; ++k) p[i][k].d[3 * i + k] = 1.0;
  }
  double theta;
  Dual<12> g[12];
  if (!hingeGeometry(p[0], p[1], p[2], p[3], theta, g)) return kh;
  // g = sigma g', H = sigma^2 H'.
  const double cg = -2.0 * factor * h.coefficient * sigma * sigma;
  const double ch = 0.5 * cg * wrapped(theta, h.restAngle);
  for (int r = 0; r < 12; ++r) {
    for (int q = 0; q < 12; ++q) kh(r, q) = cg * g[r].v * g[q].v + ch * (g[r].d[q] + g[q].d[r]);
  }
  return kh;
}

/// A wing's height over its hinge: the distance of q to the line through c along e (|e| = l),
/// |(q - c) x e| / l.
double wingHeight(const Vec3& q, const Vec3& c, const double (&e)[3], double l) {
  const double w[3] = {q[0] - c[0], q[1] - c[1], q[2] - c[2]};
  double n[3];
  cross(w, e, n);
  return std::sqrt(dot(n, n)) / l;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Parameters and one hinge

void DihedralBendingParameters::validate() const {
  requireFiniteNonNegative("bendingStiffness", bendingStiffness);
  requireFiniteNonNegative("minDist", minDist);
  requireFiniteNonNegative("rayleighStiffness", rayleighStiffness);
}

std::string_view toString(DihedralStatus status) {
  switch (status) {
    case DihedralStatus::Active:
      return "active";
    case DihedralStatus::ShortEdge:
      return "short_edge";
    case DihedralStatus::SmallHeight:
      return "small_height";
    case DihedralStatus::Unrepresentable:
      return "unrepresentable";
    case DihedralStatus::NoHinge:
      return "no_hinge";
    case DihedralStatus::DeadEdge:
      return "dead_edge";
  }
  return "unknown";
}

double dihedralAngle(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  double theta, g[12];
  hingeGeometry(a.data(), b.data(), c.data(), d.data(), theta, g);
  return theta;
}

DihedralRecord dihedralHinge(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                             const DihedralBendingParameters& p) {
  DihedralRecord r;
  for (const Vec3* q : {&a, &b, &c, &d}) {
    for (double v : *q) {
      if (!(std::fabs(v) <= kMaxCoordinate)) {
        r.status = DihedralStatus::Unrepresentable;
        return r;
      }
    }
  }
  const double e[3] = {d[0] - c[0], d[1] - c[1], d[2] - c[2]};
  const double l = std::sqrt(dot(e, e));
  if (!(l > p.minDist) || l == 0.0) {
    r.status = DihedralStatus::ShortEdge;
    return r;
  }
  // Heights as |(p - C) x e| / l (distance to the line CD).
  const double ha = wingHeight(a, c, e, l), hb = wingHeight(b, c, e, l);
  const double minH = std::max(p.minDist, kRelativeRestHeight * l);
  if (!(ha > minH) || !(hb > minH)) {
    r.status = DihedralStatus::SmallHeight;
    return r;
  }
  r.status = DihedralStatus::Active;
  r.coefficient = p.bendingStiffness * l / (3.0 * (ha + hb));
  r.restAngle = dihedralAngle(a, b, c, d);
  return r;
}

// ---------------------------------------------------------------------------------------------
// Construction and the table

DihedralBending::DihedralBending(Topology& topology, DihedralBendingParameters parameters)
    : topology_(&topology), params_(parameters) {
  params_.validate();
  attach(topology);
}

DihedralBending::~DihedralBending() = default;

DihedralRecord DihedralBending::hingeFromMesh(const Topology& t, EdgeId e,
                                              const DihedralBendingParameters& p) {
  DihedralRecord r;
  r.edge = e;
  const auto vid = detail::hingeVertices(t, e);
  if (!vid) {
    r.status = DihedralStatus::NoHinge;
    return r;
  }
  DihedralRecord h = dihedralHinge(t.restPosition((*vid)[0]), t.restPosition((*vid)[1]),
                                   t.restPosition((*vid)[2]), t.restPosition((*vid)[3]), p);
  h.edge = e;
  if (h.status == DihedralStatus::Active) h.vertices = *vid;
  return h;
}

std::vector<DihedralRecord> DihedralBending::buildFromScratch(const Topology& topology,
                                                              const DihedralBendingParameters& p) {
  return detail::recordPerLiveEdge(topology,
                                   [&](EdgeId e) { return hingeFromMesh(topology, e, p); });
}

DihedralHinge DihedralBending::toEntry(const DihedralRecord& r) {
  return DihedralHinge{
      {r.vertices[0].idx(), r.vertices[1].idx(), r.vertices[2].idx(), r.vertices[3].idx()},
      r.coefficient,
      r.restAngle};
}

void DihedralBending::fillRecord(const DihedralHinge& h, DihedralRecord& r) const {
  r.vertices = {PointId(h.v[0]), PointId(h.v[1]), PointId(h.v[2]), PointId(h.v[3])};
  r.coefficient = h.coefficient;
  r.restAngle = h.restAngle;
}

// ---------------------------------------------------------------------------------------------
// Forces

void DihedralBending::checkSize(std::span<const double> a, const char* what) const {
  const std::size_t need = 3 * static_cast<std::size_t>(topology_->pointCapacity());
  if (a.size() < need) {
    throw std::invalid_argument(std::string("DihedralBending::") + what +
                                ": vectors must hold 3 * pointCapacity = " + std::to_string(need) +
                                " doubles, got " + std::to_string(a.size()));
  }
}

void DihedralBending::addForce(std::span<const double> x, std::span<const double> /*v*/,
                               std::span<double> f) const {
  checkSize(x, "addForce");
  checkSize(f, "addForce");
  for (const DihedralHinge& h : entries()) {
    hingeForce(x.data(), f.data(), h.v, h.coefficient, h.restAngle);
  }
}

void DihedralBending::addDForce(std::span<const double> x, std::span<const double> dx,
                                std::span<double> df, double kFactor, double bFactor) const {
  checkSize(x, "addDForce");
  checkSize(dx, "addDForce");
  checkSize(df, "addDForce");
  const double k = kFactor + bFactor * params_.rayleighStiffness;
  const double* xp = x.data();
  const double* dxp = dx.data();
  double* dfp = df.data();
  if (params_.exactHessian) {
    if (k == 0.0 && kFactor == 0.0) return;
    for (const DihedralHinge& h : entries()) hingeExactDForce(xp, dxp, dfp, h, kFactor, k);
    return;
  }
  if (k == 0.0) return;
  for (const DihedralHinge& h : entries()) {
    double theta, g[12];
    if (!hingeGeometry(at(xp, h.v[0]), at(xp, h.v[1]), at(xp, h.v[2]), at(xp, h.v[3]), theta, g)) {
      continue;
    }
    double s = 0.0;
    for (int i = 0; i < 4; ++i) s += dot(g + 3 * i, at(dxp, h.v[i]));
    const double m = -2.0 * k * h.coefficient * s;
    for (int i = 0; i < 4; ++i) {
      double* fi = at(dfp, h.v[i]);
      fi[0] += m * g[3 * i];
      fi[1] += m * g[3 * i + 1];
      fi[2] += m * g[3 * i + 2];
    }
  }
}

double DihedralBending::potentialEnergy(std::span<const double> x) const {
  checkSize(x, "potentialEnergy");
  const double* xp = x.data();
  double e = 0.0;
  for (const DihedralHinge& h : entries()) {
    double theta, g[12];
    hingeGeometry(at(xp, h.v[0]), at(xp, h.v[1]), at(xp, h.v[2]), at(xp, h.v[3]), theta, g);
    const double d = wrapped(theta, h.restAngle);
    e += h.coefficient * d * d;
  }
  return e;
}

std::size_t DihedralBending::numDegenerateAt(std::span<const double> x) const {
  checkSize(x, "numDegenerateAt");
  std::size_t n = 0;
  for (const DihedralHinge& h : entries()) {
    double theta, g[12];
    const double* xp = x.data();
    if (!hingeGeometry(at(xp, h.v[0]), at(xp, h.v[1]), at(xp, h.v[2]), at(xp, h.v[3]), theta, g)) {
      ++n;
    }
  }
  return n;
}

namespace {

void assemble(std::span<const DihedralHinge> hinges, const double* x, MatrixAccumulator& m,
              double factor) {
  for (const DihedralHinge& h : hinges) {
    double theta, g[12];
    const bool ok =
        hingeGeometry(at(x, h.v[0]), at(x, h.v[1]), at(x, h.v[2]), at(x, h.v[3]), theta, g);
    const double c = -2.0 * factor * h.coefficient;
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) {
        Eigen::Matrix3d b = Eigen::Matrix3d::Zero();
        if (ok) {
          for (int r = 0; r < 3; ++r) {
            for (int q = 0; q < 3; ++q) b(r, q) = c * g[3 * i + r] * g[3 * j + q];
          }
        }
        m.addBlock(PointId(h.v[i]), PointId(h.v[j]), b);
      }
    }
  }
}

}  // namespace

void DihedralBending::addKToMatrix(std::span<const double> x, MatrixAccumulator& m,
                                   double kFactor) const {
  checkSize(x, "addKToMatrix");
  if (!params_.exactHessian) {
    assemble(entries(), x.data(), m, kFactor);
    return;
  }
  for (const DihedralHinge& h : entries()) {
    const Eigen::Matrix<double, 12, 12> kh = hingeExactStiffness(x.data(), h, kFactor);
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) {
        m.addBlock(PointId(h.v[i]), PointId(h.v[j]), kh.block<3, 3>(3 * i, 3 * j));
      }
    }
  }
}

bool DihedralBending::setExactStiffness(bool exact) {
  params_.exactHessian = exact;
  return true;
}

void DihedralBending::addBToMatrix(std::span<const double> x, MatrixAccumulator& m,
                                   double bFactor) const {
  const double factor = bFactor * params_.rayleighStiffness;
  if (factor == 0.0) return;
  checkSize(x, "addBToMatrix");
  assemble(entries(), x.data(), m, factor);
}

void DihedralBending::draw(std::vector<std::array<PointId, 2>>& segments) const {
  segments.reserve(segments.size() + entries().size());
  for (const DihedralHinge& h : entries()) segments.push_back({PointId(h.v[0]), PointId(h.v[1])});
}

void DihedralBending::addForceOfRecords(std::span<const DihedralRecord> records,
                                        std::span<const double> x, std::span<double> f) {
  for (const DihedralRecord& r : records) {
    if (r.status != DihedralStatus::Active) continue;
    const std::array<std::uint32_t, 4> v{r.vertices[0].idx(), r.vertices[1].idx(),
                                         r.vertices[2].idx(), r.vertices[3].idx()};
    hingeForce(x.data(), f.data(), v, r.coefficient, r.restAngle);
  }
}

// ---------------------------------------------------------------------------------------------
// Validation (detail::HingeTable::validate): what is the model's own.

std::string DihedralBending::describe(const DihedralRecord& r) {
  std::ostringstream os;
  os.precision(17);
  os << edgeName(r.edge) << " [" << toString(r.status);
  if (r.status == DihedralStatus::Active) {
    os << ": A=" << r.vertices[0] << " B=" << r.vertices[1] << " C=" << r.vertices[2]
       << " D=" << r.vertices[3] << " c=" << r.coefficient << " theta0=" << r.restAngle;
  }
  os << "]";
  return os.str();
}

/// The same hinge up to the labelling (A, C) <-> (B, D), which leaves theta unchanged.
bool DihedralBending::sameHinge(const DihedralRecord& a, const DihedralRecord& b) {
  if (a.status != b.status) return false;
  if (a.status != DihedralStatus::Active) return true;
  const auto& u = a.vertices;
  const auto& w = b.vertices;
  const bool direct = u[0] == w[0] && u[1] == w[1] && u[2] == w[2] && u[3] == w[3];
  const bool swapped = u[0] == w[1] && u[1] == w[0] && u[2] == w[3] && u[3] == w[2];
  if (!direct && !swapped) return false;
  const auto close = [](double p, double q, double scale) {
    return std::fabs(p - q) <= 1e-12 * scale;
  };
  return close(a.coefficient, b.coefficient, std::max(std::fabs(b.coefficient), 1e-300)) &&
         close(a.restAngle, b.restAngle, 1.0);
}

/// Rest positions plus noise: a random non-flat x.
void DihedralBending::fillValidationPositions(const Topology& topology, std::span<double> x) const {
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> dist(-0.1, 0.1);
  for (PointId p : topology.points()) {
    const Vec3 r = topology.restPosition(p);
    for (int k = 0; k < 3; ++k) x[3 * p.idx() + k] = r[k] * (1.0 + dist(rng)) + dist(rng);
  }
}

void DihedralBending::addTableForces(std::span<const double> x, std::span<double> f) const {
  addForce(x, x, f);
}

}  // namespace cutsim::forcefields

// ---- the component's registration (scenes, and every other front end) ----
#include "cutsim/forcefields/registry.hpp"

namespace cutsim::forcefields {
namespace {
const bool registered = ForceFieldRegistry::instance().add(
    {"DihedralBending",
     "nonlinear bending on the dihedral angle (Discrete Shells): sharp folds, curved rest shapes",
     {{"bendingStiffness", KeyType::Number, "k, >= 0 (default 1): the springs' k, so k = 3 D"},
      {"minDist", KeyType::Number,
       "degenerate-hinge threshold, an absolute length >= 0 (default 1e-6)"},
      {"rayleighStiffness", KeyType::Number,
       "this field's Rayleigh stiffness damping factor, >= 0 (default 0)"},
      {"exactHessian", KeyType::Boolean,
       "K is the exact Hessian (indefinite away from the rest angle; what Newton needs) instead of "
       "its Gauss-Newton part (default false)"}},
     {},
     [](const ParameterSource& s) -> std::any {
       DihedralBendingParameters p;
       p.bendingStiffness = s.nonNegative("bendingStiffness", p.bendingStiffness);
       p.minDist = s.nonNegative("minDist", p.minDist);
       p.rayleighStiffness = s.nonNegative("rayleighStiffness", p.rayleighStiffness);
       p.exactHessian = s.boolean("exactHessian", p.exactHessian);
       s.check([&] { p.validate(); });
       return p;
     },
     [](const std::any& p, topology::Topology& t) -> std::unique_ptr<ForceField> {
       return std::make_unique<DihedralBending>(t,
                                                std::any_cast<const DihedralBendingParameters&>(p));
     }});
}  // namespace
std::string DihedralBending::problemAtRest() const {
  // The hinge's stiffness scale: the Gauss-Newton K is 2 c grad(theta) grad(theta)^T, and
  // |grad(theta)| is 1 / h at a wing of height h.
  std::size_t beyond = 0;
  for (const DihedralHinge& h : entries()) {
    auto at = [&](int i) { return topology_->restPosition(PointId(h.v[std::size_t(i)])); };
    const Vec3 a = at(0), b = at(1), c = at(2), d = at(3);
    const double e[3] = {d[0] - c[0], d[1] - c[1], d[2] - c[2]};
    const double l = std::sqrt(dot(e, e));
    const double hmin = std::min(wingHeight(a, c, e, l), wingHeight(b, c, e, l));
    if (!(h.coefficient > 0)) continue;
    // (in logarithms: 2 c / h^2 itself may overflow)
    if (!(std::log(2.0) + std::log(h.coefficient) - 2.0 * std::log(hmin) <
          std::log(kMaxHingeStiffness)))
      ++beyond;
  }
  if (beyond == 0) return "";
  return "bendingStiffness: " + std::to_string(beyond) + " of " +
         std::to_string(numActiveHinges()) +
         " hinges would be stiffer than the solves can hold (2 c / h^2 >= 1e306, with c = k l / "
         "(3 (hA + hB)) and h the smaller wing height) at k = " +
         describeNumber(params_.bendingStiffness) + "; lower bendingStiffness";
}

void DihedralBending::saveState(ArchiveWriter& out) const {
  fields(out, params_.exactHessian);
  saveTable(out);
}
void DihedralBending::loadState(ArchiveReader& in) {
  bool exact = false;
  fields(in, exact);
  setExactStiffness(exact);  // (through the setter: it drops what the other Hessian cached)
  loadTable(in, *topology_);
}

}  // namespace cutsim::forcefields
