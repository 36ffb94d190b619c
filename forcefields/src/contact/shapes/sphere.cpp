// The sphere obstacle. Contact meets it as a round core (ObstacleShape::Meets::Round): a point
// thickened by the radius.

#include "shape_support.hpp"

namespace cutsim::forcefields {
namespace {

using namespace shapes;

class SphereShape final : public ObstacleShape {
 public:
  SphereShape(const Vec3& center, double radius) : center_(center), radius_(radius) { validate(); }
  static SphereShape read(const ParameterSource& s) {
    const Vec3 c = s.vec3("center");
    s.require("radius");
    const double r = s.positive("radius", 0.0);
    return checked<SphereShape>(s, c, r);
  }

  std::string name() const override { return "sphere"; }
  Meets meets() const override { return Meets::Round; }
  void validate() const override {
    requireFinite3("center", center_);
    requireFinitePositive("radius", radius_);
  }
  double signedDistance(const Vec3& q, const Vec3& offset, Vec3& gradient) const override {
    const V3 d = toV3(q) - (toV3(center_) + toV3(offset));
    const double l = d.norm();
    gradient = fromV3(l > 0 ? V3(d / l) : V3(V3::UnitZ()));
    return l - radius_;
  }
  ObstacleBounds bounds(const Vec3& o) const override {
    return ballBounds({{center_[0] + o[0], center_[1] + o[1], center_[2] + o[2]}}, radius_);
  }
  RoundCore round() const override { return {center_, center_, radius_, true}; }
  void surface(const Vec3& o, double, std::vector<Vec3>& pts,
               std::vector<std::array<int, 3>>& tris) const override {
    roundSurface(center_, center_, radius_, false, o, pts, tris);
  }

 private:
  Vec3 center_;
  double radius_;
};

const bool registered = ObstacleShapeRegistry::instance().add(
    shapeEntry<SphereShape>("sphere", "a ball",
                            {{"center", KeyType::Point, "[x, y, z]", {}, true},
                             {"radius", KeyType::Number, "m, > 0", {}, true}}));

}  // namespace

std::shared_ptr<const ObstacleShape> sphereShape(const Vec3& center, double radius) {
  return std::make_shared<SphereShape>(center, radius);
}

}  // namespace cutsim::forcefields
