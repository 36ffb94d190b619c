#pragma once
// Disjoint sets over 0..n-1 (union-find with path halving): the face-connected components, the
// fans of triangles around a vertex, the mesh checks. A union keeps the smaller root, so the
// roots do not depend on the order of the unions' arguments.
#include <cstddef>
#include <numeric>
#include <utility>
#include <vector>

namespace cutsim {

class UnionFind {
 public:
  explicit UnionFind(std::size_t n) : parent_(n) {
    std::iota(parent_.begin(), parent_.end(), std::size_t(0));
  }
  std::size_t size() const { return parent_.size(); }
  /// The root of x's set.
  std::size_t find(std::size_t x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];
      x = parent_[x];
    }
    return x;
  }
  /// Joins the sets of a and b; true if they were apart.
  bool unite(std::size_t a, std::size_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return false;
    if (b < a) std::swap(a, b);
    parent_[b] = a;
    return true;
  }

 private:
  std::vector<std::size_t> parent_;
};

}  // namespace cutsim
