#pragma once
// The penalty's pair search: self pairs and obstacle-mesh pairs by the hierarchies, each
// classified to its closest feature; round obstacles by each triangle's closest feature; planes
// point by point
// (contact_impl.hpp, which includes this file; inline: see there).
#include "contact_impl.hpp"

namespace cutsim::forcefields {

void Contact::Impl::keepIfNear(Pair p, std::span<const double> x, double r, std::vector<Pair>& out,
                               bool features, int t, const Screen* screen) const {
  if (features && p.kind == Kind::EE) {
    if (!screen) p.scale = edgePairScale(p.edges, x);  // (screened: the caller set it)
    if (!(p.scale > 0)) return;  // (two flat edges: their corners' pairs hold the contact)
    orderEdges(p.id);            // (the same classification whichever way they were met)
  }
  Screen own;
  if (features && !screen) {
    if (surelyDropped(p.kind, p.surface, p.obstacle, p.id, p.shape, x, t, &own)) return;
    screen = &own;
  }
  // (a point and a triangle that the screening measured: its closest point, as evaluate's)
  const bool measured = features && screen && screen->set && p.kind == Kind::VT && p.shape == 3;
  Eval e = measured ? pointTriangleEval(
                          {pointOf(p, x, 0), pointOf(p, x, 1), pointOf(p, x, 2), pointOf(p, x, 3)},
                          screen->closest, p.n0)
                    : evaluate(p, x);
  if (!(e.s < r)) return;
  if (features) {
    if (p.kind == Kind::EE || p.kind == Kind::EO) {
      if (!edgePairKept(pointOf(p, x, 0), pointOf(p, x, 1), pointOf(p, x, 2), pointOf(p, x, 3)))
        return;
    } else if (p.kind == Kind::VT || p.kind == Kind::VO || p.kind == Kind::OV) {
      if (!toFeature(p, e, x, t, measured ? &screen->snapped : nullptr)) return;
      if (p.shape != 3) e = evaluate(p, x);
    }
  }
  if (cacheOut) {  // (the cache's build: its compact record only)
    const bool ee = p.kind == Kind::EE;
    cacheOut->push_back({p.kind, p.surface, p.obstacle, ee ? p.edges[0] : p.tri, p.id, p.margins,
                         ee ? p.edges[1] : -1, e.s});
    return;
  }
  p.s0 = e.s;
  p.n0 = e.n;
  p.w0 = e.w;
  out.push_back(p);
}

bool Contact::Impl::edgePairKept(const V3& q0, const V3& q1, const V3& q2, const V3& q3) {
  std::array<double, 2> st;
  if (!closestInsideSegments(q0, q1, q2, q3, st)) return false;
  const double s2 = ((q0 + st[0] * (q1 - q0)) - (q2 + st[1] * (q3 - q2))).squaredNorm();
  const double ends =
      std::min({pointSegmentDistance2(q0, q2, q3), pointSegmentDistance2(q1, q2, q3),
                pointSegmentDistance2(q2, q0, q1), pointSegmentDistance2(q3, q0, q1)});
  constexpr double shrink = (1 - kFeatureTolerance) * (1 - kFeatureTolerance);
  return s2 < ends * shrink;
}

bool Contact::Impl::surelyDropped(Kind kind, std::uint8_t surface, std::int32_t obstacle,
                                  std::array<std::uint32_t, 4> id, std::uint8_t shape,
                                  std::span<const double> x, int t, Screen* screen) const {
  auto point = [&](int i) {
    return (surface >> i) & 1 ? surfacePoint(x, id[std::size_t(i)])
                              : obstaclePoint(obstacle, id[std::size_t(i)]);
  };
  if (kind == Kind::EE || kind == Kind::EO) {
    if (kind == Kind::EE) orderEdges(id);  // (as keepIfNear orders them)
    return !edgePairKept(point(0), point(1), point(2), point(3));
  }
  if (kind != Kind::VT || shape != 3 || t < 0) return false;
  const V3 q0 = surfacePoint(x, id[0]), q1 = surfacePoint(x, id[1]), q2 = surfacePoint(x, id[2]),
           q3 = surfacePoint(x, id[3]);
  const auto closest = closestOnTriangle(q0, q1, q2, q3);
  const auto bw = snapToFeature(q0, q1, q2, q3, closest);  // (closestFeatureOnTriangle)
  if (screen) *screen = Screen{true, closest, bw};
  int on[3], m = 0;
  for (int c = 0; c < 3; ++c)
    if (-bw[std::size_t(c)] != 0.0) on[m++] = c;
  if (m == 1) {
    const std::uint32_t c = id[std::size_t(on[0] + 1)];
    return c < id[0] || pointOwner[c] != t;
  }
  if (m == 2) return edgeOwner[triE[std::size_t(t)][std::size_t(3 - on[0] - on[1])]] != t;
  return false;
}

bool Contact::Impl::toFeature(Pair& p, const Eval& e, std::span<const double> x, int t,
                              const std::array<double, 3>* snapped) const {
  const V3 q = pointOf(p, x, 0);
  // (at a corner or on an edge within kFeatureTolerance: aligned surfaces; `snapped`: the
  // screening's snap of the same weights)
  const auto w = snapped ? *snapped
                         : snapToFeature(q, pointOf(p, x, 1), pointOf(p, x, 2), pointOf(p, x, 3),
                                         {-e.w[1], -e.w[2], -e.w[3]});
  int on[3], m = 0;
  for (int c = 0; c < 3; ++c)
    if (w[std::size_t(c)] != 0.0) on[m++] = c;
  if (m == 3 || m == 0) return true;
  const bool obstacleSide = p.kind == Kind::VO;  // the triangle is an obstacle's
  const MeshObstacle* mesh = obstacleSide ? &meshes[std::size_t(p.obstacle)] : nullptr;
  // The feature's squared distance (a snapped feature's is up to (1 + kFeatureTolerance)^2 of
  // the triangle's), and another triangle is nearer below (1 - kFeatureTolerance)^2 of it (as
  // the brute force compares distances): then the triangle a point was snapped from is never
  // nearer than the feature, and the feature's owner keeps the pair.
  const double d2 =
      (q - (w[0] * pointOf(p, x, 1) + w[1] * pointOf(p, x, 2) + w[2] * pointOf(p, x, 3)))
          .squaredNorm();
  constexpr double shrink = (1 - kFeatureTolerance) * (1 - kFeatureTolerance);
  const double near2 = d2 * shrink - 1e-300;
  // The squared distance from q to triangle u of the same side.
  auto dist2 = [&](int u) {
    std::array<V3, 3> c;
    for (int k = 0; k < 3; ++k)
      c[std::size_t(k)] =
          obstacleSide
              ? obstaclePoint(p.obstacle,
                              std::uint32_t(mesh->triangles[std::size_t(u)][std::size_t(k)]))
              : surfacePoint(x, triV[std::size_t(u)][std::size_t(k)]);
    const auto bw = closestOnTriangle(q, c[0], c[1], c[2]);
    return (q - (bw[0] * c[0] + bw[1] * c[1] + bw[2] * c[2])).squaredNorm();
  };
  // A triangle that holds the pair's own point (a self pair's neighbours) is not its contact.
  auto holdsPoint = [&](int u) {
    return p.kind == Kind::VT && shares(triV[std::size_t(u)], p.id[0]);
  };
  auto nearer = [&](int u) { return u != t && !holdsPoint(u) && dist2(u) < near2; };
  const std::uint32_t inv = kInvalidIndex;
  if (m == 2) {
    const int opposite = 3 - on[0] - on[1];
    const std::uint32_t a = p.id[std::size_t(on[0] + 1)], b = p.id[std::size_t(on[1] + 1)];
    if (obstacleSide) {
      const int edge = mesh->triEdges[std::size_t(t)][std::size_t(opposite)];
      if (mesh->edgeOwner[std::size_t(edge)] != t) return false;
      for (int u : mesh->edgeTris[std::size_t(edge)])
        if (nearer(u)) return false;
    } else {
      const std::uint32_t edge = triE[std::size_t(t)][std::size_t(opposite)];
      if (edgeOwner[edge] != t) return false;
      for (std::int32_t u : edgeTris[edge])
        if (u >= 0 && (holdsPoint(u) || nearer(u)))
          return false;  // (a triangle's own corner and edge: no pair)
    }
    p.id = {p.id[0], a, b, inv};
    p.shape = 2;
  } else {
    const std::uint32_t c = p.id[std::size_t(on[0] + 1)];
    // Two points: the pair is kept once (from the lower id for self pairs, from the surface's
    // point for obstacles), and when each is the other's closest feature.
    if (p.kind == Kind::OV || (p.kind == Kind::VT && c < p.id[0])) return false;
    // Kept only from the corner's owner triangle (checked first: it is the cheap test, and the
    // corner's other triangles, which the search also pairs with the point, all end here).
    if (obstacleSide ? mesh->vertexOwner[c] != t : pointOwner[c] != t) return false;
    const V3 qc = obstacleSide ? obstaclePoint(p.obstacle, c) : surfacePoint(x, c);
    for (std::int32_t k = starStart[p.id[0]]; k < starStart[p.id[0] + 1]; ++k) {
      const auto& U = triV[std::size_t(star[std::size_t(k)])];
      if (!obstacleSide && shares(U, c)) continue;
      const auto bw = closestOnTriangle(qc, surfacePoint(x, U[0]), surfacePoint(x, U[1]),
                                        surfacePoint(x, U[2]));
      const V3 f = bw[0] * surfacePoint(x, U[0]) + bw[1] * surfacePoint(x, U[1]) +
                   bw[2] * surfacePoint(x, U[2]);
      if ((qc - f).squaredNorm() < near2) return false;
    }
    if (obstacleSide) {
      for (int u : mesh->vertexTris[c])
        if (nearer(u)) return false;
    } else {
      for (std::int32_t k = starStart[c]; k < starStart[c + 1]; ++k)
        if (holdsPoint(star[std::size_t(k)]) || nearer(star[std::size_t(k)]))
          return false;  // (neighbours: no pair)
    }
    p.id = {p.id[0], c, inv, inv};
    p.shape = 1;
  }
  const std::uint8_t sides = p.kind == Kind::VO ? 0b0001 : p.kind == Kind::OV ? 0b0000 : 0b0001;
  p.surface = std::uint8_t(sides | (p.kind == Kind::VO ? 0 : (p.shape == 2 ? 0b0110 : 0b0010)));
  return true;
}

void Contact::Impl::selfTrianglePair(int i, int j, std::span<const double> x,
                                     std::vector<Pair>& out, bool features,
                                     const Tight& boxesAtX) const {
  const auto& A = triV[std::size_t(i)];
  const auto& B = triV[std::size_t(j)];
  if (sweep) {
    sweptTrianglePair(i, j, x, out);
    return;
  }
  const double r = triMargin[std::size_t(i)] + triMargin[std::size_t(j)];
  // The triangles' own boxes, grown by r: a primitive outside the other's cannot be within r.
  Box ba = boxesAtX.tri[std::size_t(i)], bb = boxesAtX.tri[std::size_t(j)];
  ba.inflate(r);
  bb.inflate(r);
  auto vt = [&](std::uint32_t v, int t, const Box& box) {
    const auto& T = triV[std::size_t(t)];
    if (!shares(T, v) && box.contains(surfacePoint(x, v))) {
      Pair p{.kind = Kind::VT, .obstacle = -1, .id = {v, T[0], T[1], T[2]}, .surface = 0b1111};
      p.tri = t;
      p.margins = {i, j};
      keepIfNear(p, x, r, out, features, t);
    }
  };
  for (int k = 0; k < 3; ++k) {
    if (pointOwner[A[std::size_t(k)]] == i) vt(A[std::size_t(k)], j, bb);
    if (pointOwner[B[std::size_t(k)]] == j) vt(B[std::size_t(k)], i, ba);
  }
  for (int a = 0; a < 3; ++a) {
    const std::uint32_t ea = triE[std::size_t(i)][std::size_t(a)];
    if (edgeOwner[ea] != i) continue;
    const std::uint32_t a0 = A[std::size_t((a + 1) % 3)], a1 = A[std::size_t((a + 2) % 3)];
    Box sa = boxesAtX.edge[ea];
    sa.inflate(r);
    if (!sa.overlaps(bb)) continue;
    for (int b = 0; b < 3; ++b) {
      const std::uint32_t eb = triE[std::size_t(j)][std::size_t(b)];
      if (edgeOwner[eb] != j) continue;
      const std::uint32_t b0 = B[std::size_t((b + 1) % 3)], b1 = B[std::size_t((b + 2) % 3)];
      if (a0 == b0 || a0 == b1 || a1 == b0 || a1 == b1) continue;
      if (!sa.overlaps(boxesAtX.edge[eb])) continue;
      Pair p{.kind = Kind::EE, .obstacle = -1, .id = {a0, a1, b0, b1}, .surface = 0b1111};
      p.margins = {i, j};
      p.edges = {std::int32_t(ea), std::int32_t(eb)};
      keepIfNear(p, x, r, out, features);
    }
  }
}

void Contact::Impl::meshTrianglePair(int k, int i, int j, std::span<const double> x,
                                     std::vector<Pair>& out, bool features) const {
  const MeshObstacle& m = meshes[std::size_t(k)];
  const auto& A = triV[std::size_t(i)];
  const auto& T = m.triangles[std::size_t(j)];
  auto keep = [&](Pair p, int t) {
    p.tri = t;
    p.margins = {i, -1};
    const double r =
        sweep ? reachOf(p) : triMargin[std::size_t(i)] + obstacleMargin[std::size_t(k)];
    keepIfNear(p, x, r, out, features, t);
  };
  for (int c = 0; c < 3; ++c) {
    if (pointOwner[A[std::size_t(c)]] == i)
      keep(Pair{.kind = Kind::VO,
                .obstacle = k,
                .id = {A[std::size_t(c)], std::uint32_t(T[0]), std::uint32_t(T[1]),
                       std::uint32_t(T[2])},
                .surface = 0b0001},
           j);
    if (m.vertexOwner[std::size_t(T[std::size_t(c)])] == j)
      keep(Pair{.kind = Kind::OV,
                .obstacle = k,
                .id = {std::uint32_t(T[std::size_t(c)]), A[0], A[1], A[2]},
                .surface = 0b1110},
           i);
  }
  for (int a = 0; a < 3; ++a) {
    if (edgeOwner[triE[std::size_t(i)][std::size_t(a)]] != i) continue;
    const std::uint32_t a0 = A[std::size_t((a + 1) % 3)], a1 = A[std::size_t((a + 2) % 3)];
    for (int b = 0; b < 3; ++b) {
      const int eb = m.triEdges[std::size_t(j)][std::size_t(b)];
      if (m.edgeOwner[std::size_t(eb)] != j) continue;
      keep(Pair{.kind = Kind::EO,
                .obstacle = k,
                .id = {a0, a1, std::uint32_t(m.edges[std::size_t(eb)][0]),
                       std::uint32_t(m.edges[std::size_t(eb)][1])},
                .surface = 0b0011},
           -1);
    }
  }
}

void Contact::Impl::searchPairs(std::span<const double> x, std::vector<Pair>& out, bool features) {
  if (P.selfContact)
    bvh.selfPairs([&](int i, int j) { selfTrianglePair(i, j, x, out, features, tight); });
  for (std::size_t k = 0; k < O.size(); ++k) {
    if (!meshLike(k)) continue;
    refitObstacle(k);
    bvh.crossPairs(meshes[k].bvh,
                   [&](int i, int j) { meshTrianglePair(int(k), i, j, x, out, features); });
  }
}

void Contact::Impl::analyticPairs(std::span<const double> x, std::vector<Pair>& out) {
  for (std::size_t k = 0; k < O.size(); ++k) {
    if (meshLike(k)) {
      continue;
    } else if (roundLike(k)) {
      // Each triangle's closest feature (its interior, an edge, a corner), each feature once
      // (from the first triangle that meets it). On several threads when there are many
      // triangles: each over a contiguous run of them, each feature once within its run; the
      // runs' pairs are then appended in order, each feature once, so from the first triangle
      // that meets it, as one thread would.
      pointDistances(int(k), x);
      // (a feature's key: a corner's point id, or an edge's id + the number of point slots)
      auto run = [&](std::size_t begin, std::size_t end, std::vector<char>& seen,
                     std::vector<Pair>& to, std::vector<std::uint32_t>& keys) {
        for (std::size_t t = begin; t < end; ++t) {
          const auto& T = triV[t];
          const double within =
              triMargin[t] + obstacleMargin[k];  // (the obstacle's motion included)
          const double smin = std::min({pointSdf[T[0]], pointSdf[T[1]], pointSdf[T[2]]});
          const std::array<V3, 4> q{surfacePoint(x, T[0]), surfacePoint(x, T[1]),
                                    surfacePoint(x, T[2]), V3::Zero()};
          if (smin - longestEdge({q[0], q[1], q[2]}) >= within) continue;
          if (roundPoint(k) && planeSeparates(int(k), {q[0], q[1], q[2]}, within)) continue;
          const Eval e = roundObstacle(int(k), q, 3, V3::UnitZ());
          if (!(e.s < within)) continue;
          Pair pr{.kind = Kind::FO, .obstacle = std::int32_t(k), .id = {0, 0, 0, 0}, .surface = 0};
          int m = 0;
          for (int c = 0; c < 3; ++c)
            if (e.w[std::size_t(c)] > 0) {
              pr.id[std::size_t(m)] = T[std::size_t(c)];
              pr.w0[std::size_t(m)] = e.w[std::size_t(c)];
              ++m;
            }
          if (m == 0) continue;
          std::uint32_t key = std::uint32_t(kInvalidIndex);
          if (m == 1) {
            key = pr.id[0];
          } else if (m == 2) {
            const int opposite = e.w[0] > 0 ? (e.w[1] > 0 ? 2 : 1) : 0;
            key = std::uint32_t(pointOwner.size()) + triE[t][std::size_t(opposite)];
          }
          if (m < 3 && std::exchange(seen[key], 1)) continue;
          pr.surface = std::uint8_t((1 << m) - 1);
          // (the triangle's interior: the pair is the triangle itself, as just measured)
          const Eval f = m == 3 ? e : evaluate(pr, x);
          pr.s0 = f.s;
          pr.n0 = f.n;
          pr.w0 = f.w;
          to.push_back(pr);
          keys.push_back(key);
        }
      };
      const std::size_t slots = pointOwner.size() + edgeOwner.size();
      const int parts = partsFor(tris.size(), kTrianglesPerThread);
      if (parts <= 1) {
        seenFeature.assign(slots, 0);
        featureKeys.clear();
        run(0, tris.size(), seenFeature, out, featureKeys);
      } else {
        partPairs.resize(std::size_t(parts));
        partSeen.resize(std::size_t(parts));
        partKeys.resize(std::size_t(parts));
        inParts(tris.size(), parts, [&](int j, std::size_t begin, std::size_t end) {
          const std::size_t u = std::size_t(j);
          partSeen[u].assign(slots, 0);
          partPairs[u].clear();
          partKeys[u].clear();
          run(begin, end, partSeen[u], partPairs[u], partKeys[u]);
        });
        seenFeature.assign(slots, 0);
        for (std::size_t u = 0; u < partPairs.size(); ++u)
          for (std::size_t i = 0; i < partPairs[u].size(); ++i) {
            const std::uint32_t key = partKeys[u][i];
            if (key != std::uint32_t(kInvalidIndex) && std::exchange(seenFeature[key], 1)) continue;
            out.push_back(partPairs[u][i]);
          }
      }
    } else {
      for (std::uint32_t p = 0; p < pointOwner.size(); ++p) {
        if (pointOwner[p] < 0) continue;
        V3 g;
        const double s = sdf(int(k), surfacePoint(x, p), g);
        if (s < pointMargin[p] + obstacleMargin[k]) {
          Pair pr{
              .kind = Kind::PO, .obstacle = std::int32_t(k), .id = {p, 0, 0, 0}, .surface = 0b0001};
          pr.s0 = s;
          pr.n0 = g;
          pr.w0 = {1, 0, 0, 0};
          out.push_back(pr);
        }
      }
    }
  }
}

}  // namespace cutsim::forcefields
