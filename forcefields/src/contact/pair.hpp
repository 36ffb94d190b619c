#pragma once
// Private to the contact wing: a pair of primitives (its kind, its points, what is frozen of it
// at the step's start), the penalty law, a pair's evaluation and its friction force.
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "geometry.hpp"

namespace cutsim::forcefields::contact {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

/// The kinds of pairs.
enum class Kind : std::uint8_t {
  VT,  ///< surface point [0] vs surface triangle [1..3]
  EE,  ///< surface edge [0, 1] vs surface edge [2, 3]
  PO,  ///< surface point [0] vs an analytic obstacle
  VO,  ///< surface point [0] vs obstacle triangle [1..3] (obstacle vertices)
  OV,  ///< obstacle point [0] vs surface triangle [1..3]
  EO,  ///< surface edge [0, 1] vs obstacle edge [2, 3]
  FO,  ///< a surface point [0], edge [0, 1] or triangle [0, 1, 2] vs a sphere or a capsule
};

// (Checkpoints store pairs as their bytes: the padding is declared, zeroed.)
struct Pair {
  Kind kind;
  std::array<std::uint8_t, 3> padding0{};
  std::int32_t obstacle = -1;         ///< -1: self-contact
  std::array<std::uint32_t, 4> id{};  ///< point ids (surface) or vertex indices (obstacle mesh)
  std::uint8_t surface = 0;           ///< bit i: id[i] is a surface point
  bool excluded = false;
  /// VT, VO and OV: what of the triangle the point meets: 3 the triangle (id[1..3]), 2 one of
  /// its edges (id[1..2]), 1 one of its corners (id[1]); unused ids are kInvalidIndex. The
  /// penalty's pairs are the closest features (each met once); the displacement bound checks
  /// whole triangles.
  std::uint8_t shape = 3;
  /// 1: friction held this step (linearised at rest, viscous): with the step's start direction its
  /// Coulomb force carried the pair past rest, and the step is solved again (holdOvershoots).
  std::uint8_t held = 0;
  /// The search's record (for the cache): VT, VO, OV: the triangle's index (in the surface or
  /// the obstacle mesh); `margins`: the surface triangles whose margins the search added.
  std::int32_t tri = -1;
  std::array<std::int32_t, 2> margins{-1, -1};
  /// EE self pairs: the edges (of id[0..1] and id[2..3] as the search met them; the
  /// classification may put the ids in the other order after: the share is symmetric).
  std::array<std::int32_t, 2> edges{-1, -1};
  /// How many ids are in use.
  int points() const {
    switch (kind) {
      case Kind::VT:
      case Kind::VO:
      case Kind::OV:
        return 1 + shape;
      case Kind::EE:
      case Kind::EO:
        return 4;
      default:
        return 4;
    }
  }
  // Frozen at the step's start:
  /// The share of the law a self edge-edge pair gets: 1 - (both edges' flatness), see
  /// Impl::edgeFlat (1 for every other pair).
  double scale = 1.0;
  double s0 = 0.0, lambda = 0.0, mu = 0.0;
  V3 n0 = V3::UnitZ();
  std::array<double, 4> w0{};
  /// dF/du at the step's start, as fa (I - n0 n0^T) + fb ft ft^T (see frictionForce).
  double fa = 0.0, fb = 0.0;
  V3 ft = V3::Zero();
  Eigen::Matrix3d frictionMatrix() const {
    return fa * (Eigen::Matrix3d::Identity() - n0 * n0.transpose()) + fb * ft * ft.transpose();
  }
};
static_assert(offsetof(Pair, obstacle) == 4 && offsetof(Pair, tri) == 28 &&
                  offsetof(Pair, scale) == 48 && sizeof(Pair) == 176,
              "Pair: a layout with undeclared padding (its bytes are checkpointed)");

/// The penalty law: E(s) = k/3 (d - s)^3 / s for d / 100 < s < d, zero beyond d with its first
/// two derivatives (C2), steep towards zero (the force at d / 100 is about 3300 k d) and continued
/// quadratically below d / 100 (the force grows linearly on, through zero and below: a pair
/// found at or through zero distance has finite values, and the stiffness stays bounded, so that
/// the solves stay well conditioned).
struct Law {
  double d, k;
  double sm() const { return 1e-2 * d; }
  static double energyAt(double d, double k, double s) {
    return k / 3 * (d - s) * (d - s) * (d - s) / s;
  }
  static double forceAt(double d, double k, double s) {
    const double a = d - s;
    return k * a * a / s + k / 3 * a * a * a / (s * s);
  }
  static double curvatureAt(double d, double k, double s) {
    const double a = d - s, r = a / s;
    return 2 * k * r + 2 * k * r * r + 2 * k / 3 * r * r * r;
  }
  /// E(s).
  double energy(double s) const {
    if (s >= d) return 0.0;
    if (s >= sm()) return energyAt(d, k, s);
    const double m = sm(), t = s - m;
    return energyAt(d, k, m) - forceAt(d, k, m) * t + 0.5 * curvatureAt(d, k, m) * t * t;
  }
  /// -E'(s) >= 0: the magnitude of the normal force.
  double force(double s) const {
    if (s >= d) return 0.0;
    if (s >= sm()) return forceAt(d, k, s);
    return forceAt(d, k, sm()) - curvatureAt(d, k, sm()) * (s - sm());
  }
  /// E''(s) >= 0.
  double curvature(double s) const {
    if (s >= d) return 0.0;
    return curvatureAt(d, k, std::max(s, sm()));
  }
};

/// Distance, unit normal and weights of a pair at some positions.
struct Eval {
  double s = kInf;
  V3 n = V3::UnitZ();
  std::array<double, 4> w{};
};

/// Friction force on the pair's relative velocity u (tangential to n0); with `keep`, its
/// derivative dF/du = fa (I - n0 n0^T) + fb ft ft^T goes into the pair. A held pair's is the
/// viscous law at any speed.
inline V3 frictionForce(const Pair& p, double eps, const V3& u, Pair* keep = nullptr) {
  const V3 ut = u - p.n0 * p.n0.dot(u);
  const double l = ut.norm();
  const double c = p.mu * p.lambda;
  if (l <= eps || p.held) {
    if (keep) {
      keep->fa = -(c / eps);
      keep->fb = 0.0;
      keep->ft = V3::Zero();
    }
    return -(c / eps) * ut;
  }
  const V3 t = ut / l;
  if (keep) {
    keep->fa = -(c / l);
    keep->fb = c / l;
    keep->ft = t;
  }
  return -c * t;
}

}  // namespace cutsim::forcefields::contact
