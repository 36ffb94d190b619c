// Ids of points, edges and triangles are distinct types: an id of one kind never converts into
// another (the compiler rejects swapped arguments), and converts to and from an integer only
// explicitly (PointId(3), p.idx()).
#include <gtest/gtest.h>

#include <map>
#include <sstream>
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
// An id is made from an integer only explicitly, and read as one only explicitly (idx()).
static_assert(!std::is_convertible_v<int, PointId> && !std::is_convertible_v<Index, EdgeId>);
static_assert(std::is_constructible_v<PointId, int>);
static_assert(!std::is_convertible_v<PointId, Index> && !std::is_convertible_v<EdgeId, int>);
static_assert(!std::is_convertible_v<TriangleId, bool> && !std::is_constructible_v<int, PointId>);
static_assert(sizeof(PointId) == sizeof(Index) && std::is_trivially_copyable_v<PointId>);
// The topology's queries take only their own kind.
static_assert(std::is_invocable_v<decltype(&Topology::edgeVertices), const Topology&, EdgeId>);
static_assert(!std::is_invocable_v<decltype(&Topology::edgeVertices), const Topology&, PointId>);
static_assert(!std::is_invocable_v<decltype(&Topology::triangleVertices), const Topology&, EdgeId>);
static_assert(!std::is_invocable_v<decltype(&Topology::restPosition), const Topology&, TriangleId>);

TEST(Ids, CompareAndCountWithinTheirKind) {
  PointId p(3);
  ++p;
  EXPECT_EQ(p, PointId(4));
  EXPECT_EQ(p.idx(), 4u);
  EXPECT_EQ(Index(p), 4u);
  EXPECT_LT(PointId(2), p);
  EXPECT_NE(PointId(2), p);
  EXPECT_GE(p, PointId(4));
  std::map<EdgeId, int> byEdge{{EdgeId(7), 1}};
  EXPECT_EQ(byEdge.at(EdgeId(7)), 1);
  EXPECT_EQ(PointId::invalid().idx(), topology::kInvalidIndex);
  std::unordered_set<TriangleId> set{TriangleId(1), TriangleId(1), TriangleId(2)};
  EXPECT_EQ(set.size(), 2u);
  EXPECT_EQ(TriangleId(topology::kInvalidIndex), TriangleId::invalid());
}

TEST(Ids, PrintAsTheirNumber) {
  std::ostringstream s;
  s << PointId(4) << " " << EdgeId(0) << " " << TriangleId::invalid();
  EXPECT_EQ(s.str(), "4 0 4294967295");
  EXPECT_EQ(testing::PrintToString(PointId(12)), "12");
}

}  // namespace
}  // namespace cutsim::test
