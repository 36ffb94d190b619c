// The obstacle shapes' registry (obstacle.hpp): every registered shape is built from values made
// after its declared keys, refuses each missing required key by name, and answers the queries
// of its interface consistently: the gradient of its signed distance against finite differences,
// the closest point (q - distance * gradient) on its surface, its drawn surface within its bounds
// and on its surface, its distance against a brute force over its drawn triangles where those
// are exact (boxes, meshes, planes).
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <map>
#include <random>
#include <stdexcept>
#include <variant>

#include "cutsim/base/errors.hpp"
#include "cutsim/forcefields/obstacle.hpp"
#include "support/fixtures.hpp"

namespace cutsim::test {
namespace {

using forcefields::ObstacleShape;
using forcefields::ObstacleShapeRegistry;

/// Parameters by key: numbers, strings (a file's name taken from the data's scene folder) and
/// points.
class MapSource final : public ParameterSource {
 public:
  using Value = std::variant<double, std::string, Vec3>;
  std::map<std::string, Value, std::less<>> values;

  bool has(std::string_view key) const override { return values.count(key) > 0; }
  double number(std::string_view key) const override { return as<double>(key); }
  long integer(std::string_view key, long, long) const override { return long(as<double>(key)); }
  bool boolean(std::string_view key) const override { return as<double>(key) != 0; }
  std::string string(std::string_view key) const override { return as<std::string>(key); }
  std::string file(std::string_view key) const override {
    return (std::filesystem::path(CUTSIM_DATA_DIR) / "scenes" / string(key)).string();
  }
  [[noreturn]] void fail(std::string_view key, const std::string& message) const override {
    throw InvalidInput(std::string(key), message);
  }
  std::vector<long> integers(std::string_view key, long, long) const override { fail(key, "?"); }
  std::vector<std::vector<double>> rows(std::string_view key, std::size_t,
                                        std::size_t) const override {
    fail(key, "?");
  }
  std::unique_ptr<ParameterSource> object(std::string_view key,
                                          std::initializer_list<std::string_view>) const override {
    fail(key, "?");
  }
  Vec3 vec3(std::string_view key) const override { return as<Vec3>(key); }
  std::vector<Vec3> points(std::string_view key, std::size_t) const override { fail(key, "?"); }
  std::pair<Vec3, Vec3> box(std::string_view key) const override { fail(key, "?"); }

 private:
  template <class T>
  T as(std::string_view key) const {
    auto it = values.find(key);
    if (it == values.end()) fail(key, "missing key");
    if (!std::holds_alternative<T>(it->second)) fail(key, "wrong type");
    return std::get<T>(it->second);
  }
};

/// A value of a key's declared type: numbers 0.2, points [0.1, 0.2, 0.3] moved by 0.1 more for
/// each point key before it (a nonzero normal, positive sizes, a capsule's two distinct ends), a
/// string's declared example.
MapSource::Value valueOf(const KeyInfo& key, int pointsBefore) {
  switch (key.type) {
    case KeyType::Number:
      return 0.2;
    case KeyType::Point: {
      const double s = 0.1 * pointsBefore;
      return Vec3{0.1 + s, 0.2 + s, 0.3 + s};
    }
    case KeyType::String:
      if (key.choices.empty()) ADD_FAILURE() << key.name << ": a string key declares no example";
      return key.choices.empty() ? std::string() : key.choices.back();
    default:
      ADD_FAILURE() << key.name << ": no value made for a key of type " << toString(key.type);
      return 0.0;
  }
}

MapSource everyKey(const ObstacleShapeRegistry::Entry& e) {
  MapSource s;
  int points = 0;
  for (const KeyInfo& k : e.keys)
    s.values[k.name] = valueOf(k, k.type == KeyType::Point ? points++ : points);
  return s;
}

using V3 = Eigen::Vector3d;
V3 v3(const Vec3& v) {
  return {v[0], v[1], v[2]};
}

double pointTriangleDistance(const V3& p, const V3& a, const V3& b, const V3& c) {
  // (a brute force: the plane's foot if inside, else the closest of the three edges)
  const V3 n = (b - a).cross(c - a);
  const V3 f = p - n.dot(p - a) / n.squaredNorm() * n;
  auto inside = [&](const V3& u, const V3& v) { return (v - u).cross(f - u).dot(n) >= 0; };
  if (inside(a, b) && inside(b, c) && inside(c, a)) return (p - f).norm();
  auto seg = [&](const V3& u, const V3& v) {
    const double t = std::clamp((p - u).dot(v - u) / (v - u).squaredNorm(), 0.0, 1.0);
    return (p - (u + t * (v - u))).norm();
  };
  return std::min({seg(a, b), seg(b, c), seg(c, a)});
}

TEST(ObstacleShapes, EveryShapeIsBuiltFromItsDeclaredKeysAndNeedsEachRequiredOne) {
  const auto& registry = ObstacleShapeRegistry::instance();
  ASSERT_GE(registry.names().size(), 5u);
  for (const auto& [name, entry] : registry.entries()) {
    SCOPED_TRACE(name);
    const MapSource all = everyKey(entry);
    const auto shape = forcefields::makeObstacleShape(name, all);
    ASSERT_TRUE(shape);
    EXPECT_EQ(shape->name(), name);
    EXPECT_NO_THROW(shape->validate());
    for (const KeyInfo& k : entry.keys) {
      if (!k.required) continue;
      MapSource missing = all;
      missing.values.erase(k.name);
      try {
        forcefields::makeObstacleShape(name, missing);
        ADD_FAILURE() << "built without its required key " << k.name;
      } catch (const InvalidInput& e) {
        EXPECT_NE(std::string(e.what()).find(k.name), std::string::npos) << e.what();
      }
    }
  }
  try {
    forcefields::makeObstacleShape("torus", MapSource{});
    ADD_FAILURE() << "an unknown shape was built";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.where(), "type");
    EXPECT_NE(std::string(e.what()).find("sphere"), std::string::npos) << e.what();
  }
}

TEST(ObstacleShapes, BadValuesAreRefusedNamingTheirKey) {
  EXPECT_THROW(forcefields::sphereShape({0, 0, 0}, -1.0), InvalidInput);
  EXPECT_THROW(forcefields::planeShape({0, 0, 0}, {0, 0, 0}), InvalidInput);
  EXPECT_THROW(forcefields::boxShape({0, 0, 0}, {1, 0, 1}), InvalidInput);
  EXPECT_THROW(forcefields::capsuleShape({0, 0, NAN}, {0, 0, 1}, 0.1), InvalidInput);
  EXPECT_THROW(forcefields::meshShape({{0, 0, 0}}, {{0, 1, 2}}), InvalidInput);
  try {
    forcefields::sphereShape({0, 0, 0}, 0.0);
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.where(), "radius");
  }
}

// The interface's queries agree with each other, for every registered shape, moved by an offset.
TEST(ObstacleShapes, DistancesGradientsClosestPointsBoundsAndSurfacesAgree) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-0.6, 0.9);
  const Vec3 offset{0.05, -0.03, 0.02};
  for (const auto& [name, entry] : ObstacleShapeRegistry::instance().entries()) {
    SCOPED_TRACE(name);
    const auto shape = forcefields::makeObstacleShape(name, everyKey(entry));
    std::vector<Vec3> pts;
    std::vector<std::array<int, 3>> tris;
    shape->surface(offset, 2.0, pts, tris);
    ASSERT_FALSE(tris.empty());
    const auto b = shape->bounds(offset);
    double size = 0.0;
    for (const Vec3& p : pts) {
      Vec3 g;
      // Every drawn point lies on the surface (a round one's drawing is inscribed: exactly on
      // it at its vertices) and within the bounds.
      EXPECT_NEAR(shape->signedDistance(p, offset, g), 0.0, 1e-12);
      for (std::size_t c = 0; c < 3; ++c) {
        EXPECT_GE(p[c], b.lo[c] - 1e-12);
        EXPECT_LE(p[c], b.hi[c] + 1e-12);
        size = std::max(size, std::abs(p[c]));
      }
    }
    const bool exactDrawing = shape->meets() != ObstacleShape::Meets::Round;
    for (int i = 0; i < 200; ++i) {
      const Vec3 q{u(rng), u(rng), u(rng)};
      Vec3 g;
      const double s = shape->signedDistance(q, offset, g);
      ASSERT_TRUE(std::isfinite(s));
      EXPECT_NEAR(v3(g).norm(), 1.0, 1e-12);
      // The closest point is on the surface, at |s| from q.
      const Vec3 c{q[0] - s * g[0], q[1] - s * g[1], q[2] - s * g[2]};
      Vec3 gc;
      EXPECT_NEAR(shape->signedDistance(c, offset, gc), 0.0, 1e-12);
      // The gradient, by central differences (away from the shape's creases and inside a box,
      // where the distance has kinks: a point is skipped when its two sides disagree).
      const double h = 1e-6;
      V3 fd;
      bool smooth = true;
      for (int k = 0; k < 3; ++k) {
        Vec3 qp = q, qm = q;
        qp[std::size_t(k)] += h;
        qm[std::size_t(k)] -= h;
        Vec3 gp, gm;
        const double sp = shape->signedDistance(qp, offset, gp),
                     sm = shape->signedDistance(qm, offset, gm);
        smooth = smooth && (v3(gp) - v3(gm)).norm() < 1e-3;
        fd[k] = (sp - sm) / (2 * h);
      }
      if (smooth) EXPECT_LT((fd - v3(g)).norm(), 1e-6) << q[0] << " " << q[1] << " " << q[2];
      // Against a brute force over the drawn triangles, where the drawing is the shape (a
      // plane's square is checked only near its middle).
      if (exactDrawing &&
          (shape->meets() != ObstacleShape::Meets::HalfSpace || std::abs(s) < 0.3)) {
        double best = INFINITY;
        for (const auto& t : tris)
          best = std::min(
              best, pointTriangleDistance(v3(q), v3(pts[std::size_t(t[0])]),
                                          v3(pts[std::size_t(t[1])]), v3(pts[std::size_t(t[2])])));
        if (shape->meets() != ObstacleShape::Meets::HalfSpace)
          EXPECT_NEAR(std::abs(s), best, 1e-12 * (1 + size));
        EXPECT_LE(std::abs(s), best + 1e-12);
      }
      // Inside is negative for a solid shape only.
      if (!shape->solid()) EXPECT_GE(s, 0.0);
    }
  }
}

// What contact takes of a shape (its half-space, its round core, its triangles) is the shape its
// queries describe: on the surface, with the distance's gradient as the plane's normal.
TEST(ObstacleShapes, WhatContactMeetsIsTheShapeTheQueriesDescribe) {
  const Vec3 zero{0, 0, 0};
  for (const auto& [name, entry] : ObstacleShapeRegistry::instance().entries()) {
    SCOPED_TRACE(name);
    const auto shape = forcefields::makeObstacleShape(name, everyKey(entry));
    Vec3 g;
    switch (shape->meets()) {
      case ObstacleShape::Meets::HalfSpace: {
        // Contact takes a triangle's distance to a half-space as its nearest corner's: the
        // distance is linear (a point between two has the weighted mean of theirs) and its
        // gradient constant.
        const Vec3 p{0.3, -0.7, 0.2}, q{-0.5, 0.4, 0.9};
        Vec3 gp, gq;
        const double sp = shape->signedDistance(p, zero, gp),
                     sq = shape->signedDistance(q, zero, gq);
        for (double t : {0.25, 0.5, 0.9}) {
          const Vec3 m{p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]),
                       p[2] + t * (q[2] - p[2])};
          EXPECT_NEAR(shape->signedDistance(m, zero, g), sp + t * (sq - sp), 1e-12) << t;
          EXPECT_LT((v3(g) - v3(gp)).norm(), 1e-12);
        }
        EXPECT_LT((v3(gp) - v3(gq)).norm(), 1e-12);
        EXPECT_THROW(shape->round(), std::logic_error);
        break;
      }
      case ObstacleShape::Meets::Round: {
        const auto core = shape->round();
        EXPECT_EQ(core.point, core.a == core.b) << "a point core is a sphere's";
        // Points at the radius from the core's ends and middle, sideways, are on the surface.
        const V3 a = v3(core.a), b = v3(core.b), axis = b - a;
        const V3 side = axis.norm() > 0 ? axis.unitOrthogonal() : V3::UnitX();
        for (double t : {0.0, 0.5, 1.0}) {
          const V3 q = a + t * axis + core.radius * side;
          EXPECT_NEAR(shape->signedDistance({q.x(), q.y(), q.z()}, zero, g), 0.0, 1e-12) << t;
        }
        EXPECT_NEAR(shape->signedDistance(core.a, zero, g), -core.radius, 1e-12);
        break;
      }
      case ObstacleShape::Meets::Mesh: {
        std::vector<Vec3> pts;
        std::vector<std::array<int, 3>> tris;
        shape->triangles(pts, tris);
        ASSERT_FALSE(tris.empty());
        for (const auto& t : tris)
          for (int c : t) {
            ASSERT_LT(std::size_t(c), pts.size());
            EXPECT_NEAR(shape->signedDistance(pts[std::size_t(c)], zero, g), 0.0, 1e-12);
          }
        break;
      }
    }
  }
}

}  // namespace
}  // namespace cutsim::test
