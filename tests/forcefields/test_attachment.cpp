// Attachment: the tissue beneath. Finite differences, the areas against a rebuild after every
// operation of random topology sequences, a cut through attached tissue, release along a path.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "cutsim/forcefields/attachment.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/field_helpers.hpp"
#include "support/fixtures.hpp"
#include "support/force_field_harness.hpp"
#include "support/random_ops.hpp"

namespace cutsim::forcefields {
namespace {

using test::SequenceCase;
using topology::MeshData;
using topology::Topology;
using Model = test::FieldModel<Attachment>;

AttachmentParameters someParameters() {
  AttachmentParameters p;
  p.stiffness = 300.0;
  p.damping = 2.0;
  return p;
}

TEST(Attachment, EachPointHoldsAThirdOfItsTrianglesAreas) {
  Model m = test::makeFieldModel<Attachment>(test::grid(5, 2.0, 0.2, 3), someParameters());
  double total = 0.0, meshArea = 0.0;
  for (PointId p : m.topo->points()) total += m.ff->area(p);
  for (TriangleId t : m.topo->triangles()) {
    const auto v = m.topo->triangleVertices(t);
    const Vec3 a = m.topo->restPosition(v[0]), b = m.topo->restPosition(v[1]),
               c = m.topo->restPosition(v[2]);
    meshArea += 0.5 * std::fabs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]));
  }
  EXPECT_NEAR(total, meshArea, 1e-12 * meshArea);
  EXPECT_EQ(m.ff->numAttached(), m.topo->numPoints());
  // At rest: no force, no energy.
  EXPECT_EQ(m.ff->potentialEnergy(m.rest), 0.0);
  EXPECT_EQ(test::maxAbs(test::forceAt(*m.ff, m.rest)), 0.0);
}

TEST(Attachment, ForceStiffnessAndDampingMatchFiniteDifferences) {
  for (const auto& [name, mesh] : test::smallMeshes()) {
    SCOPED_TRACE(name);
    Model m = test::makeFieldModel<Attachment>(mesh, someParameters());
    const std::vector<double> x = test::perturbed(m.rest, 0.3, 5);
    EXPECT_LE(test::forceVsEnergyError(*m.ff, x, 1e-5), 1e-7);
    const std::vector<double> dx = test::randomVector(x.size(), 1.0, 6);
    test::expectExactStiffness(*m.ff, x, dx, m.n(), 1e-6, 1e-8);
    // Damping: f(v) is linear, B its matrix.
    const std::vector<double> v = test::randomVector(x.size(), 0.5, 7);
    std::vector<double> f0(x.size(), 0.0), f1(x.size(), 0.0), bv(x.size(), 0.0);
    m.ff->addForce(x, std::vector<double>(x.size(), 0.0), f0);
    m.ff->addForce(x, v, f1);
    m.ff->addDForce(x, v, bv, 0.0, 1.0);
    for (std::size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(f1[i] - f0[i], bv[i], 1e-12);
    TripletAccumulator acc;
    m.ff->addBToMatrix(x, acc, 1.0);
    const Eigen::MatrixXd b(acc.toSparse(static_cast<Index>(m.n())));
    EXPECT_LE(test::relativeError(bv, test::times(b, v)), 1e-14);
  }
}

TEST(Attachment, ARegionAttachesOnlyItsPoints) {
  AttachmentParameters p = someParameters();
  p.region = AttachmentParameters::Region::Box;
  p.boxMin = {-1.0, -1.0, -1.0};
  p.boxMax = {1.01, 10.0, 1.0};
  Model m = test::makeFieldModel<Attachment>(test::grid(5, 4.0), p);
  std::size_t inside = 0;
  for (PointId pt : m.topo->points()) {
    const bool in = m.topo->restPosition(pt)[0] <= 1.01;
    inside += in ? 1 : 0;
    EXPECT_EQ(m.ff->attached(pt), in ? 1.0 : 0.0);
  }
  EXPECT_EQ(m.ff->numAttached(), inside);
  EXPECT_GT(inside, 0u);
  EXPECT_LT(inside, m.topo->numPoints());
}

TEST(Attachment, ACutThroughAttachedTissueLeavesBothLipsAttached) {
  Model m = test::makeFieldModel<Attachment>(test::grid(9, 1.0), someParameters());
  const std::vector<Vec3> path = {{0.1, 0.43, 0.0}, {0.9, 0.43, 0.0}};
  m.topo->cutPolyline(path);
  ASSERT_TRUE(m.topo->validate().ok()) << m.topo->validate().summary();
  for (PointId p : m.topo->points()) EXPECT_EQ(m.ff->attached(p), 1.0) << "point " << p.idx();
  double total = 0.0;
  for (PointId p : m.topo->points()) total += m.ff->area(p);
  EXPECT_NEAR(total, 1.0, 1e-12);
}

TEST(Attachment, ReleaseAlongAPathFreesExactlyThePointsWithinHalfTheWidth) {
  Model m = test::makeFieldModel<Attachment>(test::grid(11, 1.0), someParameters());
  const std::vector<Vec3> path = {{0.2, 0.5, 0.0}, {0.8, 0.5, 0.0}};
  const double halfWidth = 0.15;
  const std::size_t released = m.ff->release(nearPolyline(path, halfWidth));
  std::size_t expected = 0;
  for (PointId p : m.topo->points()) {
    const Vec3 x = m.topo->restPosition(p);
    const double dx = std::max({0.2 - x[0], 0.0, x[0] - 0.8});
    const bool near = std::hypot(dx, x[1] - 0.5) <= halfWidth;
    expected += near ? 1 : 0;
    EXPECT_EQ(m.ff->attached(p), near ? 0.0 : 1.0) << "point " << p.idx();
  }
  EXPECT_EQ(released, expected);
  EXPECT_GT(expected, 0u);
  EXPECT_EQ(m.ff->release(nearPolyline(path, halfWidth)), 0u);  // already released
  // Released points carry no force.
  const std::vector<double> x = test::perturbed(m.rest, 0.1, 3);
  const std::vector<double> f = test::forceAt(*m.ff, x);
  for (PointId p : m.topo->points()) {
    if (m.ff->attached(p) == 0.0) {
      for (int c = 0; c < 3; ++c) EXPECT_EQ(f[3 * p.idx() + c], 0.0);
    }
  }
}

TEST(Attachment, BadParametersAreRejectedNamingTheParameter) {
  const auto rejects = [](AttachmentParameters p, const std::string& where) {
    try {
      p.validate();
      ADD_FAILURE() << "accepted; expected an error at " << where;
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.where(), where);
    }
  };
  AttachmentParameters p = someParameters();
  p.stiffness = -1.0;
  rejects(p, "stiffness");
  p = someParameters();
  p.damping = std::nan("");
  rejects(p, "damping");
  p = someParameters();
  p.region = AttachmentParameters::Region::Sphere;
  p.radius = 0.0;
  rejects(p, "sphere");
}

class AttachmentIncremental : public ::testing::TestWithParam<SequenceCase> {};

TEST_P(AttachmentIncremental, AreasAndTargetsEqualARebuildAfterEveryOperation) {
  const SequenceCase c = GetParam();
  const MeshData mesh = test::sequenceSheet(c);
  Topology topo(mesh.points, mesh.triangles);
  AttachmentParameters p = someParameters();
  p.region = AttachmentParameters::Region::Box;  // half attached: new points in between
  p.boxMin = {-100.0, -100.0, -100.0};
  p.boxMax = {mesh.points[mesh.points.size() / 2][0], 100.0, 100.0};
  Attachment a(topo, p);
  ASSERT_TRUE(topo.validate().ok()) << topo.validate().summary();
  // topo.validate() after every operation runs Attachment::validate (a rebuild of the areas).
  ASSERT_NO_FATAL_FAILURE(test::runRandomOps(topo, c.seed + 2000, c.steps, [](const auto&) {}));
  Attachment fresh(topo, someParameters());
  for (PointId pt : topo.points()) EXPECT_NEAR(a.area(pt), fresh.area(pt), 1e-12);
}

INSTANTIATE_TEST_SUITE_P(AttachmentSequences, AttachmentIncremental,
                         ::testing::Values(SequenceCase{1, 8, 150}, SequenceCase{2, 10, 200}));

}  // namespace
}  // namespace cutsim::forcefields
