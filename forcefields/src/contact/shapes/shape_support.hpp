#pragma once
// Private to the obstacle shapes (one file each in this folder): conversions to the contact
// code's vectors, the checks every shape makes, and the registration of a shape that is its own
// parameter struct.
#include <Eigen/Core>
#include <algorithm>
#include <any>
#include <array>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <utility>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/forcefields/obstacle.hpp"

namespace cutsim::forcefields::shapes {

using V3 = Eigen::Vector3d;

inline V3 toV3(const Vec3& v) {
  return {v[0], v[1], v[2]};
}
inline Vec3 fromV3(const V3& v) {
  return {v.x(), v.y(), v.z()};
}
inline bool finite3(const Vec3& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}
inline double norm3(const Vec3& v) {
  return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}
inline void requireFinite3(const char* key, const Vec3& v) {
  if (!finite3(v)) throw InvalidInput(key, "must be finite");
}
/// The bounds of a ball of radius r around each of the points.
inline ObstacleBounds ballBounds(std::initializer_list<Vec3> centres, double r) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  ObstacleBounds b{{inf, inf, inf}, {-inf, -inf, -inf}};
  for (const Vec3& c : centres)
    for (std::size_t i = 0; i < 3; ++i) {
      b.lo[i] = std::min(b.lo[i], c[i] - r);
      b.hi[i] = std::max(b.hi[i], c[i] + r);
    }
  return b;
}

/// add(x, y, z): appends the point (x, y, z) + offset to points, returns its index (a shape's
/// surface() builds its drawing with it).
inline auto pointAdder(std::vector<Vec3>& points, const Vec3& offset) {
  return [&points, offset](double x, double y, double z) {
    points.push_back({x + offset[0], y + offset[1], z + offset[2]});
    return int(points.size()) - 1;
  };
}

/// The drawing of a sphere (a == b, capsule false) or a capsule: a UV sphere (a capsule: two
/// half spheres joined by a cylinder) of 24 x 12 quads, moved by `offset`.
inline void roundSurface(const Vec3& a, const Vec3& b, double radius, bool capsule,
                         const Vec3& offset, std::vector<Vec3>& pts,
                         std::vector<std::array<int, 3>>& tris) {
  pts.clear();
  tris.clear();
  auto add = pointAdder(pts, offset);
  const double pi = std::numbers::pi;
  const int nu = 24, nv = 12;
  Vec3 ax{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double len = norm3(ax);
  Vec3 z = len > 1e-12 ? Vec3{ax[0] / len, ax[1] / len, ax[2] / len} : Vec3{0, 0, 1};
  Vec3 t = std::abs(z[0]) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  Vec3 x{z[1] * t[2] - z[2] * t[1], z[2] * t[0] - z[0] * t[2], z[0] * t[1] - z[1] * t[0]};
  const double lx = norm3(x);
  for (double& c : x) c /= lx;
  const Vec3 y{z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]};
  for (int j = 0; j <= nv; ++j) {
    const double th = pi * double(j) / nv;  // from the -z pole to the +z pole
    const double cz = -std::cos(th), r = std::sin(th);
    const Vec3& c = (j <= nv / 2) ? a : b;
    for (int i = 0; i < nu; ++i) {
      const double ph = 2 * pi * double(i) / nu;
      const double cx = r * std::cos(ph), cy = r * std::sin(ph);
      add(c[0] + radius * (cx * x[0] + cy * y[0] + cz * z[0]),
          c[1] + radius * (cx * x[1] + cy * y[1] + cz * z[1]),
          c[2] + radius * (cx * x[2] + cy * y[2] + cz * z[2]));
    }
    if (capsule && j == nv / 2) {  // the same ring again, at the other end
      for (int i = 0; i < nu; ++i) {
        const double ph = 2 * pi * double(i) / nu;
        const double cx = std::cos(ph), cy = std::sin(ph);
        add(b[0] + radius * (cx * x[0] + cy * y[0]), b[1] + radius * (cx * x[1] + cy * y[1]),
            b[2] + radius * (cx * x[2] + cy * y[2]));
      }
    }
  }
  const int rings = int(pts.size()) / nu;
  for (int j = 0; j + 1 < rings; ++j)
    for (int i = 0; i < nu; ++i) {
      const int p00 = j * nu + i, p01 = j * nu + (i + 1) % nu, p10 = p00 + nu, p11 = p01 + nu;
      tris.push_back({p00, p01, p11});
      tris.push_back({p00, p11, p10});
    }
}

/// S(args...), its constructor's InvalidInput reported by `s` at the key it names (a shape's
/// read()).
template <class S, class... Args>
S checked(const ParameterSource& s, Args&&... args) {
  std::optional<S> out;
  s.check([&] { out.emplace(std::forward<Args>(args)...); });
  return std::move(*out);
}

/// The registry entry of a shape class S that is its own parameter struct: S::read(source)
/// returns the checked S.
template <class S>
ObstacleShapeRegistry::Entry shapeEntry(std::string name, std::string summary,
                                        std::vector<KeyInfo> keys) {
  return {std::move(name),
          std::move(summary),
          std::move(keys),
          {},
          [](const ParameterSource& s) -> std::any { return S::read(s); },
          [](const std::any& p) -> std::unique_ptr<ObstacleShape> {
            return std::make_unique<S>(std::any_cast<const S&>(p));
          }};
}

}  // namespace cutsim::forcefields::shapes
