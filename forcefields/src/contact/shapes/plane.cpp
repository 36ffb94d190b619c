// The plane obstacle: the half-space on the side its normal points to is free. Contact meets it
// point by point (ObstacleShape::Meets::HalfSpace).
#include <cmath>

#include "shape_support.hpp"

namespace cutsim::forcefields {
namespace {

using namespace shapes;

class PlaneShape final : public ObstacleShape {
 public:
  /// point, normal: checked (finite; the normal nonzero), then the normal made unit.
  PlaneShape(const Vec3& point, const Vec3& normal) : point_(point), normal_(normal) {
    validate();
    const double l =
        std::sqrt(normal_[0] * normal_[0] + normal_[1] * normal_[1] + normal_[2] * normal_[2]);
    for (double& c : normal_) c /= l;
  }
  static PlaneShape read(const ParameterSource& s) {
    const Vec3 point = s.vec3("point");
    const Vec3 n = s.vec3("normal");
    if (!(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] > 1e-24))
      s.fail("normal", "must be a nonzero vector");
    return checked<PlaneShape>(s, point, n);
  }

  std::string name() const override { return "plane"; }
  Meets meets() const override { return Meets::HalfSpace; }
  void validate() const override {
    requireFinite3("point", point_);
    if (!finite3(normal_) || !(norm3(normal_) > 1e-12))
      throw InvalidInput("normal", "must be a finite, nonzero vector");
  }
  double signedDistance(const Vec3& q, const Vec3& offset, Vec3& gradient) const override {
    const V3 g = toV3(normal_).normalized();
    gradient = fromV3(g);
    return g.dot(toV3(q) - (toV3(point_) + toV3(offset)));
  }
  ObstacleBounds bounds(const Vec3&) const override {
    constexpr double inf = std::numeric_limits<double>::infinity();
    return {{-inf, -inf, -inf}, {inf, inf, inf}};
  }
  void surface(const Vec3& o, double planeSize, std::vector<Vec3>& pts,
               std::vector<std::array<int, 3>>& tris) const override {
    pts.clear();
    tris.clear();
    auto add = pointAdder(pts, o);
    const double l = norm3(normal_);
    const Vec3 n{normal_[0] / l, normal_[1] / l, normal_[2] / l};
    Vec3 a = std::abs(n[0]) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    Vec3 u{n[1] * a[2] - n[2] * a[1], n[2] * a[0] - n[0] * a[2], n[0] * a[1] - n[1] * a[0]};
    const double lu = norm3(u);
    for (double& c : u) c /= lu;
    const Vec3 w{n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]};
    const double h = planeSize / 2;
    for (int k = 0; k < 4; ++k) {
      const double su = (k == 1 || k == 2) ? h : -h, sw = k >= 2 ? h : -h;
      add(point_[0] + su * u[0] + sw * w[0], point_[1] + su * u[1] + sw * w[1],
          point_[2] + su * u[2] + sw * w[2]);
    }
    tris = {{0, 1, 2}, {0, 2, 3}};
  }

 private:
  Vec3 point_, normal_;
};

const bool registered = ObstacleShapeRegistry::instance().add(shapeEntry<PlaneShape>(
    "plane", "the half-space its normal points away from is solid (a floor, a table)",
    {{"point", KeyType::Point, "[x, y, z]: a point on the plane", {}, true},
     {"normal", KeyType::Point, "[x, y, z]: nonzero, towards the free side", {}, true}}));

}  // namespace

std::shared_ptr<const ObstacleShape> planeShape(const Vec3& point, const Vec3& normal) {
  return std::make_shared<PlaneShape>(point, normal);
}

}  // namespace cutsim::forcefields
