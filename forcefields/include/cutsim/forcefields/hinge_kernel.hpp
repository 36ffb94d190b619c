#pragma once
// The hinge kernel of FastTriangularBendingSprings (spec: bending-springs.md, sections 2 and 3).
//
// A hinge is an interior edge CD with its two wings A and B (the vertices opposite the edge in its
// two triangles). Set-up (computeHinge) turns four REST points into the weights alpha (for A, B,
// C, D) and the stiffness lambda, or into the reason why the hinge gets no spring. Everything a
// spring contributes afterwards comes from the inline functions below (residual, scatter,
// energy, block coefficient), which energy, force, dForce and assembly all call, so the paths
// cannot disagree:
//
//   R = sum_i alpha_i x_i,   E = 1/2 lambda |R|^2,   f_i -= lambda alpha_i R,
//   K block (i, j) = -lambda alpha_i alpha_j I3.
//
// The stored form folds lambda into the weights: w_i = sqrt(lambda / k) alpha_i (k the bending
// stiffness, a factor common to all springs), so that with R' = sum_i w_i x_i
//
//   E = 1/2 k |R'|^2,   f_i -= k w_i R',   K block (i, j) = -k w_i w_j I3,
//
// which is the same thing with one number less per spring; the table stores only w_A, w_C and
// sqrt(lambda / k), since the weights of A, B (and of C, D) sum to sqrt(lambda / k) (and minus it).
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
  /// lambda for k = 1 (lambda = lambdaPerStiffness * k, the last operation, as in SOFA)
  double lambdaPerStiffness = 0.0;
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

/// The stored weights w_i = sqrt(lambda / k) alpha_i of an active hinge.
std::array<double, 4> foldedWeights(const HingeWeights& h);

/// R' = sum_i w_i x[3 v_i ..]: the residual of one spring (x flat, 3 doubles per point).
inline void hingeResidual(const double* __restrict x, const std::uint32_t* v, const double* w,
                          double* r) {
  const double* xa = x + 3 * static_cast<std::size_t>(v[0]);
  const double* xb = x + 3 * static_cast<std::size_t>(v[1]);
  const double* xc = x + 3 * static_cast<std::size_t>(v[2]);
  const double* xd = x + 3 * static_cast<std::size_t>(v[3]);
  r[0] = w[0] * xa[0] + w[1] * xb[0] + w[2] * xc[0] + w[3] * xd[0];
  r[1] = w[0] * xa[1] + w[1] * xb[1] + w[2] * xc[1] + w[3] * xd[1];
  r[2] = w[0] * xa[2] + w[1] * xb[2] + w[2] * xc[2] + w[3] * xd[2];
}

/// f[3 v_i ..] += c w_i r for the four vertices (force: c = -k on R'(x); dForce: c = -kFactor k
/// on R'(dx)).
inline void hingeScatter(double* __restrict f, const std::uint32_t* v, const double* w, double c,
                         const double* r) {
  // Written out (not a loop) so that -O2 keeps ids and weights in registers.
  const double r0 = r[0], r1 = r[1], r2 = r[2];
  double* fa = f + 3 * static_cast<std::size_t>(v[0]);
  double* fb = f + 3 * static_cast<std::size_t>(v[1]);
  double* fc = f + 3 * static_cast<std::size_t>(v[2]);
  double* fd = f + 3 * static_cast<std::size_t>(v[3]);
  const double ca = c * w[0], cb = c * w[1], cc = c * w[2], cd = c * w[3];
  fa[0] += ca * r0;
  fa[1] += ca * r1;
  fa[2] += ca * r2;
  fb[0] += cb * r0;
  fb[1] += cb * r1;
  fb[2] += cb * r2;
  fc[0] += cc * r0;
  fc[1] += cc * r1;
  fc[2] += cc * r2;
  fd[0] += cd * r0;
  fd[1] += cd * r1;
  fd[2] += cd * r2;
}

/// hingeScatter's terms for the vertices p with p - lo < span (unsigned) only, each computed as
/// hingeScatter computes it (the passes on several threads: each adds to the points it owns).
inline void hingeScatterOwned(double* __restrict f, const std::uint32_t* v, const double* w,
                              double c, const double* r, std::uint32_t lo, std::uint32_t span) {
  const double r0 = r[0], r1 = r[1], r2 = r[2];
  for (int i = 0; i < 4; ++i) {
    if (v[i] - lo >= span) continue;
    double* fi = f + 3 * static_cast<std::size_t>(v[i]);
    const double ci = c * w[i];
    fi[0] += ci * r0;
    fi[1] += ci * r1;
    fi[2] += ci * r2;
  }
}

/// 1/2 k |R'|^2.
inline double hingeEnergy(double k, const double* r) {
  return 0.5 * k * (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
}

/// The scalar of K block (i, j) = coefficient * I3: -k w_i w_j (= -lambda alpha_i alpha_j).
inline double hingeBlockCoefficient(double k, const double* w, int i, int j) {
  return -k * w[i] * w[j];
}

}  // namespace cutsim::forcefields
