#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <random>
#include <sstream>
#include <stdexcept>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/numbers.hpp"
#include "hinge_table_impl.hpp"
#include "parallel.hpp"

namespace cutsim::forcefields {

template class detail::HingeTable<FastTriangularBendingSprings, detail::BendingSpringTraits>;

namespace {

using detail::edgeName;
using topology::Topology;

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
    : topology_(&topology), params_(parameters), partition_(std::make_unique<PointPartition>()) {
  params_.validate();
  attach(topology);
}

FastTriangularBendingSprings::~FastTriangularBendingSprings() = default;

HingeRecord FastTriangularBendingSprings::hingeFromMesh(const Topology& t, EdgeId e,
                                                        const BendingParameters& p) {
  HingeRecord r;
  r.edge = e;
  const auto vid = detail::hingeVertices(t, e);
  if (!vid) {
    r.status = HingeStatus::NoHinge;
    return r;
  }
  const HingeWeights w =
      computeHinge(t.restPosition((*vid)[0]), t.restPosition((*vid)[1]), t.restPosition((*vid)[2]),
                   t.restPosition((*vid)[3]), p.bendingStiffness, p.minDistValidity, p.areaWeights);
  r.status = w.status;
  if (w.status == HingeStatus::Active) {
    r.vertices = *vid;
    r.alpha = w.alpha;
    r.lambda = w.lambda;
    r.folded = foldedWeights(w);
    r.signedFallback = w.signedFallback;
  }
  return r;
}

std::vector<HingeRecord> FastTriangularBendingSprings::buildFromScratch(
    const Topology& topology, const BendingParameters& parameters) {
  return detail::recordPerLiveEdge(
      topology, [&](EdgeId e) { return hingeFromMesh(topology, e, parameters); });
}

BendingSpring FastTriangularBendingSprings::toEntry(const HingeRecord& r) {
  // root = w_A + w_B = sqrt(lambda / k) (alpha_A + alpha_B), alpha_A + alpha_B = 1.
  return BendingSpring{
      {r.vertices[0].idx(), r.vertices[1].idx(), r.vertices[2].idx(), r.vertices[3].idx()},
      r.folded[0],
      r.folded[2],
      r.folded[0] + r.folded[1]};
}

void FastTriangularBendingSprings::fillRecord(const BendingSpring& s, HingeRecord& r) const {
  r.vertices = {PointId(s.v[0]), PointId(s.v[1]), PointId(s.v[2]), PointId(s.v[3])};
  r.folded = s.weights();
  // alpha_A + alpha_B = 1, so w_A + w_B = sqrt(lambda / k) > 0.
  const double root = s.root;  // > 0 for an active spring
  for (int k = 0; k < 4; ++k) r.alpha[k] = r.folded[k] / root;
  r.lambda = params_.bendingStiffness * root * root;
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

/// The force pass on one thread: f += c w_i R'(x) per spring, streaming over the compact
/// springs. Ids and weights are read into locals first (the table is __restrict: stores into f
/// cannot change it).
void scatterSerial(std::span<const BendingSpring> springs, const double* __restrict x,
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

void FastTriangularBendingSprings::scatterPass(const double* __restrict x, double* __restrict f,
                                               double c) const {
  const std::span<const BendingSpring> springs = entries();
  const int parts = partsFor(springs.size());
  if (parts <= 1) {
    scatterSerial(springs, x, f, c);
    return;
  }
  const BendingSpring* __restrict sp = springs.data();
  partition_->update(parts, topology_->pointCapacity(), springs.size(), 4, tableRevision(),
                     [sp](std::size_t i, std::uint32_t* ids) {
                       for (int a = 0; a < 4; ++a) ids[a] = sp[i].v[std::size_t(a)];
                     });
  inParts(std::size_t(parts), parts, [&](int k, std::size_t, std::size_t) {
    // Pointers and factor in this thread's locals (not read from the caller's stack after every
    // store).
    const BendingSpring* __restrict springsHere = sp;
    const double* __restrict xHere = x;
    double* __restrict fHere = f;
    const double cHere = c;
    const std::uint32_t lo = partition_->first(k), span = partition_->size(k);
    for (const std::uint32_t i : partition_->elements(k)) {
      const std::array<std::uint32_t, 4> v = springsHere[i].v;
      const std::array<double, 4> w = springsHere[i].weights();
      double r[3];
      hingeResidual(xHere, v.data(), w.data(), r);
      hingeScatterOwned(fHere, v.data(), w.data(), cHere, r, lo, span);
    }
  });
}

void FastTriangularBendingSprings::addForce(std::span<const double> x,
                                            std::span<const double> /*v*/,
                                            std::span<double> f) const {
  checkSizes(x, f, "addForce");
  scatterPass(x.data(), f.data(), -params_.bendingStiffness);
}

void FastTriangularBendingSprings::addDForce(std::span<const double> /*x*/,
                                             std::span<const double> dx, std::span<double> df,
                                             double kFactor, double bFactor) const {
  checkSizes(dx, df, "addDForce");
  const double k = kFactor + bFactor * params_.rayleighStiffness;
  if (k == 0.0) return;
  scatterPass(dx.data(), df.data(), -k * params_.bendingStiffness);
}

double FastTriangularBendingSprings::potentialEnergy(std::span<const double> x) const {
  checkSizes(x, x, "potentialEnergy");
  double e = 0.0;
  for (const BendingSpring& s : entries()) {
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
  const bool diagonalOnly = m.diagonalOnly();  // (a preconditioner's: the blocks (i, i))
  for (const BendingSpring& s : springs) {
    const std::array<double, 4> w = s.weights();
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) {
        if (diagonalOnly && i != j) continue;
        m.addScaledIdentity(PointId(s.v[i]), PointId(s.v[j]),
                            factor * hingeBlockCoefficient(k, w.data(), i, j));
      }
    }
  }
}

}  // namespace

void FastTriangularBendingSprings::addKToMatrix(std::span<const double> /*x*/, MatrixAccumulator& m,
                                                double kFactor) const {
  assemble(entries(), m, kFactor, params_.bendingStiffness);
}

void FastTriangularBendingSprings::addBToMatrix(std::span<const double> /*x*/, MatrixAccumulator& m,
                                                double bFactor) const {
  const double factor = bFactor * params_.rayleighStiffness;
  if (factor == 0.0) return;
  assemble(entries(), m, factor, params_.bendingStiffness);
}

void FastTriangularBendingSprings::draw(std::vector<std::array<PointId, 2>>& segments) const {
  segments.reserve(segments.size() + entries().size());
  for (const BendingSpring& s : entries()) segments.push_back({PointId(s.v[0]), PointId(s.v[1])});
}

void FastTriangularBendingSprings::addForceOfRecords(std::span<const HingeRecord> records,
                                                     std::span<const double> x,
                                                     std::span<double> f) {
  for (const HingeRecord& h : records) {
    if (h.status != HingeStatus::Active) continue;
    const std::array<std::uint32_t, 4> v{h.vertices[0].idx(), h.vertices[1].idx(),
                                         h.vertices[2].idx(), h.vertices[3].idx()};
    // The spec's form (alpha, lambda), independent of the folded weights of the table.
    double r[3];
    hingeResidual(x.data(), v.data(), h.alpha.data(), r);
    hingeScatter(f.data(), v.data(), h.alpha.data(), -h.lambda, r);
  }
}

// ---------------------------------------------------------------------------------------------
// Validation (detail::HingeTable::validate): what is the springs' own.

std::string FastTriangularBendingSprings::describe(const HingeRecord& r) {
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
bool FastTriangularBendingSprings::sameHinge(const HingeRecord& a, const HingeRecord& b) {
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

void FastTriangularBendingSprings::fillValidationPositions(const Topology&,
                                                           std::span<double> x) const {
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> dist(-1.0, 1.0);
  for (double& xi : x) xi = dist(rng);
}

void FastTriangularBendingSprings::addTableForces(std::span<const double> x,
                                                  std::span<double> f) const {
  scatterSerial(entries(), x.data(), f.data(), -params_.bendingStiffness);
}

}  // namespace cutsim::forcefields

// ---- the component's registration (scenes, and every other front end) ----
#include "cutsim/forcefields/registry.hpp"

namespace cutsim::forcefields {
namespace {
const bool registered = ForceFieldRegistry::instance().add(
    {"FastTriangularBendingSprings",
     "linear bending springs across interior edges (SOFA's FastTriangularBendingSprings)",
     {{"bendingStiffness", KeyType::Number,
       "k, >= 0 (default 1); k = 3 D for cylindrical bending of a plate of rigidity D"},
      {"minDistValidity", KeyType::Number,
       "degenerate-spring threshold, an absolute length >= 0 (default 1e-6)"},
      {"rayleighStiffness", KeyType::Number,
       "this field's Rayleigh stiffness damping factor, >= 0 (default 0)"},
      {"areaWeights",
       KeyType::Choice,
       "unsigned (SOFA's, default) or signed (no force at rest on cut meshes)",
       {"unsigned", "signed"}}},
     {},
     [](const ParameterSource& s) -> std::any {
       BendingParameters p;
       p.bendingStiffness = s.nonNegative("bendingStiffness", p.bendingStiffness);
       p.minDistValidity = s.nonNegative("minDistValidity", p.minDistValidity);
       p.rayleighStiffness = s.nonNegative("rayleighStiffness", p.rayleighStiffness);
       p.areaWeights =
           parseAreaWeights(s.choice("areaWeights", "unsigned", {"unsigned", "signed"}));
       s.check([&] { p.validate(); });
       return p;
     },
     [](const std::any& p, topology::Topology& t) -> std::unique_ptr<ForceField> {
       return std::make_unique<FastTriangularBendingSprings>(
           t, std::any_cast<const BendingParameters&>(p));
     }});
}  // namespace
std::string FastTriangularBendingSprings::problemAtRest() const {
  const std::size_t dropped = counters().unrepresentable;
  if (!(params_.bendingStiffness > 0) || dropped == 0) return "";
  return "bendingStiffness: " + std::to_string(dropped) + " of " +
         std::to_string(dropped + numActiveSprings()) +
         " springs would be dropped: their stiffness (k times a factor of the hinge's shape) is "
         "beyond what a spring can hold (1e306) at k = " +
         describeNumber(params_.bendingStiffness) + "; lower bendingStiffness";
}

void FastTriangularBendingSprings::saveState(ArchiveWriter& out) const {
  saveTable(out);
}
void FastTriangularBendingSprings::loadState(ArchiveReader& in) {
  loadTable(in, *topology_);
}

}  // namespace cutsim::forcefields
