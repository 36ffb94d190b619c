// The penalty and friction force field: forces, products, energy, matrices, and the
// measures the CSV reports (contact_impl.hpp).
#include "contact_impl.hpp"

namespace cutsim::forcefields {

void Contact::addForce(std::span<const double> x, std::span<const double> v,
                       std::span<double> f) const {
  const Impl& I = *impl_;
  const Law law{parameters_.thickness, parameters_.stiffness};
  const auto& E = I.evaluation.at(I, x);
  for (std::size_t pi = 0; pi < I.pairs.size(); ++pi) {
    const Pair& p = I.pairs[pi];
    if (p.excluded) continue;
    const Eval& e = E.evals()[pi];
    if (E.closer(pi)) {
      const double mag = p.scale * law.force(e.s);
      for (int i = 0; i < 4; ++i)
        if ((p.surface >> i) & 1)
          for (int c = 0; c < 3; ++c)
            f[3 * p.id[std::size_t(i)] + std::size_t(c)] += mag * e.w[std::size_t(i)] * e.n[c];
    }
    if (p.lambda > 0 && p.mu > 0) {
      const V3 ff = frictionForce(p, parameters_.stickVelocity, I.relativeVelocity(p, v));
      for (int i = 0; i < 4; ++i)
        if ((p.surface >> i) & 1)
          for (int c = 0; c < 3; ++c)
            f[3 * p.id[std::size_t(i)] + std::size_t(c)] += p.w0[std::size_t(i)] * ff[c];
    }
  }
}

void Contact::addFrictionForce(std::span<const double> /*x*/, std::span<const double> v,
                               std::span<double> f) const {
  // Lagged: the normal forces and directions frozen at the step's start, the positions unread.
  const Impl& I = *impl_;
  for (const Pair& p : I.pairs) {
    if (p.excluded || !(p.lambda > 0 && p.mu > 0)) continue;
    const V3 ff = frictionForce(p, parameters_.stickVelocity, I.relativeVelocity(p, v));
    for (int i = 0; i < 4; ++i)
      if ((p.surface >> i) & 1)
        for (int c = 0; c < 3; ++c)
          f[3 * p.id[std::size_t(i)] + std::size_t(c)] += p.w0[std::size_t(i)] * ff[c];
  }
}

void Contact::beginProducts(std::span<const double> x) const {
  impl_->evaluation.hold(*impl_, x);
}

void Contact::endProducts(std::span<const double> x) const {
  impl_->evaluation.release(x);
}

void Contact::addDForce(std::span<const double> x, std::span<const double> dx, std::span<double> df,
                        double kFactor, double bFactor) const {
  const Impl& I = *impl_;
  I.evaluation.at(I, x);
  auto at = [&](std::uint32_t p) { return Eigen::Map<const V3>(dx.data() + 3 * std::size_t(p)); };
  auto to = [&](std::uint32_t p) { return Eigen::Map<V3>(df.data() + 3 * std::size_t(p)); };
  for (const auto& c : I.evaluation.products(I, kFactor, bFactor)) {
    V3 u = V3::Zero();
    for (int i = 0; i < 4; ++i)
      if ((c.surface >> i) & 1) u += c.w[std::size_t(i)] * at(c.id[std::size_t(i)]);
    const auto& a = c.a;
    const V3 g(a[0] * u[0] + a[1] * u[1] + a[2] * u[2], a[1] * u[0] + a[3] * u[1] + a[4] * u[2],
               a[2] * u[0] + a[4] * u[1] + a[5] * u[2]);
    for (int i = 0; i < 4; ++i)
      if ((c.surface >> i) & 1) to(c.id[std::size_t(i)]) += c.w[std::size_t(i)] * g;
  }
}

double Contact::potentialEnergy(std::span<const double> x) const {
  const Impl& I = *impl_;
  const Law law{parameters_.thickness, parameters_.stiffness};
  double energy = 0.0;
  const auto& E = I.evaluation.at(I, x);
  for (std::size_t pi = 0; pi < I.pairs.size(); ++pi)
    if (E.closer(pi)) energy += I.pairs[pi].scale * law.energy(E.evals()[pi].s);
  return energy;
}

namespace {
/// Adds w_i w_j B to block (i, j) of every pair of the pair's surface points; where a block has
/// no place in the accumulator's pattern, adds |w_i| (sum_j |w_j|) B to the diagonal blocks
/// instead (B is semi-definite: the lumped blocks bound the true ones in the same direction, by
/// Cauchy-Schwarz), and says so.
void addPairBlocks(const Pair& p, const std::array<double, 4>& w, const Eigen::Matrix3d& B,
                   MatrixAccumulator& m) {
  if (m.diagonalOnly()) {
    for (int i = 0; i < 4; ++i)
      if ((p.surface >> i) & 1)
        m.addBlock(PointId(p.id[std::size_t(i)]), PointId(p.id[std::size_t(i)]),
                   (w[std::size_t(i)] * w[std::size_t(i)]) * B);
    return;
  }
  bool fits = true;
  double sum = 0.0;
  for (int i = 0; i < 4; ++i) {
    if (!((p.surface >> i) & 1)) continue;
    sum += std::abs(w[std::size_t(i)]);
    for (int j = 0; j < i && fits; ++j)
      if ((p.surface >> j) & 1)
        fits = m.contains(PointId(p.id[std::size_t(i)]), PointId(p.id[std::size_t(j)]));
  }
  if (!fits) m.approximated();
  for (int i = 0; i < 4; ++i) {
    if (!((p.surface >> i) & 1)) continue;
    if (!fits) {
      m.addBlock(PointId(p.id[std::size_t(i)]), PointId(p.id[std::size_t(i)]),
                 (std::abs(w[std::size_t(i)]) * sum) * B);
      continue;
    }
    for (int j = 0; j < 4; ++j)
      if ((p.surface >> j) & 1)
        m.addBlock(PointId(p.id[std::size_t(i)]), PointId(p.id[std::size_t(j)]),
                   (w[std::size_t(i)] * w[std::size_t(j)]) * B);
  }
}
}  // namespace

void Contact::addKToMatrix(std::span<const double> x, MatrixAccumulator& m, double kFactor) const {
  const Impl& I = *impl_;
  const Law law{parameters_.thickness, parameters_.stiffness};
  const auto& E = I.evaluation.at(I, x);
  for (std::size_t pi = 0; pi < I.pairs.size(); ++pi) {
    const Pair& p = I.pairs[pi];
    if (!E.closer(pi)) continue;
    const Eval& e = E.evals()[pi];
    const Eigen::Matrix3d nn = (-kFactor * p.scale * law.curvature(e.s)) * (e.n * e.n.transpose());
    addPairBlocks(p, e.w, nn, m);
  }
}

void Contact::addBToMatrix(std::span<const double> /*x*/, MatrixAccumulator& m,
                           double bFactor) const {
  const Impl& I = *impl_;
  for (const Pair& p : I.pairs) {
    if (p.excluded || !(p.lambda > 0 && p.mu > 0)) continue;
    addPairBlocks(p, p.w0, bFactor * p.frictionMatrix(), m);
  }
}

ContactMeasure Contact::measure(std::span<const double> x, std::span<const double> v) const {
  const Impl& I = *impl_;
  const Law law{parameters_.thickness, parameters_.stiffness};
  const auto& E = I.evaluation.at(I, x);
  ContactMeasure m;
  m.obstacleNormal.assign(obstacles_.size(), 0.0);
  m.obstacleFriction.assign(obstacles_.size(), 0.0);
  for (std::size_t pi = 0; pi < I.pairs.size(); ++pi) {
    const Pair& p = I.pairs[pi];
    ++m.candidates;
    if (p.excluded) {
      ++m.excluded;
      continue;
    }
    const Eval& e = E.evals()[pi];
    double fn = 0.0, ft = 0.0;
    if (E.closer(pi)) {
      ++m.active;
      fn = p.scale * law.force(e.s);
    }
    if (p.lambda > 0 && p.mu > 0)
      ft = frictionForce(p, parameters_.stickVelocity, I.relativeVelocity(p, v)).norm();
    if (p.obstacle < 0) {
      m.selfNormal += fn;
      m.selfFriction += ft;
    } else {
      m.obstacleNormal[std::size_t(p.obstacle)] += fn;
      m.obstacleFriction[std::size_t(p.obstacle)] += ft;
    }
  }
  return m;
}

}  // namespace cutsim::forcefields
