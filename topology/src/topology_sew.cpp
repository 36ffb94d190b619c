// Sewing: lips joined back into one surface where they meet in the world, the reverse of a cut.
// See Topology::sew and "Sewing" in docs/topology-events.md.
#include <CGAL/boost/graph/Euler_operations.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <unordered_set>

#include "cutsim/topology/geometry.hpp"
#include "topology_impl.hpp"

namespace cutsim::topology {

namespace {

using geometry::dot;
using geometry::sub;
double dist(const Vec3& a, const Vec3& b) {
  return std::sqrt(geometry::dist2(a, b));
}

/// A lip point is put on the other lip's edge only where its foot is at least this fraction of
/// the edge from either end.
constexpr double kSplitFrom = 0.2;
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}
std::string pt(std::size_t i) {
  return std::to_string(i);
}

/// Uniform hash grid of segments' boxes (grown by a margin), for the lips' edges near a point.
class SegmentGrid {
 public:
  SegmentGrid(double cell) : cell_(cell) {}
  void insert(std::size_t id, const Vec3& a, const Vec3& b, double margin) {
    long lo[3], hi[3];
    for (int c = 0; c < 3; ++c) {
      lo[c] = cellOf(std::min(a[c], b[c]) - margin);
      hi[c] = cellOf(std::max(a[c], b[c]) + margin);
    }
    for (long i = lo[0]; i <= hi[0]; ++i)
      for (long j = lo[1]; j <= hi[1]; ++j)
        for (long k = lo[2]; k <= hi[2]; ++k) cells_[key(i, j, k)].push_back(id);
  }
  /// The segments whose grown box holds p (may repeat none: each cell lists a segment once, and
  /// p lies in one cell).
  const std::vector<std::size_t>& at(const Vec3& p) const {
    static const std::vector<std::size_t> none;
    auto it = cells_.find(key(cellOf(p[0]), cellOf(p[1]), cellOf(p[2])));
    return it == cells_.end() ? none : it->second;
  }

 private:
  long cellOf(double v) const { return long(std::floor(v / cell_)); }
  static std::uint64_t key(long i, long j, long k) {
    auto u = [](long v) { return std::uint64_t(v) & 0x1FFFFF; };
    return (u(i) << 42) | (u(j) << 21) | u(k);
  }
  double cell_;
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> cells_;
};

}  // namespace

SewResult Topology::sew(std::span<const double> positions, const SewOptions& options) {
  Impl& I = *impl_;
  const double tol = options.tolerance;
  if (!(tol > 0) || !std::isfinite(tol))
    throw TopologyError("sew: the tolerance " + num(tol) + " must be a positive distance");
  if (positions.size() < 3 * std::size_t(I.mesh.num_vertices()))
    throw TopologyError("sew: " + pt(positions.size() / 3) + " positions given for " +
                        pt(I.mesh.num_vertices()) + " point slots");
  checkRepairOptions(options.repair, "sew");
  std::unordered_set<Index> locked, preferred;
  for (PointId p : options.locked) locked.insert(p.idx());
  for (PointId p : options.preferred) preferred.insert(p.idx());

  return I.committed(*this, "sew", [&] {
    Mesh& mesh = I.mesh;
    SewResult result;
    // Where a point is now: given for the points that existed before; for a point inserted by
    // this transaction, the same weights of its ancestors' positions.
    auto world = [&](VI v) -> Vec3 {
      auto at = [&](Index p) {
        return Vec3{positions[3 * p], positions[3 * p + 1], positions[3 * p + 2]};
      };
      if (v.idx() < I.vBefore) return at(v.idx());
      Vec3 out{0, 0, 0};
      for (auto [a, w] : I.ancestry.at(PointId(v.idx()))) {
        Vec3 q = at(a.idx());
        for (int c = 0; c < 3; ++c) out[c] += w * q[c];
      }
      return out;
    };
    // A point this sew inserted lies on a lip that takes part: `within` is not asked about it.
    auto taking = [&](VI v) {
      return !options.within || v.idx() >= I.vBefore || options.within(PointId(v.idx()));
    };

    // The lips: border halfedges (no face; their opposite has one) with both ends taking part.
    struct Lip {
      HI h;
      VI u, v;      // source, target
      Vec3 a, b;    // where they are
      Vec3 inward;  // towards the triangle across, perpendicular to the edge
    };
    auto lips = [&] {
      std::vector<Lip> out;
      for (HI h : mesh.halfedges()) {
        if (!mesh.is_border(h)) continue;
        VI u = mesh.source(h), v = mesh.target(h);
        if (!taking(u) || !taking(v)) continue;
        Lip l{h, u, v, world(u), world(v), {0, 0, 0}};
        for (const Vec3& q : {l.a, l.b})
          for (double c : q)
            if (!std::isfinite(c))
              throw TopologyError("sew: the position of point " + pt(l.u.idx()) + " or " +
                                  pt(l.v.idx()) + " is not finite");
        const Vec3 c = world(mesh.target(mesh.next(mesh.opposite(h))));
        const Vec3 d = sub(l.b, l.a),
                   m{(l.a[0] + l.b[0]) / 2, (l.a[1] + l.b[1]) / 2, (l.a[2] + l.b[2]) / 2};
        Vec3 w = sub(c, m);
        const double dd = dot(d, d);
        if (dd > 0) {
          const double along = dot(w, d) / dd;
          for (int k = 0; k < 3; ++k) w[k] -= along * d[k];
        }
        l.inward = w;
        out.push_back(l);
      }
      return out;
    };
    auto gridOf = [&](const std::vector<Lip>& ls) {
      double mean = 0;
      for (const Lip& l : ls) mean += dist(l.a, l.b);
      mean = ls.empty() ? tol : mean / double(ls.size());
      SegmentGrid g(std::max(2 * tol, mean));
      for (std::size_t i = 0; i < ls.size(); ++i) g.insert(i, ls[i].a, ls[i].b, tol);
      return g;
    };
    // Two lips face each other: they run in opposite directions, their triangles on either side.
    auto facing = [](const Lip& p, const Lip& q) {
      return dot(sub(p.b, p.a), sub(q.b, q.a)) < 0 && dot(p.inward, q.inward) < 0;
    };

    // 1. A lip point facing the middle of the other lip's edge (its foot at least a fifth of the
    //    edge from either end: nearer an end, a split would make an edge too short for any
    //    triangle to be well shaped, and the end is its partner), no end of that edge within the
    //    tolerance, becomes a point of that edge (one split per edge and round).
    for (int round = 0; round < 16; ++round) {
      const std::vector<Lip> ls = lips();
      const SegmentGrid grid = gridOf(ls);
      std::map<std::size_t, std::pair<double, double>> splits;  // lip -> (distance, parameter)
      std::unordered_map<std::uint32_t, std::size_t> lipOf;     // halfedge -> lip
      for (std::size_t i = 0; i < ls.size(); ++i) lipOf[ls[i].h.idx()] = i;
      for (std::size_t i = 0; i < ls.size(); ++i) {
        // The lip point ls[i].u, with its two lips: ls[i] (out) and the one into it (in, where
        // the lip turns it may face the other lip when the one out does not).
        const Lip& out = ls[i];
        const auto in = lipOf.find(mesh.prev(out.h).idx());
        const Vec3 p = out.a;
        for (std::size_t j : grid.at(p)) {
          const Lip& q = ls[j];
          if (q.u == out.u || q.v == out.u) continue;
          if (!facing(out, q) && (in == lipOf.end() || !facing(ls[in->second], q))) continue;
          const Vec3 d = sub(q.b, q.a);
          const double dd = dot(d, d);
          if (!(dd > 0)) continue;
          const double s = std::clamp(dot(sub(p, q.a), d) / dd, 0.0, 1.0);
          const Vec3 c{q.a[0] + s * d[0], q.a[1] + s * d[1], q.a[2] + s * d[2]};
          const double e = dist(p, c);
          if (e > tol || dist(p, q.a) <= tol || dist(p, q.b) <= tol) continue;
          if (s < kSplitFrom || s > 1 - kSplitFrom) continue;
          auto [it, fresh] = splits.emplace(j, std::make_pair(e, s));
          if (!fresh && e < it->second.first) it->second = {e, s};
        }
      }
      if (splits.empty()) break;
      for (const auto& [j, ds] : splits) {
        // (An earlier split this round may have made the lip's edge again, around a triangle
        // with two lips: found by its ends.)
        const HI h = I.findHalfedge(ls[j].u, ls[j].v);
        if (!h.is_valid() || !mesh.is_border(h)) continue;
        VI m = I.splitEdgeNoTxn(mesh.edge(h), ls[j].u, ds.second);
        ++result.splits;
        result.inserted.push_back(PointId(m.idx()));
      }
    }

    // 2. Pairs of facing lips whose ends meet within the tolerance: first those that are the two
    //    copies a cut made of one edge (their ends at the same rest positions: sewn, the material
    //    is as it was), then the others, each the closest first.
    const std::vector<Lip> ls = lips();
    const SegmentGrid grid = gridOf(ls);
    struct Pair {
      bool copies;
      double gap;
      std::size_t p, q;
    };
    std::vector<Pair> pairs;
    for (std::size_t i = 0; i < ls.size(); ++i)
      for (std::size_t j : grid.at(ls[i].b)) {
        if (j <= i) continue;
        const Lip &p = ls[i], &q = ls[j];
        const double gap = std::max(dist(p.b, q.a), dist(p.a, q.b));
        const bool copies =
            mesh.point(p.v) == mesh.point(q.u) && mesh.point(p.u) == mesh.point(q.v);
        if (gap <= tol && facing(p, q)) pairs.push_back({copies, gap, i, j});
      }
    std::sort(pairs.begin(), pairs.end(), [](const Pair& x, const Pair& y) {
      if (x.copies != y.copies) return x.copies;
      return x.gap != y.gap ? x.gap < y.gap : std::make_pair(x.p, x.q) < std::make_pair(y.p, y.q);
    });
    // Taken one by one, the closest first: a pair joins the groups of its lips' points facing
    // each other at either end, unless that would join two points of one edge (lips whose edges
    // are shorter than the gap between them) or leave the surface non-manifold (lips that cross
    // each other), which leaves it open.
    std::vector<VI> members;
    std::unordered_map<Index, std::size_t> slot;
    auto slotOf = [&](VI v) {
      auto [it, fresh] = slot.emplace(v.idx(), members.size());
      if (fresh) members.push_back(v);
      return it->second;
    };
    std::vector<std::size_t> parent;
    std::unordered_map<std::size_t, std::vector<std::size_t>> inGroup;  // root -> its slots
    auto root = [&](std::size_t i) {
      while (parent[i] != i) i = parent[i] = parent[parent[i]];
      return i;
    };
    auto grow = [&] {
      while (parent.size() < members.size()) {
        inGroup[parent.size()] = {parent.size()};
        parent.push_back(parent.size());
      }
    };
    // The slots two groups would make together, and whether an edge joins two of them.
    auto together = [&](std::size_t a, std::size_t b) {
      std::vector<std::size_t> out = inGroup[root(a)];
      if (root(a) != root(b)) {
        const auto& other = inGroup[root(b)];
        out.insert(out.end(), other.begin(), other.end());
      }
      return out;
    };
    // Whether `group` may become one point, `other` another at the same time: no edge joins two
    // of its points (it would collapse), and the edges from it to each other point or group
    // (which become one edge) hold one triangle on either side at most between them (else a
    // triangle would repeat, an edge join three or two triangles face opposite ways).
    auto fits = [&](const std::vector<std::size_t>& group, const std::vector<std::size_t>& other) {
      std::unordered_set<Index> mine, theirs;
      for (std::size_t i : group) mine.insert(members[i].idx());
      for (std::size_t i : other) theirs.insert(members[i].idx());
      // Held points join only the copies of themselves (the same rest position).
      const VI* held = nullptr;
      for (std::size_t i : group)
        if (locked.count(members[i].idx())) {
          if (held && mesh.point(*held) != mesh.point(members[i])) return false;
          held = &members[i];
        }
      // neighbour (a group or a point) -> triangles on the edges into the group, out of it
      std::unordered_map<std::uint64_t, std::array<int, 2>> faces;
      std::vector<HI> in;
      for (std::size_t i : group) {
        in.clear();
        I.incomingHalfedges(members[i], in);
        for (HI h : in) {
          const VI n = mesh.source(h);
          if (mine.count(n.idx())) return false;
          std::uint64_t key;
          if (theirs.count(n.idx()))
            key = std::uint64_t(1) << 63;
          else if (auto it = slot.find(n.idx()); it != slot.end() && it->second < parent.size())
            key = (std::uint64_t(1) << 62) | root(it->second);
          else
            key = n.idx();
          auto& f = faces[key];
          f[0] += mesh.face(h).is_valid() ? 1 : 0;
          f[1] += mesh.face(mesh.opposite(h)).is_valid() ? 1 : 0;
          if (f[0] > 1 || f[1] > 1) return false;
        }
      }
      return true;
    };
    std::vector<char> used(ls.size(), 0);
    std::vector<Pair> joined;
    std::size_t refused = 0;
    for (const Pair& pr : pairs) {
      if (used[pr.p] || used[pr.q]) continue;
      const std::size_t a1 = slotOf(ls[pr.p].v), b1 = slotOf(ls[pr.q].u);
      const std::size_t a2 = slotOf(ls[pr.p].u), b2 = slotOf(ls[pr.q].v);
      grow();
      const std::vector<std::size_t> s1 = together(a1, b1), s2 = together(a2, b2);
      bool overlap = false;
      for (std::size_t i : s1) overlap = overlap || root(i) == root(a2) || root(i) == root(b2);
      if (overlap || !fits(s1, s2) || !fits(s2, s1)) {
        ++refused;
        continue;
      }
      for (auto [x, y] : {std::make_pair(a1, b1), std::make_pair(a2, b2)}) {
        std::size_t rx = root(x), ry = root(y);
        if (rx == ry) continue;
        if (ry < rx) std::swap(rx, ry);
        parent[ry] = rx;
        auto& into = inGroup[rx];
        const auto& from = inGroup[ry];
        into.insert(into.end(), from.begin(), from.end());
        inGroup.erase(ry);
      }
      used[pr.p] = used[pr.q] = 1;
      joined.push_back(pr);
      result.largestGap = std::max(result.largestGap, pr.gap);
    }
    result.edgesLeftOpen = refused;
    if (joined.empty() && refused > 0)
      throw TopologyError("sew: the lips within the tolerance " + num(tol) +
                          " of each other cannot be joined without joining both ends of an "
                          "edge or leaving the surface non-manifold: the tolerance is not small "
                          "beside the lips' edges there, or the lips cross");
    if (joined.empty()) {
      // Say how far apart the closest facing lips are.
      double best = std::numeric_limits<double>::infinity();
      std::size_t bp = 0, bq = 0;
      for (std::size_t i = 0; i < ls.size(); ++i)
        for (std::size_t j = i + 1; j < ls.size(); ++j) {
          if (!facing(ls[i], ls[j]) || ls[i].v == ls[j].v || ls[i].u == ls[j].u) continue;
          const double gap = std::max(dist(ls[i].b, ls[j].a), dist(ls[i].a, ls[j].b));
          if (gap < best) best = gap, bp = i, bq = j;
        }
      if (!std::isfinite(best))
        throw TopologyError("sew: there are no two facing lips" +
                            std::string(options.within ? " where the sew takes part" : "") +
                            " (border edges running opposite ways, their triangles on either "
                            "side)");
      const Vec3 m = ls[bp].a;
      throw TopologyError("sew: no lips lie within the tolerance " + num(tol) +
                          " of each other: the closest facing border edges, (" +
                          pt(ls[bp].u.idx()) + ", " + pt(ls[bp].v.idx()) + ") and (" +
                          pt(ls[bq].u.idx()) + ", " + pt(ls[bq].v.idx()) + ") near (" + num(m[0]) +
                          ", " + num(m[1]) + ", " + num(m[2]) + "), are " + num(best) + " apart");
    }
    result.edgesJoined = joined.size();

    // 3. The groups of points to join.
    std::map<std::size_t, std::vector<VI>> byRoot;
    for (std::size_t i = 0; i < members.size(); ++i) byRoot[root(i)].push_back(members[i]);

    std::unordered_map<std::uint64_t, VI> subst;
    std::vector<FI> affected;
    std::vector<std::pair<VI, std::size_t>> expect;  // joined point, triangles it must have
    std::vector<VI> seeds;
    for (auto& [root, group] : byRoot) {
      if (group.size() < 2) continue;
      std::sort(group.begin(), group.end());
      for (std::size_t a = 0; a < group.size(); ++a)
        for (std::size_t b = a + 1; b < group.size(); ++b)
          if (I.findHalfedge(group[a], group[b]).is_valid())
            throw TopologyError("sew: joining the lips would join both ends of the edge (" +
                                pt(group[a].idx()) + ", " + pt(group[b].idx()) +
                                "): the tolerance " + num(tol) +
                                " is not small beside the lips' edges there");
      VI keep;
      std::vector<VI> held;
      for (VI v : group)
        if (locked.count(v.idx())) held.push_back(v);
      bool sameRest = true;
      for (VI v : group) sameRest = sameRest && mesh.point(v) == mesh.point(group.front());
      if (!held.empty()) {
        keep = held.front();
      } else if (sameRest) {
        keep = group.front();
        for (VI v : group)
          if (preferred.count(v.idx())) {
            keep = v;
            break;
          }
      } else {
        std::vector<std::pair<PointId, double>> anc;
        for (VI v : group) anc.emplace_back(PointId(v.idx()), 1.0 / double(group.size()));
        keep = I.newPoint(anc);
      }
      std::size_t triangles = 0;
      for (VI v : group) {
        std::vector<HI> in;
        I.incomingHalfedges(v, in);
        for (HI h : in)
          if (FI f = mesh.face(h); f.is_valid()) {
            ++triangles;
            if (v != keep) {
              subst[Impl::faceVertexKey(f, v)] = keep;
              affected.push_back(f);
            }
          }
        if (v != keep) ++result.pointsRemoved;
      }
      expect.emplace_back(keep, triangles);
      seeds.push_back(keep);
      SewResult::Group g{PointId(keep.idx()), {}};
      for (VI v : group) g.points.push_back(PointId(v.idx()));
      result.groups.push_back(std::move(g));
    }
    std::sort(affected.begin(), affected.end());
    affected.erase(std::unique(affected.begin(), affected.end()), affected.end());
    try {
      I.reattach(affected, subst);
    } catch (const InjectedFailure&) {
      throw;
    } catch (const TopologyError&) {
      throw TopologyError(
          "sew: the lips cannot be joined there without leaving the surface non-manifold (a "
          "triangle would repeat or an edge join three)");
    }
    // A joined point must not hold two pieces together at a corner only (a bowtie): every
    // triangle it belongs to in the one fan around it, one border gap at most.
    for (auto [v, triangles] : expect) {
      std::vector<HI> in;
      I.incomingHalfedges(v, in);
      std::size_t n = 0, gaps = 0;
      for (HI h : in) {
        n += mesh.face(h).is_valid() ? 1 : 0;
        gaps += mesh.is_border(h) ? 1 : 0;
      }
      if (n != triangles || gaps > 1) {
        const Vec3 w = world(v);
        throw TopologyError("sew: joining the lips near (" + num(w[0]) + ", " + num(w[1]) + ", " +
                            num(w[2]) +
                            ") would leave two pieces touching at a single point: sew more of "
                            "the seam at once, or less");
      }
    }

    // 4. The quality repair around the seam.
    if (options.repair.minAngle > 0) {
      RepairOptions repair = options.repair;
      for (PointId p : options.locked) repair.locked.push_back(p);
      std::unordered_map<Index, Index> replaced;
      result.repair = I.repairNoTxn(seeds, repair, replaced);
      for (VI& v : seeds) {
        Index p = v.idx();
        for (auto it = replaced.find(p); it != replaced.end(); it = replaced.find(p))
          p = it->second;
        v = VI(p);
      }
      for (SewResult::Group& g : result.groups) {
        Index p = g.into.idx();
        for (auto it = replaced.find(p); it != replaced.end(); it = replaced.find(p))
          p = it->second;
        g.into = PointId(p);
      }
      for (PointId& q : result.inserted) {
        Index p = q.idx();
        for (auto it = replaced.find(p); it != replaced.end(); it = replaced.find(p))
          p = it->second;
        q = PointId(p);
      }
    }
    for (VI v : seeds)
      if (I.vertexAlive(v)) result.merged.push_back(PointId(v.idx()));
    std::sort(result.merged.begin(), result.merged.end());
    result.merged.erase(std::unique(result.merged.begin(), result.merged.end()),
                        result.merged.end());
    // (A point joined into another is isolated now and goes at the commit.)
    std::erase_if(result.inserted, [&](PointId p) {
      return !I.vertexAlive(VI(p.idx())) || mesh.is_isolated(VI(p.idx()));
    });
    std::sort(result.inserted.begin(), result.inserted.end());
    result.inserted.erase(std::unique(result.inserted.begin(), result.inserted.end()),
                          result.inserted.end());
    return result;
  });
}

}  // namespace cutsim::topology
