#pragma once
// TriangularFEM: a corotational linear membrane, one constant-strain triangle per live triangle
// (as SOFA's TriangularFEMForceField, method "large"), maintained incrementally from topology
// events. Notes: docs/forcefields.md.
//
// Per triangle (a, b, c) with rest positions X: a rest frame in the triangle's plane gives 2D rest
// coordinates, whose edge matrix Dm = [Pb - Pa, Pc - Pa] (2x2) is stored inverted as the shape
// gradients g_b, g_c (rows of Dm^-1; g_a = -g_b - g_c), with the rest area A. At x:
//
//   F = sum_k x_k g_k^T (3x2),  F = R S (polar: R 3x2 with orthonormal columns, S = sqrt(F^T F)),
//   eps = S - I,  sigma = 2 mu eps + lambda tr(eps) I  (plane stress: mu = E / (2 (1 + nu)),
//   lambda = E nu / (1 - nu^2)),  E_tri = A h (mu eps:eps + lambda/2 tr(eps)^2),
//   f_k = -A h R sigma g_k.
//
// Prestrain. restScale = s scales every element's rest shape isotropically in its plane, as
// restScale on SOFA's TriangularFEMForceFieldOptim scales the rest positions: Dm = s Dm_mesh, so
// the shape gradients are g / s and the rest area, which weighs the energy and the forces, is the
// SCALED one, A = s^2 A_mesh. With s < 1 the material wants to shrink: a sheet held at its mesh
// positions (F = I / s) is under equibiaxial tension with strain eps = 1/s - 1, stress
// sigma = E eps / (1 - nu), and it stores A h sigma eps per element. Shapes similar to the scaled
// rest shape (s X, moved rigidly) are force-free.
//
// The rotation is the polar factor of F (not SOFA's frame aligned with the edge ab): the two agree
// to first order in the strain, and with the polar factor the force is the exact gradient of the
// energy.
//
// Stiffness. With tangent "corotational", K is the usual corotational approximation, R held
// constant,
//
//   K block (k, l) = -A h R [ mu (g_k . g_l) I2 + mu g_l g_k^T + lambda g_k g_l^T ] R^T,
//
// symmetric and negative semi-definite, exact for rigid motions of the rest shape (eps = 0) and
// off by O(strain) elsewhere. It lacks the geometric stiffness of the stress, which is all the
// out-of-plane stiffness a membrane in tension has: a linearised implicit step then treats a
// prestressed sheet's out-of-plane mode explicitly and, once h omega > 2, flips its sign every
// step (a period-two chatter). By default (tangent "projected") K is the exact Hessian projected
// to the nearest negative semi-definite matrix per element, in closed form: the corotational K
// plus, where their eigenvalues are positive, the twist mode (dF = R J, eigenvalue
// 2 (mu + lambda) (tr S - 2) / tr S, times A) and the two out-of-plane modes (dF = n v_i^T,
// eigenvalues (2 mu (s_i - 1) + lambda (tr S - 2)) / s_i with s_i, v_i the eigenpairs of S and n
// the normal):
//
//   K block (k, l) += -A h [ twist/2 (R J g_k)(R J g_l)^T + (g_l^T m g_k) n n^T ],
//   m = sum_i max(0, eigenvalue_i) v_i v_i^T,
//
// (Smith, de Goes and Kim 2019, "Analytic eigensystems for isotropic distortion energies", for a
// 3 x 2 F). In tension it is the exact K; in compression it is the corotational K. Either way
// stiffnessIsExact() is false. With exactHessian = true (or
// setExactStiffness(true)) K is the exact Jacobian of the force, exact to rounding, in closed
// form: with dF = sum_l dx_l g_l^T,
//
//   d(f_k) = -A h dP g_k,   dP = 2 mu dF + (lambda tr(eps) - 2 mu) dR + lambda tr(dS) R,
//   S dS + dS S = F^T dF + dF^T F (a 2x2 Sylvester equation, solved in closed form),
//   dR = (dF - R dS) S^-1,
//
// symmetric (minus the Hessian of E_tri) but not negative semi-definite in general (compressed
// triangles); addKToMatrix symmetrises each 9 x 9 element block (symmetric up to rounding).
//
// There is no damping (B = 0). A triangle whose current area is (nearly) zero has no rotation:
// it contributes no force and zero blocks in both modes (its energy still counts). A triangle whose
// REST area is (nearly) zero has no element at all (a "degenerate" triangle, counted; validate()
// checks the set against a rebuild).
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "cutsim/forcefields/force_field.hpp"
#include "cutsim/topology/dense_slot_table.hpp"
#include "cutsim/topology/events.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim {
class ParameterSource;
}  // namespace cutsim

namespace cutsim::forcefields {

/// The component's parameters.
struct TriangularFEMParameters {
  double youngModulus = 1000.0;  ///< E: finite, >= 0
  double poissonRatio = 0.3;     ///< nu: finite, in (-1, 0.5)
  double thickness = 1.0;        ///< h: finite, >= 0
  /// s: finite, > 0. Every element's rest shape scaled by s in its plane (prestrain: s < 1 puts a
  /// sheet held at its mesh positions under equibiaxial tension, strain 1/s - 1); the rest area
  /// is the scaled one, s^2 times the mesh's. See "Prestrain" at the top of this file.
  double restScale = 1.0;
  /// The stiffness K when it is not the exact one: "Stiffness" at the top of this file.
  enum class Tangent {
    Projected,     ///< the exact K projected to negative semi-definite (the default)
    Corotational,  ///< R held constant: no geometric stiffness of tension
  };
  Tangent tangent = Tangent::Projected;
  /// K = the exact Jacobian of the force (symmetric, indefinite) instead of `tangent`: see
  /// "Stiffness" at the top of this file.
  bool exactHessian = false;

  /// Throws cutsim::InvalidInput with where() = the parameter's name for a value out of range,
  /// NaN or infinite (exactHessian: any value).
  void validate() const;
};

/// One element as stored: 3 point ids, the shape gradients g_b, g_c and the rest area (56 bytes),
/// both of the rest shape scaled by restScale.
struct FemTriangle {
  std::array<std::uint32_t, 3> v;  ///< a, b, c (counter-clockwise, as the triangle)
  std::uint32_t pad = 0;
  std::array<double, 4> g;  ///< g_b = (g[0], g[1]), g_c = (g[2], g[3])
  double area;              ///< rest area (restScale^2 times the mesh triangle's)
};
static_assert(sizeof(FemTriangle) == 56);

namespace detail {
/// What the elements' table stores per triangle (topology/dense_slot_table.hpp): an element, or
/// the status of a triangle without one.
struct FemTableTraits {
  enum class Status : std::uint8_t {
    DeadTriangle,  ///< a dead slot (or beyond the table)
    Degenerate,    ///< a live triangle without an element (rest area too small)
  };
  static constexpr Status kEmpty = Status::DeadTriangle;
  static constexpr bool kHasFlag = false;
  static constexpr std::string_view kNoun = "element";
  static constexpr std::string_view kNouns = "elements";
  template <class F>
  static void forEachPoint(FemTriangle& e, F&& f) {
    for (std::uint32_t& p : e.v) f(p);
  }
};
}  // namespace detail

/// One triangle as a record: what the table holds, or what a rebuild computes.
struct FemRecord {
  TriangleId triangle = TriangleId::invalid();
  bool degenerate = false;  ///< no element (rest area too small)
  std::array<PointId, 3> vertices{PointId::invalid(), PointId::invalid(), PointId::invalid()};
  std::array<double, 4> g{};  ///< zeros when degenerate (of the scaled rest shape)
  double area = 0.0;          ///< zero when degenerate (scaled rest area)
};

class TriangularFEM : public ForceField, public topology::TopologyObserver {
 public:
  /// Validates the parameters, builds the table once from the current mesh (rest frames from
  /// topology.restPosition, scaled by restScale) and subscribes to the topology, which must outlive
  /// this object's use.
  TriangularFEM(topology::Topology& topology, TriangularFEMParameters parameters);
  TriangularFEM(const TriangularFEM&) = delete;
  TriangularFEM& operator=(const TriangularFEM&) = delete;
  ~TriangularFEM() override;

  // ---- ForceField ----
  std::string typeName() const override { return "TriangularFEM"; }
  void addForce(std::span<const double> x, std::span<const double> v,
                std::span<double> f) const override;
  /// df += kFactor K dx (bFactor is ignored: no damping); K is the corotational K, or the exact
  /// one with exactHessian.
  void addDForce(std::span<const double> x, std::span<const double> dx, std::span<double> df,
                 double kFactor, double bFactor) const override;
  double potentialEnergy(std::span<const double> x) const override;
  /// Nine 3x3 blocks per element, zero blocks included (the pattern depends on the topology only).
  void addKToMatrix(std::span<const double> x, MatrixAccumulator& m, double kFactor) const override;
  /// Nothing (no damping).
  void addBToMatrix(std::span<const double> x, MatrixAccumulator& m, double bFactor) const override;
  /// The three edges of every element.
  void draw(std::vector<std::array<PointId, 2>>& segments) const override;
  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override;
  void loadState(ArchiveReader& in) override;
  /// parameters().exactHessian.
  bool stiffnessIsExact() const override { return params_.exactHessian; }
  /// Sets parameters().exactHessian = exact; returns true (both are available).
  bool setExactStiffness(bool exact) override;

  // ---- TopologyObserver: the table follows triangle events and point renumbering only ----
  void onTrianglesDestroyed(const topology::Topology&,
                            const topology::TrianglesDestroyed&) override;
  void onTrianglesCreated(const topology::Topology&, const topology::TrianglesCreated&) override;
  void onPointsRenumbered(const topology::Topology&, const topology::Renumbering&) override;
  void onTrianglesRenumbered(const topology::Topology&, const topology::Renumbering&) override;
  std::string observerName() const override { return typeName(); }
  /// Compares the table with buildFromScratch: one entry per live triangle, the same vertices (as
  /// a rotation of the triangle's), the same degenerate flag, rest area and energy of a random
  /// displacement (1e-10 relative), plus the internal consistency of the array and the map.
  void validate(const topology::Topology& topology,
                std::vector<std::string>& problems) const override;

  // ---- the table ----
  const TriangularFEMParameters& parameters() const { return params_; }
  std::span<const FemTriangle> elements() const { return table_.entries(); }
  std::size_t numElements() const { return table_.size(); }
  std::size_t numDegenerate() const { return numDegenerate_; }
  /// The record of triangle t (triangle = kInvalidIndex for a dead slot or beyond the table).
  FemRecord element(TriangleId t) const;
  std::size_t numTriangleSlots() const { return table_.numSlots(); }

  /// The table built from scratch: one record per live triangle, ascending id.
  static std::vector<FemRecord> buildFromScratch(const topology::Topology& topology,
                                                 const TriangularFEMParameters& parameters);
  /// The element of one triangle from its rest positions, its rest shape scaled by
  /// parameters.restScale (whether it is degenerate does not depend on the scale).
  static FemRecord elementFromMesh(const topology::Topology& topology, TriangleId t,
                                   const TriangularFEMParameters& parameters);

 protected:
  void checkSize(std::span<const double> a, const char* name, const char* what) const;

 private:
  void addExactKToMatrix(std::span<const double> x, MatrixAccumulator& m, double kFactor) const;
  void setTriangle(TriangleId t, const FemRecord& r);
  void clearTriangle(TriangleId t);

  const topology::Topology* topology_;
  TriangularFEMParameters params_;
  double mu_ = 0.0, lambda_ = 0.0;  // plane-stress Lame coefficients times the thickness
  // The elements, compact (hot: streamed by every force pass), their triangles and the triangle
  // index (an element, Degenerate, or DeadTriangle).
  topology::DenseSlotTable<TriangleId, FemTriangle, detail::FemTableTraits> table_;
  std::size_t numDegenerate_ = 0;
  std::vector<std::string> eventProblems_;
  topology::Subscription subscription_;
};

/// The keys of a TriangularFEM-like registry entry (youngModulus, poissonRatio, thickness,
/// restScale, and tangent and exactHessian if asked), checked.
TriangularFEMParameters readTriangularFEMParameters(const cutsim::ParameterSource& s,
                                                    bool withExactHessian);

}  // namespace cutsim::forcefields
