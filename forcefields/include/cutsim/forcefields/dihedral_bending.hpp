#pragma once
// DihedralBending: a nonlinear bending force field after Discrete Shells (Grinspun, Hirani,
// Desbrun and Schroeder, SCA 2003), maintained incrementally from topology events.
// Notes and the accuracy study: docs/forcefields.md, docs/study.md.
//
// One hinge per interior edge, named as in bending-springs.md: C and D are the edge's endpoints,
// A and B the wings (A in the triangle to the left of edgeVertices(e), C = v0, D = v1). With REST
// edge length l, REST wing heights hA, hB (distances of A and B to the line CD), the signed
// dihedral angle theta at x and its rest value theta0:
//
//   E = c (theta - theta0)^2,   c = k l / (3 (hA + hB)),
//
// so that for small folds of a flat sheet E agrees with FastTriangularBendingSprings at the same
// k (whose energy is (4/3) k l sin^2(theta/2) / (hA + hB)). theta - theta0 is wrapped to
// [-pi, pi], and theta = atan2(((NB x NA) . e) / |e|, NA . NB) with
//
//   NA = (xA - xC) x (xA - xD),   NB = (xB - xD) x (xB - xC),   e = xD - xC,
//
// (theta = 0 for a flat hinge; it grows when wing A moves along +NA; robust up to +-pi).
// Its gradient is closed form (Bridson, Marino and Fedkiw, SCA 2003):
//
//   g_A = |e| NA / |NA|^2,   g_B = |e| NB / |NB|^2,
//   g_C =   ((xA - xD).e / |e|) NA / |NA|^2 + ((xB - xD).e / |e|) NB / |NB|^2,
//   g_D = - ((xA - xC).e / |e|) NA / |NA|^2 - ((xB - xC).e / |e|) NB / |NB|^2,
//
// and the force is f_i = -2 c (theta - theta0) g_i, exactly -dE/dx.
//
// Stiffness. The exact K = dF/dx is minus the Hessian of E:
//
//   K_exact = -(2 c g g^T + 2 c (theta - theta0) d2theta/dx2),
//
// which is indefinite away from the rest angle. By default (exactHessian = false) K
// (addDForce, addKToMatrix) is minus the Gauss-Newton part only:
//
//   K block (i, j) = -2 c g_i g_j^T     (symmetric, negative semi-definite, rank one per hinge),
//
// which is the exact d(force)/dx where theta = theta0 (the dropped term vanishes there) and NOT
// elsewhere: an implicit step with it is a stable, slightly over-damped Newton-like step, and
// stiffnessIsExact() is false. With exactHessian = true (or setExactStiffness(true)) K is
// K_exact, exact to rounding, for Newton's method on the incremental potential (which then needs
// its own safeguard against the indefinite part: a line search, a projection, ...). The second
// derivatives are computed by forward-mode automatic differentiation of the closed-form gradient
// above (one pass per hinge with one direction in addDForce, with twelve in addKToMatrix, whose
// 12 x 12 hinge blocks are symmetrised), so they are exactly the derivatives of that gradient.
// Rayleigh damping: B = rayleighStiffness * K_GN, the Gauss-Newton K in both modes (so B stays
// negative semi-definite); addDForce then gives (kFactor K + bFactor B) dx with each its own K.
//
// Degenerate hinges: at set-up, a hinge whose rest edge is <= minDist, or a rest wing height
// <= minDist or <= 1e-8 l (a sliver: coincident points, zero areas), or with coordinates beyond
// 1e60 gets no term and is counted. During a run, a hinge whose CURRENT edge length or wing height
// falls below 1e-12 of the hinge's current size has no direction: it gives no force and zero
// stiffness at that x (its energy still counts). Nothing computes a NaN or an infinity.
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "cutsim/forcefields/detail/hinge_table.hpp"
#include "cutsim/forcefields/force_field.hpp"
#include "cutsim/topology/events.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::forcefields {

/// The component's parameters.
struct DihedralBendingParameters {
  double bendingStiffness = 1.0;   ///< k: finite, >= 0 (the springs' k: k = 3 D)
  double minDist = 1e-6;           ///< degenerate hinge threshold (absolute length): finite, >= 0
  double rayleighStiffness = 0.0;  ///< this component's Rayleigh stiffness factor: finite, >= 0
  /// K = the exact Hessian's opposite (indefinite) instead of the Gauss-Newton K (negative
  /// semi-definite): see "Stiffness" at the top of this file. B uses the Gauss-Newton K in both.
  bool exactHessian = false;

  /// Throws cutsim::InvalidInput with where() = the parameter's name for a negative, NaN or
  /// infinite value (exactHessian: any value).
  void validate() const;
};

/// The state of one edge slot of the table.
enum class DihedralStatus : std::uint8_t {
  Active = 0,       ///< a hinge term
  ShortEdge,        ///< rest |pD - pC| <= minDist
  SmallHeight,      ///< a rest wing height <= minDist or <= 1e-8 l (a sliver)
  Unrepresentable,  ///< rest coordinates beyond 1e60
  NoHinge,          ///< fewer than two triangles on the edge (a boundary edge)
  DeadEdge,         ///< the edge slot is dead
};

/// "active", "short_edge", "small_height", "unrepresentable", "no_hinge", "dead_edge".
std::string_view toString(DihedralStatus status);

/// One hinge as a record: what the table holds for an edge, or what a rebuild computes.
struct DihedralRecord {
  EdgeId edge = EdgeId::invalid();
  DihedralStatus status = DihedralStatus::NoHinge;
  /// A, B (wings), C, D (edge endpoints); kInvalidIndex unless active.
  std::array<PointId, 4> vertices{PointId::invalid(), PointId::invalid(), PointId::invalid(),
                                  PointId::invalid()};
  double coefficient = 0.0;  ///< c = k l / (3 (hA + hB)); zero unless active
  double restAngle = 0.0;    ///< theta0 in (-pi, pi]; zero unless active
};

/// One active hinge as stored (32 bytes).
struct DihedralHinge {
  std::array<std::uint32_t, 4> v;  ///< A, B, C, D
  double coefficient;              ///< c = k l / (3 (hA + hB))
  double restAngle;                ///< theta0
};
static_assert(sizeof(DihedralHinge) == 32);

/// The counters of the table (the current state).
struct DihedralCounters {
  std::size_t active = 0;
  std::size_t noHinge = 0;
  std::size_t shortEdge = 0;
  std::size_t smallHeight = 0;
  std::size_t unrepresentable = 0;
  std::size_t degenerate() const { return shortEdge + smallHeight + unrepresentable; }
  bool operator==(const DihedralCounters&) const = default;
};

/// The signed dihedral angle of the hinge (A, B; C, D) (see the top of this file); 0 if it is
/// degenerate (no direction).
double dihedralAngle(const topology::Vec3& a, const topology::Vec3& b, const topology::Vec3& c,
                     const topology::Vec3& d);

/// The set-up of one hinge from its rest points (edge and vertices left unset).
DihedralRecord dihedralHinge(const topology::Vec3& a, const topology::Vec3& b,
                             const topology::Vec3& c, const topology::Vec3& d,
                             const DihedralBendingParameters& parameters);

namespace detail {

/// What the hinge table of DihedralBending stores and counts (detail/hinge_table.hpp).
struct DihedralHingeTraits {
  using Entry = DihedralHinge;
  using Record = DihedralRecord;
  using Status = DihedralStatus;
  using Counters = DihedralCounters;
  using Counter = std::size_t DihedralCounters::*;

  static constexpr Counter counter(DihedralStatus s) {
    switch (s) {
      case DihedralStatus::Active:
        return &DihedralCounters::active;
      case DihedralStatus::ShortEdge:
        return &DihedralCounters::shortEdge;
      case DihedralStatus::SmallHeight:
        return &DihedralCounters::smallHeight;
      case DihedralStatus::Unrepresentable:
        return &DihedralCounters::unrepresentable;
      case DihedralStatus::NoHinge:
        return &DihedralCounters::noHinge;
      case DihedralStatus::DeadEdge:
        break;
    }
    return nullptr;
  }
  static constexpr std::string_view kName = "DihedralBending";
  static constexpr std::string_view kNoun = "hinge";
  static constexpr std::string_view kNouns = "hinges";
  static constexpr bool kChecksEntryCount = false;
  /// No per-hinge flag.
  static constexpr bool DihedralRecord::*kFlag = nullptr;
  static constexpr Counter kFlagCounter = nullptr;
  static constexpr std::string_view kFlagName = "";
};

}  // namespace detail

/// The table and the events (hinge(e), counters(), numEdgeSlots(), the TopologyObserver handlers
/// and validate()) come from detail::HingeTable, shared with FastTriangularBendingSprings; this
/// class holds the model's own parts.
class DihedralBending : public ForceField,
                        public detail::HingeTable<DihedralBending, detail::DihedralHingeTraits> {
 public:
  /// Validates the parameters, builds the table once from the current mesh (rest positions from
  /// topology.restPosition) and subscribes to the topology, which must outlive this object's use.
  DihedralBending(topology::Topology& topology, DihedralBendingParameters parameters);
  DihedralBending(const DihedralBending&) = delete;
  DihedralBending& operator=(const DihedralBending&) = delete;
  ~DihedralBending() override;

  // ---- ForceField ----
  std::string typeName() const override { return std::string(detail::DihedralHingeTraits::kName); }
  void addForce(std::span<const double> x, std::span<const double> v,
                std::span<double> f) const override;
  /// df += (kFactor + bFactor rayleighStiffness) K_GN(x) dx (Gauss-Newton K: see the top);
  /// with exactHessian, df += (kFactor K_exact(x) + bFactor rayleighStiffness K_GN(x)) dx.
  void addDForce(std::span<const double> x, std::span<const double> dx, std::span<double> df,
                 double kFactor, double bFactor) const override;
  double potentialEnergy(std::span<const double> x) const override;
  /// 16 blocks per active hinge (zero blocks for a hinge degenerate at x): K_GN, or K_exact with
  /// exactHessian.
  void addKToMatrix(std::span<const double> x, MatrixAccumulator& m, double kFactor) const override;
  /// rayleighStiffness K_GN in both modes.
  void addBToMatrix(std::span<const double> x, MatrixAccumulator& m, double bFactor) const override;
  /// parameters().exactHessian.
  bool stiffnessIsExact() const override { return params_.exactHessian; }
  /// Sets parameters().exactHessian = exact; returns true (both are available).
  bool setExactStiffness(bool exact) override;
  /// One segment per active hinge, from wing A to wing B.
  void draw(std::vector<std::array<PointId, 2>>& segments) const override;
  /// "bendingStiffness: ..." when a hinge's stiffness at rest (2 c / h^2, h its smaller wing
  /// height) is beyond what the solves can hold (1e306), as a stiffness of 1e308 makes it.
  std::string problemAtRest() const override;
  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override;
  void loadState(ArchiveReader& in) override;

  // ---- the table (its events are detail::HingeTable's) ----
  // validate() compares the table with buildFromScratch: statuses per edge, active hinges with
  // the same wings and edge ends (as sets), coefficient and rest angle (1e-12), the counters, and
  // the forces on a random non-flat x.
  const DihedralBendingParameters& parameters() const { return params_; }
  std::span<const DihedralHinge> activeHinges() const { return entries(); }
  std::size_t numActiveHinges() const { return entries().size(); }
  /// Records of every live edge of the table, ascending edge id.
  std::vector<DihedralRecord> records() const { return liveRecords(); }
  /// Hinges that are degenerate at x (no direction: no force, no stiffness there).
  std::size_t numDegenerateAt(std::span<const double> x) const;

  /// The table built from scratch: one record per live edge, ascending id.
  static std::vector<DihedralRecord> buildFromScratch(const topology::Topology& topology,
                                                      const DihedralBendingParameters& parameters);
  /// The hinge of edge e computed from the mesh (A in the triangle left of edgeVertices(e)).
  static DihedralRecord hingeFromMesh(const topology::Topology& topology, EdgeId e,
                                      const DihedralBendingParameters& parameters);
  /// f += forces of `records` at x (the brute-force twin of addForce).
  static void addForceOfRecords(std::span<const DihedralRecord> records, std::span<const double> x,
                                std::span<double> f);

 private:
  friend HingeTable;
  // What detail::HingeTable asks of the field.
  static DihedralHinge toEntry(const DihedralRecord& r);
  void fillRecord(const DihedralHinge& h, DihedralRecord& r) const;
  static bool sameHinge(const DihedralRecord& a, const DihedralRecord& b);
  static std::string describe(const DihedralRecord& r);
  void fillValidationPositions(const topology::Topology& topology, std::span<double> x) const;
  void addTableForces(std::span<const double> x, std::span<double> f) const;

  void checkSize(std::span<const double> a, const char* what) const;

  const topology::Topology* topology_;
  DihedralBendingParameters params_;
};

extern template class detail::HingeTable<DihedralBending, detail::DihedralHingeTraits>;

}  // namespace cutsim::forcefields
