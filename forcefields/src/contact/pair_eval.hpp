#pragma once
// A pair's distance, normal and weights at some positions; the pairs evaluated once per x
// and packed for the solves' products
// (contact_impl.hpp, which includes this file; inline: see there).
#include "contact_impl.hpp"

namespace cutsim::forcefields {

V3 Contact::Impl::relativeVelocity(const Pair& p, std::span<const double> v) const {
  V3 u = V3::Zero();
  const int count = p.kind == Kind::PO || p.kind == Kind::FO ? 3 : p.points();
  for (int i = 0; i < count; ++i) {
    if ((p.surface >> i) & 1)
      u += p.w0[std::size_t(i)] * surfacePoint(v, p.id[std::size_t(i)]);
    else if (p.kind != Kind::PO && p.kind != Kind::FO)
      u += p.w0[std::size_t(i)] * velocity[std::size_t(p.obstacle)];
  }
  if (p.kind == Kind::PO || p.kind == Kind::FO) u -= velocity[std::size_t(p.obstacle)];
  return u;
}

double Contact::Impl::sdf(int k, const V3& q, V3& g) const {
  const V3& off = offset[std::size_t(k)];
  Vec3 gradient;
  const double s = O[std::size_t(k)].shape->signedDistance({q.x(), q.y(), q.z()},
                                                           {off.x(), off.y(), off.z()}, gradient);
  g = V3(gradient[0], gradient[1], gradient[2]);
  return s;
}

Eval Contact::Impl::evaluate(const Pair& p, std::span<const double> x, bool sided) const {
  Eval e = evaluateUnsided(p, x);
  if (sided && p.obstacle >= 0 && p.kind != Kind::PO && p.kind != Kind::FO && e.n.dot(p.n0) < 0) {
    e.s = -e.s;
    e.n = -e.n;
  }
  return e;
}

Eval Contact::Impl::evaluateUnsided(const Pair& p, std::span<const double> x) const {
  std::array<V3, 4> q{V3::Zero(), V3::Zero(), V3::Zero(), V3::Zero()};
  if (p.kind == Kind::PO || p.kind == Kind::FO) {
    for (int i = 0; i < 3; ++i)
      if ((p.surface >> i) & 1) q[std::size_t(i)] = surfacePoint(x, p.id[std::size_t(i)]);
    return evaluatePoints(p, q);
  }
  for (int i = 0; i < p.points(); ++i) q[std::size_t(i)] = pointOf(p, x, i);
  return evaluatePoints(p, q);
}

Eval Contact::Impl::pointTriangleEval(const std::array<V3, 4>& q, const std::array<double, 3>& bw,
                                      const V3& n0) {
  Eval e;
  const V3 d = q[0] - (bw[0] * q[1] + bw[1] * q[2] + bw[2] * q[3]);
  e.s = d.norm();
  e.n = e.s > 1e-300 ? V3(d / e.s) : n0;
  e.w = {1, -bw[0], -bw[1], -bw[2]};
  return e;
}

Eval Contact::Impl::evaluatePoints(const Pair& p, const std::array<V3, 4>& q) const {
  Eval e;
  switch (p.kind) {
    case Kind::PO: {
      e.s = sdf(p.obstacle, q[0], e.n);
      e.w = {1, 0, 0, 0};
      return e;
    }
    case Kind::FO: {
      const int m = (p.surface & 4) ? 3 : (p.surface & 2) ? 2 : 1;
      return roundObstacle(p.obstacle, q, m, p.n0);
    }
    case Kind::VT:
    case Kind::VO:
    case Kind::OV: {
      if (p.shape == 2) {
        const double t = closestSegmentSegment(q[0], q[0], q[1], q[2])[1];
        const V3 d = q[0] - (q[1] + t * (q[2] - q[1]));
        e.s = d.norm();
        e.n = e.s > 1e-300 ? V3(d / e.s) : p.n0;
        e.w = {1, -(1 - t), -t, 0};
        return e;
      }
      if (p.shape == 1) {
        const V3 d = q[0] - q[1];
        e.s = d.norm();
        e.n = e.s > 1e-300 ? V3(d / e.s) : p.n0;
        e.w = {1, -1, 0, 0};
        return e;
      }
      return pointTriangleEval(q, closestOnTriangle(q[0], q[1], q[2], q[3]), p.n0);
    }
    case Kind::EE:
    case Kind::EO: {
      const auto st = closestSegmentSegment(q[0], q[1], q[2], q[3]);
      const V3 d = (q[0] + st[0] * (q[1] - q[0])) - (q[2] + st[1] * (q[3] - q[2]));
      e.s = d.norm();
      e.n = e.s > 1e-300 ? V3(d / e.s) : p.n0;
      e.w = {1 - st[0], st[0], -(1 - st[1]), -st[1]};
      return e;
    }
  }
  return e;
}

Eval Contact::Impl::roundObstacle(int k, const std::array<V3, 4>& q, int m,
                                  const V3& fallback) const {
  const RoundCore& o = cores[std::size_t(k)];
  const V3 a = V3(o.a[0], o.a[1], o.a[2]) + offset[std::size_t(k)];
  const V3 b =
      roundPoint(std::size_t(k)) ? a : V3(V3(o.b[0], o.b[1], o.b[2]) + offset[std::size_t(k)]);
  Eval e;
  V3 pf = q[0], pc = a;
  e.w = {1, 0, 0, 0};
  if (m == 1) {
    const auto st = closestSegmentSegment(q[0], q[0], a, b);
    pc = a + st[1] * (b - a);
  } else if (m == 2) {
    const auto st = closestSegmentSegment(q[0], q[1], a, b);
    pf = q[0] + st[0] * (q[1] - q[0]);
    pc = a + st[1] * (b - a);
    e.w = {1 - st[0], st[0], 0, 0};
  } else if ((b - a).squaredNorm() > 0 && segmentCrossesTriangle(a, b, q[0], q[1], q[2])) {
    // The core pierces the triangle: distance -radius at the crossing, along the old normal.
    const V3 n = (q[1] - q[0]).cross(q[2] - q[0]);
    const double s0 = n.dot(a - q[0]), s1 = n.dot(b - q[0]);
    const V3 xp = a + (s0 / (s0 - s1)) * (b - a);
    const auto bw = closestOnTriangle(xp, q[0], q[1], q[2]);
    e.s = -o.radius;
    e.n = fallback;
    e.w = {bw[0], bw[1], bw[2], 0};
    return e;
  } else {
    double best = kInf;
    for (const V3& c : {a, b}) {
      const auto bw = closestOnTriangle(c, q[0], q[1], q[2]);
      const V3 f = bw[0] * q[0] + bw[1] * q[1] + bw[2] * q[2];
      const double dd = (f - c).squaredNorm();
      if (dd < best) {
        best = dd;
        pf = f;
        pc = c;
        e.w = {bw[0], bw[1], bw[2], 0};
      }
    }
    if ((b - a).squaredNorm() > 0)
      for (int i = 0; i < 3; ++i) {
        const int j = (i + 1) % 3;
        const auto st = closestSegmentSegment(q[std::size_t(i)], q[std::size_t(j)], a, b);
        const V3 f = q[std::size_t(i)] + st[0] * (q[std::size_t(j)] - q[std::size_t(i)]);
        const V3 c = a + st[1] * (b - a);
        const double dd = (f - c).squaredNorm();
        if (dd < best) {
          best = dd;
          pf = f;
          pc = c;
          e.w = {0, 0, 0, 0};
          e.w[std::size_t(i)] = 1 - st[0];
          e.w[std::size_t(j)] = st[0];
        }
      }
  }
  const V3 d = pf - pc;
  const double l = d.norm();
  e.s = l - o.radius;
  e.n = l > 1e-300 ? V3(d / l) : fallback;
  return e;
}

auto Contact::Impl::Evaluation::products(const Impl& I, double kFactor, double bFactor)
    -> const std::vector<Product>& {
  for (std::size_t k = 0; k < packs_.size(); ++k)
    if (packs_[k].evaluation == count_ && packs_[k].kFactor == kFactor &&
        packs_[k].bFactor == bFactor) {
      lastPack_ = k;
      return packs_[k].list;
    }
  lastPack_ = 1 - lastPack_;  // (replaces the pack used less recently)
  Pack& pack = packs_[lastPack_];
  std::vector<Product>& products = pack.list;
  products.clear();
  const Law law{I.P.thickness, I.P.stiffness};
  auto push = [&](const Pair& p, const std::array<double, 4>& w, const Eigen::Matrix3d& A) {
    products.push_back(
        {p.id, p.surface, w, {A(0, 0), A(0, 1), A(0, 2), A(1, 1), A(1, 2), A(2, 2)}});
  };
  for (std::size_t i = 0; i < I.pairs.size(); ++i) {
    const Pair& p = I.pairs[i];
    if (p.excluded) continue;
    const bool penalty = closerThanD_[i] && kFactor != 0.0,
               rubs = p.lambda > 0 && p.mu > 0 && bFactor != 0.0;
    if (!penalty && !rubs) continue;
    const Eigen::Matrix3d K =
        penalty ? Eigen::Matrix3d((-kFactor * p.scale * law.curvature(evals_[i].s)) *
                                  (evals_[i].n * evals_[i].n.transpose()))
                : Eigen::Matrix3d::Zero();
    const Eigen::Matrix3d F =
        rubs ? Eigen::Matrix3d(bFactor * p.frictionMatrix()) : Eigen::Matrix3d::Zero();
    if (penalty && rubs && evals_[i].w == p.w0) {
      push(p, p.w0, K + F);
      continue;
    }
    if (penalty) push(p, evals_[i].w, K);
    if (rubs) push(p, p.w0, F);
  }
  pack.kFactor = kFactor;
  pack.bFactor = bFactor;
  pack.evaluation = count_;
  return products;
}

auto Contact::Impl::Evaluation::at(const Impl& I, std::span<const double> x) -> const Evaluation& {
  if (valid_ && from_ == x.data() && x.size() == x_.size() && heldAt(x)) return *this;
  if (valid_ && sameBits(x, x_)) {
    from_ = x.data();
    return *this;
  }
  const double d = I.P.thickness;
  const auto& pairs = I.pairs;
  const bool atStart = sameBits(x, I.lastX);
  if (!atStart) {
    moved_.assign(x.size() / 3, kInf);
    if (I.lastX.size() == x.size())
      for (std::size_t p = 0; p < moved_.size(); ++p)
        moved_[p] =
            (I.surfacePoint(x, std::uint32_t(p)) - I.surfacePoint(I.lastX, std::uint32_t(p)))
                .norm();
  }
  evals_.resize(pairs.size());
  closerThanD_.assign(pairs.size(), 0);
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const Pair& p = pairs[i];
    if (p.excluded) continue;
    double m = 0.0;
    if (!atStart)
      for (int k = 0; k < 4; ++k)
        if ((p.surface >> k) & 1) m = std::max(m, moved_[p.id[std::size_t(k)]]);
    if (p.s0 - 2 * m >= d) continue;
    // At the step's start a pair is as the search measured it (but for a moving obstacle's,
    // whose distance was taken again where the obstacle ends the step).
    if (atStart && !I.obstacleMoves(p))
      evals_[i] = Eval{p.s0, p.n0, p.w0};
    else
      evals_[i] = I.evaluate(p, x, true);
    closerThanD_[i] = evals_[i].s < d;
  }
  ++count_;
  x_.assign(x.begin(), x.end());
  from_ = x.data();
  valid_ = true;
  return *this;
}

}  // namespace cutsim::forcefields
