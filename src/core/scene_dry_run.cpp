// Scene files: the dry run of a scene's timeline on a copy of the rest mesh (every cut and removal
// made there first, every selection resolved), so that a scene that loads also runs.
#include <limits>
#include <set>

#include "cutsim/topology/geometry.hpp"
#include "scene_internal.hpp"
#include "scene_json.hpp"

namespace cutsim::core::detail {

using topology::geometry::closestOnTriangle;
using topology::geometry::dist2;

namespace {

std::string vecText(const Vec3& p) {
  return "(" + Reader::text(p[0]) + ", " + Reader::text(p[1]) + ", " + Reader::text(p[2]) + ")";
}

/// Distance from p to the mesh and the longest edge of the nearest triangle.
std::pair<double, double> distanceToSurface(const topology::MeshData& mesh, const Vec3& p) {
  double best = std::numeric_limits<double>::infinity(), edge = 0;
  for (const auto& t : mesh.triangles) {
    const Vec3 &a = mesh.points[t[0]], &b = mesh.points[t[1]], &c = mesh.points[t[2]];
    const double d = dist2(p, closestOnTriangle(p, a, b, c));
    if (d < best) {
      best = d;
      edge = topology::geometry::longestEdge(a, b, c);
    }
  }
  return {std::sqrt(best), edge};
}

}  // namespace

std::vector<topology::TriangleId> trianglesInRegion(const topology::Topology& topo,
                                                    const Region& region) {
  std::vector<topology::TriangleId> out;
  for (topology::TriangleId t : topo.triangles()) {
    const auto v = topo.triangleVertices(t);
    Vec3 c{0, 0, 0};
    for (int i = 0; i < 3; ++i) {
      const Vec3 p = topo.restPosition(v[i]);
      for (int k = 0; k < 3; ++k) c[k] += p[k] / 3.0;
    }
    if (region.contains(c)) out.push_back(t);
  }
  return out;
}

void dryRun(const Reader& r, const Scene& scene, const topology::MeshData& mesh) {
  topology::Topology topo(mesh);
  for (const FixedSpec& f : scene.fixed) {
    if (f.selection.resolve(topo).empty()) {
      r.fail(selectionPointer(f.selection, f.location.pointer), "selects no point of the mesh");
    }
  }
  std::set<std::string> active;
  for (const SceneAction& a : scene.timeline) {
    const std::string& ptr = a.location.pointer;
    switch (a.kind) {
      case SceneAction::Kind::Cut:
      case SceneAction::Kind::ProgressiveCut: {
        for (std::size_t i = 0; i < a.polyline.size(); ++i) {
          const auto [d, edge] = distanceToSurface(mesh, a.polyline[i]);
          if (d > 0.25 * edge) {
            r.fail(ptr + "/polyline/" + Reader::idx(i),
                   "the cut misses the surface: point " + vecText(a.polyline[i]) + " is " +
                       Reader::text(d) + " away from the rest surface");
          }
        }
        try {
          topology::CutOptions options;
          options.snapTolerance = a.snapTolerance;
          topo.cutPolyline(a.polyline, options);
        } catch (const TopologyError& e) {
          r.fail(ptr + "/polyline",
                 std::string("the cut cannot be made on the rest surface: ") + e.what());
        }
        break;
      }
      case SceneAction::Kind::Remove: {
        const auto tris = trianglesInRegion(topo, a.region);
        const std::string rp = ptr + (a.region.kind == Region::Kind::Sphere ? "/sphere" : "/box");
        if (tris.empty()) r.fail(rp, "removes no triangle: no rest centroid lies inside");
        try {
          topo.removeTriangles(tris);
        } catch (const TopologyError& e) {
          r.fail(rp, std::string("the removal cannot be made: ") + e.what());
        }
        break;
      }
      case SceneAction::Kind::Grasp:
        if (active.count(a.name)) {
          r.fail(ptr + "/name", "a grasp named \"" + a.name + "\" is already active");
        }
        if (a.selection.resolve(topo).empty()) {
          r.fail(selectionPointer(a.selection, ptr), "selects no live point at that time");
        }
        active.insert(a.name);
        break;
      case SceneAction::Kind::Release:
        if (!active.erase(a.name)) {
          r.fail(ptr + "/name", "no grasp named \"" + a.name + "\" is active at that time");
        }
        break;
      case SceneAction::Kind::Tearing:
        break;
    }
  }
}

}  // namespace cutsim::core::detail
