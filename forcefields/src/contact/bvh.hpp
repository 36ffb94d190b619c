#pragma once
// Private to the contact code: a compact bounding volume hierarchy of axis-aligned boxes over a
// list of elements (the live triangles of the surface, or an obstacle's triangles). Built by
// median splits on the longest axis of the boxes' centres; refitted bottom-up when the boxes move
// (nodes are stored so that children follow their parent: one reverse sweep refits).
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "cutsim/base/archive.hpp"
#include "geometry.hpp"

namespace cutsim::forcefields::contact {

class Bvh {
 public:
  /// Builds over boxes[i] (element i), leaves of at most leafSize elements.
  void build(const std::vector<Box>& boxes, int leafSize = 2);
  /// New boxes, same elements (same count): the hierarchy is kept, its boxes follow.
  void refit(const std::vector<Box>& boxes);
  bool empty() const { return nodes_.empty(); }
  std::size_t size() const { return order_.size(); }

  /// Calls f(i, j) once for every unordered pair i != j of elements whose boxes overlap.
  void selfPairs(const std::function<void(int, int)>& f) const;
  /// Calls f(i, j) for every element i of this and j of other whose boxes overlap.
  void crossPairs(const Bvh& other, const std::function<void(int, int)>& f) const;
  /// Calls f(i) for every element whose box overlaps b.
  void query(const Box& b, const std::function<void(int)>& f) const;
  /// A nearest-first descent (a nearest point, a ray's first hit): dist(box) is a lower bound of
  /// what the elements in the box can give, within(d) whether a bound d may still beat the best
  /// so far (it may tighten as the search goes); f(i) is called for every element whose box's
  /// bound is within. Each box's bound is computed once (a child's when its parent is entered,
  /// kept on the stack with it); without calls through std::function.
  template <class Dist, class Within, class F>
  void visitNearest(Dist&& dist, Within&& within, F&& f) const {
    if (nodes_.empty()) return;
    std::vector<std::pair<std::int32_t, double>> stack;
    stack.reserve(64);
    stack.emplace_back(0, dist(nodes_[0].box));
    while (!stack.empty()) {
      const auto [index, d] = stack.back();
      stack.pop_back();
      if (!within(d)) continue;
      const Node& n = nodes_[std::size_t(index)];
      if (n.left < 0) {
        for (std::int32_t i = n.first; i < n.first + n.count; ++i) {
          const int e = order_[std::size_t(i)];
          if (within(dist(boxes_[std::size_t(e)]))) f(e);
        }
      } else {
        const double dl = dist(nodes_[std::size_t(n.left)].box);
        const double dr = dist(nodes_[std::size_t(n.right)].box);
        const bool leftFirst = dl <= dr;
        stack.push_back(leftFirst ? std::pair{n.right, dr} : std::pair{n.left, dl});
        stack.push_back(leftFirst ? std::pair{n.left, dl}
                                  : std::pair{n.right, dr});  // nearer on top
      }
    }
  }

  /// Problems of the hierarchy against the boxes it was last given: every element in exactly one
  /// leaf, every node's box the union of its children's.
  void check(const std::vector<Box>& boxes, std::vector<std::string>& problems) const;

  /// Checkpoints: the hierarchy as built (its shape follows the boxes it was built with).
  void save(ArchiveWriter& out) const;
  void load(ArchiveReader& in);

 private:
  struct Node {
    Box box;
    std::int32_t left = -1, right = -1;  // children (both -1 for a leaf)
    std::int32_t first = 0, count = 0;   // leaf: order_[first .. first + count)
  };
  std::int32_t buildNode(std::int32_t first, std::int32_t count, int leafSize);
  void selfNode(std::int32_t n, const std::function<void(int, int)>& f) const;
  void pairNodes(const Bvh& other, std::int32_t a, std::int32_t b, bool same,
                 const std::function<void(int, int)>& f) const;
  std::vector<Node> nodes_;
  std::vector<std::int32_t> order_;  // element indices, leaves' ranges
  std::vector<Box> boxes_;           // the elements' boxes of the last build / refit
};

}  // namespace cutsim::forcefields::contact
