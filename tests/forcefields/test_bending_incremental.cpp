// FastTriangularBendingSprings follows the topology's events (spec section 6): after EVERY
// operation of long random sequences, the incrementally maintained table equals a rebuild from
// scratch (topology.validate() calls the field's validate()).
#include <gtest/gtest.h>

#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/field_helpers.hpp"
#include "support/fixtures.hpp"
#include "support/random_ops.hpp"

namespace cutsim::forcefields {
namespace {

using test::SequenceCase;
using topology::kInvalidIndex;
using topology::PointId;
using topology::Topology;
using topology::TriangleId;

class BendingIncremental : public ::testing::TestWithParam<SequenceCase> {};

TEST_P(BendingIncremental, TableEqualsRebuildAfterEveryOperation) {
  const SequenceCase c = GetParam();
  const topology::MeshData mesh = test::sequenceSheet(c);
  Topology topo(mesh.points, mesh.triangles);
  // Both weightings observe the same topology.
  BendingParameters pu;
  pu.bendingStiffness = 1.3;
  BendingParameters ps = pu;
  ps.areaWeights = AreaWeights::Signed;
  FastTriangularBendingSprings unsignedField(topo, pu);
  FastTriangularBendingSprings signedField(topo, ps);
  ASSERT_TRUE(topo.validate().ok()) << topo.validate().summary();

  ASSERT_NO_FATAL_FAILURE(test::runRandomOps(topo, c.seed, c.steps));
  EXPECT_EQ(unsignedField.numActiveSprings(), signedField.numActiveSprings());
  // A field built afresh on the final mesh agrees as well.
  FastTriangularBendingSprings fresh(topo, pu);
  EXPECT_EQ(fresh.counters(), unsignedField.counters());
}

INSTANTIATE_TEST_SUITE_P(Sequences, BendingIncremental,
                         ::testing::Values(SequenceCase{1, 8, 150}, SequenceCase{2, 10, 200},
                                           SequenceCase{3, 12, 250}, SequenceCase{4, 6, 120},
                                           SequenceCase{5, 10, 200}, SequenceCase{6, 9, 200},
                                           SequenceCase{7, 14, 400}, SequenceCase{8, 11, 300}));

TEST(BendingIncrementalOps, SplittingAnInteriorEdgeAddsThreeSprings) {
  const topology::MeshData mesh = test::grid(5);
  Topology topo(mesh.points, mesh.triangles);
  FastTriangularBendingSprings ff(topo, {});
  const std::size_t before = ff.numActiveSprings();
  const EdgeId e =
      topo.findEdge(topology::PointId(6), topology::PointId(12));  // an interior diagonal
  ASSERT_NE(e.idx(), kInvalidIndex);
  const PointId p = topo.splitEdge(e, 0.5);
  EXPECT_EQ(ff.numActiveSprings(), before + 3);
  EXPECT_TRUE(topo.validate().ok()) << topo.validate().summary();
  // The rest force stays zero: the new point sits on the flat rest surface.
  const std::vector<double> x = test::restOf(topo);
  std::vector<double> f(x.size(), 0.0);
  ff.addForce(x, x, f);
  for (double v : f) EXPECT_NEAR(v, 0.0, 1e-12);
  EXPECT_LT(p.idx(), topo.pointCapacity());
}

TEST(BendingIncrementalOps, TearingAnEdgeRemovesItsSpring) {
  const topology::MeshData mesh = test::grid(5);
  Topology topo(mesh.points, mesh.triangles);
  FastTriangularBendingSprings ff(topo, {});
  const EdgeId e = topo.findEdge(topology::PointId(6), topology::PointId(12));
  ASSERT_EQ(ff.hinge(e).status, HingeStatus::Active);
  topo.tear(e);
  EXPECT_NE(ff.hinge(e).status, HingeStatus::Active);
  EXPECT_TRUE(topo.validate().ok()) << topo.validate().summary();
}

TEST(BendingIncrementalOps, CompactionRenumbersTheTable) {
  const topology::MeshData mesh = test::grid(7, 10.0, 0.2, 3);
  Topology topo(mesh.points, mesh.triangles);
  FastTriangularBendingSprings ff(topo, {});
  topo.removeTriangles(
      std::vector<TriangleId>{TriangleId(0), TriangleId(1), TriangleId(17), TriangleId(40)});
  topo.splitEdge(topo.edges()[10], 0.3);
  ASSERT_TRUE(topo.validate().ok()) << topo.validate().summary();
  topo.compact();
  EXPECT_TRUE(topo.validate().ok()) << topo.validate().summary();
  EXPECT_EQ(ff.numEdgeSlots(), topo.edgeCapacity());
  EXPECT_EQ(topo.edgeCapacity(), topo.numEdges());
}

}  // namespace
}  // namespace cutsim::forcefields
