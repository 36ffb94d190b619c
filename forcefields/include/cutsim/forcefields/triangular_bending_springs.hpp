#pragma once
// TriangularBendingSprings: SOFA's component of that name. Across each interior edge, a linear
// spring joins the two wings A and B (the corners of its two triangles opposite the edge), with
// the rest length |X_B - X_A| of the rest shape:
//
//   d = x_B - x_A, l = |d|, u = d / l,  I = ks (l - L0) + kd (v_B - v_A) . u,
//   f_A = I u,  f_B = -I u,  E = 1/2 ks (l - L0)^2,
//   K block (A, B) = (B, A) = -(A, A) = -(B, B) = (ks - t) u u^T + t Id,  t = ks (l - L0) / l.
//
// The hinges are FastTriangularBendingSprings' table (the same events through cuts and tears):
// its valid hinges, so a degenerate hinge (wings closer than minDistValidity, a vanishing edge or
// height) has no spring, where SOFA keeps one. As in SOFA, a spring shorter than 1e-4 gives no
// force, and the damping is explicit: no B, and K without the damping's part (SOFA's K carries the
// damping intensity of the last force evaluation in t; with kd = 0 the two are the same). K is the
// exact Jacobian of the elastic force.
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"

namespace cutsim::forcefields {

struct TriangularBendingSpringsParameters {
  double stiffness = 100000.0;  ///< ks: finite, >= 0 (SOFA's default)
  double damping = 1.0;         ///< kd: finite, >= 0 (SOFA's default)
  void validate() const;
};

class TriangularBendingSprings final : public FastTriangularBendingSprings {
 public:
  TriangularBendingSprings(topology::Topology& topology,
                           TriangularBendingSpringsParameters parameters);

  std::string typeName() const override { return "TriangularBendingSprings"; }
  void addForce(std::span<const double> x, std::span<const double> v,
                std::span<double> f) const override;
  void addDForce(std::span<const double> x, std::span<const double> dx, std::span<double> df,
                 double kFactor, double bFactor) const override;
  double potentialEnergy(std::span<const double> x) const override;
  void addKToMatrix(std::span<const double> x, MatrixAccumulator& m, double kFactor) const override;
  /// Nothing: the damping is explicit, as SOFA's.
  void addBToMatrix(std::span<const double> x, MatrixAccumulator& m, double bFactor) const override;
  const TriangularBendingSpringsParameters& springParameters() const { return sp_; }

 private:
  double restLength(const BendingSpring& s) const;
  const topology::Topology* topo_;
  TriangularBendingSpringsParameters sp_;
};

}  // namespace cutsim::forcefields
