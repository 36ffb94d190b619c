#pragma once
// Basic index and geometry types of the topology layer. Deliberately free of CGAL.
#include <array>
#include <concepts>
#include <cstdint>
#include <functional>
#include <limits>

#include "cutsim/base/vec3.hpp"

namespace cutsim::topology {

/// The integer of a slot.
using Index = std::uint32_t;
inline constexpr Index kInvalidIndex = std::numeric_limits<Index>::max();

/// A slot of one kind of element. Ids of points, edges and triangles are distinct types: an id
/// is made from an integer only explicitly (`PointId(3)`, `EdgeId{e}`), so that an integer or an
/// id of another kind never becomes one by accident (`PointId p = 3 * edge;` does not compile:
/// tests/compile_fail/), and reads as an integer (to index arrays) or by idx().
template <class Tag>
class Id {
 public:
  constexpr Id() = default;
  template <std::integral T>
  explicit constexpr Id(T value) : value_(Index(value)) {}
  constexpr operator Index() const { return value_; }  // NOLINT
  constexpr Index index() const { return value_; }
  constexpr Index idx() const { return value_; }
  /// The id of no element (kInvalidIndex).
  static constexpr Id invalid() { return Id(kInvalidIndex); }
  constexpr Id& operator++() {
    ++value_;
    return *this;
  }
  constexpr Id operator++(int) {
    Id old = *this;
    ++value_;
    return old;
  }
  constexpr Id& operator--() {
    --value_;
    return *this;
  }

 private:
  Index value_ = 0;
};

/// Indices of points (vertices), edges and triangles. They are slots: stable between compactions,
/// never reused before a compaction (see docs/topology-events.md, "Index policy").
using PointId = Id<struct PointTag>;
using EdgeId = Id<struct EdgeTag>;
using TriangleId = Id<struct TriangleTag>;

using Vec3 = cutsim::Vec3;
using TriangleVertices = std::array<PointId, 3>;
using TriangleEdges = std::array<EdgeId, 3>;
using EdgeVertices = std::array<PointId, 2>;

}  // namespace cutsim::topology

template <class Tag>
struct std::hash<cutsim::topology::Id<Tag>> {
  std::size_t operator()(cutsim::topology::Id<Tag> id) const noexcept {
    return std::hash<cutsim::topology::Index>()(id.index());
  }
};
