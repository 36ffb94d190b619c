#pragma once
// The hinge kernel of FastTriangularBendingSprings (spec: bending-springs.md, sections 2 and 3).
//
// A hinge is an interior edge CD with its two wings A and B (the vertices opposite the edge in its
// two triangles). Set-up (computeHinge) turns four REST points into the weights alpha (for A, B,
// C, D) and the stiffness lambda, or into the reason why the hinge gets no spring. Everything a
// spring contributes afterwards comes from the three inline functions below (residual, scatter,
// block coefficient), which energy, force, dForce and assembly all call, so the paths cannot
// disagree:
//
//   R = sum_i alpha_i x_i,   E = 1/2 lambda |R|^2,   f_i -= lambda alpha_i R,
//   K block (i, j) = -lambda alpha_i alpha_j I3.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "cutsim/topology/types.hpp"

namespace cutsim::forcefields {

/// Which areas weight the hinge (spec section 2): SOFA's unsigned areas, or this project's signed
/// areas (force-free flat rest hinges, convex or not).
enum class AreaWeights : std::uint8_t { Unsigned, Signed };

/// The state of one hinge (one edge slot). The first five come out of computeHinge; NoHinge and
/// DeadEdge describe edges that have no hinge at all.
enum class HingeStatus : std::uint8_t {
  Active = 0,         ///< a spring
  ShortWingDistance,  ///< |pB - pA| <= minDistValidity (SOFA's test)
  ShortEdge,          ///< |pD - pC| <= minDistValidity (SOFA's test)
  SmallHeight,        ///< hA or hB <= minDistValidity (SOFA would divide by zero)
  Unrepresentable,    ///< weights or stiffness not representable in double (zero area sums,
                      ///< coordinates beyond 1e75, a stiffness that would overflow)
  NoHinge,            ///< the edge has fewer than two triangles (a boundary edge): not degenerate
  DeadEdge,           ///< the edge slot is dead
};
inline constexpr int kNumHingeStatus = 7;

/// "active", "short_wing_distance", "short_edge", "small_height", "unrepresentable", "no_hinge",
/// "dead_edge".
std::string_view toString(HingeStatus status);

/// True for the reasons that deactivate a hinge that has two triangles.
constexpr bool isDegenerate(HingeStatus s) {
  return s == HingeStatus::ShortWingDistance || s == HingeStatus::ShortEdge ||
         s == HingeStatus::SmallHeight || s == HingeStatus::Unrepresentable;
}

/// What set-up produces for one hinge.
struct HingeWeights {
  std::array<double, 4> alpha{};  ///< weights of A, B, C, D (zeros unless active)
  double lambda = 0.0;            ///< stiffness (zero unless active)
  HingeStatus status = HingeStatus::NoHinge;
  bool signedFallback = false;  ///< signed weights were asked for, the unsigned ones are used
};

/// Set-up of one hinge from its rest points (spec section 2). Never produces NaN or infinity and
/// never raises a floating-point exception, whatever the points (finite) and parameters (finite,
/// >= 0).
HingeWeights computeHinge(const topology::Vec3& pA, const topology::Vec3& pB,
                          const topology::Vec3& pC, const topology::Vec3& pD,
                          double bendingStiffness, double minDistValidity, AreaWeights weights);

// ---- the local kernel: every path goes through these ----

/// R = sum_i alpha_i x[3 v_i ..]: the residual of one spring (x flat, 3 doubles per point).
inline void hingeResidual(const double* x, const std::uint32_t* v, const double* alpha,
                          double* r) {
  const double* xa = x + 3 * static_cast<std::size_t>(v[0]);
  const double* xb = x + 3 * static_cast<std::size_t>(v[1]);
  const double* xc = x + 3 * static_cast<std::size_t>(v[2]);
  const double* xd = x + 3 * static_cast<std::size_t>(v[3]);
  for (int k = 0; k < 3; ++k) {
    r[k] = alpha[0] * xa[k] + alpha[1] * xb[k] + alpha[2] * xc[k] + alpha[3] * xd[k];
  }
}

/// f[3 v_i ..] += c alpha_i r for the four vertices (force: c = -lambda; dForce: c = -kFactor
/// lambda applied to the residual of dx).
inline void hingeScatter(double* f, const std::uint32_t* v, const double* alpha, double c,
                         const double* r) {
  for (int i = 0; i < 4; ++i) {
    double* fi = f + 3 * static_cast<std::size_t>(v[i]);
    const double ci = c * alpha[i];
    fi[0] += ci * r[0];
    fi[1] += ci * r[1];
    fi[2] += ci * r[2];
  }
}

/// 1/2 lambda |R|^2.
inline double hingeEnergy(double lambda, const double* r) {
  return 0.5 * lambda * (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
}

/// The scalar of K block (i, j) = coefficient * I3: -lambda alpha_i alpha_j.
inline double hingeBlockCoefficient(double lambda, const double* alpha, int i, int j) {
  return -lambda * alpha[i] * alpha[j];
}

}  // namespace cutsim::forcefields
