#include "cutsim/forcefields/hinge_kernel.hpp"

#include <algorithm>
#include <cmath>

namespace cutsim::forcefields {
namespace {

using topology::Vec3;

Vec3 sub(const Vec3& a, const Vec3& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
Vec3 scale(const Vec3& a, double s) {
  return {a[0] * s, a[1] * s, a[2] * s};
}
double dot(const Vec3& a, const Vec3& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
double norm(const Vec3& a) {
  return std::sqrt(dot(a, a));
}

/// Coordinates beyond this magnitude make the products of set-up (four lengths) overflow-prone.
constexpr double kMaxCoordinate = 1e75;

bool inRange(const Vec3& p) {
  return std::fabs(p[0]) <= kMaxCoordinate && std::fabs(p[1]) <= kMaxCoordinate &&
         std::fabs(p[2]) <= kMaxCoordinate;
}

HingeWeights deactivated(HingeStatus status) {
  HingeWeights w;
  w.status = status;
  return w;
}

template <typename T>
using V3 = std::array<T, 3>;

template <typename T>
V3<T> subT(const Vec3& a, const Vec3& b) {
  return {T(a[0]) - T(b[0]), T(a[1]) - T(b[1]), T(a[2]) - T(b[2])};
}
template <typename T>
T dotT(const V3<T>& a, const V3<T>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
template <typename T>
V3<T> crossT(const V3<T>& a, const V3<T>& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
template <typename T>
T normT(const V3<T>& a) {
  using std::sqrt;
  return sqrt(dotT(a, a));
}

/// Weights and stiffness of a hinge that passed the validity tests, in precision T.
template <typename T>
HingeWeights finish(const Vec3& pA, const Vec3& pB, const Vec3& pC, const Vec3& pD, double k,
                    double hA, double hB, double l, AreaWeights weights) {
  using std::fabs;
  const T a = hA, b = hB;
  const T perK = T(2) / T(3) * (a + b) / (a * a * b * b) * T(l);
  if (!(perK < T(1e300) && perK > T(1e-300))) return deactivated(HingeStatus::Unrepresentable);
  // lambda = perK * k, checked in long double before it is formed in double. Up to 1e306: the
  // spring's stiffness entries (lambda alpha_i alpha_j, |alpha| <= 10) stay below the double
  // range, so a huge but representable stiffness (1e300 on a unit hinge: an energy of 1.7e299)
  // is kept, not dropped; sums that overflow are caught where they are formed (non-finite energy,
  // forces or residuals stop the evaluation or the step, naming it).
  const long double lambdaL = static_cast<long double>(perK) * static_cast<long double>(k);
  if (k > 0.0 && !(lambdaL < 1e306L && lambdaL > 1e-300L)) {
    return deactivated(HingeStatus::Unrepresentable);
  }

  const V3<T> nAv = crossT(subT<T>(pA, pC), subT<T>(pA, pD));
  const V3<T> nBv = crossT(subT<T>(pB, pD), subT<T>(pB, pC));
  const V3<T> nCv = crossT(subT<T>(pC, pB), subT<T>(pC, pA));
  const V3<T> nDv = crossT(subT<T>(pD, pA), subT<T>(pD, pB));
  const T nA = normT(nAv), nB = normT(nBv), nC = normT(nCv), nD = normT(nDv);
  if (!(nA + nB > T(0)) || !(nC + nD > T(0))) return deactivated(HingeStatus::Unrepresentable);

  HingeWeights w;
  w.status = HingeStatus::Active;
  w.lambdaPerStiffness = static_cast<double>(perK);
  w.lambda = w.lambdaPerStiffness * k;

  bool useUnsigned = true;
  if (weights == AreaWeights::Signed) {
    const V3<T> s{nAv[0] + nBv[0], nAv[1] + nBv[1], nAv[2] + nBv[2]};
    const T sNorm = normT(s);
    if (sNorm > T(1e-6) * (nA + nB)) {
      const V3<T> n{s[0] / sNorm, s[1] / sNorm, s[2] / sNorm};
      const T sA = dotT(nAv, n), sB = dotT(nBv, n), sC = dotT(nCv, n), sD = dotT(nDv, n);
      const T sumAB = sA + sB, sumCD = sC + sD;
      // |alpha| <= 10 for every weight, tested without dividing.
      if (sumAB > T(0) && sumCD > T(0) && fabs(sA) <= T(10) * sumAB && fabs(sB) <= T(10) * sumAB &&
          fabs(sC) <= T(10) * sumCD && fabs(sD) <= T(10) * sumCD) {
        w.alpha = {static_cast<double>(sB / sumAB), static_cast<double>(sA / sumAB),
                   static_cast<double>(-sD / sumCD), static_cast<double>(-sC / sumCD)};
        useUnsigned = false;
      }
    }
    w.signedFallback = useUnsigned;
  }
  if (useUnsigned) {
    w.alpha = {static_cast<double>(nB / (nA + nB)), static_cast<double>(nA / (nA + nB)),
               static_cast<double>(-nD / (nC + nD)), static_cast<double>(-nC / (nC + nD))};
  }
  return w;
}

}  // namespace

std::array<double, 4> foldedWeights(const HingeWeights& h) {
  const double s = std::sqrt(h.lambdaPerStiffness);
  return {s * h.alpha[0], s * h.alpha[1], s * h.alpha[2], s * h.alpha[3]};
}

std::string_view toString(HingeStatus status) {
  switch (status) {
    case HingeStatus::Active:
      return "active";
    case HingeStatus::ShortWingDistance:
      return "short_wing_distance";
    case HingeStatus::ShortEdge:
      return "short_edge";
    case HingeStatus::SmallHeight:
      return "small_height";
    case HingeStatus::Unrepresentable:
      return "unrepresentable";
    case HingeStatus::NoHinge:
      return "no_hinge";
    case HingeStatus::DeadEdge:
      return "dead_edge";
  }
  return "unknown";
}

HingeWeights computeHinge(const Vec3& pA, const Vec3& pB, const Vec3& pC, const Vec3& pD,
                          double bendingStiffness, double minDistValidity, AreaWeights weights) {
  if (!inRange(pA) || !inRange(pB) || !inRange(pC) || !inRange(pD)) {
    return deactivated(HingeStatus::Unrepresentable);
  }
  // SOFA's two validity tests, strict, on squared lengths. Squared lengths of in-range points stay
  // below ~1e151, so clamping eps keeps eps^2 finite without changing any outcome.
  const double eps = std::min(minDistValidity, 1e100);
  const double eps2 = eps * eps;
  const Vec3 ab = sub(pB, pA);
  if (!(dot(ab, ab) > eps2)) return deactivated(HingeStatus::ShortWingDistance);
  const Vec3 dc = sub(pC, pD);
  const double l2 = dot(dc, dc);
  if (!(l2 > eps2) || !(l2 > 0.0)) return deactivated(HingeStatus::ShortEdge);

  // Heights of the wings over the line CD.
  const double l = std::sqrt(l2);
  const Vec3 u = scale(dc, 1.0 / l);
  const Vec3 ac = sub(pC, pA);
  const Vec3 bc = sub(pC, pB);
  const double hA = norm(sub(ac, scale(u, dot(ac, u))));
  const double hB = norm(sub(bc, scale(u, dot(bc, u))));
  if (!(hA > eps) || !(hB > eps) || !(hA > 0.0) || !(hB > 0.0)) {
    return deactivated(HingeStatus::SmallHeight);
  }

  // The rest in double, exactly as SOFA computes it, when every length is of moderate
  // scale (then no intermediate can overflow or underflow); otherwise in long double with its
  // wider exponent, and rejected if lambda does not fit a double comfortably.
  const double k = bendingStiffness;
  const auto moderate = [](double v) { return std::abs(std::ilogb(v)) <= 100; };
  if (moderate(hA) && moderate(hB) && moderate(l)) {
    return finish<double>(pA, pB, pC, pD, k, hA, hB, l, weights);
  }
  return finish<long double>(pA, pB, pC, pD, k, hA, hB, l, weights);
}

}  // namespace cutsim::forcefields
