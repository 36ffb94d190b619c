// The pairs excluded after topology changes: neighbours in the material (the lips of a cut)
// until they first separate beyond the thickness
// (contact_impl.hpp).
#include "contact_impl.hpp"

namespace cutsim::forcefields {

std::array<std::uint32_t, 5> Contact::Impl::exclusionKey(const Pair& p) {
  std::array<std::uint32_t, 4> id = p.id;
  if (p.kind == Kind::EE) {
    std::array<std::uint32_t, 2> a{std::min(id[0], id[1]), std::max(id[0], id[1])};
    std::array<std::uint32_t, 2> b{std::min(id[2], id[3]), std::max(id[2], id[3])};
    if (b < a) std::swap(a, b);
    id = {a[0], a[1], b[0], b[1]};
  } else {
    std::sort(id.begin() + 1, id.end());
  }
  return {std::uint32_t(p.kind), id[0], id[1], id[2], id[3]};
}

Pair Contact::Impl::fromKey(const std::array<std::uint32_t, 5>& key) {
  Pair p{
      .kind = Kind(key[0]), .obstacle = -1, .id = {key[1], key[2], key[3], key[4]}, .surface = 0};
  int used = 0;
  for (int i = 0; i < 4; ++i)
    if (p.id[std::size_t(i)] != std::uint32_t(kInvalidIndex)) ++used;
  if (p.kind == Kind::VT) p.shape = std::uint8_t(used - 1);
  p.surface = std::uint8_t((1 << used) - 1);
  return p;
}

Pair Contact::Impl::closestFeature(const Pair& p) {
  Pair f = p;
  const std::uint32_t inv = kInvalidIndex;
  if (p.kind == Kind::VT) {
    std::array<std::uint32_t, 3> on{inv, inv, inv};
    int m = 0;
    for (int c = 0; c < 3; ++c)
      if (std::abs(p.w0[std::size_t(c + 1)]) > 1e-9)
        on[std::size_t(m++)] = p.id[std::size_t(c + 1)];
    if (m == 0 || m == 3) return f;
    f.id = {p.id[0], on[0], on[1], inv};
    f.shape = std::uint8_t(m);
    f.surface = std::uint8_t((1 << (m + 1)) - 1);
    return f;
  }
  if (p.kind != Kind::EE) return f;
  // An end of an edge stands for the edge.
  auto side = [&](std::uint32_t a, std::uint32_t b, double t, std::array<std::uint32_t, 2>& out) {
    if (t <= 1e-9)
      out = {a, inv};
    else if (t >= 1 - 1e-9)
      out = {b, inv};
    else
      out = {a, b};
    return out[1] == inv ? 1 : 2;
  };
  std::array<std::uint32_t, 2> A, B;
  const int na = side(p.id[0], p.id[1], p.w0[1], A), nb = side(p.id[2], p.id[3], -p.w0[3], B);
  if (na == 2 && nb == 2) return f;
  if (na == 1)
    f.id = {A[0], B[0], B[1], inv};
  else
    f.id = {B[0], A[0], A[1], inv};
  f.kind = Kind::VT;
  f.shape = std::uint8_t(na == 1 ? nb : na);
  f.surface = std::uint8_t((1 << (f.shape + 1)) - 1);
  return f;
}

bool Contact::Impl::restNeighbours(const Pair& p) const {
  std::array<V3, 4> rest;
  rest.fill(V3::Zero());
  const int count = p.points(), split = (p.kind == Kind::EE || p.kind == Kind::EO) ? 2 : 1;
  for (int i = 0; i < count; ++i) rest[std::size_t(i)] = restX[p.id[std::size_t(i)]];
  // (primitives whose boxes are farther apart than d along an axis are: most pairs, between
  // layers of a fold that are far apart in the material)
  V3 loA = rest[0], hiA = rest[0], loB = rest[std::size_t(split)], hiB = rest[std::size_t(split)];
  for (int i = 1; i < split; ++i) {
    loA = loA.cwiseMin(rest[std::size_t(i)]);
    hiA = hiA.cwiseMax(rest[std::size_t(i)]);
  }
  for (int i = split + 1; i < count; ++i) {
    loB = loB.cwiseMin(rest[std::size_t(i)]);
    hiB = hiB.cwiseMax(rest[std::size_t(i)]);
  }
  if (((loB - hiA).maxCoeff() > P.thickness) || ((loA - hiB).maxCoeff() > P.thickness))
    return false;
  return evaluatePoints(p, rest).s <= P.thickness;
}

bool Contact::Impl::isReleased(const Pair& p) const {
  if (released.empty()) return false;
  bool all = true;
  crossPoints(p, [&](const std::pair<std::uint32_t, std::uint32_t>& ab) {
    all = all && released.count(ab);
  });
  return all;
}

}  // namespace cutsim::forcefields
