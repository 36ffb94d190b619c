// The displacement bound: additive continuous collision detection along the proposed
// displacements, the swept boxes of the bound's search, and the limit's passes
// (contact_impl.hpp).
#include "contact_impl.hpp"

namespace cutsim::forcefields {

double Contact::Impl::pairSafeFraction(const Pair& p, std::span<const double> x0,
                                       const std::vector<V3>& dx) const {
  if (p.kind == Kind::PO || p.kind == Kind::FO) return 1.0;  // (bounded per triangle)
  std::array<V3, 4> q0, d;
  q0.fill(V3::Zero());
  d.fill(V3::Zero());
  V3 mean = V3::Zero();
  const int count = p.points();
  for (int i = 0; i < count; ++i) {
    q0[std::size_t(i)] = pointOf(p, x0, i);
    d[std::size_t(i)] =
        (p.surface >> i) & 1 ? dx[p.id[std::size_t(i)]] : move[std::size_t(p.obstacle)];
    mean += d[std::size_t(i)] / double(count);
  }
  // The two primitives' points: [0, split) and [split, count).
  const int split = (p.kind == Kind::EE || p.kind == Kind::EO) ? 2 : 1;
  double a = 0, b = 0;
  for (int i = 0; i < count; ++i) {
    const double m = (d[std::size_t(i)] - mean).norm();
    (i < split ? a : b) = std::max(i < split ? a : b, m);
  }
  return safeFraction(
      [&](double t) {
        std::array<V3, 4> q;
        for (int i = 0; i < 4; ++i) q[std::size_t(i)] = q0[std::size_t(i)] + t * d[std::size_t(i)];
        return evaluatePoints(p, q).s;  // (unused points stay at zero)
      },
      a + b, gapFloor());
}

double Contact::Impl::reachOf(const Pair& p) const {
  const int count = p.points(), split = (p.kind == Kind::EE || p.kind == Kind::EO) ? 2 : 1;
  if (absoluteReach) {
    // Each primitive's largest displacement: shortening displacements keeps it valid.
    double a = 0, b = 0;
    for (int i = 0; i < count; ++i)
      (i < split ? a : b) = std::max(i < split ? a : b, motionOf(p, i).norm());
    return a + b + gapFloor();
  }
  V3 mean = V3::Zero();
  for (int i = 0; i < count; ++i) mean += motionOf(p, i) / double(count);
  double a = 0, b = 0;
  for (int i = 0; i < count; ++i)
    (i < split ? a : b) = std::max(i < split ? a : b, (motionOf(p, i) - mean).norm());
  // (a pair that could come within the floor is bounded too)
  return a + b + gapFloor();
}

Box Contact::Impl::sweptPoint(std::span<const double> x, std::uint32_t v) const {
  Box b;
  const V3 q = surfacePoint(x, v);
  b.add(q);
  b.add(q + (*sweep)[v]);
  return b;
}

void Contact::Impl::prepareSwept(std::span<const double> x, const std::vector<V3>& dx) {
  const bool rebuild = !bvhBuilt;
  bvhBuilt = true;
  tightBoxes(x, tight);
  boxes.resize(tris.size());
  // (grown by the floor: a pair that could come within it is found)
  const double eps = 1e-9 * std::max(meanEdge, 1e-300) + gapFloor();
  for (std::size_t i = 0; i < tris.size(); ++i) {
    Box b = tight.tri[i];
    for (int k = 0; k < 3; ++k)
      b.add(surfacePoint(x, triV[i][std::size_t(k)]) + dx[triV[i][std::size_t(k)]]);
    b.inflate(eps);
    boxes[i] = b;
  }
  if (rebuild || bvh.size() != boxes.size())
    bvh.build(boxes);
  else
    bvh.refit(boxes);
}

void Contact::Impl::tightBoxes(std::span<const double> x, Tight& out) const {
  out.tri.resize(tris.size());
  out.edge.resize(edgeOwner.size());
  for (std::size_t i = 0; i < tris.size(); ++i) {
    const auto& T = triV[i];
    const V3 a = surfacePoint(x, T[0]), b = surfacePoint(x, T[1]), c = surfacePoint(x, T[2]);
    Box& t = out.tri[i];
    t.lo = a.cwiseMin(b).cwiseMin(c);
    t.hi = a.cwiseMax(b).cwiseMax(c);
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t e = triE[i][std::size_t(k)];
      if (edgeOwner[e] != std::int32_t(i)) continue;
      const V3 p = surfacePoint(x, T[std::size_t((k + 1) % 3)]),
               q = surfacePoint(x, T[std::size_t((k + 2) % 3)]);
      out.edge[e].lo = p.cwiseMin(q);
      out.edge[e].hi = p.cwiseMax(q);
    }
  }
}

void Contact::Impl::sweptTrianglePair(int i, int j, std::span<const double> x,
                                      std::vector<Pair>& out) const {
  const auto& A = triV[std::size_t(i)];
  const auto& B = triV[std::size_t(j)];
  const Box& ba = boxes[std::size_t(i)];
  const Box& bb = boxes[std::size_t(j)];
  auto keep = [&](const Pair& p) { keepIfNear(p, x, reachOf(p), out); };
  auto vt = [&](std::uint32_t v, int t, const Box& box) {
    const auto& T = triV[std::size_t(t)];
    if (!shares(T, v) && box.overlaps(sweptPoint(x, v)))
      keep(Pair{.kind = Kind::VT, .obstacle = -1, .id = {v, T[0], T[1], T[2]}, .surface = 0b1111});
  };
  for (int k = 0; k < 3; ++k) {
    if (pointOwner[A[std::size_t(k)]] == i) vt(A[std::size_t(k)], j, bb);
    if (pointOwner[B[std::size_t(k)]] == j) vt(B[std::size_t(k)], i, ba);
  }
  for (int a = 0; a < 3; ++a) {
    if (edgeOwner[triE[std::size_t(i)][std::size_t(a)]] != i) continue;
    const std::uint32_t a0 = A[std::size_t((a + 1) % 3)], a1 = A[std::size_t((a + 2) % 3)];
    Box sa = sweptPoint(x, a0);
    sa.add(sweptPoint(x, a1));
    sa.inflate(gapFloor());
    if (!sa.overlaps(bb)) continue;
    for (int b = 0; b < 3; ++b) {
      if (edgeOwner[triE[std::size_t(j)][std::size_t(b)]] != j) continue;
      const std::uint32_t b0 = B[std::size_t((b + 1) % 3)], b1 = B[std::size_t((b + 2) % 3)];
      if (a0 == b0 || a0 == b1 || a1 == b0 || a1 == b1) continue;
      Box sb = sweptPoint(x, b0);
      sb.add(sweptPoint(x, b1));
      if (sa.overlaps(sb))
        keep(Pair{.kind = Kind::EE, .obstacle = -1, .id = {a0, a1, b0, b1}, .surface = 0b1111});
    }
  }
}

void Contact::Impl::searchAround(std::span<const double> x, const std::vector<char>& fast,
                                 std::vector<Pair>& out) {
  auto hasFast = [&](std::size_t t) {
    return fast[triV[t][0]] || fast[triV[t][1]] || fast[triV[t][2]];
  };
  for (std::size_t k = 0; k < O.size(); ++k)
    if (meshLike(k)) refitObstacle(k);
  for (std::size_t i = 0; i < tris.size(); ++i) {
    if (!hasFast(i)) continue;
    if (P.selfContact)
      bvh.query(boxes[i], [&](int j) {
        // Each pair of triangles once: from the lower index when both hold a fast point.
        if (std::size_t(j) == i || (hasFast(std::size_t(j)) && std::size_t(j) < i)) return;
        sweptTrianglePair(int(i), j, x, out);
      });
    for (std::size_t k = 0; k < O.size(); ++k)
      if (meshLike(k))
        meshes[k].bvh.query(boxes[i],
                            [&](int j) { meshTrianglePair(int(k), int(i), j, x, out, false); });
  }
}

bool Contact::Impl::planeSeparates(int k, const std::array<V3, 3>& tv, double within) const {
  const RoundCore& o = cores[std::size_t(k)];
  const V3 c = V3(o.a[0], o.a[1], o.a[2]) + offset[std::size_t(k)];
  const V3 e1 = tv[1] - tv[0], e2 = tv[2] - tv[0], r = c - tv[0];
  const V3 normal = e1.cross(e2);
  const double area2 = normal.norm();
  if (!(area2 >= 1e-6 * e1.norm() * e2.norm())) return false;
  const double margin = 1e-9 * (r.norm() + e1.norm() + e2.norm());
  return std::abs(normal.dot(r)) / area2 - margin - o.radius >= within;
}

double Contact::Impl::triangleObstacleDistance(int k, const std::array<V3, 3>& tv, double within,
                                               double smin) const {
  if (smin <= 0) return -1.0;
  // (a half-space's distance is linear over the triangle: the smallest corner's)
  if (meets[std::size_t(k)] == ObstacleShape::Meets::HalfSpace) return smin >= within ? kInf : smin;
  if (smin - longestEdge(tv) >= within) return kInf;
  double D = smin;
  const RoundCore& o = cores[std::size_t(k)];
  const V3 c = V3(o.a[0], o.a[1], o.a[2]) + offset[std::size_t(k)];
  if (roundPoint(std::size_t(k))) {
    if (planeSeparates(k, tv, within)) return kInf;
    D = pointTriangleDistance(c, tv[0], tv[1], tv[2]) - o.radius;
  } else if (roundLike(std::size_t(k))) {
    const V3 b = V3(o.b[0], o.b[1], o.b[2]) + offset[std::size_t(k)];
    D = segmentTriangleDistance(c, b, tv[0], tv[1], tv[2]) - o.radius;
  }
  return std::max(D, 0.0);
}

bool Contact::Impl::limit(std::span<const double> x, const std::vector<Pair>& near,
                          const std::vector<V3>& disp, std::span<const char> locked, double gamma,
                          std::vector<double>& scale, bool plain) {
  bool any = false;
  reframedAny = false;
  struct TriangleItem {
    int k;
    std::size_t t;
    double D;
  };
  auto at = [&](std::size_t p) -> V3 { return anchor[p] + scale[p] * (disp[p] - anchor[p]); };
  std::vector<TriangleItem> items;
  for (std::size_t k = 0; k < O.size(); ++k) {
    if (meshLike(k)) continue;
    const V3& m = move[k];
    // Per point: how far it travels relative to the obstacle, and its distance to it (each
    // measured once, not once per triangle around the point).
    pointDistances(int(k), x);
    pointReach.resize(disp.size());
    for (std::size_t p = 0; p < disp.size(); ++p) pointReach[p] = (at(p) - m).norm();
    auto run = [&](std::size_t begin, std::size_t end, std::vector<TriangleItem>& to) {
      for (std::size_t t = begin; t < end; ++t) {
        const auto& T = triV[t];
        // How far the triangle's points travel relative to the obstacle.
        const double reach = std::max({pointReach[T[0]], pointReach[T[1]], pointReach[T[2]]});
        if (!(reach > 0)) continue;
        const std::array<V3, 3> tv{surfacePoint(x, T[0]), surfacePoint(x, T[1]),
                                   surfacePoint(x, T[2])};
        const double smin = std::min({pointSdf[T[0]], pointSdf[T[1]], pointSdf[T[2]]});
        // Dropped only at 1.25 times its reach or more, where the CCD below would take the
        // whole step at its first advance (0.81 D / lp >= 1): the same bounds as measuring it
        // (and at ten floors more: its CCD's floor is then a tenth of its distance).
        const double D =
            triangleObstacleDistance(int(k), tv, 1.25 * reach + gapFloor() / kCcdFraction, smin);
        // Already touching or inside (a corner inside, or made so by a topology operation):
        // not bounded, the penalty pushes it out; bounding it at zero would freeze it there.
        if (D > 0 && D < kInf) to.push_back({int(k), t, D});
      }
    };
    // (on several threads over a large surface: runs of triangles, appended in order)
    std::vector<std::vector<TriangleItem>> partItems;
    gatherInParts(tris.size(), partsFor(tris.size(), kTrianglesPerThread), partItems, items, run);
  }
  std::vector<const Pair*> pairsToCheck;
  for (const Pair& p : near) {
    if (p.kind == Kind::PO || p.kind == Kind::FO || !(p.s0 > 0))
      continue;  // (at zero distance: as above)
    // Excluded pairs (new after a cut) have no penalty but are kept apart like the others; at
    // zero distance (the lips themselves) they cannot be, and are left to separate.
    if (p.obstacle < 0 && p.s0 <= P.thickness && excludedPair(closestFeature(p))) continue;
    pairsToCheck.push_back(&p);
  }
  std::vector<V3> dx(disp.size());
  for (std::size_t p = 0; p < disp.size(); ++p) dx[p] = at(p);
  // Points changed in the last round (the pairs that hold one are checked again).
  std::vector<char> moved(disp.size(), 1), movedNext(disp.size(), 0);
  auto touched = [&](const Pair& p) {
    for (int i = 0; i < 4; ++i)
      if (((p.surface >> i) & 1) && moved[p.id[std::size_t(i)]]) return true;
    return false;
  };
  // The frame a pair is bounded in: its obstacle's motion, else its points' common anchor.
  auto frameOf = [&](const Pair& p, bool& common) {
    common = true;
    if (p.obstacle >= 0) return move[std::size_t(p.obstacle)];
    V3 a = V3::Zero();
    bool first = true;
    for (int i = 0; i < 4; ++i) {
      if (!((p.surface >> i) & 1)) continue;
      const V3& b = anchor[p.id[std::size_t(i)]];
      if (first)
        a = b;
      else if (b != a)
        common = false;
      first = false;
    }
    return a;
  };
  // Every point of the pair already moves less than gamma times its distance in the pair's
  // frame: it stays apart.
  auto withinBound = [&](const Pair& p) {
    bool common = true;
    const V3 f = frameOf(p, common);
    if (!common) return false;
    const double b = keepApart(p.s0, gamma);
    for (int i = 0; i < 4; ++i)
      if (((p.surface >> i) & 1) && (dx[p.id[std::size_t(i)]] - f).squaredNorm() > b * b)
        return false;
    return true;
  };
  // A pair's bound on its free points: gamma times its distance, less what its prescribed
  // points (a grasp) travel, which cannot be shortened.
  auto pairBound = [&](const Pair& p, const V3& frame) {
    double lockedMove = 0.0;
    for (int i = 0; i < 4; ++i) {
      const std::uint32_t q = p.id[std::size_t(i)];
      if (((p.surface >> i) & 1) && q < locked.size() && locked[q])
        lockedMove = std::max(lockedMove, (dx[q] - frame).norm());
    }
    return keepApart(p.s0 - lockedMove, gamma);
  };
  // Bounds point p by b in the frame f (a point keeps the first moving frame it is given).
  auto restrict = [&](std::uint32_t p, double b, const V3& f, bool& changed) {
    if (p < locked.size() && locked[p]) return;  // prescribed: it pushes, like a moving obstacle
    bool reframed = false;
    if (f != anchor[p] && anchor[p] == V3::Zero()) {
      anchor[p] = f;
      reframed = true;
      reframedAny = true;
    }
    if (!(b < bound[p]) && !reframed) return;
    bound[p] = std::min(bound[p], b);
    const double l = (disp[p] - anchor[p]).norm();
    const double s = l > bound[p] ? bound[p] / l : 1.0;
    if (reframed || s < scale[p]) {
      scale[p] = reframed ? s : std::min(scale[p], s);
      dx[p] = at(p);
      changed = true;
      movedNext[p] = 1;
    }
  };
  // (The plain bound is repeated until it holds: a point that takes an obstacle's frame
  // changes what its earlier pairs see.)
  for (int round = 0; round < (plain ? 1000 : 8); ++round) {
    bool changed = false;
    for (const Pair* p : pairsToCheck) {
      if (round > 0 && !touched(*p)) continue;  // nothing of it changed since its last check
      const double safe = plain ? 0.0 : withinBound(*p) ? 1.0 : pairSafeFraction(*p, x, dx);
      if (safe >= 1.0) continue;
      bool common = true;
      const V3 f = frameOf(*p, common);
      V3 frame = f;
      if (!common)  // a self pair with a point that goes with an obstacle: all its points do
        for (int i = 0; i < 4; ++i)
          if (((p->surface >> i) & 1) && anchor[p->id[std::size_t(i)]] != V3::Zero())
            frame = anchor[p->id[std::size_t(i)]];
      // Each point keeps the part of its motion the pair provably has (or gamma times the
      // distance, which suffices alone).
      const double b = pairBound(*p, frame);
      for (int i = 0; i < 4; ++i)
        if ((p->surface >> i) & 1) {
          const std::uint32_t q = p->id[std::size_t(i)];
          restrict(q, std::max(b, safe * (dx[q] - frame).norm()), frame, changed);
        }
    }
    for (const TriangleItem& it : items) {
      const auto& T = triV[it.t];
      if (round > 0 && !moved[T[0]] && !moved[T[1]] && !moved[T[2]]) continue;
      const V3& m = move[std::size_t(it.k)];
      if (!plain) {
        const std::array<V3, 3> c0{surfacePoint(x, T[0]), surfacePoint(x, T[1]),
                                   surfacePoint(x, T[2])};
        const double lp =
            std::max({(dx[T[0]] - m).norm(), (dx[T[1]] - m).norm(), (dx[T[2]] - m).norm()});
        const auto dist = [&](double t) {
          // Relative to the obstacle, which moves by `move` over the step.
          const std::array<V3, 3> c{c0[0] + t * (dx[T[0]] - m), c0[1] + t * (dx[T[1]] - m),
                                    c0[2] + t * (dx[T[2]] - m)};
          const double D = triangleObstacleDistance(it.k, c, kInf);
          return D < 0 ? 0.0 : D;
        };
        // From its distance at the start (x and the obstacles' start do not change), unless a
        // displacement is not finite (then measured: not finite, nothing of the step is safe).
        const bool finite = dx[T[0]].allFinite() && dx[T[1]].allFinite() && dx[T[2]].allFinite();
        const double safe =
            finite ? safeFraction(dist, lp, it.D, gapFloor()) : safeFraction(dist, lp, gapFloor());
        if (safe >= 1.0) continue;
        for (std::uint32_t p : T)
          restrict(p, std::max(keepApart(it.D, gamma), safe * (dx[p] - m).norm()), m, changed);
        continue;
      }
      for (std::uint32_t p : T) restrict(p, keepApart(it.D, gamma), m, changed);
    }
    any = any || changed;
    if (!changed) break;
    std::swap(moved, movedNext);
    std::fill(movedNext.begin(), movedNext.end(), 0);
  }
  return any;
}

std::size_t Contact::respondToMovingObstacles(std::span<const double> x0, std::span<double> x1,
                                              std::span<double> v1, double dt,
                                              std::span<const char> constrained) {
  Impl& I = *impl_;
  const std::size_t n = x0.size() / 3;
  const double d = I.P.thickness;
  std::size_t moved = 0;
  for (std::size_t k = 0; k < obstacles_.size(); ++k) {
    const Obstacle& o = obstacles_[k];
    if (!o.moving() || !o.shape->solid() || I.move[k] == V3::Zero()) continue;
    const Vec3 off0{I.startOffset[k][0], I.startOffset[k][1], I.startOffset[k][2]};
    const Vec3 off1{I.offset[k][0], I.offset[k][1], I.offset[k][2]};
    const double mu = o.friction;  // (an obstacle pair's, as the penalty's)
    for (std::size_t p = 0; p < n; ++p) {
      if (!I.topo.isPointAlive(PointId(Index(p)))) continue;
      if (I.pointOwner.size() > p && I.pointOwner[p] < 0) continue;
      if (p < constrained.size() && constrained[p]) continue;
      Vec3 g0, g1;
      const double s0 =
          o.shape->signedDistance({x0[3 * p], x0[3 * p + 1], x0[3 * p + 2]}, off0, g0);
      // (only points the obstacle may reach in the step: within d plus its travel and theirs)
      const V3 step(x1[3 * p] - x0[3 * p], x1[3 * p + 1] - x0[3 * p + 1],
                    x1[3 * p + 2] - x0[3 * p + 2]);
      if (!(s0 > 0) || !(s0 < d + I.move[k].norm() + step.norm())) continue;
      const double s1 =
          o.shape->signedDistance({x1[3 * p], x1[3 * p + 1], x1[3 * p + 2]}, off1, g1);
      // Within the thickness: no closer than at the start; coming in from farther: no closer
      // than the thickness. (Half the thickness, where the law pushes, was tried: the next
      // linearised solve lags behind the obstacle again there, and the rising ball of the tests
      // split 865 times in 210 steps instead of none.)
      const double keep = std::min(s0, d);
      if (!(s1 < keep)) continue;
      const V3 nrm(g1[0], g1[1], g1[2]);
      // The displacement relative to the obstacle.
      const V3 rel = step - I.move[k];
      V3 delta;
      if (s1 > 0 && nrm.dot(V3(g0[0], g0[1], g0[2])) > 0) {
        // Back along the normal at the end by what it lacks, its tangential part reduced by mu
        // times that correction (Coulomb).
        const double push = keep - s1;
        const V3 tangential = rel - rel.dot(nrm) * nrm;
        const double t = tangential.norm();
        delta = push * nrm;
        if (t > 0) delta -= std::min(t, mu * push) / t * tangential;
      } else {
        // It would end inside the obstacle or past its middle (an obstacle that travels more
        // than its half-width in a step), where the normal points to the other side: carried
        // with the obstacle instead, at its start distance (obstacles only translate).
        delta = -rel;
      }
      for (int c = 0; c < 3; ++c) {
        x1[3 * p + std::size_t(c)] += delta[c];
        v1[3 * p + std::size_t(c)] += delta[c] / dt;
      }
      ++moved;
    }
  }
  return moved;
}

std::size_t Contact::limitDisplacement(std::span<const double> x0, std::span<double> x1,
                                       std::span<double> v1, double dt,
                                       std::span<const char> constrained) {
  Impl& I = *impl_;
  const std::size_t n = x0.size() / 3;
  I.updateTables();
  respondToMovingObstacles(x0, x1, v1, dt, constrained);
  // Margins: the proposed displacements. A pair farther apart than its two primitives' largest
  // displacements cannot meet; the others bound their points.
  std::vector<V3> disp(n, V3::Zero());
  for (std::size_t p = 0; p < n; ++p)
    if (I.topo.isPointAlive(PointId(Index(p))))
      disp[p] =
          V3(x1[3 * p] - x0[3 * p], x1[3 * p + 1] - x0[3 * p + 1], x1[3 * p + 2] - x0[3 * p + 2]);
  std::vector<double> scale(n, 1.0);
  I.bound.assign(n, kInf);
  I.anchor.assign(n, V3::Zero());
  auto dxOf = [&](std::size_t p) -> V3 { return I.anchor[p] + scale[p] * (disp[p] - I.anchor[p]); };
  // No point travels more than two mean rest edges in a step (a solve that proposes more is far
  // from the motion it linearised; the step splits): this also keeps the search below local.
  const double travel = 2.0 * I.meanEdge;
  if (travel > 0)
    for (std::size_t p = 0; p < n; ++p) {
      const double l = disp[p].norm();
      if (l > travel && !(p < constrained.size() && constrained[p])) {
        scale[p] = travel / l;
        I.bound[p] = travel;
      }
    }
  // The obstacles from where they start the step, moving by `move` along it (the penalty took
  // them where they end it).
  const std::vector<V3> endOffset = I.offset;
  I.offset = I.startOffset;
  // Two primitives cannot meet when they are farther apart than how far their points move
  // relative to each other (reachOf). Shortening a displacement changes the relative motions:
  // the pairs are found again for the shortened displacements until a pass changes nothing. The
  // last resort takes each primitive's whole displacement as its reach (which shortening keeps
  // valid), bounds every pair it finds, and repeats until it changes nothing.
  const int passes = 5;
  int lastRepeats = 0;
  for (int pass = 0; pass <= passes; ++pass) {
    const bool last = pass == passes;
    // The search: boxes swept along the displacements (obstacle meshes grown by their motion),
    // pairs within their reach.
    std::vector<V3>& dx = I.sweptMotion;
    dx.resize(n);
    for (std::size_t p = 0; p < n; ++p) dx[p] = dxOf(p);
    I.obstacleMargin.assign(obstacles_.size(), 0.0);
    for (std::size_t k = 0; k < obstacles_.size(); ++k)
      I.obstacleMargin[k] = I.move[k].norm() + 1e-9 * I.meanEdge + I.gapFloor();
    std::vector<Pair>& near = I.nearPairs;
    near.clear();
    I.sweep = &dx;
    I.absoluteReach = last;
    // From the search's cache when it holds every pair within reach (a pair's distance changes
    // by at most 4 times the largest displacement), else by swept boxes.
    // A point is slow when it has moved less than a quarter of the cache's reach since the
    // cache was built, displacement (doubled) included: a pair of slow points that the cache
    // does not hold was at least cacheR apart then, and cannot meet now. The pairs that hold a
    // fast point are searched by swept boxes, from the fast points' triangles.
    std::vector<double> none(obstacles_.size(), 0.0);
    std::vector<char>& fast = I.fastPoint;
    fast.assign(n, 1);
    bool cached = I.cacheCovers(x0, 0.0, none);
    std::size_t fastCount = 0;
    if (cached) {
      for (std::size_t p = 0; p < n; ++p) {
        fast[p] = !(I.sinceCache[p] + 2 * dx[p].norm() < 0.25 * I.cacheR);
        fastCount += fast[p] && I.pointOwner.size() > p && I.pointOwner[p] >= 0;
      }
      for (std::size_t k = 0; k < obstacles_.size(); ++k)
        if (I.meshLike(k) && !(I.obstacleSinceCache[k] + 2 * I.move[k].norm() < 0.25 * I.cacheR))
          cached = false;
      if (10 * fastCount > n) cached = false;  // (then one search is cheaper)
    }
    if (cached) {
      I.nearFromCache(x0, fast, near);
      if (fastCount > 0) {
        I.prepareSwept(x0, dx);
        I.searchAround(x0, fast, near);
      }
    } else {
      I.prepareSwept(x0, dx);
      I.searchPairs(x0, near, false);
    }
    I.sweep = nullptr;
    I.absoluteReach = false;
    if (!I.limit(x0, near, disp, constrained, parameters_.displacementFraction, scale, last)) break;
    // The last resort searches again until it changes nothing: a point that took an obstacle's
    // frame may move farther than it was searched with, and a shortened motion changes the
    // displacement a frame's point ends with.
    if (last && ++lastRepeats < 100) --pass;
  }
  I.offset = endOffset;
  std::size_t clamped = 0;
  for (std::size_t p = 0; p < n; ++p) {
    const V3 dx = dxOf(p);
    if (dx == disp[p]) continue;
    for (int c = 0; c < 3; ++c) {
      x1[3 * p + std::size_t(c)] = x0[3 * p + std::size_t(c)] + dx[c];
      v1[3 * p + std::size_t(c)] = dx[c] / dt;
    }
    ++clamped;
  }
  return clamped;
}

}  // namespace cutsim::forcefields
