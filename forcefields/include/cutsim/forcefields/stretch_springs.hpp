#pragma once
// StretchSprings: one linear spring per live edge of the mesh (as SOFA's MeshSpringForceField on a
// triangle mesh), maintained incrementally from topology events. Notes: docs/forcefields.md.
//
// For a spring between points i and j with rest length L0, d = x_j - x_i, l = |d|, u = d / l:
//
//   f_j = -ks (l - L0) u - kd ((v_j - v_i) . u) u,   f_i = -f_j,   E = 1/2 ks (l - L0)^2,
//   K block (j, j) = (i, i) = -(i, j) = -(j, i) = -ks [ a (I - u u^T) + u u^T ],  a = 1 - L0 / l,
//   B block (j, j) = (i, i) = -(i, j) = -(j, i) = -kd u u^T.
//
// Prestrain: L0 = restScale * |X_j - X_i| (X the rest positions of the mesh), as restScale on
// SOFA's FEM fields scales the rest positions. With restScale < 1 every spring of a sheet held at
// its mesh positions is stretched by the strain 1/restScale - 1 (a resting tension).
//
// Whether K is exact: with stableJacobian (the default), a is clamped to >= 0 (compressed
// springs), which keeps K negative semi-definite for implicit solvers; K is then NOT the exact
// derivative of the force for compressed springs (it is for stretched ones), and
// stiffnessIsExact() is false. With stableJacobian = false, K is the exact Jacobian of the
// elastic force everywhere, and stiffnessIsExact() is true. setExactStiffness(true) sets
// stableJacobian = false; setExactStiffness(false) restores the value given at construction.
// K never includes the derivative of the damping force with respect to positions (u depends on
// x), as in SOFA: with damping > 0 and nonzero relative velocities, "exact" means exact for the
// elastic force (the damping force is handled by B).
// A spring whose current length is zero (l^2 below the smallest normal double) has no direction:
// it contributes no force, no damping and zero matrix blocks (its energy 1/2 ks L0^2 still counts).
#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "cutsim/forcefields/force_field.hpp"
#include "cutsim/topology/dense_slot_table.hpp"
#include "cutsim/topology/events.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::forcefields {

class PointPartition;  // (parallel.hpp, private)

/// The component's parameters.
struct StretchParameters {
  double stiffness = 100.0;    ///< ks, per spring: finite, >= 0
  double damping = 0.0;        ///< kd, per spring: finite, >= 0
  bool stableJacobian = true;  ///< clamp 1 - L0/l to >= 0 in K (see the top of this file)
  /// s: finite, > 0. Every rest length is s times the mesh's (prestrain: s < 1 stretches a sheet
  /// held at its mesh positions by 1/s - 1).
  double restScale = 1.0;
  /// Each spring's stiffness and damping divided by its mesh rest length (N/m becomes N): SOFA's
  /// MeshSpringForceField, whose springs are stiffness / L0.
  bool perRestLength = false;

  /// Throws cutsim::InvalidInput with where() = the parameter's name for a value out of range
  /// (negative; restScale: not > 0), NaN or infinite.
  void validate() const;
};

/// One spring as stored: its two point ids and its rest length (16 bytes).
struct StretchSpring {
  std::uint32_t a;    ///< first endpoint (edgeVertices(e)[0] when the edge was created)
  std::uint32_t b;    ///< second endpoint
  double restLength;  ///< restScale times the mesh's edge length
};
static_assert(sizeof(StretchSpring) == 16);

namespace detail {
/// What the springs' table stores per edge (topology/dense_slot_table.hpp): a spring, or nothing.
struct StretchTableTraits {
  enum class Status : std::uint8_t { NoSpring };
  static constexpr Status kEmpty = Status::NoSpring;
  static constexpr bool kHasFlag = false;
  static constexpr std::string_view kNoun = "spring";
  static constexpr std::string_view kNouns = "springs";
  template <class F>
  static void forEachPoint(StretchSpring& s, F&& f) {
    f(s.a);
    f(s.b);
  }
};
}  // namespace detail

/// One spring as a record: what the table holds for an edge, or what a rebuild computes.
struct StretchRecord {
  EdgeId edge = EdgeId::invalid();
  std::array<PointId, 2> vertices{PointId::invalid(), PointId::invalid()};
  double restLength = 0.0;
};

class StretchSprings : public ForceField, public topology::TopologyObserver {
 public:
  /// Validates the parameters, builds the table once from the current mesh (rest lengths from
  /// topology.restPosition, times restScale) and subscribes to the topology, which must outlive
  /// this object's use.
  StretchSprings(topology::Topology& topology, StretchParameters parameters);
  StretchSprings(const StretchSprings&) = delete;
  StretchSprings& operator=(const StretchSprings&) = delete;
  ~StretchSprings() override;

  // ---- ForceField ----
  std::string typeName() const override { return "StretchSprings"; }
  /// v is read only when damping > 0.
  void addForce(std::span<const double> x, std::span<const double> v,
                std::span<double> f) const override;
  void addDForce(std::span<const double> x, std::span<const double> dx, std::span<double> df,
                 double kFactor, double bFactor) const override;
  double potentialEnergy(std::span<const double> x) const override;
  /// Four 3x3 blocks per spring, zero blocks included (the pattern depends on the topology only).
  void addKToMatrix(std::span<const double> x, MatrixAccumulator& m, double kFactor) const override;
  /// Nothing when bFactor * damping is zero; else four blocks per spring.
  void addBToMatrix(std::span<const double> x, MatrixAccumulator& m, double bFactor) const override;
  /// One segment per spring.
  void draw(std::vector<std::array<PointId, 2>>& segments) const override;
  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override;
  void loadState(ArchiveReader& in) override;
  /// !parameters().stableJacobian (see the top of this file).
  bool stiffnessIsExact() const override { return !params_.stableJacobian; }
  /// exact: stableJacobian = false; otherwise the stableJacobian given at construction. Drops
  /// the linearisation cached by addDForce when that changes K. Returns true.
  bool setExactStiffness(bool exact) override;
  /// Between these the products at that x reuse the linearisation without comparing x again.
  void beginProducts(std::span<const double> x) const override;
  void endProducts(std::span<const double> x) const override;

  // ---- TopologyObserver: the table follows edge events and point renumbering only ----
  void onEdgesDestroyed(const topology::Topology&, const topology::EdgesDestroyed&) override;
  void onEdgesCreated(const topology::Topology&, const topology::EdgesCreated&) override;
  void onPointsRenumbered(const topology::Topology&, const topology::Renumbering&) override;
  void onEdgesRenumbered(const topology::Topology&, const topology::Renumbering&) override;
  std::string observerName() const override { return typeName(); }
  /// Compares the table with buildFromScratch on `topology`: one spring per live edge, the same
  /// endpoints (as an unordered pair) and the same rest length (1e-12 relative), springs on live
  /// points only, plus the internal consistency of the compact array and the edge map.
  void validate(const topology::Topology& topology,
                std::vector<std::string>& problems) const override;

  // ---- the table ----
  const StretchParameters& parameters() const { return params_; }
  /// The springs, compact (their order changes with removals and compaction).
  std::span<const StretchSpring> springs() const { return table_.entries(); }
  std::size_t numSprings() const { return table_.size(); }
  /// The record of edge e (edge = kInvalidIndex if e has no spring: dead or beyond the table).
  StretchRecord spring(EdgeId e) const;
  /// Records of every spring, ascending edge id.
  std::vector<StretchRecord> records() const;
  std::size_t numEdgeSlots() const { return table_.numSlots(); }
  /// Bytes held by the table per edge slot (sizes, not capacities).
  double bytesPerEdgeSlot() const { return table_.bytesPerSlot(); }

  /// The table built from scratch on the current mesh: one record per live edge, ascending id,
  /// rest lengths scaled by parameters.restScale.
  static std::vector<StretchRecord> buildFromScratch(const topology::Topology& topology,
                                                     const StretchParameters& parameters);

 private:
  double springWeight(const StretchSpring& s) const;
  /// Runs body(i, lo, span, owned) over the springs i: on one thread every spring once with
  /// owned = std::false_type (every endpoint its own), on several (cutsim::threads()) the parts
  /// of a PointPartition in parallel, owned = std::true_type: the spring adds its terms to the
  /// endpoints p with p - lo < span (unsigned) only. Same bits either way.
  template <class Body>
  void overSprings(Body&& body) const;
  /// pass(std::true_type) if perRestLength, else pass(std::false_type): the loops compiled for
  /// each, the common one without a weight per spring.
  template <class Pass>
  void withWeights(Pass&& pass) const {
    if (params_.perRestLength)
      pass(std::true_type{});
    else
      pass(std::false_type{});
  }
  void checkSize(std::span<const double> a, const char* name, const char* what) const;

  const topology::Topology* topology_;
  StretchParameters params_;
  bool constructedStableJacobian_;  // params_.stableJacobian as given to the constructor
  // The springs, compact (hot: streamed by every force pass), their edges and the edge index.
  topology::DenseSlotTable<EdgeId, StretchSpring, detail::StretchTableTraits> table_;
  std::vector<std::string> eventProblems_;  // inconsistencies seen while handling events
  topology::Subscription subscription_;
  // Linearisation cache of addDForce: per spring, u and a = 1 - L0 / l at the positions linX_,
  // reused while addDForce is called again at bitwise the same x (an implicit step's CG
  // iterations) and neither the table nor stableJacobian has changed (events and
  // setExactStiffness drop it). Not for concurrent calls on one field.
  struct Linearisation {
    double u[3];
    double a;
  };
  mutable std::vector<Linearisation> lin_;
  mutable std::vector<double> linX_;
  mutable bool linValid_ = false;
  // A solve's operator holds x (beginProducts): its memory, and whether lin_ was made at it.
  mutable int held_ = 0;
  mutable const double* heldX_ = nullptr;
  mutable bool linAtHeld_ = false;
  // The springs split by the points they write, for the passes on several threads.
  std::unique_ptr<PointPartition> partition_;
  const std::vector<Linearisation>& linearisation(std::span<const double> x) const;
};

}  // namespace cutsim::forcefields
