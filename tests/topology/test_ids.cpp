// Ids of points, edges and triangles are distinct types: an id of one kind never converts into
// another (the compiler rejects swapped arguments), while each converts to and from an integer.
#include <gtest/gtest.h>

#include <map>
#include <type_traits>
#include <unordered_set>

#include "cutsim/topology/topology.hpp"

namespace cutsim::test {
namespace {

using topology::EdgeId;
using topology::Index;
using topology::PointId;
using topology::Topology;
using topology::TriangleId;

static_assert(!std::is_convertible_v<EdgeId, PointId>);
static_assert(!std::is_convertible_v<TriangleId, PointId>);
static_assert(!std::is_convertible_v<PointId, EdgeId>);
static_assert(!std::is_convertible_v<TriangleId, EdgeId>);
static_assert(!std::is_convertible_v<PointId, TriangleId>);
static_assert(!std::is_convertible_v<EdgeId, TriangleId>);
// An id is made from an integer only explicitly, and reads as one (to index arrays).
static_assert(!std::is_convertible_v<int, PointId> && !std::is_convertible_v<Index, EdgeId>);
static_assert(std::is_constructible_v<PointId, int> && std::is_convertible_v<PointId, Index>);
static_assert(sizeof(PointId) == sizeof(Index) && std::is_trivially_copyable_v<PointId>);
// The topology's queries take only their own kind.
static_assert(std::is_invocable_v<decltype(&Topology::edgeVertices), const Topology&, EdgeId>);
static_assert(!std::is_invocable_v<decltype(&Topology::edgeVertices), const Topology&, PointId>);
static_assert(!std::is_invocable_v<decltype(&Topology::triangleVertices), const Topology&, EdgeId>);
static_assert(!std::is_invocable_v<decltype(&Topology::restPosition), const Topology&, TriangleId>);

TEST(Ids, BehaveAsIntegersWithinTheirKind) {
  PointId p(3);
  ++p;
  EXPECT_EQ(p, 4u);
  EXPECT_EQ(p.index(), 4u);
  EXPECT_LT(PointId(2), p);
  std::map<EdgeId, int> byEdge{{EdgeId(7), 1}};
  EXPECT_EQ(byEdge.at(EdgeId(7)), 1);
  EXPECT_EQ(p.idx(), p.index());
  EXPECT_EQ(PointId::invalid(), topology::kInvalidIndex);
  std::unordered_set<TriangleId> set{TriangleId(1), TriangleId(1), TriangleId(2)};
  EXPECT_EQ(set.size(), 2u);
  EXPECT_EQ(TriangleId(topology::kInvalidIndex), topology::kInvalidIndex);
}

}  // namespace
}  // namespace cutsim::test
