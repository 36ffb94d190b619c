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
  ToolPath p;
  s.require("path");
  const std::size_t width = withAxis ? 7 : 4;
  const auto rows = s.rows("path", width, 1);
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
        s.fail(key + "/4", what + "'s axis (the last three numbers) must not be zero");
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

}  // namespace cutsim::core
