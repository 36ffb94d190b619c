#include "cutsim/forcefields/stretch_springs.hpp"

#include <algorithm>
#include <cassert>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/numbers.hpp"
#include "parallel.hpp"

namespace cutsim::forcefields {
namespace {

using topology::kInvalidIndex;
using topology::Topology;

/// Below this squared length a spring has no direction (u undefined): it is skipped. The smallest
/// normal double keeps l^2 exact enough for u = d / l to be a unit vector.
constexpr double kMinLength2 = std::numeric_limits<double>::min();

std::string edgeName(EdgeId e) {
  return "edge " + std::to_string(e.idx());
}

/// The rest length of the segment (a, b): restScale times its length in the mesh's rest
/// positions; the same function for events and rebuilds.
double restLengthOf(const Topology& t, PointId a, PointId b, double restScale) {
  const topology::Vec3 pa = t.restPosition(a), pb = t.restPosition(b);
  return restScale * std::hypot(pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]);
}

/// The direction of a spring at x: u = (x_b - x_a) / l and l; false for a zero-length spring.
inline bool direction(const double* __restrict x, std::uint32_t a, std::uint32_t b, double u[3],
                      double& l) {
  const double* xa = x + 3 * static_cast<std::size_t>(a);
  const double* xb = x + 3 * static_cast<std::size_t>(b);
  u[0] = xb[0] - xa[0];
  u[1] = xb[1] - xa[1];
  u[2] = xb[2] - xa[2];
  const double l2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
  if (!(l2 >= kMinLength2)) return false;
  l = std::sqrt(l2);
  const double inv = 1.0 / l;
  u[0] *= inv;
  u[1] *= inv;
  u[2] *= inv;
  return true;
}

/// The coefficient a of the K block -ks [a (I - u u^T) + u u^T].
inline double tangentFactor(double restLength, double l, bool stable) {
  const double a = 1.0 - restLength / l;
  return stable ? std::max(a, 0.0) : a;
}

/// The K block (j, j) of a spring, times `factor`: -factor ks [a I + (1 - a) u u^T].
Eigen::Matrix3d stiffnessBlock(const double u[3], double a, double factorTimesKs) {
  const Eigen::Vector3d uv(u[0], u[1], u[2]);
  Eigen::Matrix3d m = ((1.0 - a) * uv) * uv.transpose();
  m.diagonal().array() += a;
  return -factorTimesKs * m;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Parameters

void StretchParameters::validate() const {
  requireFiniteNonNegative("stiffness", stiffness);
  requireFiniteNonNegative("damping", damping);
  requireFinitePositive("restScale", restScale);
}

// ---------------------------------------------------------------------------------------------
// Construction and the table

StretchSprings::StretchSprings(Topology& topology, StretchParameters parameters)
    : topology_(&topology),
      params_(parameters),
      constructedStableJacobian_(parameters.stableJacobian),
      partition_(std::make_unique<PointPartition>()) {
  params_.validate();
  const std::vector<StretchRecord> records = buildFromScratch(topology, params_);
  table_.reset(topology.edgeCapacity(), records.size());
  for (const StretchRecord& r : records) {
    table_.set(r.edge, {r.vertices[0].idx(), r.vertices[1].idx(), r.restLength});
  }
  subscription_ = topology.subscribe(*this);
}

StretchSprings::~StretchSprings() = default;

std::vector<StretchRecord> StretchSprings::buildFromScratch(const Topology& topology,
                                                            const StretchParameters& parameters) {
  std::vector<StretchRecord> records;
  const std::vector<EdgeId> edges = topology.edges();
  records.reserve(edges.size());
  for (EdgeId e : edges) {
    const topology::EdgeVertices ev = topology.edgeVertices(e);
    records.push_back(
        {e, {ev[0], ev[1]}, restLengthOf(topology, ev[0], ev[1], parameters.restScale)});
  }
  return records;
}

StretchRecord StretchSprings::spring(EdgeId e) const {
  StretchRecord r;
  const Index i = table_.find(e);
  if (i == table_.kNoEntry) return r;
  const StretchSpring& s = table_.entry(i);
  r.edge = e;
  r.vertices = {PointId(s.a), PointId(s.b)};
  r.restLength = s.restLength;
  return r;
}

std::vector<StretchRecord> StretchSprings::records() const {
  std::vector<StretchRecord> out;
  out.reserve(table_.size());
  for (EdgeId e{0}; e.idx() < table_.numSlots(); ++e) {
    if (table_.hasEntry(e)) out.push_back(spring(e));
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Forces

void StretchSprings::checkSize(std::span<const double> a, const char* name,
                               const char* what) const {
  const std::size_t need = 3 * static_cast<std::size_t>(topology_->pointCapacity());
  if (a.size() < need) {
    throw std::invalid_argument(std::string("StretchSprings::") + what + ": " + name +
                                " must hold 3 * pointCapacity = " + std::to_string(need) +
                                " doubles, got " + std::to_string(a.size()));
  }
}

namespace {
/// SOFA's MeshSpringForceField: stiffness and damping divided by the mesh's rest length.
inline double perRestLengthWeight(double restLength, double restScale) {
  const double l = restLength / restScale;
  return l > std::numeric_limits<double>::epsilon() ? 1.0 / l : 1.0;
}
}  // namespace

double StretchSprings::springWeight(const StretchSpring& s) const {
  return params_.perRestLength ? perRestLengthWeight(s.restLength, params_.restScale) : 1.0;
}

template <class Body>
void StretchSprings::overSprings(Body&& body) const {
  const std::span<const StretchSpring> springs = table_.entries();
  const int parts = partsFor(springs.size());
  if (parts <= 1) {
    for (std::size_t i = 0; i < springs.size(); ++i) body(i, 0u, ~0u, std::false_type{});
    return;
  }
  partition_->update(parts, topology_->pointCapacity(), springs.size(), 2, table_.revision(),
                     [&](std::size_t i, std::uint32_t* ids) {
                       ids[0] = springs[i].a;
                       ids[1] = springs[i].b;
                     });
  inParts(std::size_t(parts), parts, [&](int k, std::size_t, std::size_t) {
    // The body's own copy on this thread's stack: what it captured (by value) is not read, after
    // every store, from the memory of the thread that called (a cache line both would write).
    auto local = body;
    const std::uint32_t lo = partition_->first(k), span = partition_->size(k);
    for (const std::uint32_t i : partition_->elements(k)) local(i, lo, span, std::true_type{});
  });
}

void StretchSprings::addForce(std::span<const double> x, std::span<const double> v,
                              std::span<double> f) const {
  checkSize(x, "x", "addForce");
  checkSize(f, "f", "addForce");
  const double ks = params_.stiffness, kd = params_.damping;
  const bool damped = kd != 0.0;
  if (damped) checkSize(v, "v", "addForce");
  const double* __restrict xp = x.data();
  const double* __restrict vp = damped ? v.data() : nullptr;
  double* __restrict fp = f.data();
  const double restScale = params_.restScale;
  // Springs are taken by value in the force passes: a store into f could otherwise alias the
  // table, and the compiler would reload the spring after every store.
  const StretchSpring* __restrict springs = table_.entries().data();
  withWeights([&](auto perRestLength) {
    overSprings([=](std::size_t i, std::uint32_t lo, std::uint32_t span, auto owned) {
      const StretchSpring s = springs[i];
      double u[3], l;
      if (!direction(xp, s.a, s.b, u, l)) return;
      const double w = perRestLength ? perRestLengthWeight(s.restLength, restScale) : 1.0;
      double intensity = -(ks * w) * (l - s.restLength);
      if (damped) {
        const double* va = vp + 3 * static_cast<std::size_t>(s.a);
        const double* vb = vp + 3 * static_cast<std::size_t>(s.b);
        intensity -=
            (kd * w) * ((vb[0] - va[0]) * u[0] + (vb[1] - va[1]) * u[1] + (vb[2] - va[2]) * u[2]);
      }
      // (Each end's sum written as one expression, fused alike on every path: the threads test
      // compares the paths' bits in the release build, where the compiler may fuse.)
      if (!owned || s.b - lo < span) {
        double* fb = fp + 3 * static_cast<std::size_t>(s.b);
        for (int k = 0; k < 3; ++k) fb[k] += intensity * u[k];
      }
      if (!owned || s.a - lo < span) {
        double* fa = fp + 3 * static_cast<std::size_t>(s.a);
        for (int k = 0; k < 3; ++k) fa[k] -= intensity * u[k];
      }
    });
  });
}

void StretchSprings::addDForce(std::span<const double> x, std::span<const double> dx,
                               std::span<double> df, double kFactor, double bFactor) const {
  checkSize(x, "x", "addDForce");
  checkSize(dx, "dx", "addDForce");
  checkSize(df, "df", "addDForce");
  const double k = kFactor * params_.stiffness;
  const double b = bFactor * params_.damping;
  if (k == 0.0 && b == 0.0) return;
  const Linearisation* __restrict lin = linearisation(x).data();
  const double* __restrict dxp = dx.data();
  double* __restrict dfp = df.data();
  const StretchSpring* __restrict springs = table_.entries().data();
  const double restScale = params_.restScale;
  withWeights([&](auto perRestLength) {
    overSprings([=](std::size_t i, std::uint32_t lo, std::uint32_t span, auto owned) {
      const StretchSpring s = springs[i];
      const Linearisation& L = lin[i];
      const double* da = dxp + 3 * static_cast<std::size_t>(s.a);
      const double* db = dxp + 3 * static_cast<std::size_t>(s.b);
      const double w[3] = {db[0] - da[0], db[1] - da[1], db[2] - da[2]};
      const double uw = L.u[0] * w[0] + L.u[1] * w[1] + L.u[2] * w[2];
      // g = (kFactor K_jj + bFactor B_jj) w = -k (a w + (1 - a) (u.w) u) - b (u.w) u. A spring
      // without direction has u = 0 and a = 0: no contribution.
      const double sw = perRestLength ? perRestLengthWeight(s.restLength, restScale) : 1.0;
      const double cu = -(k * sw * (1.0 - L.a) + b * sw) * uw;
      const double cw = -k * sw * L.a;
      double g[3];
      for (int c = 0; c < 3; ++c) g[c] = cw * w[c] + cu * L.u[c];
      if (!owned || s.b - lo < span) {
        double* fb = dfp + 3 * static_cast<std::size_t>(s.b);
        for (int c = 0; c < 3; ++c) fb[c] += g[c];
      }
      if (!owned || s.a - lo < span) {
        double* fa = dfp + 3 * static_cast<std::size_t>(s.a);
        for (int c = 0; c < 3; ++c) fa[c] -= g[c];
      }
    });
  });
}

const std::vector<StretchSprings::Linearisation>& StretchSprings::linearisation(
    std::span<const double> x) const {
  const std::span<const StretchSpring> springs = table_.entries();
  const bool atHeld = held_ > 0 && x.data() == heldX_;
  if (linValid_ && linX_.size() == x.size() && lin_.size() == springs.size()) {
    if (atHeld && linAtHeld_) return lin_;
    if (std::memcmp(linX_.data(), x.data(), x.size() * sizeof(double)) == 0) {
      linAtHeld_ = atHeld;
      return lin_;
    }
  }
  linAtHeld_ = atHeld;
  const bool stable = params_.stableJacobian;
  const double* __restrict xp = x.data();
  lin_.resize(springs.size());
  // Each spring's own entry: any split of the springs gives the same bits.
  inParts(springs.size(), partsFor(springs.size()), [&](int, std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const StretchSpring s = springs[i];
      Linearisation& L = lin_[i];
      double l;
      if (direction(xp, s.a, s.b, L.u, l)) {
        L.a = tangentFactor(s.restLength, l, stable);
      } else {
        L.u[0] = L.u[1] = L.u[2] = 0.0;
        L.a = 0.0;
      }
    }
  });
  linX_.assign(x.begin(), x.end());
  linValid_ = true;
  return lin_;
}

double StretchSprings::potentialEnergy(std::span<const double> x) const {
  checkSize(x, "x", "potentialEnergy");
  const double* __restrict xp = x.data();
  double e = 0.0;
  for (const StretchSpring s : table_.entries()) {
    const double* xa = xp + 3 * static_cast<std::size_t>(s.a);
    const double* xb = xp + 3 * static_cast<std::size_t>(s.b);
    const double d0 = xb[0] - xa[0], d1 = xb[1] - xa[1], d2 = xb[2] - xa[2];
    const double stretch = std::sqrt(d0 * d0 + d1 * d1 + d2 * d2) - s.restLength;
    e += springWeight(s) * stretch * stretch;
  }
  return 0.5 * params_.stiffness * e;
}

void StretchSprings::addKToMatrix(std::span<const double> x, MatrixAccumulator& m,
                                  double kFactor) const {
  checkSize(x, "x", "addKToMatrix");
  const double k = kFactor * params_.stiffness;
  const bool stable = params_.stableJacobian;
  const bool diagonalOnly = m.diagonalOnly();  // (a preconditioner's: the (a, a), (b, b) blocks)
  for (const StretchSpring s : table_.entries()) {
    double u[3], l;
    Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
    if (direction(x.data(), s.a, s.b, u, l)) {
      block = stiffnessBlock(u, tangentFactor(s.restLength, l, stable), k * springWeight(s));
    }
    const PointId a(s.a), b(s.b);
    m.addBlock(a, a, block);
    m.addBlock(b, b, block);
    if (diagonalOnly) continue;
    m.addBlock(a, b, -block);
    m.addBlock(b, a, -block);
  }
}

void StretchSprings::addBToMatrix(std::span<const double> x, MatrixAccumulator& m,
                                  double bFactor) const {
  const double b = bFactor * params_.damping;
  if (b == 0.0) return;
  checkSize(x, "x", "addBToMatrix");
  const bool diagonalOnly = m.diagonalOnly();
  for (const StretchSpring s : table_.entries()) {
    double u[3], l;
    Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
    if (direction(x.data(), s.a, s.b, u, l)) {
      const Eigen::Vector3d uv(u[0], u[1], u[2]);
      block = (-b * springWeight(s) * uv) * uv.transpose();
    }
    const PointId a(s.a), b(s.b);
    m.addBlock(a, a, block);
    m.addBlock(b, b, block);
    if (diagonalOnly) continue;
    m.addBlock(a, b, -block);
    m.addBlock(b, a, -block);
  }
}

void StretchSprings::beginProducts(std::span<const double> x) const {
  if (held_++ == 0) {
    heldX_ = x.data();
    linAtHeld_ = false;
  }
}

void StretchSprings::endProducts(std::span<const double> x) const {
  assert(held_ > 0);
  if (--held_ == 0) {
    assert(x.data() == heldX_);  // (holds end in the reverse order of their beginning)
    (void)x;
    heldX_ = nullptr;
    linAtHeld_ = false;
  }
}

bool StretchSprings::setExactStiffness(bool exact) {
  const bool stable = exact ? false : constructedStableJacobian_;
  if (stable != params_.stableJacobian) {
    params_.stableJacobian = stable;
    linValid_ = false;  // the cached tangent factors were clamped (or not) for the other K
  }
  return true;
}

void StretchSprings::draw(std::vector<std::array<PointId, 2>>& segments) const {
  segments.reserve(segments.size() + table_.size());
  for (const StretchSpring& s : table_.entries()) segments.push_back({PointId(s.a), PointId(s.b)});
}

// ---------------------------------------------------------------------------------------------
// Topology events. Only edges carry springs: an edge destroyed loses its spring, an edge created
// (new, or re-created with other endpoints by an incision) gets one with the rest length of its
// endpoints' rest positions, times restScale. Triangle events change nothing; a point is destroyed
// only after the edges around it, whose destruction already removed their springs.

void StretchSprings::onEdgesDestroyed(const Topology&, const topology::EdgesDestroyed& ev) {
  linValid_ = false;
  for (EdgeId e : ev.edges) {
    if (!table_.hasEntry(e)) {
      eventProblems_.push_back("edges destroyed: " + edgeName(e) + " had no spring");
      continue;
    }
    table_.setStatus(e, detail::StretchTableTraits::Status::NoSpring);
  }
}

void StretchSprings::onEdgesCreated(const Topology& t, const topology::EdgesCreated& ev) {
  linValid_ = false;
  table_.grow(t);
  for (std::size_t i = 0; i < ev.edges.size(); ++i) {
    const EdgeId e = ev.edges[i];
    const topology::EdgeVertices& v = ev.vertices[i];
    if (table_.hasEntry(e)) {
      eventProblems_.push_back("edges created: " + edgeName(e) + " already had a spring");
    }
    table_.set(e, {v[0].idx(), v[1].idx(), restLengthOf(t, v[0], v[1], params_.restScale)});
  }
}

void StretchSprings::onPointsRenumbered(const Topology&, const topology::Renumbering& ev) {
  linValid_ = false;
  table_.remapPoints(ev, eventProblems_);
}

void StretchSprings::onEdgesRenumbered(const Topology&, const topology::Renumbering& ev) {
  linValid_ = false;
  // The springs move with their edges and are re-laid out in the new edge order.
  table_.renumber(ev, eventProblems_);
}

// ---------------------------------------------------------------------------------------------
// Validation: the incremental table against a rebuild from scratch.

namespace {

std::string describeRecord(const StretchRecord& r) {
  std::ostringstream os;
  os.precision(17);
  os << edgeName(r.edge) << " [" << r.vertices[0] << "-" << r.vertices[1] << ", rest length "
     << r.restLength << "]";
  return os.str();
}

bool sameSpring(const StretchRecord& a, const StretchRecord& b) {
  if (std::minmax(a.vertices[0], a.vertices[1]) != std::minmax(b.vertices[0], b.vertices[1])) {
    return false;
  }
  return std::fabs(a.restLength - b.restLength) <=
         1e-12 * std::max(std::fabs(b.restLength), 1e-300);
}

}  // namespace

void StretchSprings::validate(const Topology& topology, std::vector<std::string>& problems) const {
  for (const std::string& p : eventProblems_) problems.push_back(p);

  // The table's own consistency, live edges against its slots, springs on live points only.
  table_.validate(topology, problems, "");

  // Against the rebuild.
  const std::vector<StretchRecord> ref = buildFromScratch(topology, params_);
  for (const StretchRecord& r : ref) {
    const StretchRecord mine = spring(r.edge);
    if (mine.edge.idx() == kInvalidIndex) {
      problems.push_back("no spring for " + edgeName(r.edge) + ", a rebuild gives " +
                         describeRecord(r));
    } else if (!sameSpring(mine, r)) {
      problems.push_back("table has " + describeRecord(mine) + ", a rebuild gives " +
                         describeRecord(r));
    }
  }
  if (table_.size() != ref.size()) {
    problems.push_back(std::to_string(table_.size()) + " springs, a rebuild has " +
                       std::to_string(ref.size()));
  }
}

}  // namespace cutsim::forcefields

// ---- the component's registration (scenes, and every other front end) ----
#include "cutsim/forcefields/registry.hpp"

namespace cutsim::forcefields {
namespace {
const bool registered = ForceFieldRegistry::instance().add(
    {"StretchSprings",
     "one linear spring per edge (SOFA's MeshSpringForceField)",
     {{"stiffness", KeyType::Number, "ks per spring, >= 0 (required)", {}, true},
      {"damping", KeyType::Number, "kd per spring, >= 0 (default 0)"},
      {"perRestLength", KeyType::Boolean,
       "stiffness and damping divided by each spring's rest length, as SOFA's MeshSpringForceField "
       "(default false)"},
      {"stableJacobian", KeyType::Boolean,
       "clamp compressed springs' K to keep it semi-definite (default true)"},
      {"restScale", KeyType::Number,
       "> 0, multiplies every rest length (prestrain: < 1 puts a held sheet under "
       "tension, strain 1/restScale - 1) (default 1)"}},
     {},
     [](const ParameterSource& s) -> std::any {
       StretchParameters p;
       s.require("stiffness");
       p.stiffness = s.nonNegative("stiffness", p.stiffness);
       p.damping = s.nonNegative("damping", p.damping);
       p.perRestLength = s.boolean("perRestLength", p.perRestLength);
       p.stableJacobian = s.boolean("stableJacobian", p.stableJacobian);
       p.restScale = s.positive("restScale", p.restScale);
       s.check([&] { p.validate(); });
       return p;
     },
     [](const std::any& p, topology::Topology& t) -> std::unique_ptr<ForceField> {
       return std::make_unique<StretchSprings>(t, std::any_cast<const StretchParameters&>(p));
     }});
}  // namespace
void StretchSprings::saveState(ArchiveWriter& out) const {
  fields(out, params_.stableJacobian);
  table_.save(out);
}
void StretchSprings::loadState(ArchiveReader& in) {
  fields(in, params_.stableJacobian);
  table_.load(in);
  linValid_ = false;
  eventProblems_.clear();
  std::vector<std::string> problems;
  validate(*topology_, problems);
  if (!problems.empty()) in.fail("StretchSprings: " + problems.front());
}

}  // namespace cutsim::forcefields
