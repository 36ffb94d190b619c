// Obstacles (obstacle.hpp): what every obstacle has (a name, a friction, a path), the shapes'
// registry and its lookups. Each shape is a file of shapes/.
#include "cutsim/forcefields/obstacle.hpp"

#include <cmath>
#include <stdexcept>

#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"

namespace cutsim::forcefields {

ObstacleShape::~ObstacleShape() = default;

RoundCore ObstacleShape::round() const {
  throw std::logic_error("the obstacle shape " + name() + " is not round");
}
void ObstacleShape::triangles(std::vector<Vec3>&, std::vector<std::array<int, 3>>&) const {
  throw std::logic_error("the obstacle shape " + name() + " is not met as a mesh");
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

namespace {
bool finite3(const Vec3& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}
}  // namespace

void Obstacle::validate() const {
  requireFiniteNonNegative("friction", friction);
  if (!shape) throw InvalidInput("type", "the obstacle has no shape");
  shape->validate();
  for (std::size_t k = 0; k < path.size(); ++k) {
    if (!std::isfinite(path[k].time) || !finite3(path[k].offset))
      throw InvalidInput("path/" + std::to_string(k), "must be finite");
    if (k > 0 && !(path[k].time > path[k - 1].time))
      throw InvalidInput("path/" + std::to_string(k), "times must increase");
  }
}

std::shared_ptr<const ObstacleShape> makeObstacleShape(const std::string& type,
                                                       const ParameterSource& parameters) {
  const auto& registry = ObstacleShapeRegistry::instance();
  const auto* entry = registry.find(type);
  if (!entry) {
    std::string names;
    for (const std::string& n : registry.names()) names += (names.empty() ? "" : ", ") + n;
    throw InvalidInput("type", "unknown obstacle type \"" + type + "\" (" + names + ")");
  }
  return entry->build(entry->read(parameters));
}

}  // namespace cutsim::forcefields
