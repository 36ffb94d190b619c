#include "cutsim/forcefields/parameters.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <random>
#include <sstream>
#include <stdexcept>

namespace cutsim::forcefields {
namespace {

using topology::kInvalidIndex;
using topology::Topology;

constexpr std::uint32_t kStatusBase = 0xFFFFFFF0u;
constexpr std::uint32_t kFallbackBit = 0x80000000u;
constexpr std::uint32_t kEdgeMask = ~kFallbackBit;

constexpr std::uint32_t encode(HingeStatus s) {
  return kStatusBase + static_cast<std::uint32_t>(s);
}
constexpr bool isSpringSlot(std::uint32_t code) {
  return code < kStatusBase;
}
constexpr HingeStatus decode(std::uint32_t code) {
  return static_cast<HingeStatus>(code - kStatusBase);
}

std::string edgeName(EdgeId e) {
  return "edge " + std::to_string(e);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Parameters

void BendingParameters::validate() const {
  requireFiniteNonNegative("bendingStiffness", bendingStiffness);
  requireFiniteNonNegative("minDistValidity", minDistValidity);
  requireFiniteNonNegative("rayleighStiffness", rayleighStiffness);
  if (areaWeights != AreaWeights::Unsigned && areaWeights != AreaWeights::Signed) {
    throw InvalidInput("areaWeights",
                       "unknown value " + std::to_string(static_cast<int>(areaWeights)));
  }
}

AreaWeights parseAreaWeights(std::string_view name) {
  if (name == "unsigned") return AreaWeights::Unsigned;
  if (name == "signed") return AreaWeights::Signed;
  throw InvalidInput("areaWeights",
                     "unknown value '" + std::string(name) + "' (expected unsigned or signed)");
}

std::string_view toString(AreaWeights weights) {
  return weights == AreaWeights::Signed ? "signed" : "unsigned";
}

// ---------------------------------------------------------------------------------------------
// Construction and the table

FastTriangularBendingSprings::FastTriangularBendingSprings(Topology& topology,
                                                           BendingParameters parameters)
    : topology_(&topology), params_(parameters) {
  params_.validate();
  const std::vector<HingeRecord> records = buildFromScratch(topology, params_);
  edgeSlot_.assign(topology.edgeCapacity(), encode(HingeStatus::DeadEdge));
  std::size_t active = 0;
  for (const HingeRecord& r : records) active += r.status == HingeStatus::Active ? 1 : 0;
  springs_.reserve(active);
  springEdge_.reserve(active);
  for (const HingeRecord& r : records) setEdge(r.edge, r, r.folded);
  subscription_ = topology.subscribe(*this);
}

FastTriangularBendingSprings::~FastTriangularBendingSprings() = default;

HingeRecord FastTriangularBendingSprings::hingeFromMesh(const Topology& t, EdgeId e,
                                                        const BendingParameters& p) {
  HingeRecord r;
  r.edge = e;
  const std::array<TriangleId, 2> tris = t.edgeTriangles(e);
  if (tris[0] == kInvalidIndex || tris[1] == kInvalidIndex) {
    r.status = HingeStatus::NoHinge;
    return r;
  }
  const topology::EdgeVertices ev = t.edgeVertices(e);
  const std::array<PointId, 4> vid{t.oppositeVertex(tris[0], e), t.oppositeVertex(tris[1], e),
                                   ev[0], ev[1]};
  const HingeWeights w =
      computeHinge(t.restPosition(vid[0]), t.restPosition(vid[1]), t.restPosition(vid[2]),
                   t.restPosition(vid[3]), p.bendingStiffness, p.minDistValidity, p.areaWeights);
  r.status = w.status;
  if (w.status == HingeStatus::Active) {
    r.vertices = vid;
    r.alpha = w.alpha;
    r.lambda = w.lambda;
    r.folded = foldedWeights(w);
    r.signedFallback = w.signedFallback;
  }
  return r;
}

std::vector<HingeRecord> FastTriangularBendingSprings::buildFromScratch(
    const Topology& topology, const BendingParameters& parameters) {
  std::vector<HingeRecord> records;
  const std::vector<EdgeId> edges = topology.edges();
  records.reserve(edges.size());
  for (EdgeId e : edges) records.push_back(hingeFromMesh(topology, e, parameters));
  return records;
}

void FastTriangularBendingSprings::countStatus(HingeStatus s, int delta) {
  auto bump = [delta](std::size_t& c) {
    c = static_cast<std::size_t>(static_cast<long long>(c) + delta);
  };
  switch (s) {
    case HingeStatus::Active:
      bump(counters_.activeSprings);
      break;
    case HingeStatus::ShortWingDistance:
      bump(counters_.shortWingDistance);
      break;
    case HingeStatus::ShortEdge:
      bump(counters_.shortEdge);
      break;
    case HingeStatus::SmallHeight:
      bump(counters_.smallHeight);
      break;
    case HingeStatus::Unrepresentable:
      bump(counters_.unrepresentable);
      break;
    case HingeStatus::NoHinge:
      bump(counters_.noHinge);
      break;
    case HingeStatus::DeadEdge:
      break;
  }
}

void FastTriangularBendingSprings::ensureEdgeSlots(std::size_t n) {
  if (edgeSlot_.size() < n) edgeSlot_.resize(n, encode(HingeStatus::DeadEdge));
}

void FastTriangularBendingSprings::removeSpring(std::uint32_t slot) {
  if (springEdge_[slot] & kFallbackBit) --counters_.signedFallbacks;
  const std::uint32_t last = static_cast<std::uint32_t>(springs_.size() - 1);
  if (slot != last) {
    springs_[slot] = springs_[last];
    springEdge_[slot] = springEdge_[last];
    edgeSlot_[springEdge_[slot] & kEdgeMask] = slot;
  }
  springs_.pop_back();
  springEdge_.pop_back();
}

void FastTriangularBendingSprings::setEdge(EdgeId e, const HingeRecord& r,
                                           const std::array<double, 4>& folded) {
  if (e >= kFallbackBit) throw std::length_error("FastTriangularBendingSprings: edge id too large");
  ensureEdgeSlots(static_cast<std::size_t>(e) + 1);
  const std::uint32_t old = edgeSlot_[e];
  const bool wasActive = isSpringSlot(old);
  countStatus(wasActive ? HingeStatus::Active : decode(old), -1);
  countStatus(r.status, +1);
  if (r.status != HingeStatus::Active) {
    if (wasActive) removeSpring(old);
    edgeSlot_[e] = encode(r.status);
    return;
  }
  // root = w_A + w_B = sqrt(lambda / k) (alpha_A + alpha_B), alpha_A + alpha_B = 1.
  const BendingSpring spring{{r.vertices[0], r.vertices[1], r.vertices[2], r.vertices[3]},
                             folded[0],
                             folded[2],
                             folded[0] + folded[1]};
  const std::uint32_t edgeCode = e | (r.signedFallback ? kFallbackBit : 0u);
  if (r.signedFallback) ++counters_.signedFallbacks;
  if (wasActive) {
    if (springEdge_[old] & kFallbackBit) --counters_.signedFallbacks;
    springs_[old] = spring;
    springEdge_[old] = edgeCode;
    return;
  }
  if (springs_.size() >= kStatusBase) {
    throw std::length_error("FastTriangularBendingSprings: too many springs");
  }
  edgeSlot_[e] = static_cast<std::uint32_t>(springs_.size());
  springs_.push_back(spring);
  springEdge_.push_back(edgeCode);
}

void FastTriangularBendingSprings::recomputeEdge(const Topology& t, EdgeId e) {
  if (!t.isEdgeAlive(e)) return;  // its destruction event follows
  const HingeRecord r = hingeFromMesh(t, e, params_);
  setEdge(e, r, r.folded);
}

HingeRecord FastTriangularBendingSprings::hinge(EdgeId e) const {
  HingeRecord r;
  r.edge = e;
  if (e >= edgeSlot_.size()) {
    r.status = HingeStatus::DeadEdge;
    return r;
  }
  const std::uint32_t code = edgeSlot_[e];
  if (!isSpringSlot(code)) {
    r.status = decode(code);
    return r;
  }
  return springRecord(code);
}

HingeRecord FastTriangularBendingSprings::springRecord(std::size_t i) const {
  const BendingSpring& s = springs_[i];
  HingeRecord r;
  r.edge = springEdge_[i] & kEdgeMask;
  r.status = HingeStatus::Active;
  r.signedFallback = (springEdge_[i] & kFallbackBit) != 0;
  r.vertices = {s.v[0], s.v[1], s.v[2], s.v[3]};
  r.folded = s.weights();
  // alpha_A + alpha_B = 1, so w_A + w_B = sqrt(lambda / k) > 0.
  const double root = s.root;  // > 0 for an active spring
  for (int k = 0; k < 4; ++k) r.alpha[k] = r.folded[k] / root;
  r.lambda = params_.bendingStiffness * root * root;
  return r;
}

std::vector<HingeRecord> FastTriangularBendingSprings::hinges() const {
  std::vector<HingeRecord> out;
  for (EdgeId e = 0; e < edgeSlot_.size(); ++e) {
    if (edgeSlot_[e] != encode(HingeStatus::DeadEdge)) out.push_back(hinge(e));
  }
  return out;
}

double FastTriangularBendingSprings::bytesPerEdgeSlot() const {
  if (edgeSlot_.empty()) return 0.0;
  const double bytes = static_cast<double>(springs_.size() * sizeof(BendingSpring) +
                                           springEdge_.size() * sizeof(std::uint32_t) +
                                           edgeSlot_.size() * sizeof(std::uint32_t));
  return bytes / static_cast<double>(edgeSlot_.size());
}

// ---------------------------------------------------------------------------------------------
// Forces

void FastTriangularBendingSprings::checkSizes(std::span<const double> a, std::span<const double> b,
                                              const char* what) const {
  const std::size_t need = 3 * static_cast<std::size_t>(topology_->pointCapacity());
  if (a.size() < need || b.size() < need) {
    throw std::invalid_argument(std::string("FastTriangularBendingSprings::") + what +
                                ": vectors must hold 3 * pointCapacity = " + std::to_string(need) +
                                " doubles, got " + std::to_string(a.size()) + " and " +
                                std::to_string(b.size()));
  }
}

namespace {

/// The force pass: f += c w_i R'(x) per spring, streaming over the compact springs. Ids and
/// weights are read into locals first (the table is __restrict: stores into f cannot change it).
void scatterPass(std::span<const BendingSpring> springs, const double* __restrict x,
                 double* __restrict f, double c) {
  const BendingSpring* __restrict sp = springs.data();
  const std::size_t n = springs.size();
  for (std::size_t k = 0; k < n; ++k) {
    const std::array<std::uint32_t, 4> v = sp[k].v;
    const std::array<double, 4> w = sp[k].weights();
    double r[3];
    hingeResidual(x, v.data(), w.data(), r);
    hingeScatter(f, v.data(), w.data(), c, r);
  }
}

}  // namespace

void FastTriangularBendingSprings::addForce(std::span<const double> x,
                                            std::span<const double> /*v*/,
                                            std::span<double> f) const {
  checkSizes(x, f, "addForce");
  scatterPass(springs_, x.data(), f.data(), -params_.bendingStiffness);
}

void FastTriangularBendingSprings::addDForce(std::span<const double> /*x*/,
                                             std::span<const double> dx, std::span<double> df,
                                             double kFactor, double bFactor) const {
  checkSizes(dx, df, "addDForce");
  const double k = kFactor + bFactor * params_.rayleighStiffness;
  if (k == 0.0) return;
  scatterPass(springs_, dx.data(), df.data(), -k * params_.bendingStiffness);
}

double FastTriangularBendingSprings::potentialEnergy(std::span<const double> x) const {
  checkSizes(x, x, "potentialEnergy");
  double e = 0.0;
  for (const BendingSpring& s : springs_) {
    double r[3];
    const std::array<double, 4> w = s.weights();
    hingeResidual(x.data(), s.v.data(), w.data(), r);
    e += hingeEnergy(params_.bendingStiffness, r);
  }
  return e;
}

namespace {

/// factor * K (k the bending stiffness): 16 scaled identities per spring.
void assemble(std::span<const BendingSpring> springs, MatrixAccumulator& m, double factor,
              double k) {
  for (const BendingSpring& s : springs) {
    const std::array<double, 4> w = s.weights();
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) {
        m.addScaledIdentity(s.v[i], s.v[j], factor * hingeBlockCoefficient(k, w.data(), i, j));
      }
    }
  }
}

}  // namespace

void FastTriangularBendingSprings::addKToMatrix(std::span<const double> /*x*/, MatrixAccumulator& m,
                                                double kFactor) const {
  assemble(springs_, m, kFactor, params_.bendingStiffness);
}

void FastTriangularBendingSprings::addBToMatrix(std::span<const double> /*x*/, MatrixAccumulator& m,
                                                double bFactor) const {
  const double factor = bFactor * params_.rayleighStiffness;
  if (factor == 0.0) return;
  assemble(springs_, m, factor, params_.bendingStiffness);
}

void FastTriangularBendingSprings::draw(std::vector<std::array<PointId, 2>>& segments) const {
  segments.reserve(segments.size() + springs_.size());
  for (const BendingSpring& s : springs_) segments.push_back({s.v[0], s.v[1]});
}

void FastTriangularBendingSprings::addForceOfRecords(std::span<const HingeRecord> records,
                                                     std::span<const double> x,
                                                     std::span<double> f) {
  for (const HingeRecord& h : records) {
    if (h.status != HingeStatus::Active) continue;
    const std::array<std::uint32_t, 4> v{h.vertices[0], h.vertices[1], h.vertices[2],
                                         h.vertices[3]};
    // The spec's form (alpha, lambda), independent of the folded weights of the table.
    double r[3];
    hingeResidual(x.data(), v.data(), h.alpha.data(), r);
    hingeScatter(f.data(), v.data(), h.alpha.data(), -h.lambda, r);
  }
}

// ---------------------------------------------------------------------------------------------
// Topology events (spec section 6). Handlers see the mesh in its final state.

void FastTriangularBendingSprings::onTrianglesDestroyed(const Topology& t,
                                                        const topology::TrianglesDestroyed& ev) {
  // Each surviving edge of a removed triangle: recompute from the triangles it has now.
  for (const topology::TriangleEdges& te : ev.edges) {
    for (EdgeId e : te) recomputeEdge(t, e);
  }
}

void FastTriangularBendingSprings::onEdgesDestroyed(const Topology&,
                                                    const topology::EdgesDestroyed& ev) {
  for (EdgeId e : ev.edges) {
    if (e >= edgeSlot_.size() || edgeSlot_[e] == encode(HingeStatus::DeadEdge)) {
      eventProblems_.push_back("edges destroyed: " + edgeName(e) + " was not in the table");
      continue;
    }
    HingeRecord dead;
    dead.edge = e;
    dead.status = HingeStatus::DeadEdge;
    setEdge(e, dead, dead.folded);
  }
}

void FastTriangularBendingSprings::onPointsDestroyed(const Topology&,
                                                     const topology::PointsDestroyed&) {
  // No live spring may reference a destroyed point: a point is destroyed only with all its
  // triangles, whose destruction already deactivated or recomputed every hinge around it.
  // Checking it would cost a pass over the table; validate() does.
}

void FastTriangularBendingSprings::onEdgesCreated(const Topology& t,
                                                  const topology::EdgesCreated& ev) {
  ensureEdgeSlots(t.edgeCapacity());
  for (EdgeId e : ev.edges) {
    if (edgeSlot_[e] != encode(HingeStatus::DeadEdge)) {
      eventProblems_.push_back("edges created: " + edgeName(e) + " was already in the table");
    }
    HingeRecord inactive;
    inactive.edge = e;
    inactive.status = HingeStatus::NoHinge;
    setEdge(e, inactive, inactive.folded);
  }
}

void FastTriangularBendingSprings::onTrianglesCreated(const Topology& t,
                                                      const topology::TrianglesCreated& ev) {
  ensureEdgeSlots(t.edgeCapacity());
  for (const topology::TriangleEdges& te : ev.edges) {
    for (EdgeId e : te) recomputeEdge(t, e);
  }
}

void FastTriangularBendingSprings::onPointsRenumbered(const Topology&,
                                                      const topology::Renumbering& ev) {
  const std::span<const topology::Index> map = ev.oldToNew;
  for (BendingSpring& s : springs_) {
    for (std::uint32_t& v : s.v) {
      const topology::Index n = v < map.size() ? map[v] : kInvalidIndex;
      if (n == kInvalidIndex) {
        eventProblems_.push_back("points renumbered: a spring references dead point " +
                                 std::to_string(v));
      } else {
        v = n;
      }
    }
  }
}

void FastTriangularBendingSprings::onEdgesRenumbered(const Topology&,
                                                     const topology::Renumbering& ev) {
  // Entries move old -> new with their edges; the springs are re-laid out in the new edge order,
  // which restores the streaming locality of a fresh mesh.
  std::vector<std::uint32_t> slots(ev.newSize, encode(HingeStatus::DeadEdge));
  for (std::size_t old = 0; old < edgeSlot_.size(); ++old) {
    const topology::Index n = old < ev.oldToNew.size() ? ev.oldToNew[old] : kInvalidIndex;
    if (n == kInvalidIndex || n >= ev.newSize) {
      if (edgeSlot_[old] != encode(HingeStatus::DeadEdge)) {
        eventProblems_.push_back("edges renumbered: live " + edgeName(static_cast<EdgeId>(old)) +
                                 " has no new index");
      }
      continue;
    }
    slots[n] = edgeSlot_[old];
  }
  std::vector<BendingSpring> springs;
  std::vector<std::uint32_t> springEdge;
  springs.reserve(springs_.size());
  springEdge.reserve(springs_.size());
  for (EdgeId e = 0; e < slots.size(); ++e) {
    if (!isSpringSlot(slots[e])) continue;
    const std::uint32_t old = slots[e];
    slots[e] = static_cast<std::uint32_t>(springs.size());
    springs.push_back(springs_[old]);
    springEdge.push_back(e | (springEdge_[old] & kFallbackBit));
  }
  if (springs.size() != springs_.size()) {
    eventProblems_.push_back("edges renumbered: springs lost with their edges");
  }
  springs_ = std::move(springs);
  springEdge_ = std::move(springEdge);
  edgeSlot_ = std::move(slots);
  // Counters follow what is left.
  BendingCounters c;
  for (EdgeId e = 0; e < edgeSlot_.size(); ++e) {
    const std::uint32_t code = edgeSlot_[e];
    if (isSpringSlot(code)) {
      ++c.activeSprings;
      if (springEdge_[code] & kFallbackBit) ++c.signedFallbacks;
      continue;
    }
    switch (decode(code)) {
      case HingeStatus::ShortWingDistance:
        ++c.shortWingDistance;
        break;
      case HingeStatus::ShortEdge:
        ++c.shortEdge;
        break;
      case HingeStatus::SmallHeight:
        ++c.smallHeight;
        break;
      case HingeStatus::Unrepresentable:
        ++c.unrepresentable;
        break;
      case HingeStatus::NoHinge:
        ++c.noHinge;
        break;
      default:
        break;
    }
  }
  counters_ = c;
}

// ---------------------------------------------------------------------------------------------
// Validation: the incremental table against a rebuild from scratch.

namespace {

std::string describeRecord(const HingeRecord& r) {
  std::ostringstream os;
  os.precision(17);
  os << edgeName(r.edge) << " [" << toString(r.status);
  if (r.status == HingeStatus::Active) {
    os << ": A=" << r.vertices[0] << " B=" << r.vertices[1] << " C=" << r.vertices[2]
       << " D=" << r.vertices[3] << " alpha=(" << r.alpha[0] << ", " << r.alpha[1] << ", "
       << r.alpha[2] << ", " << r.alpha[3] << ") lambda=" << r.lambda;
    if (r.signedFallback) os << " signed fallback";
  }
  os << "]";
  return os.str();
}

/// Same hinge up to labelling: wings {A, B} and edge ends {C, D} as sets, the weight of each
/// vertex id, lambda to 1e-12 relative.
bool sameHinge(const HingeRecord& a, const HingeRecord& b) {
  if (a.status != b.status) return false;
  if (a.status != HingeStatus::Active) return true;
  if (a.signedFallback != b.signedFallback) return false;
  std::map<PointId, double> wa, wb;
  for (int i = 0; i < 4; ++i) {
    wa[a.vertices[i]] += a.alpha[i];
    wb[b.vertices[i]] += b.alpha[i];
  }
  if (wa.size() != 4 || wb.size() != 4) return false;
  const auto wingsA = std::minmax(a.vertices[0], a.vertices[1]);
  const auto wingsB = std::minmax(b.vertices[0], b.vertices[1]);
  if (wingsA != wingsB) return false;
  for (const auto& [v, w] : wa) {
    const auto it = wb.find(v);
    if (it == wb.end()) return false;
    if (std::fabs(w - it->second) > 1e-12 * std::max(1.0, std::fabs(w))) return false;
  }
  return std::fabs(a.lambda - b.lambda) <= 1e-12 * std::max(std::fabs(a.lambda), 1e-300);
}

}  // namespace

void FastTriangularBendingSprings::validate(const Topology& topology,
                                            std::vector<std::string>& problems) const {
  const std::string who = "FastTriangularBendingSprings: ";
  const std::size_t problemsBefore = problems.size();
  for (const std::string& p : eventProblems_) problems.push_back(who + p);

  // Internal consistency of the compact array and the edge map.
  if (springs_.size() != springEdge_.size()) {
    problems.push_back(who + "springs and their edge back-references differ in size");
    return;
  }
  for (std::size_t s = 0; s < springs_.size(); ++s) {
    const std::uint32_t e = springEdge_[s] & kEdgeMask;
    if (e >= edgeSlot_.size() || edgeSlot_[e] != s) {
      problems.push_back(who + "spring " + std::to_string(s) + " of " + edgeName(e) +
                         " is not what the edge map points to");
    }
  }
  if (edgeSlot_.size() < topology.edgeCapacity()) {
    problems.push_back(who + "the table has " + std::to_string(edgeSlot_.size()) +
                       " edge slots, the topology " + std::to_string(topology.edgeCapacity()));
  }
  for (EdgeId e = 0; e < edgeSlot_.size(); ++e) {
    const bool alive = e < topology.edgeCapacity() && topology.isEdgeAlive(e);
    const bool inTable = edgeSlot_[e] != encode(HingeStatus::DeadEdge);
    if (alive != inTable) {
      problems.push_back(
          who + edgeName(e) +
          (alive ? " is alive but dead in the table" : " is dead but alive in the table"));
    }
  }

  // Against the rebuild.
  const std::vector<HingeRecord> ref = buildFromScratch(topology, params_);
  BendingCounters refCounters;
  for (const HingeRecord& r : ref) {
    switch (r.status) {
      case HingeStatus::Active:
        ++refCounters.activeSprings;
        if (r.signedFallback) ++refCounters.signedFallbacks;
        break;
      case HingeStatus::ShortWingDistance:
        ++refCounters.shortWingDistance;
        break;
      case HingeStatus::ShortEdge:
        ++refCounters.shortEdge;
        break;
      case HingeStatus::SmallHeight:
        ++refCounters.smallHeight;
        break;
      case HingeStatus::Unrepresentable:
        ++refCounters.unrepresentable;
        break;
      case HingeStatus::NoHinge:
        ++refCounters.noHinge;
        break;
      case HingeStatus::DeadEdge:
        break;
    }
    const HingeRecord mine = hinge(r.edge);
    if (!sameHinge(mine, r)) {
      problems.push_back(who + "table has " + describeRecord(mine) + ", a rebuild gives " +
                         describeRecord(r));
    }
  }
  if (!(refCounters == counters_)) {
    problems.push_back(
        who + "counters differ from a rebuild (active " + std::to_string(counters_.activeSprings) +
        " vs " + std::to_string(refCounters.activeSprings) + ", degenerate " +
        std::to_string(counters_.degenerate()) + " vs " + std::to_string(refCounters.degenerate()) +
        ", fallbacks " + std::to_string(counters_.signedFallbacks) + " vs " +
        std::to_string(refCounters.signedFallbacks) + ")");
  }
  if (springs_.size() != refCounters.activeSprings) {
    problems.push_back(who + std::to_string(springs_.size()) + " active springs, a rebuild has " +
                       std::to_string(refCounters.activeSprings));
  }

  // Springs must reference live points only, then the same forces on a random x.
  const Index cap = topology.pointCapacity();
  bool pointsOk = true;
  for (std::size_t s = 0; s < springs_.size(); ++s) {
    for (std::uint32_t v : springs_[s].v) {
      if (v >= cap || !topology.isPointAlive(v)) {
        problems.push_back(who + "spring of " + edgeName(springEdge_[s] & kEdgeMask) +
                           " references dead point " + std::to_string(v));
        pointsOk = false;
      }
    }
  }
  if (!pointsOk || problems.size() != problemsBefore) return;
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> dist(-1.0, 1.0);
  std::vector<double> x(3 * static_cast<std::size_t>(cap));
  for (double& xi : x) xi = dist(rng);
  std::vector<double> f(x.size(), 0.0), fRef(x.size(), 0.0);
  scatterPass(springs_, x.data(), f.data(), -params_.bendingStiffness);
  addForceOfRecords(ref, x, fRef);
  double scale = 0.0, diff = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    scale = std::max(scale, std::fabs(fRef[i]));
    diff = std::max(diff, std::fabs(f[i] - fRef[i]));
  }
  if (diff > 1e-10 * std::max(scale, 1e-300)) {
    std::ostringstream os;
    os.precision(3);
    os << who << "forces on a random x differ from a rebuild's by " << diff << " (max force "
       << scale << ")";
    problems.push_back(os.str());
  }
}

}  // namespace cutsim::forcefields
