#pragma once
// FastTriangularBendingSprings: one linear bending spring per interior edge (Volino and
// Magnenat-Thalmann 2006, as in SOFA), maintained incrementally from topology events.
// Specification: bending-springs.md; implementation notes: docs/bending-springs.md.
//
// Stiffness: the energy 1/2 lambda |R|^2 is quadratic in x (R = sum_i alpha_i x_i, with weights
// fixed at set-up), so K block (i, j) = -lambda alpha_i alpha_j I3 (hinge_kernel.hpp) is the exact
// Jacobian of the force at every x, constant and negative semi-definite: stiffnessIsExact() is
// true and setExactStiffness(true) has nothing to change. Rayleigh damping:
// B = rayleighStiffness K.
#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "cutsim/forcefields/detail/hinge_table.hpp"
#include "cutsim/forcefields/force_field.hpp"
#include "cutsim/forcefields/hinge_kernel.hpp"
#include "cutsim/topology/events.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::forcefields {

class PointPartition;  // (parallel.hpp, private)

/// The component's parameters (spec section 1).
struct BendingParameters {
  using AreaWeights = forcefields::AreaWeights;

  double bendingStiffness = 1.0;   ///< k: finite, >= 0
  double minDistValidity = 1e-6;   ///< eps: finite, >= 0 (an absolute length)
  double rayleighStiffness = 0.0;  ///< this component's Rayleigh stiffness factor: finite, >= 0
  AreaWeights areaWeights = AreaWeights::Unsigned;

  /// Throws cutsim::InvalidInput with where() = the parameter's name for a negative, NaN or
  /// infinite value.
  void validate() const;
};

/// "unsigned" or "signed"; anything else throws InvalidInput(where = "areaWeights").
AreaWeights parseAreaWeights(std::string_view name);
std::string_view toString(AreaWeights weights);

/// One hinge as a record: what the table holds for an edge, or what a rebuild computes.
struct HingeRecord {
  EdgeId edge = EdgeId::invalid();
  HingeStatus status = HingeStatus::NoHinge;
  bool signedFallback = false;
  /// A, B (wings), C, D (edge endpoints); kInvalidIndex unless status is Active.
  std::array<PointId, 4> vertices{PointId::invalid(), PointId::invalid(), PointId::invalid(),
                                  PointId::invalid()};
  std::array<double, 4> alpha{};   ///< zeros unless active
  double lambda = 0.0;             ///< zero unless active
  std::array<double, 4> folded{};  ///< sqrt(lambda / k) alpha (zeros unless active)
};

/// The counters of the table (the current state, not a history).
struct BendingCounters {
  std::size_t activeSprings = 0;
  std::size_t noHinge = 0;  ///< live edges with fewer than two triangles
  std::size_t shortWingDistance = 0;
  std::size_t shortEdge = 0;
  std::size_t smallHeight = 0;
  std::size_t unrepresentable = 0;
  std::size_t signedFallbacks = 0;  ///< active springs on unsigned weights though signed asked
  std::size_t degenerate() const {
    return shortWingDistance + shortEdge + smallHeight + unrepresentable;
  }
  bool operator==(const BendingCounters&) const = default;
};

/// One active spring as stored (40 bytes): 4 vertex ids and 3 numbers from which the folded
/// weights w_i = sqrt(lambda / k) alpha_i (see hinge_kernel.hpp) follow, since alpha_A + alpha_B
/// = 1 and alpha_C + alpha_D = -1: w_B = root - w_A, w_D = -root - w_C with root = sqrt(lambda /
/// k). Then alpha_i = w_i / root and lambda = k root^2.
struct BendingSpring {
  std::array<std::uint32_t, 4> v;  ///< A, B, C, D
  double wA;                       ///< root alpha_A
  double wC;                       ///< root alpha_C
  double root;                     ///< sqrt(lambda / k)
  /// w for A, B, C, D (the four weights sum to 0 up to one rounding).
  std::array<double, 4> weights() const { return {wA, root - wA, wC, -root - wC}; }
};
static_assert(sizeof(BendingSpring) == 40);

namespace detail {

/// What the hinge table of FastTriangularBendingSprings stores and counts (detail/hinge_table.hpp).
struct BendingSpringTraits {
  using Entry = BendingSpring;
  using Record = HingeRecord;
  using Status = HingeStatus;
  using Counters = BendingCounters;
  using Counter = std::size_t BendingCounters::*;

  static constexpr Counter counter(HingeStatus s) {
    switch (s) {
      case HingeStatus::Active:
        return &BendingCounters::activeSprings;
      case HingeStatus::ShortWingDistance:
        return &BendingCounters::shortWingDistance;
      case HingeStatus::ShortEdge:
        return &BendingCounters::shortEdge;
      case HingeStatus::SmallHeight:
        return &BendingCounters::smallHeight;
      case HingeStatus::Unrepresentable:
        return &BendingCounters::unrepresentable;
      case HingeStatus::NoHinge:
        return &BendingCounters::noHinge;
      case HingeStatus::DeadEdge:
        break;
    }
    return nullptr;
  }
  static constexpr std::string_view kName = "FastTriangularBendingSprings";
  static constexpr std::string_view kNoun = "spring";
  static constexpr std::string_view kNouns = "springs";
  static constexpr bool kChecksEntryCount = true;
  /// The flag in the top bit of a spring's edge id: it fell back to the unsigned weights.
  static constexpr bool HingeRecord::*kFlag = &HingeRecord::signedFallback;
  static constexpr Counter kFlagCounter = &BendingCounters::signedFallbacks;
  static constexpr std::string_view kFlagName = "fallbacks";
};

}  // namespace detail

/// The table and the events (hinge(e), counters(), numEdgeSlots(), the TopologyObserver handlers
/// and validate()) come from detail::HingeTable; this class holds the springs' own parts.
class FastTriangularBendingSprings
    : public ForceField,
      public detail::HingeTable<FastTriangularBendingSprings, detail::BendingSpringTraits> {
 public:
  /// Validates the parameters, builds the table once from the current mesh (rest positions from
  /// topology.restPosition) and subscribes to the topology, which must outlive this object's use.
  FastTriangularBendingSprings(topology::Topology& topology, BendingParameters parameters);
  FastTriangularBendingSprings(const FastTriangularBendingSprings&) = delete;
  FastTriangularBendingSprings& operator=(const FastTriangularBendingSprings&) = delete;
  ~FastTriangularBendingSprings() override;

  // ---- ForceField ----
  std::string typeName() const override { return std::string(detail::BendingSpringTraits::kName); }
  void addForce(std::span<const double> x, std::span<const double> v,
                std::span<double> f) const override;
  void addDForce(std::span<const double> x, std::span<const double> dx, std::span<double> df,
                 double kFactor, double bFactor) const override;
  double potentialEnergy(std::span<const double> x) const override;
  void addKToMatrix(std::span<const double> x, MatrixAccumulator& m, double kFactor) const override;
  void addBToMatrix(std::span<const double> x, MatrixAccumulator& m, double bFactor) const override;
  /// One segment per active spring, from wing A to wing B.
  void draw(std::vector<std::array<PointId, 2>>& segments) const override;
  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override;
  void loadState(ArchiveReader& in) override;

  // ---- the table (spec section 6: its events are detail::HingeTable's) ----
  // validate() compares the table with buildFromScratch: statuses per edge, active hinges as
  // vertex sets with the same weight per vertex id and the same lambda (1e-12 relative), the
  // counters, and the forces on a random x. hinge(e) recovers alpha and lambda from the folded
  // weights (to a few units of rounding).
  const BendingParameters& parameters() const { return params_; }
  /// The active springs, compact (their order changes with removals and compaction).
  std::span<const BendingSpring> activeSprings() const { return entries(); }
  std::size_t numActiveSprings() const { return entries().size(); }
  /// "bendingStiffness: ..." when springs are dropped as unrepresentable (k times a hinge's
  /// geometry beyond 1e306, or a geometry beyond the range of doubles) while k > 0.
  std::string problemAtRest() const override;
  /// The record of active spring i (0 <= i < numActiveSprings()).
  HingeRecord springRecord(std::size_t i) const { return entryRecord(i); }
  /// Records of every live edge of the table, ascending edge id.
  std::vector<HingeRecord> hinges() const { return liveRecords(); }
  /// Bytes held by the table per edge slot (sizes, not capacities).
  using HingeTable::bytesPerEdgeSlot;

  /// The table built from scratch on the current mesh: one record per live edge, ascending id.
  static std::vector<HingeRecord> buildFromScratch(const topology::Topology& topology,
                                                   const BendingParameters& parameters);
  /// The hinge of one edge computed from the mesh (A in the triangle left of edgeVertices(e)).
  static HingeRecord hingeFromMesh(const topology::Topology& topology, EdgeId e,
                                   const BendingParameters& parameters);
  /// f += forces of `records` at x (the brute-force twin of addForce, for validation and tests).
  static void addForceOfRecords(std::span<const HingeRecord> records, std::span<const double> x,
                                std::span<double> f);

 private:
  friend HingeTable;
  // What detail::HingeTable asks of the field.
  static BendingSpring toEntry(const HingeRecord& r);
  void fillRecord(const BendingSpring& s, HingeRecord& r) const;
  static bool sameHinge(const HingeRecord& a, const HingeRecord& b);
  static std::string describe(const HingeRecord& r);
  void fillValidationPositions(const topology::Topology& topology, std::span<double> x) const;
  void addTableForces(std::span<const double> x, std::span<double> f) const;

  void checkSizes(std::span<const double> a, std::span<const double> b, const char* what) const;
  /// f += c w_i R'(x) per spring (the force with c = -k, the product with c = -kFactor k): on one
  /// thread in the springs' order, on several (cutsim::threads()) split by the points written
  /// (PointPartition), with the same bits.
  void scatterPass(const double* x, double* f, double c) const;

  const topology::Topology* topology_;
  BendingParameters params_;
  std::unique_ptr<PointPartition> partition_;  // (parallel.hpp)
};

extern template class detail::HingeTable<FastTriangularBendingSprings, detail::BendingSpringTraits>;

}  // namespace cutsim::forcefields
