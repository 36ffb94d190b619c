#pragma once
// Private to the force fields: the split of a field's elements by the points they write
// (PointPartition), with which a force pass or a product runs on several threads
// (cutsim::inParts) and still gives the one-thread pass's bits.
#include <cassert>
#include <cstdint>
#include <span>
#include <vector>

#include "cutsim/base/parallel.hpp"

namespace cutsim::forcefields {

/// The parts a pass over `elements` elements runs in (cutsim::partsFor): the thread setting,
/// fewer where a part would have under kMinElementsPerPart elements.
inline constexpr std::size_t kMinElementsPerPart = 4096;
inline int partsFor(std::size_t elements) {
  return cutsim::partsFor(elements, kMinElementsPerPart);
}

/// The elements of a field (springs, hinges, triangles: each writes a few points) split by the
/// points they write, for passes on several threads that give the one-thread pass's bits.
///
/// Part k owns the point slots [first(k), first(k) + size(k)) (the slots cut in `parts` runs of
/// about the same number of element ends) and lists, ascending, every element that writes one of
/// them. A part goes over its list and adds each element's terms to the points it owns only:
/// every point gets the same terms as in one pass over all the elements, in the same order
/// (ascending element), and each sum is rounded exactly as that pass rounds it, whatever the
/// number of parts. An element whose points two parts own is computed by both (on a mesh
/// numbered for locality, the few along the runs' ends).
class PointPartition {
 public:
  /// Rebuilds the split for `parts` runs over `pointSlots` slots, unless it was made for the same
  /// parts, slots and `revision` (the field's count of table changes). pointsOf(i, ids) writes
  /// element i's `arity` point ids into ids.
  template <class PointsOf>
  void update(int parts, std::size_t pointSlots, std::size_t elements, int arity,
              std::uint64_t revision, PointsOf&& pointsOf);
  /// Forgets the split (the next update rebuilds it).
  void invalidate() { parts_ = 0; }
  int parts() const { return parts_; }
  std::uint32_t first(int k) const { return first_[std::size_t(k)]; }
  std::uint32_t size(int k) const { return first_[std::size_t(k) + 1] - first_[std::size_t(k)]; }
  /// Part k's elements, ascending.
  std::span<const std::uint32_t> elements(int k) const {
    return {list_.data() + start_[std::size_t(k)], list_.data() + start_[std::size_t(k) + 1]};
  }

 private:
  int parts_ = 0;
  std::size_t slots_ = 0, count_ = 0;
  std::uint64_t revision_ = 0;
  std::vector<std::uint32_t> first_;  // parts + 1 point-slot bounds
  std::vector<std::size_t> start_;    // parts + 1 offsets into list_
  std::vector<std::uint32_t> list_;   // every part's elements, part after part
  std::vector<std::uint32_t> ends_;   // scratch: element ends per point slot
};

template <class PointsOf>
void PointPartition::update(int parts, std::size_t pointSlots, std::size_t elements, int arity,
                            std::uint64_t revision, PointsOf&& pointsOf) {
  if (parts == parts_ && pointSlots == slots_ && elements == count_ && revision == revision_)
    return;
  assert(arity >= 1 && arity <= 8);
  std::uint32_t ids[8];
  parts_ = 0;  // (stale until the end: an allocation that throws leaves no half-made split)
  // Slot bounds that give each part about the same number of element ends.
  ends_.assign(pointSlots + 1, 0);
  for (std::size_t i = 0; i < elements; ++i) {
    pointsOf(i, ids);
    for (int a = 0; a < arity; ++a) ++ends_[ids[a]];
  }
  const std::size_t total = elements * std::size_t(arity);
  first_.assign(std::size_t(parts) + 1, std::uint32_t(pointSlots));
  first_[0] = 0;
  std::size_t seen = 0;
  int k = 1;
  for (std::size_t p = 0; p < pointSlots && k < parts; ++p) {
    seen += ends_[p];
    while (k < parts && seen >= total * std::size_t(k) / std::size_t(parts))
      first_[std::size_t(k++)] = std::uint32_t(p + 1);
  }
  // The part of each slot, then every element once in the list of each part it writes.
  std::vector<std::uint32_t>& partOf = ends_;
  for (int q = 0; q < parts; ++q)
    for (std::uint32_t p = first_[std::size_t(q)]; p < first_[std::size_t(q) + 1]; ++p)
      partOf[p] = std::uint32_t(q);
  std::vector<std::vector<std::uint32_t>> lists(static_cast<std::size_t>(parts));
  for (std::size_t i = 0; i < elements; ++i) {
    pointsOf(i, ids);
    for (int a = 0; a < arity; ++a) {
      bool listed = false;  // (by an earlier end of the element in the same part)
      for (int b = 0; b < a; ++b) listed = listed || partOf[ids[b]] == partOf[ids[a]];
      if (!listed) lists[partOf[ids[a]]].push_back(std::uint32_t(i));
    }
  }
  start_.assign(std::size_t(parts) + 1, 0);
  list_.clear();
  for (int q = 0; q < parts; ++q) {
    list_.insert(list_.end(), lists[std::size_t(q)].begin(), lists[std::size_t(q)].end());
    start_[std::size_t(q) + 1] = list_.size();
  }
  parts_ = parts;
  slots_ = pointSlots;
  count_ = elements;
  revision_ = revision;
}

}  // namespace cutsim::forcefields
