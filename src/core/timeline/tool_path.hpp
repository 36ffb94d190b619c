#pragma once
// The path of an instrument moving in the world (the scalpel's blade, the cautery's tip): keyframes
// of a tip position and, for an instrument with a body along an axis, a unit axis, over times from
// the action's start. Between keyframes the tip moves linearly and the axis turns along the great
// circle at a constant rate; before the first keyframe and after the last the instrument holds.
// docs/instruments.md.
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "cutsim/base/fwd.hpp"
#include "cutsim/base/vec3.hpp"

namespace cutsim::core {

class ToolPath {
 public:
  /// The largest turn of the axis between two keyframes (degrees): beyond it the interpolation
  /// would pass near zero.
  static constexpr double kMaxTurn = 170.0;

  /// Reads the key "path" of s: rows [t, x, y, z, ax, ay, az] when `withAxis` (the axis from the
  /// tip along the instrument; not zero; normalised here), else [t, x, y, z]; times from the
  /// action's start, >= 0 and strictly increasing; every number finite. `what` names the
  /// instrument in messages ("the blade").
  static ToolPath read(const ParameterSource& s, bool withAxis, const std::string& what);
  /// As above, each row followed by `extras.size()` more numbers (checked finite), returned in
  /// `extras` (one vector per extra column, a value per keyframe).
  static ToolPath read(const ParameterSource& s, bool withAxis, const std::string& what,
                       std::vector<std::vector<double>>& extras);

  const std::vector<double>& times() const { return times_; }
  const std::vector<Vec3>& tips() const { return tips_; }
  /// A per-keyframe value (an extra column) at time t, interpolated as the tip is.
  double valueAt(const std::vector<double>& values, double t) const;

  bool hasAxis() const { return !axes_.empty(); }
  /// The tip and the unit axis (zero without an axis) at time t from the action's start.
  std::pair<Vec3, Vec3> at(double t) const;
  /// Times from t0 to t1 at which to sample the instrument so that between consecutive samples it
  /// moves little: t0, every keyframe between, t1, and enough between those that the axis turns
  /// by at most `maxTurn` degrees and the tip moves by at most `maxMove` (infinity: no limit) from
  /// one to the next (at most 64 per keyframe interval).
  std::vector<double> samples(double t0, double t1, double maxTurn, double maxMove) const;

 private:
  std::vector<double> times_;
  std::vector<Vec3> tips_;
  std::vector<Vec3> axes_;
};

/// A wire capsule around the segment a-b of radius r (a ball when a = b: three great circles;
/// else the axis, four lines along it and circles around both ends), as segments, each circle a
/// chain (the player marks a chain's start).
void wireCapsule(const Vec3& a, const Vec3& b, double r, std::vector<std::array<Vec3, 2>>& out);

/// The angle between unit vectors, in degrees.
double angleDegrees(const Vec3& a, const Vec3& b);
/// The unit vector a fraction f of the way from unit a to unit b along the great circle.
Vec3 slerp(const Vec3& a, const Vec3& b, double f);

}  // namespace cutsim::core
