// The path of an instrument moving in the world: keyframes read and interpolated (tool_path.hpp).
#include "tool_path.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "cutsim/base/numbers.hpp"
#include "cutsim/base/registry.hpp"
#include "cutsim/topology/geometry.hpp"

namespace cutsim::core {

using topology::geometry::dot;
using topology::geometry::lerp;
using topology::geometry::unit;

namespace {
constexpr double kPi = 3.14159265358979323846;
}

double angleDegrees(const Vec3& a, const Vec3& b) {
  return std::acos(std::clamp(dot(a, b), -1.0, 1.0)) * 180.0 / kPi;
}

Vec3 slerp(const Vec3& a, const Vec3& b, double f) {
  const double theta = std::acos(std::clamp(dot(a, b), -1.0, 1.0));
  if (!(theta > 1e-9)) return a;
  const double wa = std::sin((1 - f) * theta) / std::sin(theta),
               wb = std::sin(f * theta) / std::sin(theta);
  return unit({wa * a[0] + wb * b[0], wa * a[1] + wb * b[1], wa * a[2] + wb * b[2]});
}

ToolPath ToolPath::read(const ParameterSource& s, bool withAxis, const std::string& what) {
  std::vector<std::vector<double>> none;
  return read(s, withAxis, what, none);
}

double ToolPath::valueAt(const std::vector<double>& values, double t) const {
  const auto& T = times_;
  if (t >= T.back()) return values.back();
  if (!(t > T.front())) return values.front();
  const std::size_t i = std::size_t(std::upper_bound(T.begin(), T.end(), t) - T.begin());
  const double f = (t - T[i - 1]) / (T[i] - T[i - 1]);
  return values[i - 1] + f * (values[i] - values[i - 1]);
}

ToolPath ToolPath::read(const ParameterSource& s, bool withAxis, const std::string& what,
                        std::vector<std::vector<double>>& extras) {
  ToolPath p;
  s.require("path");
  const std::size_t base = withAxis ? 7 : 4;
  const std::size_t width = base + extras.size();
  const auto rows = s.rows("path", width, 1);
  for (auto& column : extras) column.clear();
  for (const auto& r : rows)
    for (std::size_t k = 0; k < extras.size(); ++k) extras[k].push_back(r[base + k]);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto& r = rows[i];
    const std::string key = "path/" + std::to_string(i);
    for (std::size_t k = 0; k < width; ++k)
      if (!std::isfinite(r[k])) s.fail(key + "/" + std::to_string(k), "must be a finite number");
    if (r[0] < 0) s.fail(key + "/0", "path times are from the action's start: must be >= 0");
    if (!p.times_.empty() && !(r[0] > p.times_.back()))
      s.fail(key + "/0", "path times must increase strictly");
    if (withAxis) {
      const Vec3 axis{r[4], r[5], r[6]};
      if (!(dot(axis, axis) > 0))
        s.fail(key + "/4", what + "'s axis (the three numbers after x, y, z) must not be zero");
      const Vec3 a = unit(axis);
      if (!p.axes_.empty() && angleDegrees(p.axes_.back(), a) > kMaxTurn)
        s.fail(key + "/4", what + "'s axis turns by " +
                               describeNumber(angleDegrees(p.axes_.back(), a)) +
                               " degrees from the keyframe before (at most " +
                               describeNumber(kMaxTurn) + "): add a keyframe between");
      p.axes_.push_back(a);
    }
    p.times_.push_back(r[0]);
    p.tips_.push_back({r[1], r[2], r[3]});
  }
  return p;
}

std::pair<Vec3, Vec3> ToolPath::at(double t) const {
  const auto& T = times_;
  const bool axis = hasAxis();
  if (t >= T.back()) return {tips_.back(), axis ? axes_.back() : Vec3{0, 0, 0}};
  if (!(t > T.front())) return {tips_.front(), axis ? axes_.front() : Vec3{0, 0, 0}};
  const std::size_t i = std::size_t(std::upper_bound(T.begin(), T.end(), t) - T.begin());
  const double f = (t - T[i - 1]) / (T[i] - T[i - 1]);
  return {lerp(tips_[i - 1], tips_[i], f), axis ? slerp(axes_[i - 1], axes_[i], f) : Vec3{0, 0, 0}};
}

std::vector<double> ToolPath::samples(double t0, double t1, double maxTurn, double maxMove) const {
  // (not a keyframe within rounding of either end: a sliver of sweep there would end a swept
  // curve on the sample before the last, where the instrument is not)
  const double eps = 1e-9 * std::max(1.0, std::abs(t1));
  std::vector<double> keys{t0};
  for (double k : times_)
    if (k > t0 + eps && k < t1 - eps) keys.push_back(k);
  keys.push_back(t1);
  std::vector<double> out{t0};
  for (std::size_t i = 1; i < keys.size(); ++i) {
    const auto a = at(keys[i - 1]), b = at(keys[i]);
    int n = hasAxis() ? int(std::ceil(angleDegrees(a.second, b.second) / maxTurn)) : 1;
    if (maxMove < std::numeric_limits<double>::infinity())
      n = std::max(
          n, int(std::ceil(std::sqrt(topology::geometry::dist2(a.first, b.first)) / maxMove)));
    n = std::clamp(n, 1, 64);
    for (int k = 1; k <= n; ++k) out.push_back(keys[i - 1] + (keys[i] - keys[i - 1]) * k / n);
  }
  return out;
}

void wireCapsule(const Vec3& a, const Vec3& b, double r, std::vector<std::array<Vec3, 2>>& out) {
  using topology::geometry::sub;
  const auto cross = [](const Vec3& x, const Vec3& y) {
    return Vec3{x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]};
  };
  Vec3 u{1, 0, 0}, v{0, 1, 0}, w{0, 0, 1};
  const bool capsule = topology::geometry::dist2(a, b) > 0;
  if (capsule) {
    w = unit(sub(b, a));
    const Vec3 seed = std::abs(w[0]) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    u = unit(cross(w, seed));
    v = cross(w, u);
  }
  const auto circle = [&](const Vec3& centre, const Vec3& e1, const Vec3& e2) {
    constexpr int n = 24;
    Vec3 prev{centre[0] + r * e1[0], centre[1] + r * e1[1], centre[2] + r * e1[2]};
    for (int k = 1; k <= n; ++k) {
      const double t = 2 * kPi * k / n, cs = std::cos(t), sn = std::sin(t);
      const Vec3 next{centre[0] + r * (cs * e1[0] + sn * e2[0]),
                      centre[1] + r * (cs * e1[1] + sn * e2[1]),
                      centre[2] + r * (cs * e1[2] + sn * e2[2])};
      out.push_back({prev, next});
      prev = next;
    }
  };
  if (capsule) {
    out.push_back({a, b});
    for (const Vec3& e : {u, v, Vec3{-u[0], -u[1], -u[2]}, Vec3{-v[0], -v[1], -v[2]}})
      out.push_back({Vec3{a[0] + r * e[0], a[1] + r * e[1], a[2] + r * e[2]},
                     Vec3{b[0] + r * e[0], b[1] + r * e[1], b[2] + r * e[2]}});
    circle(b, u, v);
  }
  circle(a, u, v);
  circle(a, u, w);
  circle(a, v, w);
}

}  // namespace cutsim::core
