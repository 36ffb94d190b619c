// The exact intersection oracle of the contact tests (intersection_oracle.hpp).
#include "support/intersection_oracle.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/box_intersection_d.h>

#include <algorithm>
#include <map>
#include <sstream>

namespace cutsim::test {

namespace {
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using P3 = K::Point_3;
using T3 = K::Triangle_3;
using S3 = K::Segment_3;
using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, std::size_t>;
}  // namespace

std::string Intersection::describe() const {
  std::ostringstream s;
  s << "triangles " << a << " and " << b;
  return s.str();
}

std::vector<Intersection> findIntersections(
    const std::vector<std::array<double, 3>>& points,
    const std::vector<std::array<std::size_t, 3>>& triangles,
    const std::function<bool(std::size_t, std::size_t)>& skip, std::size_t limit) {
  auto P = [&](std::size_t i) { return P3(points[i][0], points[i][1], points[i][2]); };
  std::vector<Box> boxes;
  boxes.reserve(triangles.size());
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const auto& c = triangles[t];
    CGAL::Bbox_3 b = P(c[0]).bbox() + P(c[1]).bbox() + P(c[2]).bbox();
    boxes.emplace_back(b, t);
  }
  std::vector<Intersection> out;
  auto check = [&](const Box& ba, const Box& bb) {
    if (out.size() >= limit) return;
    const std::size_t i = ba.info(), j = bb.info();
    if (skip && skip(i, j)) return;
    const auto& A = triangles[i];
    const auto& B = triangles[j];
    std::vector<std::size_t> shared;
    for (std::size_t a : A)
      if (std::find(B.begin(), B.end(), a) != B.end()) shared.push_back(a);
    const T3 ta(P(A[0]), P(A[1]), P(A[2])), tb(P(B[0]), P(B[1]), P(B[2]));
    bool hit = false;
    if (shared.empty()) {
      hit = CGAL::do_intersect(ta, tb);
    } else if (shared.size() == 1) {
      auto opposite = [&](const std::array<std::size_t, 3>& T) {
        std::vector<std::size_t> o;
        for (std::size_t k : T)
          if (k != shared[0]) o.push_back(k);
        return S3(P(o[0]), P(o[1]));
      };
      hit = CGAL::do_intersect(opposite(A), tb) || CGAL::do_intersect(opposite(B), ta);
    } else if (shared.size() == 2) {
      auto corner = [&](const std::array<std::size_t, 3>& T) {
        for (std::size_t k : T)
          if (k != shared[0] && k != shared[1]) return k;
        return T[0];
      };
      hit = CGAL::do_intersect(P(corner(A)), tb) || CGAL::do_intersect(P(corner(B)), ta);
    }
    if (hit) out.push_back({i, j});
  };
  CGAL::box_self_intersection_d(boxes.begin(), boxes.end(), check);
  return out;
}

std::vector<Intersection> simulationIntersections(
    const core::Simulation& sim, bool skipLips,
    const std::vector<std::array<double, 3>>& obstaclePoints,
    const std::vector<std::array<std::size_t, 3>>& obstacleTriangles, double restNear) {
  const auto& topo = sim.topology();
  const auto x = sim.state().x();
  std::vector<std::array<double, 3>> points(topo.pointCapacity());
  for (topology::PointId p : topo.points())
    points[p.idx()] = {x[3 * p.idx()], x[3 * p.idx() + 1], x[3 * p.idx() + 2]};
  std::vector<std::array<std::size_t, 3>> tris;
  std::vector<topology::TriangleId> ids;
  for (topology::TriangleId t : topo.triangles()) {
    const auto v = topo.triangleVertices(t);
    tris.push_back({std::size_t(v[0].idx()), std::size_t(v[1].idx()), std::size_t(v[2].idx())});
    ids.push_back(t);
  }
  const std::size_t surfaceTriangles = tris.size();
  const std::size_t base = points.size();
  points.insert(points.end(), obstaclePoints.begin(), obstaclePoints.end());
  for (const auto& t : obstacleTriangles) tris.push_back({t[0] + base, t[1] + base, t[2] + base});
  auto skip = [&](std::size_t i, std::size_t j) {
    return i >= surfaceTriangles && j >= surfaceTriangles;  // obstacle with itself
  };
  auto found = findIntersections(points, tris, skip, 1000000);
  if (skipLips) {
    // The lips of a cut: surface triangles that touch in the rest configuration without sharing
    // a point (the two sides of a cut, whatever the repair made of their points), within 1e-9 of
    // the mesh's size (the repair's relocations leave lip points a rounding away from the other
    // lip's edges).
    double size2 = 0;
    for (topology::PointId p : topo.points()) {
      const auto r = topo.restPosition(p);
      size2 = std::max(size2, r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    }
    const double touch2 = std::max(1e-18 * std::max(size2, 1e-30), restNear * restNear);
    auto R = [&](std::size_t p) {
      const auto r = topo.restPosition(topology::PointId(topology::Index(p)));
      return P3(r[0], r[1], r[2]);
    };
    std::vector<Intersection> kept;
    for (const auto& f : found) {
      if (f.a < surfaceTriangles && f.b < surfaceTriangles) {
        const auto& A = tris[f.a];
        const auto& B = tris[f.b];
        bool sharePoint = false, copies = false;
        for (std::size_t a : A)
          for (std::size_t b : B) {
            sharePoint = sharePoint || a == b;
            copies =
                copies || (a != b && CGAL::to_double(CGAL::squared_distance(R(a), R(b))) <= touch2);
          }
        if (copies) continue;  // two sides of a cut through a point that was duplicated
        std::vector<std::size_t> shared;
        for (std::size_t a : A)
          if (std::find(B.begin(), B.end(), a) != B.end()) shared.push_back(a);
        if (shared.size() == 1) {
          // The two sides of a cut that ends at the shared point: the rest triangles touch beyond
          // it.
          auto opposite = [&](const std::array<std::size_t, 3>& T) {
            std::vector<std::size_t> o;
            for (std::size_t k : T)
              if (k != shared[0]) o.push_back(k);
            return o;
          };
          auto segTri2 = [&](const std::vector<std::size_t>& e,
                             const std::array<std::size_t, 3>& T) {
            const T3 tri(R(T[0]), R(T[1]), R(T[2]));
            const S3 seg(R(e[0]), R(e[1]));
            if (CGAL::do_intersect(seg, tri)) return 0.0;
            double d2 = std::min(CGAL::to_double(CGAL::squared_distance(R(e[0]), tri)),
                                 CGAL::to_double(CGAL::squared_distance(R(e[1]), tri)));
            for (int k = 0; k < 3; ++k)
              d2 =
                  std::min(d2, CGAL::to_double(CGAL::squared_distance(
                                   seg, S3(R(T[std::size_t(k)]), R(T[std::size_t((k + 1) % 3)])))));
            return d2;
          };
          if (segTri2(opposite(A), B) <= touch2 || segTri2(opposite(B), A) <= touch2) continue;
        }
        if (!sharePoint &&
            CGAL::to_double(CGAL::squared_distance(T3(R(A[0]), R(A[1]), R(A[2])),
                                                   T3(R(B[0]), R(B[1]), R(B[2])))) <= touch2)
          continue;
      }
      kept.push_back(f);
    }
    found = std::move(kept);
  }
  if (found.size() > 10) found.resize(10);
  for (auto& f : found) {
    // Surface triangles by their ids, obstacle triangles after every surface slot.
    f.a = f.a < surfaceTriangles ? std::size_t(ids[f.a].idx())
                                 : topo.triangleCapacity() + (f.a - surfaceTriangles);
    f.b = f.b < surfaceTriangles ? std::size_t(ids[f.b].idx())
                                 : topo.triangleCapacity() + (f.b - surfaceTriangles);
  }
  return found;
}

}  // namespace cutsim::test
