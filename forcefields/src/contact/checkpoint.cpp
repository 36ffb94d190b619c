// Contact's checkpoints: what the next steps depend on (contact_impl.hpp).
#include "contact_impl.hpp"

namespace cutsim::forcefields {

namespace {

// The members are declared once for both directions (cutsim/base/archive.hpp): numbers, flags
// and tables of plain records (pairs, boxes, vectors) alike.

/// What contact measured at the last step's end (the CSV's figures).
template <class Archive, class Measure>
void measured(Archive& a, Measure& m) {
  fields(a, m.candidates, m.active, m.excluded, m.selfNormal, m.selfFriction, m.obstacleNormal,
         m.obstacleFriction);
}

/// The step's obstacle poses, pairs, margins and bounds.
template <class Archive, class State>
void stepState(Archive& a, State& s) {
  fields(a, s.offset, s.velocity, s.startOffset, s.move, s.pairs, s.nearPairs, s.sweptMotion,
         s.fastPoint, s.moveLength, s.pointMargin, s.triMargin, s.obstacleMargin, s.bound, s.anchor,
         s.reframedAny, s.absoluteReach, s.tight.tri, s.tight.edge);
}

/// The last positions, the search's cache and its schedule.
template <class Archive, class State>
void cacheState(Archive& a, State& s) {
  fields(a, s.lastX, s.cache, s.cacheX, s.cacheOffset, s.cacheRevision, s.cacheR, s.cacheBuilt,
         s.sinceCache, s.obstacleSinceCache, s.cacheUses, s.cacheBuilds, s.usesSinceBuild,
         s.plainSteps, s.backoff, s.plainSearches);
}

}  // namespace

void Contact::saveState(ArchiveWriter& out) const {
  const Impl& I = *impl_;
  out.u64(obstacles_.size());
  for (const Obstacle& o : obstacles_) fields(out, o.path);
  measured(out, last_);

  fields(out, I.built, I.revision, I.bvhBuilt, I.meanEdge, I.boxes);
  I.bvh.save(out);
  for (const auto& m : I.meshes) {
    fields(out, m.boxes);
    m.bvh.save(out);
  }
  stepState(out, I);
  // The sets as tables in their order: an exclusion's key, a released pair as two u64.
  std::vector<std::array<std::uint64_t, 2>> released;
  for (const auto& [a, b] : I.released) released.push_back({a, b});
  fields(out, std::vector(I.excluded.begin(), I.excluded.end()), released);
  cacheState(out, I);
}

void Contact::loadState(ArchiveReader& in) {
  Impl& I = *impl_;
  if (in.u64() != obstacles_.size())
    in.fail("contact: the saved run has another number of obstacles");
  for (Obstacle& o : obstacles_) {
    fields(in, o.path);
    try {
      o.validate();
    } catch (const InvalidInput& e) {
      in.fail("contact: obstacle \"" + o.name + "\": " + e.what());
    }
  }
  measured(in, last_);

  const bool built = in.boolean();
  const std::uint64_t revision = in.u64();
  // The tables of the topology as it is. A checkpoint written right after a topology change holds
  // the tables of the mesh before it, which the next step rebuilds (dropping the hierarchy):
  // the saved revision says so, and the restored contact does the same.
  I.rebuildTables();
  I.built = built;
  I.revision = revision;
  const bool current = built && revision == I.topo.revision();
  fields(in, I.bvhBuilt, I.meanEdge, I.boxes);
  I.bvh.load(in);
  for (auto& m : I.meshes) {
    fields(in, m.boxes);
    m.bvh.load(in);
  }
  stepState(in, I);
  std::vector<std::array<std::uint32_t, 5>> excluded;
  std::vector<std::array<std::uint64_t, 2>> released;
  fields(in, excluded, released);
  I.excluded = decltype(I.excluded)(excluded.begin(), excluded.end());
  I.released.clear();
  for (const auto& [a, b] : released) I.released.insert({std::uint32_t(a), std::uint32_t(b)});
  cacheState(in, I);
  I.evaluation.invalidate();
  I.sweep = nullptr;
  // Every index the records hold must be one of this mesh's.
  const std::size_t points = I.topo.pointCapacity(), tris = I.tris.size();
  auto checkPair = [&](auto kind, std::int32_t obstacle, std::uint8_t surface,
                       const std::array<std::uint32_t, 4>& id) {
    if (obstacle < -1 || obstacle >= std::int32_t(obstacles_.size()) ||
        std::uint8_t(kind) > std::uint8_t(Kind::FO))
      in.fail("contact: a pair of an obstacle or a kind that does not exist");
    for (int i = 0; i < 4; ++i)
      if (((surface >> i) & 1) && id[std::size_t(i)] != kInvalidIndex &&
          id[std::size_t(i)] >= points)
        in.fail("contact: a pair of a point that does not exist");
  };
  for (const Pair& p : I.pairs) checkPair(p.kind, p.obstacle, p.surface, p.id);
  for (const Pair& p : I.nearPairs) checkPair(p.kind, p.obstacle, p.surface, p.id);
  for (const auto& c : I.cache) {
    checkPair(c.kind, c.obstacle, c.surface, c.id);
    if (I.cacheRevision == I.topo.revision() &&
        (c.margins[0] >= std::int32_t(tris) || c.margins[1] >= std::int32_t(tris)))
      in.fail("contact: a cached pair of a triangle that does not exist");
    // (a self pair of edges holds its edges; a point's pair its triangle, of the surface or of
    // an obstacle mesh)
    const bool edgesOk =
        c.kind != Kind::EE || c.obstacle >= 0 ||
        (c.tri >= -1 && c.edge2 >= -1 && c.tri < std::int32_t(I.topo.edgeCapacity()) &&
         c.edge2 < std::int32_t(I.topo.edgeCapacity()));
    const bool triOk =
        c.kind == Kind::EE || c.tri < 0 || c.obstacle >= 0 || c.tri < std::int32_t(tris);
    if (I.cacheRevision == I.topo.revision() && !(edgesOk && triOk))
      in.fail("contact: a cached pair of an edge or a triangle that does not exist");
  }
  I.indexCache();  // (by point: after the points are checked)
  if (current && I.bvhBuilt && I.bvh.size() != tris)
    in.fail("contact: a hierarchy over another number of triangles");
  // Per point slot, per triangle, per obstacle: never longer than the mesh and the obstacles
  // (tables of the mesh before a change are replaced at the next step, unread).
  const std::size_t k = obstacles_.size(), edges = I.topo.edgeCapacity();
  auto size = [&](std::size_t got, std::size_t most, const char* what) {
    if (current && got > most)
      in.fail(std::string("contact: ") + what + " for " + std::to_string(got) +
              " elements, at most " + std::to_string(most));
  };
  size(I.boxes.size(), tris, "boxes");
  size(I.fastPoint.size(), points, "fast points");
  size(I.moveLength.size(), points, "displacements");
  size(I.pointMargin.size(), points, "point margins");
  size(I.triMargin.size(), tris, "triangle margins");
  size(I.bound.size(), points, "bounds");
  size(I.anchor.size(), points, "anchors");
  size(I.sweptMotion.size(), points, "motions");
  size(I.sinceCache.size(), points, "cache distances");
  size(I.lastX.size(), 3 * points, "positions");
  size(I.cacheX.size(), 3 * points, "cached positions");
  size(I.tight.tri.size(), tris, "boxes");
  size(I.tight.edge.size(), edges, "edge boxes");
  if (I.offset.size() != k || I.velocity.size() != k || I.startOffset.size() != k ||
      I.move.size() != k || I.obstacleMargin.size() > k || I.obstacleSinceCache.size() > k ||
      I.cacheOffset.size() > k)
    in.fail("contact: poses for another number of obstacles");
  for (std::size_t j = 0; j < I.meshes.size(); ++j)
    if (I.meshes[j].bvh.size() > I.meshes[j].triangles.size())
      in.fail("contact: an obstacle's hierarchy over other triangles");
}

}  // namespace cutsim::forcefields
