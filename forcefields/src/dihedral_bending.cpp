#include "cutsim/forcefields/parameters.hpp"
#include "cutsim/forcefields/dihedral_bending.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>
#include <random>
#include <sstream>
#include <stdexcept>

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

inline double dot(const double* a, const double* b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
inline void cross(const double* a, const double* b, double* c) {
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
/// set, g untouched) for a hinge that is degenerate at x.
inline bool hingeGeometry(const double* xa, const double* xb, const double* xc, const double* xd,
                          double& theta, double* g) {
  const double e[3] = {xd[0] - xc[0], xd[1] - xc[1], xd[2] - xc[2]};
  const double ac[3] = {xa[0] - xc[0], xa[1] - xc[1], xa[2] - xc[2]};
  const double ad[3] = {xa[0] - xd[0], xa[1] - xd[1], xa[2] - xd[2]};
  const double bc[3] = {xb[0] - xc[0], xb[1] - xc[1], xb[2] - xc[2]};
  const double bd[3] = {xb[0] - xd[0], xb[1] - xd[1], xb[2] - xd[2]};
  double na[3], nb[3], nba[3];
  cross(ac, ad, na);
  cross(bd, bc, nb);
  cross(nb, na, nba);
  const double l2 = dot(e, e);
  const double na2 = dot(na, na), nb2 = dot(nb, nb);
  // atan2 of (NB x NA).e and (NA.NB) |e|: the angle's sine and cosine times |NA| |NB| |e|.
  const double l = std::sqrt(l2);
  const double s = dot(nba, e), c = dot(na, nb) * l;
  theta = (s == 0.0 && c == 0.0) ? 0.0 : std::atan2(s, c);
  const double size2 = l2 + std::max(dot(ac, ac), dot(bc, bc));
  if (!(l2 > kRelativeCurrentHeight2 * size2) || !(l2 > 1e-280) ||
      !(na2 > kRelativeCurrentHeight2 * l2 * size2) ||
      !(nb2 > kRelativeCurrentHeight2 * l2 * size2)) {
    return false;
  }
  const double invL = 1.0 / l;
  const double ia = 1.0 / na2, ib = 1.0 / nb2;
  const double pa = l * ia, pb = l * ib;
  const double ca = dot(ad, e) * invL * ia, cb = dot(bd, e) * invL * ib;
  const double da = -dot(ac, e) * invL * ia, db = -dot(bc, e) * invL * ib;
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
  const auto height = [&](const Vec3& q) {
    const double w[3] = {q[0] - c[0], q[1] - c[1], q[2] - c[2]};
    double n[3];
    cross(w, e, n);
    return std::sqrt(dot(n, n)) / l;
  };
  const double ha = height(a), hb = height(b);
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
      {r.vertices[0], r.vertices[1], r.vertices[2], r.vertices[3]}, r.coefficient, r.restAngle};
}

void DihedralBending::fillRecord(const DihedralHinge& h, DihedralRecord& r) const {
  r.vertices = {h.v[0], h.v[1], h.v[2], h.v[3]};
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
  if (k == 0.0) return;
  const double* xp = x.data();
  const double* dxp = dx.data();
  double* dfp = df.data();
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
        m.addBlock(h.v[i], h.v[j], b);
      }
    }
  }
}

}  // namespace

void DihedralBending::addKToMatrix(std::span<const double> x, MatrixAccumulator& m,
                                   double kFactor) const {
  checkSize(x, "addKToMatrix");
  assemble(entries(), x.data(), m, kFactor);
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
  for (const DihedralHinge& h : entries()) segments.push_back({h.v[0], h.v[1]});
}

void DihedralBending::addForceOfRecords(std::span<const DihedralRecord> records,
                                        std::span<const double> x, std::span<double> f) {
  for (const DihedralRecord& r : records) {
    if (r.status != DihedralStatus::Active) continue;
    const std::array<std::uint32_t, 4> v{r.vertices[0], r.vertices[1], r.vertices[2],
                                         r.vertices[3]};
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
    for (int k = 0; k < 3; ++k) x[3 * p + k] = r[k] * (1.0 + dist(rng)) + dist(rng);
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
const bool registered = ForceFieldRegistry::instance().add({
    "DihedralBending",
    "nonlinear bending on the dihedral angle (Discrete Shells): sharp folds, curved rest shapes",
    {{"bendingStiffness", "k, >= 0 (default 1): the springs' k, so k = 3 D"},
     {"minDist", "degenerate-hinge threshold, an absolute length >= 0 (default 1e-6)"},
     {"rayleighStiffness", "this field's Rayleigh stiffness damping factor, >= 0 (default 0)"}},
    {},
    [](const ParameterSource& s) -> std::any {
      DihedralBendingParameters p;
      p.bendingStiffness = s.nonNegative("bendingStiffness", p.bendingStiffness);
      p.minDist = s.nonNegative("minDist", p.minDist);
      p.rayleighStiffness = s.nonNegative("rayleighStiffness", p.rayleighStiffness);
      s.check([&] { p.validate(); });
      return p;
    },
    [](const std::any& p, topology::Topology& t) -> std::unique_ptr<ForceField> {
      return std::make_unique<DihedralBending>(t, std::any_cast<const DihedralBendingParameters&>(p));
    }});
}  // namespace
}  // namespace cutsim::forcefields
