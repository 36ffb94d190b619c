// The force fields' passes on several threads (forcefields/src/parallel.hpp): a pass split by the
// points it writes gives the one-thread pass's bits, for 1, 2 and 3 threads, on a fresh mesh, a
// mesh numbered at random (many elements shared by two parts), after cuts (the split rebuilt
// from the changed table) and after compaction (the table renumbered).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "cutsim/base/threads.hpp"
#include "cutsim/core/simulation.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/forcefields/stretch_springs.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/fixtures.hpp"

namespace cutsim {
namespace {

using forcefields::ForceField;
using topology::PointId;
using topology::Topology;

/// Restores the process's thread setting when the test ends.
struct ThreadSetting {
  ~ThreadSetting() { setThreads(0); }
};

/// A deformed configuration of every point slot (stretched and compressed springs, curvature),
/// and a direction for the products.
struct Vectors {
  std::vector<double> x, v, dx;
};

Vectors deformed(const Topology& t, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vectors s;
  const std::size_t n = t.pointCapacity();
  s.x.resize(3 * n);
  s.v.resize(3 * n);
  s.dx.resize(3 * n);
  for (std::size_t p = 0; p < n; ++p) {
    const topology::Vec3 r = t.restPosition(PointId(topology::Index(p)));
    s.x[3 * p] = r[0] + 0.02 * u(rng);
    s.x[3 * p + 1] = r[1] + 0.02 * u(rng);
    s.x[3 * p + 2] = 0.3 * std::sin(r[0]) * std::cos(0.7 * r[1]) + 0.01 * u(rng);
    for (int c = 0; c < 3; ++c) {
      s.v[3 * p + std::size_t(c)] = u(rng);
      s.dx[3 * p + std::size_t(c)] = u(rng);
    }
  }
  return s;
}

/// Every pass of the field that threads split (force, the product twice: the linearisation made,
/// then reused, with another direction), its outputs appended in one vector.
std::vector<double> passes(const ForceField& f, const Vectors& s) {
  const std::size_t n = s.x.size();
  std::vector<double> out(3 * n, 0.0);
  std::span<double> all(out);
  // A product at other positions first: the one at x makes its linearisation anew.
  std::vector<double> other = s.x, scratch(n, 0.0);
  for (double& e : other) e *= 1.0 + 1e-3;
  f.addDForce(other, s.dx, scratch, -1e-4, -1e-2);
  f.addForce(s.x, s.v, all.subspan(0, n));
  f.addDForce(s.x, s.dx, all.subspan(n, n), -1e-4, -1e-2);
  std::vector<double> dx2(s.dx.rbegin(), s.dx.rend());
  f.addDForce(s.x, dx2, all.subspan(2 * n, n), -1e-4, -1e-2);
  return out;
}

/// The passes with 1, 2 and 3 threads agree to the bit; `what` names the case.
void sameBitsForAnyThreads(const ForceField& f, const Topology& t, const std::string& what) {
  SCOPED_TRACE(what + ", " + f.typeName());
  const Vectors s = deformed(t, 11);
  setThreads(1);
  const std::vector<double> one = passes(f, s);
  bool moved = false;
  for (double d : one) moved = moved || d != 0.0;
  ASSERT_TRUE(moved) << "the passes compute something";
  for (int threads : {2, 3, 2}) {
    setThreads(threads);
    const std::vector<double> many = passes(f, s);
    ASSERT_EQ(many.size(), one.size());
    std::size_t differ = 0, first = 0;
    for (std::size_t i = 0; i < one.size(); ++i)
      if (std::memcmp(&one[i], &many[i], sizeof(double)) != 0 && differ++ == 0) first = i;
    EXPECT_EQ(differ, 0u) << threads << " threads: " << differ << " entries differ, the first "
                          << first << " (" << one[first] << " vs " << many[first] << ")";
  }
}

struct Fields {
  std::unique_ptr<forcefields::StretchSprings> stretch;
  std::unique_ptr<forcefields::FastTriangularBendingSprings> bending;
};

Fields fieldsOn(Topology& t, bool stableJacobian) {
  forcefields::StretchParameters sp;
  sp.stiffness = 300.0;
  sp.damping = 0.7;
  sp.stableJacobian = stableJacobian;
  forcefields::BendingParameters bp;
  bp.bendingStiffness = 0.05;
  bp.rayleighStiffness = 0.1;
  return {std::make_unique<forcefields::StretchSprings>(t, sp),
          std::make_unique<forcefields::FastTriangularBendingSprings>(t, bp)};
}

/// A hanging sheet (stretch springs, bending springs, two corners held) stepped with CG, the
/// positions after each step appended.
std::vector<double> hangingSheetSteps(int steps) {
  // 96 x 96 points: CG's vectors (27,648 entries) in three parts too.
  auto sim =
      std::make_unique<core::Simulation>(std::make_unique<Topology>(test::grid(96, 1.0)), 0.2);
  Fields f = fieldsOn(sim->topology(), true);
  sim->addForceField(std::move(f.stretch));
  sim->addForceField(std::move(f.bending));
  sim->fixed().add(PointId(0));
  sim->fixed().add(PointId(95));
  sim->setGravity({0, 0, -9.81});
  core::SolverSettings s;
  s.kind = core::SolverSettings::Kind::ImplicitCG;
  s.cgMaxIterations = 30;
  s.cgTolerance = 1e-8;
  s.rayleighMass = 0.1;
  s.onSolveFailure = core::SolveFailurePolicy::Warn;
  sim->setSolver(s);
  std::vector<double> out;
  for (int i = 0; i < steps; ++i) {
    sim->step(2e-3);
    const auto x = sim->state().x();
    out.insert(out.end(), x.begin(), x.end());
  }
  return out;
}

// A grid large enough for three parts (every part has at least 4096 elements).
constexpr int kSide = 72;

TEST(Threads, ForcePassesAndProductsGiveTheSameBitsForOneTwoAndThreeThreads) {
  ThreadSetting restore;
  for (bool stable : {true, false}) {
    Topology t(test::grid(kSide, 10.0, 0.2));
    Fields f = fieldsOn(t, stable);
    const std::string jac = stable ? "stable Jacobian" : "exact Jacobian";
    sameBitsForAnyThreads(*f.stretch, t, "fresh grid, " + jac);
    sameBitsForAnyThreads(*f.bending, t, "fresh grid, " + jac);
  }
  // Numbered at random: most elements have points in two or three parts.
  Topology shuffled(test::shuffledVertices(test::grid(kSide, 10.0, 0.2), 5));
  Fields g = fieldsOn(shuffled, true);
  sameBitsForAnyThreads(*g.stretch, shuffled, "shuffled numbering");
  sameBitsForAnyThreads(*g.bending, shuffled, "shuffled numbering");
}

TEST(Threads, TheSplitFollowsCutsAndCompaction) {
  ThreadSetting restore;
  Topology t(test::grid(kSide, 10.0, 0.2));
  Fields f = fieldsOn(t, true);
  setThreads(3);
  sameBitsForAnyThreads(*f.stretch, t, "before the cuts");  // (the split made for the grid)
  const std::vector<topology::Vec3> cuts[] = {{{1.3, 2.1, 0}, {8.7, 3.4, 0}},
                                              {{2.2, 8.9, 0}, {5.1, 4.3, 0}, {7.9, 8.6, 0}}};
  for (const auto& polyline : cuts) {
    t.cutPolyline(polyline);
    sameBitsForAnyThreads(*f.stretch, t, "after a cut");
    sameBitsForAnyThreads(*f.bending, t, "after a cut");
  }
  t.compact();
  sameBitsForAnyThreads(*f.stretch, t, "after compaction");
  sameBitsForAnyThreads(*f.bending, t, "after compaction");
  std::vector<std::string> problems;
  f.stretch->validate(t, problems);
  f.bending->validate(t, problems);
  EXPECT_TRUE(problems.empty()) << problems.front();
}

// Whole steps (the force passes, CG's products and its vector work, on the threads) give the same
// positions, bit for bit, for 1, 2 and 3 threads.
TEST(Threads, StepsGiveTheSameBitsForOneTwoAndThreeThreads) {
  ThreadSetting restore;
  setThreads(1);
  const std::vector<double> one = hangingSheetSteps(6);
  for (int threads : {2, 3}) {
    setThreads(threads);
    const std::vector<double> many = hangingSheetSteps(6);
    ASSERT_EQ(many.size(), one.size());
    EXPECT_EQ(std::memcmp(one.data(), many.data(), one.size() * sizeof(double)), 0)
        << threads << " threads";
  }
}

}  // namespace
}  // namespace cutsim
