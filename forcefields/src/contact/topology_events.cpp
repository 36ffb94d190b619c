// Following the topology: the exclusions and released pairs renumbered with the points, the
// tables marked stale after a transaction, and validate() against a rebuild (contact_impl.hpp).
#include <sstream>

#include "contact_impl.hpp"

namespace cutsim::forcefields {

void Contact::onPointsRenumbered(const topology::Topology&, const topology::Renumbering& r) {
  Impl& I = *impl_;
  // Unused ids (a pair of a point and an edge or a corner) stay unused.
  bool gone = false;
  auto map = [&](std::uint32_t p) {
    if (p == std::uint32_t(kInvalidIndex)) return p;
    const std::uint32_t q =
        p < r.oldToNew.size() ? std::uint32_t(r.oldToNew[p]) : std::uint32_t(kInvalidIndex);
    if (q == std::uint32_t(kInvalidIndex)) gone = true;
    return q;
  };
  // Pairs by their points: renumbered, and dropped when a point is gone.
  auto remap = [&](std::set<std::array<std::uint32_t, 5>>& keys) {
    std::set<std::array<std::uint32_t, 5>> out;
    for (const auto& key : keys) {
      gone = false;
      Pair p{.kind = Kind(key[0]),
             .obstacle = -1,
             .id = {map(key[1]), map(key[2]), map(key[3]), map(key[4])},
             .surface = 0b1111};
      if (!gone) out.insert(Impl::exclusionKey(p));
    }
    keys = std::move(out);
  };
  remap(I.excluded);
  std::set<std::pair<std::uint32_t, std::uint32_t>> released;
  for (const auto& [a, b] : I.released) {
    gone = false;
    const std::uint32_t na = map(a), nb = map(b);
    if (!gone) released.insert(std::minmax(na, nb));
  }
  I.released = std::move(released);
}

void Contact::onTransactionEnd(const topology::Topology&, const topology::TransactionSummary&) {
  // The tables and the BVH are rebuilt at the next step's start (the revision changed); the
  // pairs of the last step refer to points that may be gone: drop them now.
  Impl& I = *impl_;
  I.pairs.clear();
  I.evaluation.invalidate();
}

void Contact::validate(const topology::Topology& topology,
                       std::vector<std::string>& problems) const {
  const Impl& I = *impl_;
  if (!I.built || I.revision != topology.revision() ||
      I.lastX.size() < 3 * topology.pointCapacity())
    return;
  if (I.tris != topology.triangles()) {
    problems.push_back("Contact: its triangle list differs from the topology's");
    return;
  }
  for (std::size_t i = 0; i < I.tris.size(); ++i) {
    const auto v = topology.triangleVertices(I.tris[i]);
    for (int k = 0; k < 3; ++k)
      if (I.triV[i][std::size_t(k)] != Index(v[std::size_t(k)]))
        problems.push_back("Contact: triangle " + std::to_string(Index(I.tris[i])) +
                           " has other corners in its table");
  }
  std::vector<Box> boxes;
  I.surfaceBoxes(I.lastX, boxes);
  // The hierarchy against the boxes it was last given (the search's, swept or grown by the
  // cache's margins), then refitted to the step's margins at the step's start.
  I.bvh.check(I.boxes, problems);
  Bvh refitted = I.bvh;
  refitted.refit(boxes);
  refitted.check(boxes, problems);
  // The BVH's pairs against every pair of triangles (small meshes).
  if (I.tris.size() > 3000 || !parameters_.selfContact) return;
  auto keys = [](const std::vector<Pair>& ps) {
    std::set<std::array<std::uint32_t, 5>> out;
    for (const Pair& p : ps) {
      if (p.obstacle >= 0) continue;
      std::array<std::uint32_t, 4> id = p.id;
      if (p.kind == Kind::EE) {  // either edge may come first
        std::array<std::uint32_t, 2> a{std::min(id[0], id[1]), std::max(id[0], id[1])};
        std::array<std::uint32_t, 2> b{std::min(id[2], id[3]), std::max(id[2], id[3])};
        if (b < a) std::swap(a, b);
        id = {a[0], a[1], b[0], b[1]};
      }
      out.insert({std::uint32_t(p.kind), id[0], id[1], id[2], id[3]});
    }
    return out;
  };
  Impl::Tight tight;
  I.tightBoxes(I.lastX, tight);
  std::vector<Pair> brute;
  for (std::size_t i = 0; i < I.tris.size(); ++i)
    for (std::size_t j = i + 1; j < I.tris.size(); ++j)
      if (boxes[i].overlaps(boxes[j]))
        I.selfTrianglePair(int(i), int(j), I.lastX, brute, true, tight);
  std::vector<Pair> fast;
  refitted.selfPairs([&](int i, int j) { I.selfTrianglePair(i, j, I.lastX, fast, true, tight); });
  const auto a = keys(brute), b = keys(fast);
  if (a != b || brute.size() != fast.size()) {
    std::ostringstream s;
    s << "Contact: the BVH finds " << fast.size() << " self pairs, every pair of triangles gives "
      << brute.size();
    problems.push_back(s.str());
  }
}

}  // namespace cutsim::forcefields
