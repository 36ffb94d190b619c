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

/// A slot of one kind of element. Ids of points, edges and triangles are distinct types: each
/// converts to and from a plain integer (to index arrays, to write literals), but never into
/// another kind, so that passing an edge where a point is expected does not compile.
template <class Tag>
class Id {
 public:
  constexpr Id() = default;
  template <std::integral T>
  constexpr Id(T value) : value_(Index(value)) {}      // NOLINT: ids are integers by design
  constexpr operator Index() const { return value_; }  // NOLINT
  constexpr Index index() const { return value_; }
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
