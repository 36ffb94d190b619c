#pragma once
// Obstacles: kinematic colliders of the contact field (contact.hpp). An obstacle is a shape, a
// name, a friction coefficient and a path (its offset over time); the shape is one registered
// entry of ObstacleShapeRegistry, in its own file (forcefields/src/contact/shapes/), read from a
// scene's "obstacles" list by its "type". Notes: docs/contact.md.
//
// A shape answers what any client asks of a collider (its signed distance and closest point,
// its bounds, a surface to draw) and tells contact how to meet it: contact's pair search knows
// three kinds of geometry (ObstacleShape::Meets), and a new shape is one of them.
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "cutsim/base/registry.hpp"
#include "cutsim/base/vec3.hpp"

namespace cutsim::forcefields {

/// An axis-aligned box (lo <= hi; an unbounded shape has infinite sides).
struct ObstacleBounds {
  Vec3 lo{0, 0, 0}, hi{0, 0, 0};
};

/// A sphere or a capsule as contact meets it: the segment a-b thickened by a radius; `point`: the
/// core is the point a (a sphere: contact then also culls triangles by their planes).
struct RoundCore {
  Vec3 a{0, 0, 0}, b{0, 0, 0};
  double radius = 0.0;
  bool point = false;
};

/// The geometry of an obstacle, at rest (offset zero); immutable once built.
class ObstacleShape {
 public:
  /// How contact's pair search meets the shape:
  /// - HalfSpace: each surface point against the signed distance (a plane; the distance is
  ///   linear over a triangle: contact asks only signedDistance());
  /// - Round: each surface triangle's closest feature against round() (spheres, capsules);
  /// - Mesh: the surface's points, edges and triangles against triangles() (boxes, meshes).
  enum class Meets { HalfSpace, Round, Mesh };

  virtual ~ObstacleShape();
  /// The registered name ("plane", "sphere", ...).
  virtual std::string name() const = 0;
  virtual Meets meets() const = 0;
  /// Throws InvalidInput naming the key ("radius", "normal", "file", ...) for a bad value.
  virtual void validate() const = 0;
  /// Signed distance of q to the shape moved by `offset` (< 0 inside; an open mesh: unsigned,
  /// its inside unknown) and the unit direction in which it grows; the closest point on the
  /// surface is q - distance * gradient.
  virtual double signedDistance(const Vec3& q, const Vec3& offset, Vec3& gradient) const = 0;
  /// Whether signedDistance() is negative inside (false: an open mesh's unsigned distance).
  /// (surface(): the points and triangles are replaced.)
  virtual bool solid() const { return true; }
  /// The bounds of the shape moved by `offset` (a plane: the whole space).
  virtual ObstacleBounds bounds(const Vec3& offset) const = 0;
  /// A surface to draw, moved by `offset` (a plane: a square of side `planeSize` around its
  /// point).
  virtual void surface(const Vec3& offset, double planeSize, std::vector<Vec3>& points,
                       std::vector<std::array<int, 3>>& triangles) const = 0;
  /// Meets::Round: its core and radius.
  virtual RoundCore round() const;
  /// Meets::Mesh: its triangles at rest (any triangle soup).
  virtual void triangles(std::vector<Vec3>& points, std::vector<std::array<int, 3>>& tris) const;
};

/// A keyframe of a moving obstacle: its offset from its scene position at a time.
struct ObstacleKey {
  double time = 0.0;
  Vec3 offset{0, 0, 0};
};

/// An obstacle: a kinematic collider (it pushes; it neither cuts nor grasps).
struct Obstacle {
  std::string name;
  std::shared_ptr<const ObstacleShape> shape;
  double friction = 0.0;  ///< mu against this obstacle: >= 0
  /// Keyframes (ascending times): the offset is interpolated linearly and held before the first
  /// and after the last. Empty: fixed.
  std::vector<ObstacleKey> path;

  Vec3 offsetAt(double t) const;
  bool moving() const { return !path.empty(); }
  /// Throws InvalidInput naming the key ("radius", "friction", "path/3", ...) for bad values.
  void validate() const;
  /// The shape's surface at offset `offset`, for drawing.
  void surface(const Vec3& offset, double planeSize, std::vector<Vec3>& points,
               std::vector<std::array<int, 3>>& triangles) const {
    shape->surface(offset, planeSize, points, triangles);
  }
  /// The shape's registered name.
  std::string shapeName() const { return shape ? shape->name() : "?"; }
};

/// The obstacle shapes by name. A shape's entry reads its keys (besides "type", "name",
/// "friction" and "path", which every obstacle has) and builds it.
using ObstacleShapeRegistry = Registry<ObstacleShape>;

/// The shapes of code-built scenes (the tests, the benchmarks, the Python module), with the
/// checks of their registered entries (InvalidInput naming the key).
std::shared_ptr<const ObstacleShape> planeShape(const Vec3& point, const Vec3& normal);
std::shared_ptr<const ObstacleShape> sphereShape(const Vec3& center, double radius);
std::shared_ptr<const ObstacleShape> boxShape(const Vec3& center, const Vec3& halfExtents);
std::shared_ptr<const ObstacleShape> capsuleShape(const Vec3& a, const Vec3& b, double radius);
std::shared_ptr<const ObstacleShape> meshShape(std::vector<Vec3> vertices,
                                               std::vector<std::array<int, 3>> triangles);

/// A shape by its registered name from parameters (for the tests: every entry built alike).
std::shared_ptr<const ObstacleShape> makeObstacleShape(const std::string& type,
                                                       const ParameterSource& parameters);

}  // namespace cutsim::forcefields
