#pragma once
// Basic index and geometry types of the topology layer. Deliberately free of CGAL.
#include <array>
#include <compare>
#include <concepts>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <limits>

#include "cutsim/base/vec3.hpp"

namespace cutsim::topology {

/// The integer of a slot.
using Index = std::uint32_t;
inline constexpr Index kInvalidIndex = std::numeric_limits<Index>::max();

/// A slot of one kind of element. Ids of points, edges and triangles are distinct types, made from
/// an integer only explicitly (`PointId(3)`, `EdgeId{e}`) and read as an integer only by idx()
/// (`x[3 * p.idx()]`, `mass[p.idx()]`): an integer never becomes an id by accident, nor an id an
/// integer or an id of another kind (`PointId p = 3 * edge;`, `Index i = p;` and `x[3 * p]` do not
/// compile: tests/compile_fail/). Ids of one kind compare with each other (==, <, <=>: in the
/// order of their numbers) and print as their number.
template <class Tag>
class Id {
 public:
  constexpr Id() = default;
  template <std::integral T>
  explicit constexpr Id(T value) : value_(Index(value)) {}
  /// The integer, said explicitly: `p.idx()` (the spelling to use; `Index(p)` also compiles).
  explicit constexpr operator Index() const { return value_; }
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
  friend constexpr bool operator==(Id, Id) = default;
  friend constexpr auto operator<=>(Id, Id) = default;
  /// Prints the number, as an integer would (a template, so that this header needs only <iosfwd>:
  /// whoever prints includes <ostream>).
  template <class Char, class Traits>
  friend std::basic_ostream<Char, Traits>& operator<<(std::basic_ostream<Char, Traits>& out,
                                                      Id id) {
    return out << id.value_;
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
    return std::hash<cutsim::topology::Index>()(id.idx());
  }
};
