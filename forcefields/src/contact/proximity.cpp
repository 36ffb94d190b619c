// The start checks of a scene: the pairs closer than a distance, the triangles that
// intersect (contact_impl.hpp).
#include <sstream>

#include "contact_impl.hpp"

namespace cutsim::forcefields {

std::vector<ContactProximity> Contact::closePairs(std::span<const double> x, double within,
                                                  std::size_t limit) {
  Impl& I = *impl_;
  I.updateTables();
  // (every kind of pair within the sum of two margins: within)
  I.pointMargin.assign(x.size() / 3, 0.5 * within);
  I.obstacleMargin.assign(obstacles_.size(), 0.5 * within);
  I.prepare(x);
  std::vector<Pair> found;
  I.collect(x, found, false);
  I.pairs.clear();
  I.evaluation.invalidate();
  std::sort(found.begin(), found.end(), [](const Pair& a, const Pair& b) { return a.s0 < b.s0; });
  std::vector<ContactProximity> out;
  for (const Pair& p : found) {
    if (out.size() >= limit) break;
    std::ostringstream s;
    const std::string obstacle =
        p.obstacle >= 0 ? "obstacle \"" + obstacles_[std::size_t(p.obstacle)].name + "\"" : "";
    switch (p.kind) {
      case Kind::VT:
        s << "point " << p.id[0] << " and the triangle of points " << p.id[1] << ", " << p.id[2]
          << ", " << p.id[3];
        break;
      case Kind::EE:
        s << "the edge of points " << p.id[0] << ", " << p.id[1] << " and the edge of points "
          << p.id[2] << ", " << p.id[3];
        break;
      case Kind::PO:
        s << "point " << p.id[0] << " and " << obstacle;
        break;
      case Kind::FO:
        s << "point " << p.id[0] << " and " << obstacle;
        break;
      case Kind::VO:
        s << "point " << p.id[0] << " and " << obstacle;
        break;
      case Kind::OV:
        s << obstacle << " (its vertex " << p.id[0] << ") and the triangle of points " << p.id[1]
          << ", " << p.id[2] << ", " << p.id[3];
        break;
      case Kind::EO:
        s << "the edge of points " << p.id[0] << ", " << p.id[1] << " and " << obstacle;
        break;
    }
    out.push_back({s.str(), p.s0});
  }
  return out;
}

std::vector<ContactProximity> Contact::intersections(std::span<const double> x, std::size_t limit) {
  Impl& I = *impl_;
  I.updateTables();
  I.pointMargin.assign(x.size() / 3, 0.0);
  I.obstacleMargin.assign(obstacles_.size(), 0.0);
  I.prepare(x);
  std::vector<ContactProximity> out;
  auto corners = [&](int i) {
    const auto& T = I.triV[std::size_t(i)];
    return std::array<V3, 3>{I.surfacePoint(x, T[0]), I.surfacePoint(x, T[1]),
                             I.surfacePoint(x, T[2])};
  };
  auto name = [&](int i) {
    const auto& T = I.triV[std::size_t(i)];
    std::ostringstream s;
    s << "the triangle of points " << T[0] << ", " << T[1] << ", " << T[2];
    return s.str();
  };
  if (parameters_.selfContact)
    I.bvh.selfPairs([&](int i, int j) {
      if (out.size() >= limit) return;
      for (std::uint32_t p : I.triV[std::size_t(i)])
        if (I.shares(I.triV[std::size_t(j)], p)) return;
      if (triangleTriangleDistance(corners(i), corners(j)) == 0.0)
        out.push_back({name(i) + " and " + name(j), 0.0});
    });
  for (std::size_t k = 0; k < obstacles_.size() && out.size() < limit; ++k) {
    const std::string obstacle = "obstacle \"" + obstacles_[k].name + "\"";
    if (I.meshLike(k)) {
      Impl::MeshObstacle& m = I.meshes[k];
      I.obstacleBoxes(int(k), m.boxes);
      m.bvh.build(m.boxes);
      if (obstacles_[k].shape->solid())
        for (std::uint32_t p = 0; p < I.pointOwner.size() && out.size() < limit; ++p) {
          V3 g;
          if (I.pointOwner[p] >= 0 && I.sdf(int(k), I.surfacePoint(x, p), g) < 0)
            out.push_back({"point " + std::to_string(p) + " is inside " + obstacle, 0.0});
        }
      I.bvh.crossPairs(m.bvh, [&](int i, int j) {
        if (out.size() >= limit) return;
        const auto& T = m.triangles[std::size_t(j)];
        const std::array<V3, 3> u{I.obstaclePoint(int(k), std::uint32_t(T[0])),
                                  I.obstaclePoint(int(k), std::uint32_t(T[1])),
                                  I.obstaclePoint(int(k), std::uint32_t(T[2]))};
        if (triangleTriangleDistance(corners(int(i)), u) == 0.0)
          out.push_back(
              {name(i) + " and " + obstacle + " (its triangle " + std::to_string(j) + ")", 0.0});
      });
      continue;
    }
    for (std::size_t t = 0; t < I.tris.size() && out.size() < limit; ++t) {
      const double D = I.triangleObstacleDistance(int(k), corners(int(t)), 1e-300);
      if (D == 0.0 || D < 0)
        out.push_back(
            {name(int(t)) + (D < 0 ? " has a corner inside " : " crosses ") + obstacle, 0.0});
    }
  }
  return out;
}

}  // namespace cutsim::forcefields
