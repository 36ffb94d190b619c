#pragma once
// TriangularFEMForceFieldOptim: SOFA's corotational membrane of the same name (method "large"),
// formula for formula, for scenes that must give what SOFA gives (docs/sofa.md). cutsim's own
// membrane is TriangularFEM (triangular_fem.hpp); the two share the table of elements (the same
// rest shapes, restScale and thickness) and differ in the rotation and the strain:
//
// Per triangle (a, b, c), the rest shape in a 2D frame with a at the origin and b on the x axis:
// b = (bx, 0), c = (cx, cy) (scaled by restScale). At x the frame is the current triangle's, x
// along ab and y in the plane towards c (not the polar factor of F):
//
//   f0 = ab / |ab|,  f1 = (n x ab) / |n x ab|,  n = ab x ac,
//   d = (bx - f0.ab, cx - f0.ac, cy - f1.ac)          (the displacement, rest minus current),
//   strain = (cy d_bx, bx d_cy, bx d_cx - cx d_bx)     (x 2A: the linear strain of the 2D
//                                                        constant-strain triangle),
//   stress = D strain / (4A) h,  D = [[mu'+g, g, 0], [g, mu'+g, 0], [0, 0, mu'/2]],
//            mu' = E / (1 + nu), g = E nu / (1 - nu^2)  (plane stress; mu' is twice Lame's mu),
//   f_b = f0 (cy s0 - cx s2) + f1 (cy s2 - cx s1),  f_c = f0 (bx s2) + f1 (bx s1),  f_a = -f_b -
//   f_c.
//
// K is SOFA's: the frame held fixed, K = -h/(4A) F^T B^T D B F (F: the 2 x 3 frame, B the 2D
// strain-displacement matrix); symmetric, negative semi-definite. The force is not the gradient of
// an energy (the frame turns with the element as it stretches along ab): potentialEnergy is the
// elastic energy of the strain in that frame, h/(8A) strain.D.strain, whose gradient with the
// frame held is the force; stiffnessIsExact() is false and there is no exact K. At a rest shape
// moved rigidly the force is zero and K equals TriangularFEM's (tests/forcefields/).
//
// The arithmetic is SOFA's, operation for operation (the rest data computed as SOFA computes it,
// the frame by SOFA's normalize, the same order of products and sums, compiled without fused
// multiply-adds): a chaotic scene then follows SOFA's rounding (docs/sofa.md).
#include "cutsim/forcefields/triangular_fem.hpp"

namespace cutsim::forcefields {

class TriangularFEMOptim final : public TriangularFEM {
 public:
  /// parameters.exactHessian must be false (there is no exact K).
  TriangularFEMOptim(topology::Topology& topology, TriangularFEMParameters parameters);

  std::string typeName() const override { return "TriangularFEMForceFieldOptim"; }
  void addForce(std::span<const double> x, std::span<const double> v,
                std::span<double> f) const override;
  /// df += kFactor K dx (SOFA's addDForce, the frame at x).
  void addDForce(std::span<const double> x, std::span<const double> dx, std::span<double> df,
                 double kFactor, double bFactor) const override;
  double potentialEnergy(std::span<const double> x) const override;
  void addKToMatrix(std::span<const double> x, MatrixAccumulator& m, double kFactor) const override;
  bool stiffnessIsExact() const override { return false; }
  /// Returns false for exact = true: SOFA's K is the only one.
  bool setExactStiffness(bool exact) override { return !exact; }

 private:
  /// SOFA's rest data of an element (its initTriangleInfo), from the rest positions.
  struct RestFrame {
    double bx, cx, cy, ss;  // ss = 0.5 / (bx cy) = 1 / (4A)
  };
  RestFrame restFrame(const FemTriangle& e) const;

  const topology::Topology* topo_;
  double restScale_;
  double muPrime_ = 0.0, gamma_ = 0.0;  // SOFA's mu' = E / (1 + nu), gamma = E nu / (1 - nu^2)
};

}  // namespace cutsim::forcefields
