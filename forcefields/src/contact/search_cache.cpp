// The search's cache (a Verlet list): its build, its cover test, the pairs from it, and the
// displacement bound's pairs among slow points from it
// (contact_impl.hpp).
#include "contact_impl.hpp"

namespace cutsim::forcefields {

void Contact::Impl::nearFromCache(std::span<const double> x, const std::vector<char>& fast,
                                  std::vector<Pair>& out) {
  // (a pair's reach is at most twice its points' largest displacement, doubled)
  moveLength.resize(sweep->size());
  double largest =
      0.0;  // of every point's and obstacle's displacement (infinity: one is not finite)
  bool finite = true;
  for (std::size_t p = 0; p < sweep->size(); ++p) {
    moveLength[p] = (*sweep)[p].norm();
    finite = finite && std::isfinite(moveLength[p]);
    largest = std::max(largest, moveLength[p]);
  }
  for (const V3& m : move) {
    finite = finite && std::isfinite(m.norm());
    largest = std::max(largest, m.norm());
  }
  if (!finite) largest = kInf;
  const double shrink = 2 * largestSinceCache;
  auto visit = [&](std::size_t ci, std::vector<Pair>& to) {
    const Cached& c = cache[ci];
    bool slow = true;
    double largestMove = 0.0;
    for (int i = 0; i < 4; ++i) {
      if ((c.surface >> i) & 1) {
        const std::uint32_t q = c.id[std::size_t(i)];
        slow = slow && !fast[q];
        largestMove = std::max(largestMove, moveLength[q]);
      } else if (c.obstacle >= 0) {
        largestMove = std::max(largestMove, move[std::size_t(c.obstacle)].norm());
      }
    }
    if (!slow) return;  // (found around the fast points)
    const double lower = c.s - cachedShrink(c);
    if (lower >= 4 * largestMove + gapFloor()) return;
    const Pair p = c.pair();
    const double reach = reachOf(p);
    if (lower < reach) keepIfNear(p, x, reach, to);
  };
  // (visited on several threads when there are many: runs of the visits, their pairs
  // appended in order, as one thread would have found them)
  // A pair is skipped below when its distance less its shrink is at least four times its
  // points' largest motion, plus the floor. Every pair is at least cacheNearest apart at the
  // cache's build: when only a few points move more than a quarter of cacheNearest - shrink (and no
  // obstacle does), only their pairs can pass, and they are visited (in the cache's order, as the
  // whole pass would).
  const double still = 0.25 * (cacheNearest - shrink - gapFloor());
  bool obstaclesStill = true;
  for (const V3& m : move) obstaclesStill = obstaclesStill && m.norm() <= still;
  std::vector<std::uint32_t>& moving = movingScratch;
  moving.clear();
  // (the index covers the points of the cache's pairs; a point beyond it is in none)
  const bool indexed = still > 0 && obstaclesStill && !cacheByPointStart.empty() &&
                       cacheByPointStart.size() <= moveLength.size() + 1;
  if (indexed)
    for (std::size_t p = 0; p + 1 < cacheByPointStart.size(); ++p)
      if (!(moveLength[p] <= still)) moving.push_back(std::uint32_t(p));
  if (indexed && 16 * moving.size() < moveLength.size()) {
    std::vector<std::uint32_t>& visits = visitScratch;
    ascendingOnce(cache.size(), recordBits, visits, [&](auto&& mark) {
      for (const std::uint32_t p : moving)
        for (std::uint32_t k = cacheByPointStart[p]; k < cacheByPointStart[p + 1]; ++k)
          mark(cacheByPoint[k]);
    });
    gatherInParts(visits.size(), partsFor(visits.size(), kRecordsPerThread), partPairs, out,
                  [&](std::size_t begin, std::size_t end, std::vector<Pair>& to) {
                    for (std::size_t k = begin; k < end; ++k)
                      if (!(double(cacheLow[visits[k]]) - shrink >= 4 * largest + gapFloor()))
                        visit(visits[k], to);
                  });
    return;
  }
  gatherInParts(cache.size(), partsFor(cache.size(), kRecordsPerThread), partPairs, out,
                [&](std::size_t begin, std::size_t end, std::vector<Pair>& to) {
                  for (std::size_t ci = begin; ci < end; ++ci) {
                    if (double(cacheLow[ci]) - shrink >= 4 * largest + gapFloor())
                      continue;  // (the test below, with bounds for every pair)
                    visit(ci, to);
                  }
                });
}

bool Contact::Impl::cacheCovers(std::span<const double> x, double rSelf,
                                const std::vector<double>& rObstacle) {
  if (!(P.searchSlack > 0) || !cacheBuilt || cacheRevision != topo.revision() ||
      cacheX.size() != x.size())
    return false;
  const std::size_t n = x.size() / 3;
  sinceCache.assign(n, 0.0);
  double m = 0.0;
  for (std::size_t p = 0; p < n; ++p)
    if (p < pointOwner.size() && pointOwner[p] >= 0) {
      sinceCache[p] =
          (surfacePoint(x, std::uint32_t(p)) - surfacePoint(cacheX, std::uint32_t(p))).norm();
      m = std::max(m, sinceCache[p]);
    }
  if (!(m < kInf)) return false;
  if (P.selfContact && !(cacheR - 2 * m >= rSelf)) return false;
  obstacleSinceCache.assign(O.size(), 0.0);
  largestSinceCache = m;
  for (std::size_t k = 0; k < O.size(); ++k) {
    if (!meshLike(k)) continue;
    obstacleSinceCache[k] = (offset[k] - cacheOffset[k]).norm();
    largestSinceCache = std::max(largestSinceCache, obstacleSinceCache[k]);
    if (!(cacheR - m - obstacleSinceCache[k] >= rObstacle[k])) return false;
  }
  return true;
}

void Contact::Impl::buildCache(std::span<const double> x, double r) {
  const std::vector<double> savedPoint = pointMargin, savedObstacle = obstacleMargin;
  pointMargin.assign(x.size() / 3, 0.5 * r);
  obstacleMargin.assign(O.size(), 0.5 * r);
  prepare(x);
  cache.clear();
  cacheBuilt = false;
  cacheOut = &cache;
  try {
    searchPairs(x, nearPairs, false);
  } catch (...) {
    cacheOut = nullptr;
    cache.clear();
    pointMargin = savedPoint;
    obstacleMargin = savedObstacle;
    throw;
  }
  cacheOut = nullptr;
  pointMargin = savedPoint;
  obstacleMargin = savedObstacle;
  triangleMargins();
  indexCache();
  cacheX.assign(x.begin(), x.end());
  cacheOffset = offset;
  cacheRevision = topo.revision();
  cacheR = r;
  cacheBuilt = true;
  ++cacheBuilds;
}

void Contact::Impl::indexCache() {
  apartIndexed = false;
  cacheEdgePairs = std::size_t(std::count_if(cache.begin(), cache.end(),
                                             [](const Cached& c) { return c.kind == Kind::EE; }));
  cacheLow.resize(cache.size());
  cacheNearest = kInf;
  for (std::size_t i = 0; i < cache.size(); ++i) {
    float f = float(cache[i].s);
    if (double(f) > cache[i].s) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
    cacheLow[i] = f;
    cacheNearest = std::min(cacheNearest, double(f));
  }
  std::size_t n = 0;
  for (const Cached& c : cache)
    for (int i = 0; i < 4; ++i)
      if (((c.surface >> i) & 1) && c.id[std::size_t(i)] != std::uint32_t(kInvalidIndex))
        n = std::max<std::size_t>(n, c.id[std::size_t(i)] + 1);
  cacheByPointStart.assign(n + 1, 0);
  for (const Cached& c : cache)
    for (int i = 0; i < 4; ++i)
      if (((c.surface >> i) & 1) && c.id[std::size_t(i)] != std::uint32_t(kInvalidIndex))
        ++cacheByPointStart[c.id[std::size_t(i)] + 1];
  for (std::size_t p = 0; p < n; ++p) cacheByPointStart[p + 1] += cacheByPointStart[p];
  cacheByPoint.resize(cacheByPointStart.back());
  std::vector<std::uint32_t> fill(cacheByPointStart.begin(), cacheByPointStart.end() - 1);
  for (std::size_t ci = 0; ci < cache.size(); ++ci)
    for (int i = 0; i < 4; ++i)
      if (((cache[ci].surface >> i) & 1) &&
          cache[ci].id[std::size_t(i)] != std::uint32_t(kInvalidIndex))
        cacheByPoint[fill[cache[ci].id[std::size_t(i)]]++] = std::uint32_t(ci);
}

double Contact::Impl::cachedShrink(const Cached& c) const {
  // (the cache holds whole primitives: four points each)
  const int split = (c.kind == Kind::EE || c.kind == Kind::EO) ? 2 : 1;
  double a = 0, b = 0;
  for (int i = 0; i < 4; ++i) {
    const double m = (c.surface >> i) & 1 ? sinceCache[c.id[std::size_t(i)]]
                                          : obstacleSinceCache[std::size_t(c.obstacle)];
    (i < split ? a : b) = std::max(i < split ? a : b, m);
  }
  return a + b;
}

void Contact::Impl::pairsFromCache(std::span<const double> x, std::vector<Pair>& out) {
  // Between flat layers most cached pairs are of two edges that are both flat, whose triangles
  // share no point (their share is 0: edgePairScale drops them). Such a pair is not read at
  // all: of the apart pairs of two edges (markApart), only the records of the edges that are
  // not flat now (flatness below exactly 1) are visited.
  const bool flatFirst = cacheEdgePairs > 0 && !edgeFlat.empty() && flatRevision == revision;
  if (!flatFirst) {
    gatherInParts(cache.size(), partsFor(cache.size(), kRecordsPerThread), partPairs, out,
                  [&](std::size_t begin, std::size_t end, std::vector<Pair>& to) {
                    for (std::size_t ci = begin; ci < end; ++ci) classifyCached(ci, x, to);
                  });
    return;
  }
  if (!apartIndexed) markApart();
  // The records visited, ascending: every record but the apart edge pairs (cacheOthers), and
  // those apart edge pairs that hold an edge that is not flat now.
  measureCacheFlatness(x, partsFor(cacheEdges.size(), kRecordsPerThread));
  ascendingOnce(cache.size(), recordBits, cacheVisitExtra, [&](auto&& mark) {
    for (const std::uint32_t e : apartEdges)
      if (flatnessOf(e, x) != 1.0)
        for (std::uint32_t k = apartByEdgeStart[e]; k < apartByEdgeStart[e + 1]; ++k)
          mark(apartByEdge[k]);
  });
  cacheVisit.resize(cacheOthers.size() + cacheVisitExtra.size());
  std::merge(cacheOthers.begin(), cacheOthers.end(), cacheVisitExtra.begin(), cacheVisitExtra.end(),
             cacheVisit.begin());
  gatherInParts(cacheVisit.size(), partsFor(cacheVisit.size(), kRecordsPerThread), partPairs, out,
                [&](std::size_t begin, std::size_t end, std::vector<Pair>& to) {
                  for (std::size_t k = begin; k < end; ++k) classifyCached(cacheVisit[k], x, to);
                });
}

void Contact::Impl::classifyCached(std::size_t ci, std::span<const double> x,
                                   std::vector<Pair>& to) const {
  const Cached& c = cache[ci];
  const double within = searchMargin(c);
  // (it cannot be within its margin; the shrink is at most twice the largest motion)
  if (c.s >= within && (c.s - 2 * largestSinceCache >= within || c.s - cachedShrink(c) >= within))
    return;
  Pair p = c.pair();
  if (c.kind == Kind::EE && !((p.scale = edgePairScale(p.edges, x)) > 0))
    return;  // (as keepIfNear would)
  const int t =
      c.kind == Kind::EE ? -1 : c.tri;  // (an edge pair's record holds its first edge there)
  Screen screen;
  if (surelyDropped(c.kind, c.surface, c.obstacle, c.id, 3, x, t, &screen)) return;
  keepIfNear(p, x, within, to, true, t, &screen);
}

void Contact::Impl::markApart() {
  std::vector<std::uint8_t> apart(cache.size(), 0);
  cacheEdges.clear();
  for (const Cached& c : cache)
    if (c.kind == Kind::EE) {
      cacheEdges.push_back(std::uint32_t(c.tri));
      cacheEdges.push_back(std::uint32_t(c.edge2));
    }
  std::sort(cacheEdges.begin(), cacheEdges.end());
  cacheEdges.erase(std::unique(cacheEdges.begin(), cacheEdges.end()), cacheEdges.end());
  cacheOthers.clear();
  apartByEdgeStart.assign(edgeTris.size() + 1, 0);
  for (std::size_t ci = 0; ci < cache.size(); ++ci) {
    const Cached& c = cache[ci];
    if (c.kind == Kind::EE) apart[ci] = edgesApart(c.tri, c.edge2);
    if (!apart[ci]) {
      cacheOthers.push_back(std::uint32_t(ci));
      continue;
    }
    ++apartByEdgeStart[std::size_t(c.tri) + 1];
    ++apartByEdgeStart[std::size_t(c.edge2) + 1];
  }
  apartEdges.clear();
  for (std::size_t e = 0; e + 1 < apartByEdgeStart.size(); ++e) {
    if (apartByEdgeStart[e + 1] > 0) apartEdges.push_back(std::uint32_t(e));
    apartByEdgeStart[e + 1] += apartByEdgeStart[e];
  }
  apartByEdge.resize(apartByEdgeStart.back());
  std::vector<std::uint32_t> fill(apartByEdgeStart.begin(), apartByEdgeStart.end() - 1);
  for (std::size_t ci = 0; ci < cache.size(); ++ci)
    if (apart[ci]) {
      apartByEdge[fill[std::size_t(cache[ci].tri)]++] = std::uint32_t(ci);
      apartByEdge[fill[std::size_t(cache[ci].edge2)]++] = std::uint32_t(ci);
    }
  apartIndexed = true;
}

void Contact::Impl::measureCacheFlatness(std::span<const double> x, int parts) const {
  if (edgeFlat.empty() || flatRevision != revision) return;
  inParts(cacheEdges.size(), parts, [&](int, std::size_t begin, std::size_t end) {
    for (std::size_t k = begin; k < end; ++k) {
      const std::uint32_t e = cacheEdges[k];
      if (e < edgeFlat.size() && edgeFlat[e].stamp != flatGeneration) measureFlatness(e, x);
    }
  });
}

}  // namespace cutsim::forcefields
