// Queries of the deformed surface through contact's bounding volume hierarchy (surface_query.hpp).
#include "cutsim/forcefields/surface_query.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "bvh.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/topology/topology.hpp"
#include "geometry.hpp"

namespace cutsim::forcefields {

using contact::Box;
using contact::V3;

namespace {

V3 v3(const topology::Vec3& p) {
  return {p[0], p[1], p[2]};
}
topology::Vec3 vec(const V3& p) {
  return {p.x(), p.y(), p.z()};
}

inline double boxDistance2(const V3& q, const Box& b) {
  const V3 d = (b.lo - q).cwiseMax(q - b.hi).cwiseMax(V3::Zero());
  return d.squaredNorm();
}

/// Where the ray o + t d, t >= 0, enters the box (0 from inside it; slabs, d's zero components
/// handled), infinity if it misses it: a lower bound of the t of what the box holds.
double rayEntry(const V3& o, const V3& d, const Box& b) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  double t0 = 0.0, t1 = inf;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0.0) {
      if (o[k] < b.lo[k] || o[k] > b.hi[k]) return inf;
      continue;
    }
    double a = (b.lo[k] - o[k]) / d[k], c = (b.hi[k] - o[k]) / d[k];
    if (a > c) std::swap(a, c);
    t0 = std::max(t0, a);
    t1 = std::min(t1, c);
    if (t0 > t1) return inf;
  }
  return t0;
}

/// Where the ray o + t d meets triangle (a, b, c) for t in [0, tMax] (Moeller and Trumbore;
/// either side; a ray in the triangle's plane does not meet it): t and the weights.
std::optional<std::pair<double, std::array<double, 3>>> rayTriangle(const V3& o, const V3& d,
                                                                    double tMax, const V3& a,
                                                                    const V3& b, const V3& c) {
  const V3 e1 = b - a, e2 = c - a;
  const V3 p = d.cross(e2);
  const double det = e1.dot(p);
  const double scale = e1.norm() * e2.norm() * d.norm();
  if (!(std::abs(det) > 1e-14 * scale)) return std::nullopt;
  const double inv = 1.0 / det;
  const V3 s = o - a;
  const double u = s.dot(p) * inv;
  if (u < 0.0 || u > 1.0) return std::nullopt;
  const V3 q = s.cross(e1);
  const double v = d.dot(q) * inv;
  if (v < 0.0 || u + v > 1.0) return std::nullopt;
  const double t = e2.dot(q) * inv;
  if (t < 0.0 || t > tMax) return std::nullopt;
  return std::pair{t, std::array<double, 3>{1.0 - u - v, u, v}};
}

/// Whether p is inside the closed surface of `faces` (a ray's crossings counted: odd inside).
bool insideClosed(const V3& p, const std::vector<std::array<V3, 3>>& faces) {
  // A direction unlikely to graze an edge of the faces.
  const V3 d = V3(0.5773, 0.5787, 0.5763).normalized();
  int crossings = 0;
  for (const auto& f : faces)
    if (rayTriangle(p, d, std::numeric_limits<double>::infinity(), f[0], f[1], f[2])) ++crossings;
  return crossings % 2 == 1;
}

}  // namespace

struct SurfaceQuery::Impl {
  const topology::Topology& topology;
  std::uint64_t revision = ~std::uint64_t(0);
  std::vector<topology::TriangleId> ids;   // the live triangles, ascending
  std::vector<std::array<V3, 3>> corners;  // their corners at the positions
  std::vector<Box> boxes;
  contact::Bvh bvh;

  explicit Impl(const topology::Topology& t) : topology(t) {}

  void update(std::span<const double> x) {
    const bool rebuild = topology.revision() != revision;
    if (rebuild) {
      revision = topology.revision();
      ids = topology.triangles();
      std::sort(ids.begin(), ids.end());
    }
    corners.resize(ids.size());
    boxes.assign(ids.size(), Box{});
    for (std::size_t i = 0; i < ids.size(); ++i) {
      const auto tv = topology.triangleVertices(ids[i]);
      for (int k = 0; k < 3; ++k) {
        const std::size_t p = 3 * std::size_t(topology::Index(tv[std::size_t(k)]));
        if (p + 2 >= x.size())
          throw InvalidInput("SurfaceQuery", "the positions hold " + std::to_string(x.size() / 3) +
                                                 " points, the surface uses point " +
                                                 std::to_string(p / 3));
        corners[i][std::size_t(k)] = V3(x[p], x[p + 1], x[p + 2]);
        boxes[i].add(corners[i][std::size_t(k)]);
      }
    }
    if (rebuild)
      bvh.build(boxes);
    else
      bvh.refit(boxes);
  }

  /// Calls f(i) for each triangle whose box overlaps b.
  template <class F>
  void overlapping(const Box& b, F&& f) const {
    bvh.query(b, [&](int i) { f(std::size_t(i)); });
  }

  std::vector<topology::TriangleId> sorted(std::vector<std::size_t>& found) const {
    std::sort(found.begin(), found.end());
    std::vector<topology::TriangleId> out;
    out.reserve(found.size());
    for (std::size_t i : found) out.push_back(ids[i]);
    return out;
  }

  /// The nearest point to p within maxDistance, ties to the smaller triangle id.
  std::optional<SurfacePoint> nearest(const V3& p, double maxDistance) const {
    double best2 = maxDistance * maxDistance;  // infinity stays infinity
    std::optional<SurfacePoint> out;
    auto consider = [&](int e) {
      const auto& c = corners[std::size_t(e)];
      const auto w = contact::closestOnTriangle(p, c[0], c[1], c[2]);
      const V3 on = w[0] * c[0] + w[1] * c[1] + w[2] * c[2];
      const double d2 = (on - p).squaredNorm();
      // Ties go to the smaller triangle id, whatever the visiting order.
      const topology::TriangleId id = ids[std::size_t(e)];
      if (d2 < best2 || (d2 == best2 && (!out || id < out->triangle))) {
        best2 = d2;
        out = SurfacePoint{id, w, vec(on), std::sqrt(d2)};
      }
    };
    bvh.visitNearest([&](const Box& b) { return boxDistance2(p, b); },
                     [&](double d2) { return d2 <= best2; }, consider);
    return out;
  }

  /// The triangles within `within` of any of the faces (whose boxes overlap theirs).
  std::vector<std::size_t> nearFaces(const std::vector<std::array<V3, 3>>& faces,
                                     double within) const {
    Box all;
    for (const auto& f : faces)
      for (const V3& p : f) all.add(p);
    all.inflate(within);
    std::vector<std::size_t> found;
    overlapping(all, [&](std::size_t i) {
      for (const auto& f : faces)
        if (contact::triangleTriangleDistance(corners[i], f) <= within) {
          found.push_back(i);
          return;
        }
    });
    return found;
  }
};

SurfaceQuery::SurfaceQuery(const topology::Topology& topology, std::span<const double> x)
    : impl_(std::make_unique<Impl>(topology)) {
  impl_->update(x);
}

SurfaceQuery::~SurfaceQuery() = default;

void SurfaceQuery::update(std::span<const double> x) {
  impl_->update(x);
}

std::size_t SurfaceQuery::size() const {
  return impl_->ids.size();
}

std::optional<SurfacePoint> SurfaceQuery::closestPoint(const topology::Vec3& q,
                                                       double maxDistance) const {
  return impl_->nearest(v3(q), maxDistance);
}

std::vector<std::optional<SurfacePoint>> SurfaceQuery::closestPoints(
    std::span<const topology::Vec3> q, double maxDistance) const {
  std::vector<std::optional<SurfacePoint>> out(q.size());
  if (q.empty()) return out;
  Box all;
  for (const topology::Vec3& p : q) all.add(v3(p));
  const V3 lo = all.lo, size = (all.hi - all.lo).cwiseMax(V3::Constant(1e-300));
  // 21 bits a coordinate, interleaved.
  auto spread = [](std::uint64_t v) {
    v &= 0x1fffff;
    v = (v | v << 32) & 0x1f00000000ffffULL;
    v = (v | v << 16) & 0x1f0000ff0000ffULL;
    v = (v | v << 8) & 0x100f00f00f00f00fULL;
    v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
    v = (v | v << 2) & 0x1249249249249249ULL;
    return v;
  };
  std::vector<std::pair<std::uint64_t, std::size_t>> order(q.size());
  for (std::size_t i = 0; i < q.size(); ++i) {
    std::uint64_t code = 0;
    for (int k = 0; k < 3; ++k) {
      const double f = std::clamp((q[i][k] - lo[k]) / size[k], 0.0, 1.0);
      code |= spread(std::uint64_t(f * double(0x1fffff))) << k;
    }
    order[i] = {code, i};
  }
  std::sort(order.begin(), order.end());
  for (const auto& [code, i] : order) out[i] = impl_->nearest(v3(q[i]), maxDistance);
  return out;
}

std::optional<SurfaceHit> SurfaceQuery::rayHit(const topology::Vec3& origin,
                                               const topology::Vec3& direction, double maxT) const {
  const Impl& I = *impl_;
  V3 d = v3(direction);
  const double len = d.norm();
  if (!(len > 0) || !std::isfinite(len))
    throw InvalidInput("rayHit", "the direction must be finite and not zero");
  d /= len;
  const V3 o = v3(origin);
  double bestT = maxT;
  std::optional<SurfaceHit> out;
  I.bvh.visitNearest(
      [&](const Box& b) { return rayEntry(o, d, b); }, [&](double t) { return t <= bestT; },
      [&](int e) {
        const auto& c = I.corners[std::size_t(e)];
        const auto hit = rayTriangle(o, d, bestT, c[0], c[1], c[2]);
        if (!hit) return;
        const topology::TriangleId id = I.ids[std::size_t(e)];
        if (out && (hit->first > out->t || (hit->first == out->t && id > out->triangle))) return;
        bestT = hit->first;
        const auto& w = hit->second;
        out = SurfaceHit{id, hit->first, w, vec(w[0] * c[0] + w[1] * c[1] + w[2] * c[2])};
      });
  return out;
}

std::vector<SurfaceHit> SurfaceQuery::segmentHits(const topology::Vec3& a,
                                                  const topology::Vec3& b) const {
  const Impl& I = *impl_;
  const V3 p = v3(a), d = v3(b) - p;
  std::vector<SurfaceHit> out;
  if (!(d.squaredNorm() > 0)) return out;
  I.bvh.visitNearest([&](const Box& box) { return rayEntry(p, d, box); },
                     [](double t) { return t <= 1.0; },
                     [&](int e) {
                       const auto& c = I.corners[std::size_t(e)];
                       if (const auto hit = rayTriangle(p, d, 1.0, c[0], c[1], c[2])) {
                         const auto& w = hit->second;
                         out.push_back(SurfaceHit{I.ids[std::size_t(e)], hit->first, w,
                                                  vec(w[0] * c[0] + w[1] * c[1] + w[2] * c[2])});
                       }
                     });
  std::sort(out.begin(), out.end(), [](const SurfaceHit& x, const SurfaceHit& y) {
    return x.t < y.t || (x.t == y.t && x.triangle < y.triangle);
  });
  return out;
}

std::vector<topology::TriangleId> SurfaceQuery::sphereOverlap(const topology::Vec3& c,
                                                              double r) const {
  const Impl& I = *impl_;
  const V3 q = v3(c);
  Box b;
  b.add(q);
  b.inflate(r);
  std::vector<std::size_t> found;
  I.overlapping(b, [&](std::size_t i) {
    const auto& t = I.corners[i];
    if (contact::pointTriangleDistance(q, t[0], t[1], t[2]) <= r) found.push_back(i);
  });
  return I.sorted(found);
}

std::vector<topology::TriangleId> SurfaceQuery::capsuleOverlap(const topology::Vec3& a,
                                                               const topology::Vec3& b,
                                                               double r) const {
  const Impl& I = *impl_;
  const V3 p = v3(a), q = v3(b);
  Box box;
  box.add(p);
  box.add(q);
  box.inflate(r);
  std::vector<std::size_t> found;
  I.overlapping(box, [&](std::size_t i) {
    const auto& t = I.corners[i];
    if (contact::segmentTriangleDistance(p, q, t[0], t[1], t[2]) <= r) found.push_back(i);
  });
  return I.sorted(found);
}

std::vector<topology::TriangleId> SurfaceQuery::sweptSegmentHits(const topology::Vec3& a0,
                                                                 const topology::Vec3& b0,
                                                                 const topology::Vec3& a1,
                                                                 const topology::Vec3& b1,
                                                                 double within) const {
  const std::vector<std::array<V3, 3>> faces = {{v3(a0), v3(b0), v3(b1)}, {v3(a0), v3(b1), v3(a1)}};
  std::vector<std::size_t> found = impl_->nearFaces(faces, within);
  return impl_->sorted(found);
}

std::vector<topology::TriangleId> SurfaceQuery::sweptTriangleHits(
    const std::array<topology::Vec3, 3>& from, const std::array<topology::Vec3, 3>& to,
    double within) const {
  const Impl& I = *impl_;
  std::array<V3, 3> p, q;
  for (std::size_t k = 0; k < 3; ++k) {
    p[k] = v3(from[k]);
    q[k] = v3(to[k]);
  }
  // The swept volume's boundary: both positions, and each edge's swept surface in two triangles.
  std::vector<std::array<V3, 3>> faces = {{p[0], p[1], p[2]}, {q[0], q[2], q[1]}};
  for (std::size_t k = 0; k < 3; ++k) {
    const std::size_t l = (k + 1) % 3;
    faces.push_back({p[k], q[k], q[l]});
    faces.push_back({p[k], q[l], p[l]});
  }
  std::vector<std::size_t> found = I.nearFaces(faces, within);
  // The triangles wholly inside: each has a corner inside the closed boundary.
  Box all;
  for (const auto& f : faces)
    for (const V3& v : f) all.add(v);
  std::vector<char> listed(I.ids.size(), 0);
  for (std::size_t i : found) listed[i] = 1;
  I.overlapping(all, [&](std::size_t i) {
    if (!listed[i] && insideClosed(I.corners[i][0], faces)) {
      listed[i] = 1;
      found.push_back(i);
    }
  });
  return I.sorted(found);
}

std::vector<std::vector<SweptCrossing>> SurfaceQuery::sweptSegmentCurves(
    std::span<const std::array<topology::Vec3, 2>> positions) const {
  const Impl& I = *impl_;
  std::vector<std::vector<SweptCrossing>> out;
  if (positions.size() < 2) return out;
  // The swept surface's triangles, with their corners' (u, s): between positions k and k + 1,
  // (a_k, b_k, b_k+1) and (a_k, b_k+1, a_k+1).
  struct Face {
    std::array<V3, 3> p;
    std::array<std::array<double, 2>, 3> us;
  };
  std::vector<Face> faces;
  std::vector<std::array<V3, 3>> corners;
  for (std::size_t k = 0; k + 1 < positions.size(); ++k) {
    const V3 a0 = v3(positions[k][0]), b0 = v3(positions[k][1]);
    const V3 a1 = v3(positions[k + 1][0]), b1 = v3(positions[k + 1][1]);
    const double s0 = double(k), s1 = double(k + 1);
    faces.push_back({{a0, b0, b1}, {{{0, s0}, {1, s0}, {1, s1}}}});
    faces.push_back({{a0, b1, a1}, {{{0, s0}, {1, s1}, {0, s1}}}});
    corners.push_back(faces[faces.size() - 2].p);
    corners.push_back(faces.back().p);
  }
  const std::vector<std::size_t> found = [&] {
    std::vector<std::size_t> f = I.nearFaces(corners, 0.0);
    std::sort(f.begin(), f.end());
    return f;
  }();

  // The curves' points, shared: a mesh vertex, a point of an edge (by its ends, lower id first,
  // and the fraction from the lower), or a point inside one triangle (where the swept surface's
  // own edges cross it).
  std::vector<SweptCrossing> nodes;
  std::map<topology::Index, int> atVertex;
  std::map<std::pair<topology::Index, topology::Index>, std::vector<std::pair<double, int>>> onEdge;
  std::map<std::size_t, std::vector<int>> inside;
  std::set<std::pair<int, int>> pieces;
  constexpr double kEnd = 1e-9;  // an edge's crossing this close to an end is at the end

  struct Candidate {
    int kind;  // 0: a vertex, 1: on an edge, 2: inside the triangle
    topology::Index a = 0, b = 0;
    double t = 0.0;
    SweptCrossing c;
  };
  for (std::size_t i : found) {
    const auto& c = I.corners[i];
    const topology::TriangleId id = I.ids[i];
    const auto tv = I.topology.triangleVertices(id);
    const double tol =
        1e-9 * std::max({(c[1] - c[0]).norm(), (c[2] - c[1]).norm(), (c[0] - c[2]).norm()});
    for (const Face& f : faces) {
      std::vector<Candidate> pts;
      // The triangle's edges through the swept triangle, each from its lower vertex id.
      for (std::size_t j = 0; j < 3; ++j) {
        std::size_t lo = (j + 1) % 3, hi = (j + 2) % 3;
        if (topology::Index(tv[hi]) < topology::Index(tv[lo])) std::swap(lo, hi);
        const auto hit = rayTriangle(c[lo], c[hi] - c[lo], 1.0, f.p[0], f.p[1], f.p[2]);
        if (!hit) continue;
        const double t = hit->first;
        Candidate k{1, topology::Index(tv[lo]), topology::Index(tv[hi]), t, {}};
        k.c.triangle = id;
        k.c.weights[lo] = 1.0 - t;
        k.c.weights[hi] = t;
        if (t <= kEnd || t >= 1.0 - kEnd) {
          const std::size_t at = t <= kEnd ? lo : hi;
          k.kind = 0;
          k.a = topology::Index(tv[at]);
          k.c.weights = {0, 0, 0};
          k.c.weights[at] = 1.0;
        }
        const V3 q = k.c.weights[0] * c[0] + k.c.weights[1] * c[1] + k.c.weights[2] * c[2];
        k.c.point = vec(q);
        const auto& w = hit->second;
        k.c.u = w[0] * f.us[0][0] + w[1] * f.us[1][0] + w[2] * f.us[2][0];
        k.c.s = w[0] * f.us[0][1] + w[1] * f.us[1][1] + w[2] * f.us[2][1];
        pts.push_back(k);
      }
      // The swept triangle's edges through the triangle.
      for (std::size_t m = 0; m < 3; ++m) {
        const std::size_t n = (m + 1) % 3;
        const V3 d = f.p[n] - f.p[m];
        if (!(d.squaredNorm() > 0)) continue;
        const auto hit = rayTriangle(f.p[m], d, 1.0, c[0], c[1], c[2]);
        if (!hit) continue;
        const double t = hit->first;
        Candidate k{2, 0, 0, t, {}};
        k.c.triangle = id;
        k.c.weights = hit->second;
        k.c.point = vec(f.p[m] + t * d);
        // On an edge or at a corner of the triangle (within rounding): the edge's or the
        // corner's point, which the triangle across finds as well.
        std::array<std::size_t, 3> zero{};
        std::size_t zeros = 0;
        for (std::size_t j = 0; j < 3; ++j)
          if (k.c.weights[j] <= kEnd) zero[zeros++] = j;
        if (zeros == 2) {
          const std::size_t at = 3 - zero[0] - zero[1];
          k.kind = 0;
          k.a = topology::Index(tv[at]);
          k.c.weights = {0, 0, 0};
          k.c.weights[at] = 1.0;
          k.c.point = vec(c[at]);
        } else if (zeros == 1) {
          std::size_t lo = (zero[0] + 1) % 3, hi = (zero[0] + 2) % 3;
          if (topology::Index(tv[hi]) < topology::Index(tv[lo])) std::swap(lo, hi);
          const double e = k.c.weights[hi] / (k.c.weights[lo] + k.c.weights[hi]);
          k.kind = 1;
          k.a = topology::Index(tv[lo]);
          k.b = topology::Index(tv[hi]);
          k.t = e;
          k.c.weights = {0, 0, 0};
          k.c.weights[lo] = 1.0 - e;
          k.c.weights[hi] = e;
          k.c.point = vec((1.0 - e) * c[lo] + e * c[hi]);
        }
        k.c.u = (1 - t) * f.us[m][0] + t * f.us[n][0];
        k.c.s = (1 - t) * f.us[m][1] + t * f.us[n][1];
        pts.push_back(k);
      }
      // The same point found twice is one (a vertex or an edge's point first).
      std::stable_sort(pts.begin(), pts.end(),
                       [](const Candidate& x, const Candidate& y) { return x.kind < y.kind; });
      std::vector<Candidate> kept;
      for (const Candidate& k : pts) {
        bool seen = false;
        for (const Candidate& o : kept)
          if ((v3(o.c.point) - v3(k.c.point)).norm() <= tol) seen = true;
        if (!seen) kept.push_back(k);
      }
      if (kept.size() < 2) continue;
      std::size_t e0 = 0, e1 = 1;
      double far = -1.0;
      for (std::size_t x = 0; x < kept.size(); ++x)
        for (std::size_t y = x + 1; y < kept.size(); ++y) {
          const double d = (v3(kept[x].c.point) - v3(kept[y].c.point)).norm();
          if (d > far) {
            far = d;
            e0 = x;
            e1 = y;
          }
        }
      auto node = [&](const Candidate& k) {
        auto make = [&] {
          nodes.push_back(k.c);
          return int(nodes.size()) - 1;
        };
        if (k.kind == 0) {
          auto [it, added] = atVertex.try_emplace(k.a, 0);
          if (added) it->second = make();
          return it->second;
        }
        if (k.kind == 1) {
          auto& list = onEdge[{k.a, k.b}];
          for (const auto& [t, n] : list)
            if (std::abs(t - k.t) <= kEnd) return n;
          list.emplace_back(k.t, make());
          return list.back().second;
        }
        auto& list = inside[i];
        for (int n : list)
          if ((v3(nodes[std::size_t(n)].point) - v3(k.c.point)).norm() <= tol) return n;
        list.push_back(make());
        return list.back();
      };
      const int n0 = node(kept[e0]), n1 = node(kept[e1]);
      if (n0 != n1) pieces.insert({std::min(n0, n1), std::max(n0, n1)});
    }
  }

  // Walk the pieces into curves, from every point that is not in the middle of one.
  std::vector<std::vector<std::pair<int, int>>> next(nodes.size());  // (node, piece)
  std::vector<std::pair<int, int>> list(pieces.begin(), pieces.end());
  for (std::size_t p = 0; p < list.size(); ++p) {
    next[std::size_t(list[p].first)].emplace_back(list[p].second, int(p));
    next[std::size_t(list[p].second)].emplace_back(list[p].first, int(p));
  }
  std::vector<char> used(list.size(), 0);
  for (std::size_t start = 0; start < nodes.size(); ++start) {
    if (next[start].size() == 2) continue;
    for (const auto& first : next[start]) {
      if (used[std::size_t(first.second)]) continue;
      std::vector<SweptCrossing> curve{nodes[start]};
      int at = int(start);
      std::pair<int, int> step = first;
      while (true) {
        used[std::size_t(step.second)] = 1;
        at = step.first;
        curve.push_back(nodes[std::size_t(at)]);
        const auto& around = next[std::size_t(at)];
        if (around.size() != 2) break;
        const auto& other = used[std::size_t(around[0].second)] ? around[1] : around[0];
        if (used[std::size_t(other.second)]) break;
        step = other;
      }
      if (curve.front().s > curve.back().s) std::reverse(curve.begin(), curve.end());
      out.push_back(std::move(curve));
    }
  }
  std::sort(out.begin(), out.end(), [](const auto& x, const auto& y) {
    if (x.front().s != y.front().s) return x.front().s < y.front().s;
    if (x.front().triangle != y.front().triangle) return x.front().triangle < y.front().triangle;
    return x.front().weights < y.front().weights;
  });
  return out;
}

}  // namespace cutsim::forcefields
