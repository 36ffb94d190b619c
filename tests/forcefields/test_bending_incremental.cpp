// FastTriangularBendingSprings follows the topology's events (spec section 6): after EVERY
// operation of long random sequences, the incrementally maintained table equals a rebuild from
// scratch (topology.validate() calls the field's validate()).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <random>
#include <sstream>

#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/fixtures.hpp"

namespace cutsim::forcefields {
namespace {

using topology::EdgeId;
using topology::kInvalidIndex;
using topology::PointId;
using topology::Topology;
using topology::TriangleId;
using topology::Vec3;

class RandomTopologyEdits {
 public:
  RandomTopologyEdits(Topology& t, std::uint64_t seed) : t_(t), rng_(seed) {}

  /// One random operation; returns its description. TopologyError (a rejected request, which
  /// changes nothing) is caught and reported in the description.
  std::string step() {
    std::ostringstream what;
    what.precision(17);
    const int op = pick(0, 13);
    try {
      if (op <= 2) {
        const EdgeId e = randomEdge(false);
        const double s = std::uniform_real_distribution<double>(0.2, 0.8)(rng_);
        what << "splitEdge(" << e << ", " << s << ")";
        announce(what);
        t_.splitEdge(e, s);
      } else if (op <= 4) {
        const EdgeId e = randomEdge(true);
        if (e == kInvalidIndex) return "no interior edge";
        what << "tear(" << e << ")";
        announce(what);
        t_.tear(e);
      } else if (op <= 6) {
        const std::vector<PointId> path = randomPath();
        what << "incise(";
        for (PointId p : path) what << p << " ";
        what << ")";
        if (path.size() < 2) return what.str() + " skipped";
        announce(what);
        t_.incise(path);
      } else if (op <= 7) {
        std::vector<TriangleId> tris = t_.triangles();
        std::shuffle(tris.begin(), tris.end(), rng_);
        tris.resize(std::min<std::size_t>(tris.size(), static_cast<std::size_t>(pick(1, 3))));
        std::sort(tris.begin(), tris.end());
        what << "removeTriangles(";
        for (TriangleId tr : tris) what << tr << " ";
        what << ")";
        for (TriangleId tr : tris) removed_.push_back(t_.triangleVertices(tr));
        announce(what);
        t_.removeTriangles(tris);
      } else if (op <= 9) {
        // A short polyline of 1 or 2 segments, turning by any angle (it may double back).
        std::uniform_real_distribution<double> u(0.3, 9.7);
        std::uniform_real_distribution<double> len(0.5, 2.5);
        std::uniform_real_distribution<double> turn(-3.14159, 3.14159);
        std::vector<Vec3> poly;
        const int n = pick(2, 3);
        Vec3 p{u(rng_), u(rng_), 0.0};
        double angle = std::uniform_real_distribution<double>(0.0, 6.283185307179586)(rng_);
        poly.push_back(p);
        for (int i = 1; i < n; ++i) {
          const double l = len(rng_);
          p = {p[0] + l * std::cos(angle), p[1] + l * std::sin(angle), 0.0};
          if (p[0] < 0.3 || p[0] > 9.7 || p[1] < 0.3 || p[1] > 9.7) break;
          poly.push_back(p);
          angle += turn(rng_);
        }
        if (poly.size() < 2) return "cutPolyline skipped (left the square)";
        what << "cutPolyline(";
        for (const Vec3& q : poly) what << "(" << q[0] << "," << q[1] << ") ";
        what << ")";
        announce(what);
        t_.cutPolyline(poly);
      } else if (op == 10) {
        what << "compact()";
        announce(what);
        removed_.clear();
        t_.compact();
      } else if (op == 12) {
        // Put back a removed triangle (rejected if its points or edges no longer allow it).
        if (removed_.empty()) return "addTriangles skipped (nothing removed)";
        const std::size_t i =
            static_cast<std::size_t>(pick(0, static_cast<int>(removed_.size()) - 1));
        const topology::TriangleVertices tv = removed_[i];
        removed_.erase(removed_.begin() + static_cast<std::ptrdiff_t>(i));
        for (PointId p : tv) {
          if (p >= t_.pointCapacity() || !t_.isPointAlive(p))
            return "addTriangles skipped (dead point)";
        }
        what << "addTriangles(" << tv[0] << " " << tv[1] << " " << tv[2] << ")";
        announce(what);
        t_.addTriangles(std::vector<topology::TriangleVertices>{tv});
      } else if (op == 13) {
        const std::vector<TriangleId> tris = t_.triangles();
        const TriangleId tr =
            tris[static_cast<std::size_t>(pick(0, static_cast<int>(tris.size()) - 1))];
        std::uniform_real_distribution<double> u(0.1, 1.0);
        std::array<double, 3> b{u(rng_), u(rng_), u(rng_)};
        const double sum = b[0] + b[1] + b[2];
        for (double& c : b) c /= sum;
        what << "splitTriangle(" << tr << ", " << b[0] << " " << b[1] << " " << b[2] << ")";
        announce(what);
        t_.splitTriangle(tr, b);
      } else {
        const EdgeId e = randomEdge(false);
        what << "splitEdge(" << e << ", 0.5)";
        announce(what);
        t_.splitEdge(e, 0.5);
      }
    } catch (const TopologyError& err) {
      what << " rejected: " << err.what();
    }
    return what.str();
  }

 private:
  /// With CUTSIM_TEST_TRACE set, prints each operation before it runs (to locate a crash).
  void announce(const std::ostringstream& what) const {
    if (trace_) std::cerr << "  op: " << what.str() << std::endl;
  }

  int pick(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }

  EdgeId randomEdge(bool interior) {
    std::vector<EdgeId> edges = t_.edges();
    if (interior) {
      std::erase_if(edges, [this](EdgeId e) { return t_.isBoundaryEdge(e); });
    }
    if (edges.empty()) return kInvalidIndex;
    return edges[static_cast<std::size_t>(pick(0, static_cast<int>(edges.size()) - 1))];
  }

  /// A short walk (1 to 4 edges) along interior edges, without repeating a vertex.
  std::vector<PointId> randomPath() {
    const EdgeId e0 = randomEdge(true);
    if (e0 == kInvalidIndex) return {};
    const auto ev = t_.edgeVertices(e0);
    std::vector<PointId> path{ev[0], ev[1]};
    const int len = pick(1, 4);
    while (static_cast<int>(path.size()) <= len) {
      std::vector<PointId> next;
      for (EdgeId e : t_.edgesAroundPoint(path.back())) {
        if (t_.isBoundaryEdge(e)) continue;
        const auto v = t_.edgeVertices(e);
        const PointId other = v[0] == path.back() ? v[1] : v[0];
        if (std::find(path.begin(), path.end(), other) == path.end()) next.push_back(other);
      }
      if (next.empty()) break;
      path.push_back(next[static_cast<std::size_t>(pick(0, static_cast<int>(next.size()) - 1))]);
    }
    return path;
  }

  Topology& t_;
  std::mt19937_64 rng_;
  std::vector<topology::TriangleVertices> removed_;  // cleared by compaction (ids change)
  bool trace_ = std::getenv("CUTSIM_TEST_TRACE") != nullptr;
};

struct SequenceCase {
  std::uint64_t seed;
  int gridSide;
  int steps;
};

class BendingIncremental : public ::testing::TestWithParam<SequenceCase> {};

TEST_P(BendingIncremental, TableEqualsRebuildAfterEveryOperation) {
  const SequenceCase c = GetParam();
  const topology::MeshData mesh = test::grid(c.gridSide, 10.0, 0.25, c.seed);
  Topology topo(mesh.points, mesh.triangles);
  // Both weightings observe the same topology.
  BendingParameters pu;
  pu.bendingStiffness = 1.3;
  BendingParameters ps = pu;
  ps.areaWeights = AreaWeights::Signed;
  FastTriangularBendingSprings unsignedField(topo, pu);
  FastTriangularBendingSprings signedField(topo, ps);
  ASSERT_TRUE(topo.validate().ok()) << topo.validate().summary();

  RandomTopologyEdits edits(topo, c.seed);
  std::vector<std::string> history;
  int accepted = 0;
  for (int i = 0; i < c.steps && topo.numTriangles() > 12; ++i) {
    const std::string what = edits.step();
    history.push_back(what);
    if (what.find("rejected") == std::string::npos) ++accepted;
    const topology::ValidationReport r = topo.validate();
    ASSERT_TRUE(r.ok()) << "after step " << i << ": " << what << "\n" << r.summary();
  }
  EXPECT_GT(accepted, c.steps / 4) << "too few operations were accepted";
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
  const EdgeId e = topo.findEdge(6, 12);  // an interior diagonal
  ASSERT_NE(e, kInvalidIndex);
  const PointId p = topo.splitEdge(e, 0.5);
  EXPECT_EQ(ff.numActiveSprings(), before + 3);
  EXPECT_TRUE(topo.validate().ok()) << topo.validate().summary();
  // The rest force stays zero: the new point sits on the flat rest surface.
  std::vector<double> x(3 * topo.pointCapacity(), 0.0), f(x.size(), 0.0);
  for (PointId q : topo.points()) {
    const Vec3 r = topo.restPosition(q);
    for (int k = 0; k < 3; ++k) x[3 * q + k] = r[k];
  }
  ff.addForce(x, x, f);
  for (double v : f) EXPECT_NEAR(v, 0.0, 1e-12);
  EXPECT_LT(p, topo.pointCapacity());
}

TEST(BendingIncrementalOps, TearingAnEdgeRemovesItsSpring) {
  const topology::MeshData mesh = test::grid(5);
  Topology topo(mesh.points, mesh.triangles);
  FastTriangularBendingSprings ff(topo, {});
  const EdgeId e = topo.findEdge(6, 12);
  ASSERT_EQ(ff.hinge(e).status, HingeStatus::Active);
  topo.tear(e);
  EXPECT_NE(ff.hinge(e).status, HingeStatus::Active);
  EXPECT_TRUE(topo.validate().ok()) << topo.validate().summary();
}

TEST(BendingIncrementalOps, CompactionRenumbersTheTable) {
  const topology::MeshData mesh = test::grid(7, 10.0, 0.2, 3);
  Topology topo(mesh.points, mesh.triangles);
  FastTriangularBendingSprings ff(topo, {});
  topo.removeTriangles(std::vector<TriangleId>{0, 1, 17, 40});
  topo.splitEdge(topo.edges()[10], 0.3);
  ASSERT_TRUE(topo.validate().ok()) << topo.validate().summary();
  topo.compact();
  EXPECT_TRUE(topo.validate().ok()) << topo.validate().summary();
  EXPECT_EQ(ff.numEdgeSlots(), topo.edgeCapacity());
  EXPECT_EQ(topo.edgeCapacity(), topo.numEdges());
}

}  // namespace
}  // namespace cutsim::forcefields
