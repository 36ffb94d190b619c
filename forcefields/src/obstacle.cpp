// Obstacles of the contact field (contact.hpp): their paths, checks and drawable surfaces.
#include <cmath>
#include <numbers>

#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/forcefields/contact.hpp"

namespace cutsim::forcefields {

void ContactParameters::validate() const {
  requireFinitePositive("thickness", thickness);
  requireFinitePositive("stiffness", stiffness);
  requireFiniteNonNegative("friction", friction);
  requireFinitePositive("stickVelocity", stickVelocity);
  if (!(displacementFraction > 0 && displacementFraction < 0.5))
    throw InvalidInput(
        "displacementFraction",
        "must be in (0, 0.5) (two primitives each moving less than half their distance "
        "cannot meet), got " +
            describeNumber(displacementFraction));
  if (!(splitAbove >= 0 && splitAbove <= 1))
    throw InvalidInput("splitAbove", "must be in [0, 1], got " + describeNumber(splitAbove));
  if (maxSplits < 0 || maxSplits > 20) throw InvalidInput("maxSplits", "must be in [0, 20]");
  requireFiniteNonNegative("searchSlack", searchSlack);
  if (threads < 0 || threads > 256)
    throw InvalidInput("threads", "must be in [0, 256] (0: as many as the machine has)");
}

Vec3 Obstacle::offsetAt(double t) const {
  if (path.empty()) return {0, 0, 0};
  if (t <= path.front().time) return path.front().offset;
  if (t >= path.back().time) return path.back().offset;
  std::size_t k = 1;
  while (path[k].time < t) ++k;
  const ObstacleKey& a = path[k - 1];
  const ObstacleKey& b = path[k];
  const double s = b.time > a.time ? (t - a.time) / (b.time - a.time) : 1.0;
  return {a.offset[0] + s * (b.offset[0] - a.offset[0]),
          a.offset[1] + s * (b.offset[1] - a.offset[1]),
          a.offset[2] + s * (b.offset[2] - a.offset[2])};
}

std::string Obstacle::shapeName() const {
  switch (shape) {
    case Shape::Plane:
      return "plane";
    case Shape::Sphere:
      return "sphere";
    case Shape::Box:
      return "box";
    case Shape::Capsule:
      return "capsule";
    case Shape::Mesh:
      return "mesh";
  }
  return "?";
}

namespace {
bool finite3(const Vec3& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}
double norm3(const Vec3& v) {
  return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}
}  // namespace

void Obstacle::validate() const {
  requireFiniteNonNegative("friction", friction);
  switch (shape) {
    case Shape::Plane:
      if (!finite3(point)) throw InvalidInput("point", "must be finite");
      if (!finite3(normal) || !(norm3(normal) > 1e-12))
        throw InvalidInput("normal", "must be a finite, nonzero vector");
      break;
    case Shape::Sphere:
      if (!finite3(point)) throw InvalidInput("center", "must be finite");
      requireFinitePositive("radius", radius);
      break;
    case Shape::Box:
      if (!finite3(point)) throw InvalidInput("center", "must be finite");
      for (int c = 0; c < 3; ++c)
        if (!(std::isfinite(halfExtents[std::size_t(c)]) && halfExtents[std::size_t(c)] > 0))
          throw InvalidInput("size", "every size must be a finite number > 0");
      break;
    case Shape::Capsule:
      if (!finite3(point)) throw InvalidInput("a", "must be finite");
      if (!finite3(pointB)) throw InvalidInput("b", "must be finite");
      requireFinitePositive("radius", radius);
      break;
    case Shape::Mesh:
      if (triangles.empty()) throw InvalidInput("file", "the obstacle mesh has no triangles");
      for (std::size_t i = 0; i < vertices.size(); ++i)
        if (!finite3(vertices[i]))
          throw InvalidInput("file", "vertex " + std::to_string(i) + " is not finite");
      for (std::size_t t = 0; t < triangles.size(); ++t)
        for (int k = 0; k < 3; ++k)
          if (triangles[t][std::size_t(k)] < 0 ||
              std::size_t(triangles[t][std::size_t(k)]) >= vertices.size())
            throw InvalidInput("file",
                               "triangle " + std::to_string(t) + " refers to a missing vertex");
      break;
  }
  for (std::size_t k = 0; k < path.size(); ++k) {
    if (!std::isfinite(path[k].time) || !finite3(path[k].offset))
      throw InvalidInput("path/" + std::to_string(k), "must be finite");
    if (k > 0 && !(path[k].time > path[k - 1].time))
      throw InvalidInput("path/" + std::to_string(k), "times must increase");
  }
}

void Obstacle::surface(const Vec3& o, double planeSize, std::vector<Vec3>& pts,
                       std::vector<std::array<int, 3>>& tris) const {
  pts.clear();
  tris.clear();
  auto add = [&](double x, double y, double z) {
    pts.push_back({x + o[0], y + o[1], z + o[2]});
    return int(pts.size()) - 1;
  };
  const double pi = std::numbers::pi;
  switch (shape) {
    case Shape::Plane: {
      const double l = norm3(normal);
      const Vec3 n{normal[0] / l, normal[1] / l, normal[2] / l};
      Vec3 a = std::abs(n[0]) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
      Vec3 u{n[1] * a[2] - n[2] * a[1], n[2] * a[0] - n[0] * a[2], n[0] * a[1] - n[1] * a[0]};
      const double lu = norm3(u);
      for (double& c : u) c /= lu;
      const Vec3 w{n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]};
      const double h = planeSize / 2;
      for (int k = 0; k < 4; ++k) {
        const double su = (k == 1 || k == 2) ? h : -h, sw = k >= 2 ? h : -h;
        add(point[0] + su * u[0] + sw * w[0], point[1] + su * u[1] + sw * w[1],
            point[2] + su * u[2] + sw * w[2]);
      }
      tris = {{0, 1, 2}, {0, 2, 3}};
      break;
    }
    case Shape::Sphere:
    case Shape::Capsule: {
      // A UV sphere (capsule: two half spheres joined by a cylinder) of 24 x 12 quads.
      const int nu = 24, nv = 12;
      Vec3 a = point, b = shape == Shape::Sphere ? point : pointB;
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
        if (shape == Shape::Capsule && j == nv / 2) {  // the same ring again, at the other end
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
      break;
    }
    case Shape::Box: {
      const Vec3& h = halfExtents;
      for (int k = 0; k < 8; ++k)
        add(point[0] + ((k & 1) ? h[0] : -h[0]), point[1] + ((k & 2) ? h[1] : -h[1]),
            point[2] + ((k & 4) ? h[2] : -h[2]));
      tris = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4},
              {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
      break;
    }
    case Shape::Mesh:
      for (const Vec3& v : vertices) add(v[0], v[1], v[2]);
      tris = triangles;
      break;
  }
}

}  // namespace cutsim::forcefields
