// The triangle-mesh obstacle (any triangle soup read from an OBJ, OFF or Gmsh file). Contact
// meets it through its triangles (ObstacleShape::Meets::Mesh); its distance is unsigned (an
// open soup has no inside).
#include <filesystem>

#include "../geometry.hpp"
#include "cutsim/topology/mesh_io.hpp"
#include "shape_support.hpp"

namespace cutsim::forcefields {
namespace {

using namespace shapes;

class MeshShape final : public ObstacleShape {
 public:
  MeshShape(std::vector<Vec3> vertices, std::vector<std::array<int, 3>> triangles)
      : vertices_(std::move(vertices)), triangles_(std::move(triangles)) {
    validate();
  }
  static MeshShape read(const ParameterSource& s) {
    const std::string file = s.file("file");
    topology::MeshData m;
    try {
      m = topology::readMesh(std::filesystem::path(file));
    } catch (const InvalidInput& e) {
      s.fail("file", "the obstacle mesh does not read: " + std::string(e.what()));
    }
    const Vec3 t = s.has("translation") ? s.vec3("translation") : Vec3{0, 0, 0};
    const double scale = s.positive("scale", 1.0);
    std::vector<Vec3> vertices;
    std::vector<std::array<int, 3>> triangles;
    for (const Vec3& p : m.points)
      vertices.push_back({scale * p[0] + t[0], scale * p[1] + t[1], scale * p[2] + t[2]});
    for (const auto& tri : m.triangles)
      triangles.push_back({int(topology::Index(tri[0])), int(topology::Index(tri[1])),
                           int(topology::Index(tri[2]))});
    if (triangles.empty()) s.fail("file", "the obstacle mesh " + file + " has no triangle");
    return checked<MeshShape>(s, std::move(vertices), std::move(triangles));
  }

  std::string name() const override { return "mesh"; }
  Meets meets() const override { return Meets::Mesh; }
  void validate() const override {
    if (triangles_.empty()) throw InvalidInput("file", "the obstacle mesh has no triangles");
    for (std::size_t i = 0; i < vertices_.size(); ++i)
      if (!finite3(vertices_[i]))
        throw InvalidInput("file", "vertex " + std::to_string(i) + " is not finite");
    for (std::size_t t = 0; t < triangles_.size(); ++t)
      for (int k = 0; k < 3; ++k)
        if (triangles_[t][std::size_t(k)] < 0 ||
            std::size_t(triangles_[t][std::size_t(k)]) >= vertices_.size())
          throw InvalidInput("file",
                             "triangle " + std::to_string(t) + " refers to a missing vertex");
  }
  double signedDistance(const Vec3& q, const Vec3& offset, Vec3& gradient) const override {
    const V3 p = toV3(q), off = toV3(offset);
    double best = std::numeric_limits<double>::infinity();
    V3 closest = p;
    for (const auto& t : triangles_) {
      const V3 a = toV3(vertices_[std::size_t(t[0])]) + off,
               b = toV3(vertices_[std::size_t(t[1])]) + off,
               c = toV3(vertices_[std::size_t(t[2])]) + off;
      const auto w = contact::closestOnTriangle(p, a, b, c);
      const V3 f = w[0] * a + w[1] * b + w[2] * c;
      const double dd = (p - f).squaredNorm();
      if (dd < best) {
        best = dd;
        closest = f;
      }
    }
    const double l = std::sqrt(best);
    gradient = fromV3(l > 0 ? V3((p - closest) / l) : V3(V3::UnitZ()));
    return l;
  }
  bool solid() const override { return false; }
  ObstacleBounds bounds(const Vec3& o) const override {
    constexpr double inf = std::numeric_limits<double>::infinity();
    ObstacleBounds b{{inf, inf, inf}, {-inf, -inf, -inf}};
    for (const Vec3& v : vertices_)
      for (std::size_t k = 0; k < 3; ++k) {
        b.lo[k] = std::min(b.lo[k], v[k] + o[k]);
        b.hi[k] = std::max(b.hi[k], v[k] + o[k]);
      }
    return b;
  }
  void surface(const Vec3& o, double, std::vector<Vec3>& pts,
               std::vector<std::array<int, 3>>& tris) const override {
    pts.clear();
    tris.clear();
    auto add = pointAdder(pts, o);
    for (const Vec3& v : vertices_) add(v[0], v[1], v[2]);
    tris = triangles_;
  }
  void triangles(std::vector<Vec3>& points, std::vector<std::array<int, 3>>& tris) const override {
    points = vertices_;
    tris = triangles_;
  }

 private:
  std::vector<Vec3> vertices_;
  std::vector<std::array<int, 3>> triangles_;
};

const bool registered = ObstacleShapeRegistry::instance().add(shapeEntry<MeshShape>(
    "mesh", "a triangle soup from a mesh file (OBJ, OFF, Gmsh .msh), moved and scaled",
    {{"file",
      KeyType::String,
      "a mesh file, relative to the scene's folder",
      {"../meshes/octahedron.off"},
      true},
     {"translation", KeyType::Point, "[x, y, z] added to its points (after the scale)"},
     {"scale", KeyType::Number, "> 0, default 1"}}));

}  // namespace

std::shared_ptr<const ObstacleShape> meshShape(std::vector<Vec3> vertices,
                                               std::vector<std::array<int, 3>> triangles) {
  return std::make_shared<MeshShape>(std::move(vertices), std::move(triangles));
}

}  // namespace cutsim::forcefields
