// The capsule obstacle (a rod, an instrument's shaft): the segment a-b thickened by a radius.
// Contact meets it as a round core (ObstacleShape::Meets::Round).
#include <algorithm>

#include "shape_support.hpp"

namespace cutsim::forcefields {
namespace {

using namespace shapes;

class CapsuleShape final : public ObstacleShape {
 public:
  CapsuleShape(const Vec3& a, const Vec3& b, double radius) : a_(a), b_(b), radius_(radius) {
    validate();
  }
  static CapsuleShape read(const ParameterSource& s) {
    const Vec3 a = s.vec3("a");
    const Vec3 b = s.vec3("b");
    s.require("radius");
    const double r = s.positive("radius", 0.0);
    return checked<CapsuleShape>(s, a, b, r);
  }

  std::string name() const override { return "capsule"; }
  Meets meets() const override { return Meets::Round; }
  void validate() const override {
    requireFinite3("a", a_);
    requireFinite3("b", b_);
    requireFinitePositive("radius", radius_);
  }
  double signedDistance(const Vec3& q, const Vec3& offset, Vec3& gradient) const override {
    const V3 off = toV3(offset);
    const V3 c = toV3(a_) + off;
    const V3 b = toV3(b_) + off;
    const V3 p = toV3(q);
    const V3 ab = b - c;
    const double ll = ab.squaredNorm();
    const double t = ll > 0 ? std::clamp((p - c).dot(ab) / ll, 0.0, 1.0) : 0.0;
    const V3 d = p - (c + t * ab);
    const double l = d.norm();
    gradient = fromV3(l > 0 ? V3(d / l) : V3(V3::UnitZ()));
    return l - radius_;
  }
  ObstacleBounds bounds(const Vec3& o) const override {
    return ballBounds(
        {{a_[0] + o[0], a_[1] + o[1], a_[2] + o[2]}, {b_[0] + o[0], b_[1] + o[1], b_[2] + o[2]}},
        radius_);
  }
  RoundCore round() const override { return {a_, b_, radius_}; }
  void surface(const Vec3& o, double, std::vector<Vec3>& pts,
               std::vector<std::array<int, 3>>& tris) const override {
    roundSurface(a_, b_, radius_, true, o, pts, tris);
  }

 private:
  Vec3 a_, b_;
  double radius_;
};

const bool registered = ObstacleShapeRegistry::instance().add(
    shapeEntry<CapsuleShape>("capsule", "a rod: the segment from a to b thickened by a radius",
                             {{"a", KeyType::Point, "[x, y, z]: one end of the core", {}, true},
                              {"b", KeyType::Point, "[x, y, z]: the other end", {}, true},
                              {"radius", KeyType::Number, "m, > 0", {}, true}}));

}  // namespace

std::shared_ptr<const ObstacleShape> capsuleShape(const Vec3& a, const Vec3& b, double radius) {
  return std::make_shared<CapsuleShape>(a, b, radius);
}

}  // namespace cutsim::forcefields
