// The simulation core: state and mass following the topology, integrators, constraints, guards.
#include <gtest/gtest.h>

#include <cfenv>
#include <cmath>
#include <limits>

#include "cutsim/core/simulation.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "support/fixtures.hpp"

namespace cutsim::test {
namespace {

using core::Simulation;
using core::SolverSettings;
using topology::Topology;
using topology::Vec3;

std::unique_ptr<Simulation> makeSheet(int n, double density, SolverSettings::Kind kind) {
  auto sim = std::make_unique<Simulation>(std::make_unique<Topology>(grid(n, 1.0)), density);
  SolverSettings s;
  s.kind = kind;
  s.cgTolerance = 1e-12;
  s.cgMaxIterations = 2000;
  sim->setSolver(s);
  return sim;
}

void addBending(Simulation& sim, double k, double rayleigh = 0.0) {
  forcefields::BendingParameters p;
  p.bendingStiffness = k;
  p.rayleighStiffness = rayleigh;
  sim.addForceField(std::make_unique<forcefields::FastTriangularBendingSprings>(sim.topology(), p));
}

class AllSolvers : public ::testing::TestWithParam<SolverSettings::Kind> {};

TEST_P(AllSolvers, FreeFallFollowsTheDiscreteRecurrence) {
  auto sim = makeSheet(4, 2.0, GetParam());
  const Vec3 g{0.3, -9.81, 0.5};
  sim->setGravity(g);
  const double h = 0.01;
  std::vector<double> x0(sim->state().x().begin(), sim->state().x().end());
  const int k = 25;
  for (int i = 0; i < k; ++i) sim->step(h);
  // Symplectic and implicit Euler both give v_k = k h g, x_k = x_0 + h^2 g k (k + 1) / 2.
  auto x = sim->state().x();
  auto v = sim->state().v();
  for (std::size_t p = 0; p < x.size() / 3; ++p)
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(v[3 * p + c], k * h * g[c], 1e-12);
      EXPECT_NEAR(x[3 * p + c], x0[3 * p + c] + h * h * g[c] * k * (k + 1) / 2.0, 1e-12);
    }
  EXPECT_NEAR(sim->time(), k * h, 1e-12);
  EXPECT_EQ(sim->steps(), k);
}

TEST_P(AllSolvers, FixedPointsStayAndGraspsFollowTheirPath) {
  auto sim = makeSheet(5, 1.0, GetParam());
  sim->setGravity({0, 0, -9.81});
  addBending(*sim, 1e-3);
  sim->fixed().add(topology::PointId(0));
  sim->fixed().add(topology::PointId(4));
  core::DisplacementPath path;
  path.times = {0.0, 0.1};
  path.displacements = {{0, 0, 0}, {0, 0, 0.05}};
  std::vector<topology::PointId> grasped{topology::PointId(24)};
  sim->addGrasp("pull", grasped, path);
  auto x0 = std::vector<double>(sim->state().x().begin(), sim->state().x().end());
  for (int i = 0; i < 20; ++i) sim->step(0.01);
  auto x = sim->state().x();
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(x[c], x0[c]);
    EXPECT_EQ(x[12 + c], x0[12 + c]);
  }
  EXPECT_NEAR(x[3 * 24 + 2], x0[3 * 24 + 2] + 0.05, 1e-12);
  // The grasp holds the sheet up against gravity: it pulls up (+z) on average.
  EXPECT_GT(sim->grasp(0).reaction()[2], 0.0);
  sim->releaseGrasp("pull");
  EXPECT_EQ(sim->numGrasps(), 0u);
  EXPECT_THROW(sim->releaseGrasp("pull"), InvalidInput);
}

INSTANTIATE_TEST_SUITE_P(Solvers, AllSolvers,
                         ::testing::Values(SolverSettings::Kind::Explicit,
                                           SolverSettings::Kind::ImplicitCG,
                                           SolverSettings::Kind::ImplicitCholmod),
                         [](const auto& solverInfo) {
                           std::string s(core::toString(solverInfo.param));
                           for (auto& c : s)
                             if (c == '-') c = '_';
                           return s;
                         });

/// A sheet with a bump: x displaced out of plane so the bending springs act.
void bump(Simulation& sim, double amplitude) {
  auto x = sim.state().x();
  for (std::size_t p = 0; p < x.size() / 3; ++p) {
    double u = x[3 * p], w = x[3 * p + 1];
    x[3 * p + 2] = amplitude * std::sin(3.14159 * u) * std::sin(3.14159 * w);
  }
}

TEST(Simulation, ExplicitAndImplicitAgreeOnASmallStableCase) {
  std::vector<std::vector<double>> results;
  for (auto kind : {SolverSettings::Kind::Explicit, SolverSettings::Kind::ImplicitCholmod}) {
    auto sim = makeSheet(6, 1.0, kind);
    addBending(*sim, 1e-2);
    sim->fixed().add(topology::PointId(0));
    sim->fixed().add(topology::PointId(5));
    sim->setGravity({0, 0, -1});
    bump(*sim, 0.05);
    for (int i = 0; i < 200; ++i) sim->step(1e-4);
    results.emplace_back(sim->state().x().begin(), sim->state().x().end());
  }
  double diff = 0, motion = 0;
  auto sim = makeSheet(6, 1.0, SolverSettings::Kind::Explicit);
  bump(*sim, 0.05);
  for (std::size_t i = 0; i < results[0].size(); ++i) {
    diff = std::max(diff, std::abs(results[0][i] - results[1][i]));
    motion = std::max(motion, std::abs(results[0][i] - sim->state().x()[i]));
  }
  EXPECT_GT(motion, 1e-4);
  EXPECT_LT(diff, 0.02 * motion);  // first-order methods, differing by O(h)
}

TEST(Simulation, ImplicitEnergyDoesNotGrowWithBendingAlone) {
  for (auto kind : {SolverSettings::Kind::ImplicitCG, SolverSettings::Kind::ImplicitCholmod}) {
    auto sim = makeSheet(7, 1.0, kind);
    addBending(*sim, 1.0);
    bump(*sim, 0.1);
    double previous = std::numeric_limits<double>::infinity();
    for (int i = 0; i < 100; ++i) {
      sim->step(0.01);
      double e = sim->kineticEnergy() + sim->potentialEnergy(0);
      EXPECT_LE(e, previous * (1 + 1e-9) + 1e-15) << core::toString(kind) << " step " << i;
      previous = e;
    }
    EXPECT_GT(previous, 0.0);
  }
}

TEST(Simulation, CgAndCholmodGiveTheSameStep) {
  std::vector<std::vector<double>> v;
  for (auto kind : {SolverSettings::Kind::ImplicitCG, SolverSettings::Kind::ImplicitCholmod}) {
    auto sim = makeSheet(8, 1.0, kind);
    addBending(*sim, 0.5, 0.01);
    sim->fixed().add(topology::PointId(0));
    sim->setGravity({0, -1, -9.81});
    bump(*sim, 0.1);
    sim->step(0.02);
    v.emplace_back(sim->state().v().begin(), sim->state().v().end());
  }
  for (std::size_t i = 0; i < v[0].size(); ++i) EXPECT_NEAR(v[0][i], v[1][i], 1e-8);
}

TEST(Simulation, CuttingConservesMassAndKeepsEverythingConsistent) {
  auto sim = makeSheet(11, 3.0, SolverSettings::Kind::ImplicitCholmod);
  addBending(*sim, 1e-2);
  sim->fixed().add(topology::PointId(0));
  sim->fixed().add(topology::PointId(10));
  sim->setGravity({0, 0, -9.81});
  const double mass0 = sim->mass().total();
  EXPECT_NEAR(mass0, 3.0, 1e-12);  // density 3 on the unit square
  for (int i = 0; i < 10; ++i) sim->step(0.01);
  auto r = sim->step(0.01);
  EXPECT_FALSE(r.analysed);  // nothing changed: the symbolic analysis is reused
  std::vector<Vec3> cut{{0.0, 0.55, 0.0}, {0.63, 0.55, 0.0}};
  sim->topology().cutPolyline(cut);
  EXPECT_NEAR(sim->mass().total(), mass0, 1e-12);
  ASSERT_TRUE(sim->topology().validate().ok()) << sim->topology().validate().summary();
  r = sim->step(0.01);
  EXPECT_TRUE(r.analysed);  // the cut changed the sparsity pattern
  sim->topology().tear(sim->topology().findEdge(topology::PointId(60), topology::PointId(61)));
  EXPECT_NEAR(sim->mass().total(), mass0, 1e-12);
  for (int i = 0; i < 20; ++i) sim->step(0.01);
  for (double c : sim->state().x()) ASSERT_TRUE(std::isfinite(c));
  ASSERT_TRUE(sim->topology().validate().ok()) << sim->topology().validate().summary();
  // Carving takes away exactly the removed triangles' mass.
  auto tris = sim->topology().triangles();
  double removed = 0;
  std::vector<topology::TriangleId> rm(tris.begin(), tris.begin() + 5);
  for (auto f : rm) removed += 3.0 * core::LumpedMass::triangleArea(sim->topology(), f);
  sim->topology().removeTriangles(rm);
  EXPECT_NEAR(sim->mass().total(), mass0 - removed, 1e-12);
  sim->topology().compact();
  ASSERT_TRUE(sim->topology().validate().ok()) << sim->topology().validate().summary();
  for (int i = 0; i < 5; ++i) sim->step(0.01);
}

/// Floating-point traps off for a test that makes infinities on purpose.
struct NoFpTraps {
  int saved = fegetexcept();
  NoFpTraps() { fedisableexcept(FE_ALL_EXCEPT); }
  ~NoFpTraps() {
    feclearexcept(FE_ALL_EXCEPT);
    feenableexcept(saved);
  }
};

TEST(Simulation, NonFiniteValuesStopTheRunWithAMessage) {
  NoFpTraps noTraps;
  auto sim = makeSheet(5, 1.0, SolverSettings::Kind::ImplicitCG);
  addBending(*sim, 1.0);
  sim->state().x()[3 * 7 + 1] = std::numeric_limits<double>::infinity();
  try {
    sim->step(0.01);
    ADD_FAILURE() << "no error";
  } catch (const SolverError& e) {
    std::string m = e.what();
    EXPECT_NE(m.find("step 1"), std::string::npos) << m;
    EXPECT_NE(m.find("FastTriangularBendingSprings"), std::string::npos) << m;
  }
  // An explicit step far beyond the stability limit blows up and is stopped with a hint.
  auto ex = makeSheet(5, 1e-3, SolverSettings::Kind::Explicit);
  addBending(*ex, 1e6);
  bump(*ex, 0.1);
  try {
    for (int i = 0; i < 2000; ++i) ex->step(0.1);
    ADD_FAILURE() << "the explicit run did not blow up";
  } catch (const SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("smaller"), std::string::npos) << e.what();
  }
}

TEST(Simulation, BadSettingsAreRejected) {
  auto sim = makeSheet(3, 1.0, SolverSettings::Kind::ImplicitCG);
  SolverSettings s;
  s.cgTolerance = -1;
  EXPECT_THROW(sim->setSolver(s), InvalidInput);
  s = {};
  s.rayleighMass = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(sim->setSolver(s), InvalidInput);
  EXPECT_THROW(sim->step(-0.1), InvalidInput);
  EXPECT_THROW(sim->step(0.0), InvalidInput);
  EXPECT_THROW(core::parseSolverKind("magic"), InvalidInput);
  EXPECT_THROW(core::LumpedMass(sim->topology(), -1.0), InvalidInput);
}

}  // namespace
}  // namespace cutsim::test
