// The box obstacle (axis-aligned). Contact meets it through its twelve triangles
// (ObstacleShape::Meets::Mesh); its signed distance is exact, inside too.
#include <string>

#include "shape_support.hpp"

namespace cutsim::forcefields {
namespace {

using namespace shapes;

class BoxShape final : public ObstacleShape {
 public:
  BoxShape(const Vec3& center, const Vec3& halfExtents) : center_(center), half_(halfExtents) {
    validate();
  }
  static BoxShape read(const ParameterSource& s) {
    const Vec3 c = s.vec3("center");
    const Vec3 size = s.vec3("size");
    Vec3 half{0, 0, 0};
    for (std::size_t k = 0; k < 3; ++k) {
      if (!(size[k] > 0)) s.fail("size/" + std::to_string(k), "must be > 0");
      half[k] = size[k] / 2;
    }
    return checked<BoxShape>(s, c, half);
  }

  std::string name() const override { return "box"; }
  Meets meets() const override { return Meets::Mesh; }
  void validate() const override {
    requireFinite3("center", center_);
    for (double h : half_)
      if (!(std::isfinite(h) && h > 0))
        throw InvalidInput("size", "every size must be a finite number > 0");
  }
  double signedDistance(const Vec3& q, const Vec3& offset, Vec3& gradient) const override {
    const V3 h = toV3(half_);
    const V3 d = toV3(q) - (toV3(center_) + toV3(offset));
    const V3 a = d.cwiseAbs() - h;
    const V3 e = a.cwiseMax(0.0);
    const double outside = e.norm();
    if (outside > 0) {
      gradient = fromV3(
          V3(d.x() < 0 ? -e.x() : e.x(), d.y() < 0 ? -e.y() : e.y(), d.z() < 0 ? -e.z() : e.z()) /
          outside);
      return outside;
    }
    int axis = 0;
    if (a.y() > a[axis]) axis = 1;
    if (a.z() > a[axis]) axis = 2;
    V3 g = V3::Zero();
    g[axis] = d[axis] < 0 ? -1.0 : 1.0;
    gradient = fromV3(g);
    return a[axis];
  }
  ObstacleBounds bounds(const Vec3& o) const override {
    ObstacleBounds b;
    for (std::size_t k = 0; k < 3; ++k) {
      b.lo[k] = center_[k] + o[k] - half_[k];
      b.hi[k] = center_[k] + o[k] + half_[k];
    }
    return b;
  }
  void surface(const Vec3& o, double, std::vector<Vec3>& pts,
               std::vector<std::array<int, 3>>& tris) const override {
    pts.clear();
    tris.clear();
    auto add = pointAdder(pts, o);
    const Vec3& h = half_;
    const Vec3& c = center_;
    for (int k = 0; k < 8; ++k)
      add(c[0] + ((k & 1) ? h[0] : -h[0]), c[1] + ((k & 2) ? h[1] : -h[1]),
          c[2] + ((k & 4) ? h[2] : -h[2]));
    tris = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4},
            {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
  }
  void triangles(std::vector<Vec3>& points, std::vector<std::array<int, 3>>& tris) const override {
    surface({0, 0, 0}, 0.0, points, tris);
  }

 private:
  Vec3 center_, half_;
};

const bool registered = ObstacleShapeRegistry::instance().add(shapeEntry<BoxShape>(
    "box", "an axis-aligned box",
    {{"center", KeyType::Point, "[x, y, z]", {}, true},
     {"size", KeyType::Point, "[sx, sy, sz]: its sides, each > 0", {}, true}}));

}  // namespace

std::shared_ptr<const ObstacleShape> boxShape(const Vec3& center, const Vec3& halfExtents) {
  return std::make_shared<BoxShape>(center, halfExtents);
}

}  // namespace cutsim::forcefields
