// The contact code's bounding volume hierarchy (bvh.hpp).
#include "bvh.hpp"

#include <algorithm>
#include <numeric>
#include <sstream>

#include "cutsim/base/archive.hpp"

namespace cutsim::forcefields::contact {

void Bvh::build(const std::vector<Box>& boxes, int leafSize) {
  boxes_ = boxes;
  nodes_.clear();
  order_.resize(boxes.size());
  std::iota(order_.begin(), order_.end(), 0);
  if (boxes.empty()) return;
  nodes_.reserve(2 * boxes.size() / std::size_t(std::max(1, leafSize)) + 2);
  buildNode(0, std::int32_t(boxes.size()), std::max(1, leafSize));
}

std::int32_t Bvh::buildNode(std::int32_t first, std::int32_t count, int leafSize) {
  const std::int32_t id = std::int32_t(nodes_.size());
  nodes_.push_back({});
  Box box, cbox;
  for (std::int32_t i = first; i < first + count; ++i) {
    box.add(boxes_[std::size_t(order_[std::size_t(i)])]);
    cbox.add(boxes_[std::size_t(order_[std::size_t(i)])].center());
  }
  nodes_[std::size_t(id)].box = box;
  if (count <= leafSize) {
    nodes_[std::size_t(id)].first = first;
    nodes_[std::size_t(id)].count = count;
    return id;
  }
  int axis = 0;
  const V3 ext = cbox.hi - cbox.lo;
  if (ext.y() > ext[axis]) axis = 1;
  if (ext.z() > ext[axis]) axis = 2;
  const std::int32_t half = count / 2;
  auto begin = order_.begin() + first, mid = begin + half, end = begin + count;
  std::nth_element(begin, mid, end, [&](std::int32_t a, std::int32_t b) {
    const double ca = boxes_[std::size_t(a)].lo[axis] + boxes_[std::size_t(a)].hi[axis];
    const double cb = boxes_[std::size_t(b)].lo[axis] + boxes_[std::size_t(b)].hi[axis];
    return ca < cb || (ca == cb && a < b);
  });
  const std::int32_t l = buildNode(first, half, leafSize);
  const std::int32_t r = buildNode(first + half, count - half, leafSize);
  nodes_[std::size_t(id)].left = l;
  nodes_[std::size_t(id)].right = r;
  return id;
}

void Bvh::refit(const std::vector<Box>& boxes) {
  boxes_ = boxes;
  // Children are created after their parent: a reverse sweep sees children first.
  for (std::size_t k = nodes_.size(); k-- > 0;) {
    Node& n = nodes_[k];
    if (n.left < 0) {
      Box b;
      for (std::int32_t i = n.first; i < n.first + n.count; ++i)
        b.add(boxes_[std::size_t(order_[std::size_t(i)])]);
      n.box = b;
    } else {
      Box b = nodes_[std::size_t(n.left)].box;
      b.add(nodes_[std::size_t(n.right)].box);
      n.box = b;
    }
  }
}

void Bvh::selfPairs(const std::function<void(int, int)>& f) const {
  if (!nodes_.empty()) selfNode(0, f);
}

void Bvh::selfNode(std::int32_t n, const std::function<void(int, int)>& f) const {
  const Node& node = nodes_[std::size_t(n)];
  if (node.left < 0) {
    for (std::int32_t i = node.first; i < node.first + node.count; ++i)
      for (std::int32_t j = i + 1; j < node.first + node.count; ++j) {
        const int a = order_[std::size_t(i)], b = order_[std::size_t(j)];
        if (boxes_[std::size_t(a)].overlaps(boxes_[std::size_t(b)])) f(a, b);
      }
    return;
  }
  selfNode(node.left, f);
  selfNode(node.right, f);
  pairNodes(*this, node.left, node.right, true, f);
}

void Bvh::pairNodes(const Bvh& other, std::int32_t a, std::int32_t b, bool same,
                    const std::function<void(int, int)>& f) const {
  const Node& na = nodes_[std::size_t(a)];
  const Node& nb = other.nodes_[std::size_t(b)];
  if (!na.box.overlaps(nb.box)) return;
  const bool leafA = na.left < 0, leafB = nb.left < 0;
  if (leafA && leafB) {
    for (std::int32_t i = na.first; i < na.first + na.count; ++i)
      for (std::int32_t j = nb.first; j < nb.first + nb.count; ++j) {
        const int ea = order_[std::size_t(i)], eb = other.order_[std::size_t(j)];
        if (boxes_[std::size_t(ea)].overlaps(other.boxes_[std::size_t(eb)])) f(ea, eb);
      }
    return;
  }
  // Descend the larger node (or the only inner one).
  const auto volume = [](const Box& bx) { return (bx.hi - bx.lo).prod(); };
  if (leafB || (!leafA && volume(na.box) >= volume(nb.box))) {
    pairNodes(other, na.left, b, same, f);
    pairNodes(other, na.right, b, same, f);
  } else {
    pairNodes(other, a, nb.left, same, f);
    pairNodes(other, a, nb.right, same, f);
  }
}

void Bvh::crossPairs(const Bvh& other, const std::function<void(int, int)>& f) const {
  if (!nodes_.empty() && !other.nodes_.empty()) pairNodes(other, 0, 0, false, f);
}

void Bvh::query(const Box& b, const std::function<void(int)>& f) const {
  if (nodes_.empty()) return;
  std::vector<std::int32_t> stack{0};
  while (!stack.empty()) {
    const Node& n = nodes_[std::size_t(stack.back())];
    stack.pop_back();
    if (!n.box.overlaps(b)) continue;
    if (n.left < 0) {
      for (std::int32_t i = n.first; i < n.first + n.count; ++i) {
        const int e = order_[std::size_t(i)];
        if (boxes_[std::size_t(e)].overlaps(b)) f(e);
      }
    } else {
      stack.push_back(n.left);
      stack.push_back(n.right);
    }
  }
}

void Bvh::check(const std::vector<Box>& boxes, std::vector<std::string>& problems) const {
  std::vector<int> seen(boxes.size(), 0);
  if (boxes.size() != boxes_.size()) {
    problems.push_back("contact BVH: holds " + std::to_string(boxes_.size()) +
                       " elements, the surface has " + std::to_string(boxes.size()));
    return;
  }
  for (std::size_t k = 0; k < nodes_.size(); ++k) {
    const Node& n = nodes_[k];
    Box b;
    if (n.left < 0) {
      for (std::int32_t i = n.first; i < n.first + n.count; ++i) {
        const auto e = std::size_t(order_[std::size_t(i)]);
        ++seen[e];
        b.add(boxes[e]);
      }
    } else {
      b = nodes_[std::size_t(n.left)].box;
      b.add(nodes_[std::size_t(n.right)].box);
    }
    if (!n.box.contains(b) || !b.contains(n.box)) {
      std::ostringstream s;
      s << "contact BVH: node " << k << "'s box is not the union of what it holds";
      problems.push_back(s.str());
    }
  }
  for (std::size_t e = 0; e < seen.size(); ++e)
    if (seen[e] != 1)
      problems.push_back("contact BVH: element " + std::to_string(e) + " is in " +
                         std::to_string(seen[e]) + " leaves");
}

void Bvh::save(ArchiveWriter& out) const {
  fields(out, nodes_, order_, boxes_);
}

void Bvh::load(ArchiveReader& in) {
  fields(in, nodes_, order_, boxes_);
  const std::int32_t n = std::int32_t(nodes_.size()), m = std::int32_t(order_.size());
  for (const Node& node : nodes_)
    if (node.left < -1 || node.left >= n || node.right < -1 || node.right >= n || node.first < 0 ||
        node.count < 0 || node.first > m - node.count)
      in.fail("contact: a BVH node outside the hierarchy");
  for (std::int32_t e : order_)
    if (e < 0 || e >= std::int32_t(boxes_.size()))
      in.fail("contact: a BVH element outside the hierarchy");
}

}  // namespace cutsim::forcefields::contact
