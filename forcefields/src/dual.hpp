#pragma once
// Forward-mode automatic differentiation for the force kernels (private to the library):
// Dual<N> carries a value and its derivatives along N directions, so that a kernel written once
// for a scalar type T gives, with T = Dual<N>, the exact directional derivatives of what it
// computes (exact to rounding: the chain rule applied to the same arithmetic). N = 1 with the
// direction dx gives the Jacobian-vector product J dx; N = 12 seeded with the unit vectors of a
// hinge's coordinates gives its 12 x 12 Jacobian.
//
// Only what the kernels use is defined: +, -, *, / (with duals and doubles) and sqrt.
// value(t) is t for a double, t.v for a dual, so that tests on values read the same for both.
#include <array>
#include <cmath>

namespace cutsim::forcefields::detail {

template <int N>
struct Dual {
  double v = 0.0;
  std::array<double, N> d{};

  Dual() = default;
  /// A constant (zero derivatives).
  Dual(double value) : v(value) {}  // NOLINT(google-explicit-constructor): as a double literal
};

inline double value(double t) {
  return t;
}
template <int N>
inline double value(const Dual<N>& t) {
  return t.v;
}

template <int N>
inline Dual<N> operator+(const Dual<N>& a, const Dual<N>& b) {
  Dual<N> r(a.v + b.v);
  for (int i = 0; i < N; ++i) r.d[i] = a.d[i] + b.d[i];
  return r;
}
template <int N>
inline Dual<N> operator-(const Dual<N>& a, const Dual<N>& b) {
  Dual<N> r(a.v - b.v);
  for (int i = 0; i < N; ++i) r.d[i] = a.d[i] - b.d[i];
  return r;
}
template <int N>
inline Dual<N> operator-(const Dual<N>& a) {
  Dual<N> r(-a.v);
  for (int i = 0; i < N; ++i) r.d[i] = -a.d[i];
  return r;
}
template <int N>
inline Dual<N> operator*(const Dual<N>& a, const Dual<N>& b) {
  Dual<N> r(a.v * b.v);
  for (int i = 0; i < N; ++i) r.d[i] = a.d[i] * b.v + a.v * b.d[i];
  return r;
}
template <int N>
inline Dual<N> operator*(double a, const Dual<N>& b) {
  Dual<N> r(a * b.v);
  for (int i = 0; i < N; ++i) r.d[i] = a * b.d[i];
  return r;
}
template <int N>
inline Dual<N> operator*(const Dual<N>& a, double b) {
  return b * a;
}
template <int N>
inline Dual<N> operator/(const Dual<N>& a, const Dual<N>& b) {
  const double inv = 1.0 / b.v;
  Dual<N> r(a.v * inv);
  for (int i = 0; i < N; ++i) r.d[i] = (a.d[i] - r.v * b.d[i]) * inv;
  return r;
}
template <int N>
inline Dual<N> operator/(double a, const Dual<N>& b) {
  const double inv = 1.0 / b.v;
  Dual<N> r(a * inv);
  const double c = -r.v * inv;
  for (int i = 0; i < N; ++i) r.d[i] = c * b.d[i];
  return r;
}

/// sqrt(a), for a > 0 (the kernels call it on lengths they have checked).
template <int N>
inline Dual<N> sqrt(const Dual<N>& a) {
  Dual<N> r(std::sqrt(a.v));
  const double c = 0.5 / r.v;
  for (int i = 0; i < N; ++i) r.d[i] = c * a.d[i];
  return r;
}

}  // namespace cutsim::forcefields::detail
