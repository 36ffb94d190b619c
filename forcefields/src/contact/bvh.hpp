#pragma once
// Private to the contact code: a compact bounding volume hierarchy of axis-aligned boxes over a
// list of elements (the live triangles of the surface, or an obstacle's triangles). Built by
// median splits on the longest axis of the boxes' centres; refitted bottom-up when the boxes move
// (nodes are stored so that children follow their parent: one reverse sweep refits).
#include <cstdint>
#include <functional>
#include <string>
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
  /// Visits the nodes whose box `enter` accepts (it may tighten what it accepts as it goes, as a
  /// nearest-point search does) and calls f(i) for every element of an accepted leaf whose own
  /// box `enter` accepts too. The nearer child of a node (by `order`, smaller first) is visited
  /// first.
  void traverse(const std::function<bool(const Box&)>& enter,
                const std::function<double(const Box&)>& order,
                const std::function<void(int)>& f) const;

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
