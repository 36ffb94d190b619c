// Contact (contact.hpp): its construction, its obstacles' moves, and the step's start: the
// obstacles' poses, the margins, the pairs (from the search's cache or a search), the
// exclusions, the friction's frozen normal forces.
#include <stdexcept>

#include "contact_impl.hpp"

namespace cutsim::forcefields {

Contact::Contact(topology::Topology& topology, ContactParameters parameters,
                 std::vector<Obstacle> obstacles)
    : parameters_(parameters), obstacles_(std::move(obstacles)) {
  parameters_.validate();
  for (std::size_t k = 0; k < obstacles_.size(); ++k) {
    Obstacle& o = obstacles_[k];
    try {
      o.validate();
    } catch (const InvalidInput& e) {
      throw InvalidInput(
          "obstacles/" + std::to_string(k) + (e.where().empty() ? "" : "/" + e.where()),
          e.message());
    }
    if (o.name.empty()) o.name = o.shapeName() + std::to_string(k);
  }
  impl_ = std::make_unique<Impl>(topology, parameters_, obstacles_);
  impl_->threads = parameters_.threads > 0 ? parameters_.threads : defaultThreads();
  for (const Obstacle& o : obstacles_) {
    impl_->meets.push_back(o.shape->meets());
    impl_->cores.push_back(impl_->meets.back() == ObstacleShape::Meets::Round ? o.shape->round()
                                                                              : RoundCore{});
  }
  impl_->buildObstacleMeshes();
  impl_->offset.assign(obstacles_.size(), V3::Zero());
  impl_->velocity.assign(obstacles_.size(), V3::Zero());
  impl_->move.assign(obstacles_.size(), V3::Zero());
  for (std::size_t k = 0; k < obstacles_.size(); ++k) {
    const Vec3 o = obstacles_[k].offsetAt(0.0);
    impl_->offset[k] = V3(o[0], o[1], o[2]);
  }
  impl_->startOffset = impl_->offset;
  impl_->subscription = topology.subscribe(*this);
}

Contact::~Contact() = default;

void Contact::setObstaclePath(std::size_t k, std::vector<ObstacleKey> path) {
  if (k >= obstacles_.size()) throw InvalidInput("obstacle", "no obstacle " + std::to_string(k));
  Obstacle moved = obstacles_[k];
  moved.path = std::move(path);
  try {
    moved.validate();
  } catch (const InvalidInput& e) {
    throw InvalidInput("obstacle \"" + moved.name + "\"", e.what());
  }
  obstacles_[k] = std::move(moved);
}

const std::vector<double>& Contact::bounds() const {
  return impl_->bound;
}
std::size_t Contact::cachedPairs() const {
  return impl_->cacheBuilt ? impl_->cache.size() : 0;
}
std::size_t Contact::searches() const {
  return impl_->cacheBuilds + impl_->plainSearches;
}
std::size_t Contact::searchesReused() const {
  return impl_->cacheUses;
}

void Contact::beginStep(std::span<const double> x, std::span<const double> v, double dt) {
  ObstaclePoses still;
  still.start.assign(obstacles_.size(), Vec3{0, 0, 0});
  still.end = still.start;
  beginStep(x, v, still, dt);
}

void Contact::beginStep(std::span<const double> x, std::span<const double> v,
                        const ObstaclePoses& poses, double dt) {
  Impl& I = *impl_;
  const ContactParameters& P = parameters_;
  if (poses.start.size() != obstacles_.size() || poses.end.size() != obstacles_.size())
    throw std::invalid_argument(
        "Contact::beginStep: a pose for each obstacle, at the step's "
        "start and end");
  // Obstacles at the step's end.
  for (std::size_t k = 0; k < obstacles_.size(); ++k) {
    const Vec3& a = poses.start[k];
    const Vec3& b = poses.end[k];
    I.offset[k] = V3(b[0], b[1], b[2]);
    I.startOffset[k] = V3(a[0], a[1], a[2]);
    I.move[k] = I.offset[k] - I.startOffset[k];
    I.velocity[k] = dt > 0 ? V3(I.move[k] / dt) : V3(V3::Zero());
  }
  // The penalty's pairs: those within 1.5 d at the step's start (the linearised integrators take
  // forces and stiffness there; a pair that comes closer during the step is bounded by
  // limitDisplacement and found at the next step).
  const std::size_t n = x.size() / 3;
  I.updateTables();
  I.resetFlatness();
  // Margins: 0.75 d plus what the points may travel relative to the surface's mean motion (with
  // room to spare: 4 |v - mean| dt), so that Newton's iterations find the pairs they approach.
  V3 mean = V3::Zero();
  double live = 0;
  for (std::size_t p = 0; p < n && p < v.size() / 3; ++p)
    if (I.pointOwner.size() > p && I.pointOwner[p] >= 0) {
      mean += V3(v[3 * p], v[3 * p + 1], v[3 * p + 2]);
      ++live;
    }
  if (live > 0) mean /= live;
  I.pointMargin.assign(n, 0.5 * P.thickness);
  for (std::size_t p = 0; p < n && p < v.size() / 3; ++p)
    if (I.pointOwner.size() > p && I.pointOwner[p] >= 0)
      I.pointMargin[p] += 4 * (V3(v[3 * p], v[3 * p + 1], v[3 * p + 2]) - mean).norm() * dt;
  const double shift = 0.5 * P.thickness + 4 * mean.norm() * dt;  // (the obstacles stay put)
  I.obstacleMargin.assign(obstacles_.size(), 0.0);
  for (std::size_t k = 0; k < obstacles_.size(); ++k) {
    const Vec3& a = poses.start[k];
    const Vec3& b = poses.end[k];
    I.obstacleMargin[k] = shift + (V3(b[0], b[1], b[2]) - V3(a[0], a[1], a[2])).norm();
  }
  // The pairs are found with the obstacles where they start the step (which side of them each
  // point is on), then measured where they end it (the penalty's pose), on that side.
  const std::vector<V3> endOffset = I.offset;
  I.offset = I.startOffset;
  bool fromCache = false;
  double widest = 0.0;
  for (std::size_t p = 0; p < n; ++p)
    if (I.pointOwner.size() > p && I.pointOwner[p] >= 0)
      widest = std::max(widest, I.pointMargin[p]);
  if (P.searchSlack > 0 && I.plainSteps > 0) {
    --I.plainSteps;
  } else if (P.searchSlack > 0 && widest <= 1.5 * P.thickness) {
    // From the cache, searched again when the points or the obstacles have moved too far. (The
    // cache is searched with the widest margin for every point: when some point moves fast, a
    // plain search, with each point's own margin, is used instead.)
    I.triangleMargins();
    const double rSelf = 2 * widest;
    std::vector<double> rObstacle(obstacles_.size(), 0.0);
    double r = rSelf;
    for (std::size_t k = 0; k < obstacles_.size(); ++k)
      r = std::max(r, rObstacle[k] = widest + I.obstacleMargin[k]);
    fromCache = true;
    if (I.cacheCovers(x, rSelf, rObstacle)) {
      ++I.cacheUses;
      ++I.usesSinceBuild;
    } else if (I.cacheBuilt && I.usesSinceBuild == 0 && I.cacheRevision == I.topo.revision()) {
      // The last cache was never reused: search plainly for a while.
      I.plainSteps = I.backoff;
      I.backoff = std::min<std::size_t>(2 * I.backoff, 64);
      I.cacheBuilt = false;
      fromCache = false;
    } else {
      if (I.usesSinceBuild > 0) I.backoff = 1;
      I.buildCache(x, r + P.searchSlack * P.thickness);
      I.cacheCovers(x, rSelf, rObstacle);
      I.usesSinceBuild = 0;
    }
  }
  if (fromCache) {
    I.pairs.clear();
    I.pairsFromCache(x, I.pairs);
    I.analyticPairs(x, I.pairs);
  } else {
    I.prepare(x);
    I.collect(x, I.pairs, true);
    ++I.plainSearches;
  }
  I.offset = endOffset;
  for (Pair& p : I.pairs)
    if (I.obstacleMoves(p)) {
      const Eval e = I.evaluate(p, x, true);
      p.s0 = e.s;
    }
  I.lastX.assign(x.begin(), x.end());
  I.evaluation.invalidate();

  // Exclusions. A self pair within d whose primitives are within d of each other in the rest
  // configuration (neighbours in the material: the two lips of a cut, which start at distance
  // zero, the small triangles a repair leaves next to a cut) has no penalty, no friction and no
  // bound (the lips of a cut may slide along each other) until its distance first exceeds d;
  // then it is a pair like any other.
  // The pairs excluded at the last step that are now farther apart than d release their points
  // for good (whichever features the search pairs them by now: a point sliding along a lip
  // meets a corner, then an edge, then a triangle).
  for (const auto& key : I.excluded) {
    const Pair p = Impl::fromKey(key);
    bool alive = true;
    for (int i = 0; i < p.points(); ++i)
      alive = alive && I.topo.isPointAlive(PointId(p.id[std::size_t(i)]));
    if (alive && I.evaluate(p, x).s > P.thickness)
      Impl::crossPoints(
          p, [&](const std::pair<std::uint32_t, std::uint32_t>& ab) { I.released.insert(ab); });
  }
  std::set<std::array<std::uint32_t, 5>> stillClose;
  for (Pair& p : I.pairs) {
    if (!I.excludedPair(p)) continue;
    p.excluded = true;
    stillClose.insert(Impl::exclusionKey(p));
  }
  I.excluded = std::move(stillClose);

  // Frozen normal forces and friction coefficients.
  const Law law{P.thickness, P.stiffness};
  for (Pair& p : I.pairs) {
    p.lambda = p.scale * law.force(p.s0);
    p.mu = p.obstacle < 0 ? P.friction : obstacles_[std::size_t(p.obstacle)].friction;
    p.held = 0;
    if (p.lambda > 0 && p.mu > 0 && !p.excluded)
      frictionForce(p, P.stickVelocity, I.relativeVelocity(p, v), &p);
  }
}

std::size_t Contact::holdOvershoots(std::span<const double> v1, std::span<const char> constrained) {
  Impl& I = *impl_;
  const double eps = parameters_.stickVelocity;
  std::size_t held = 0;
  for (Pair& p : I.pairs) {
    // Sliding at the step's start (fb > 0: the Coulomb branch, direction ft), not past rest at
    // its end along that direction: nothing to mend.
    if (p.excluded || p.held || !(p.lambda > 0 && p.mu > 0) || !(p.fb > 0)) continue;
    bool free = false;
    for (int i = 0; i < 4; ++i)
      if ((p.surface >> i) & 1) {
        const std::size_t q = p.id[std::size_t(i)];
        free = free || q >= constrained.size() || !constrained[q];
      }
    if (!free) continue;
    const V3 u = I.relativeVelocity(p, v1);
    if (!((u - p.n0 * p.n0.dot(u)).dot(p.ft) < 0)) continue;
    p.held = 1;
    frictionForce(p, eps, V3::Zero(), &p);  // the viscous law's derivative
    ++held;
  }
  if (held > 0) I.evaluation.invalidate();
  return held;
}

}  // namespace cutsim::forcefields
