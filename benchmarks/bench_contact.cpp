// The cost of contact: one implicit Euler step with CG capped at 20 iterations (CG20) of a 127 x
// 127 cloth (16,129 vertices) in two configurations, with contact and without it (the same
// positions and fields):
//   drape  the cloth laid over a ball of radius 0.25 m standing on a table, at half the contact
//          thickness from both (obstacle contact);
//   fold   the cloth folded over on itself, its two layers half the thickness apart
//          (self-contact).
// Each iteration restores the same state and takes one step, so every iteration does the same
// work: contact's cost (detection at the step's start, the penalty and friction in the solve,
// the displacement bound after it) is the difference of the two figures.
//
//   cutsim_bench_contact --benchmark_min_time=2
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <vector>

#include "cutsim/core/scene.hpp"
#include "cutsim/core/simulation.hpp"
#include "cutsim/forcefields/contact.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/forcefields/stretch_springs.hpp"

namespace {

using cutsim::core::Simulation;
using cutsim::core::SolverSettings;
using cutsim::forcefields::ContactParameters;
using cutsim::forcefields::Obstacle;
using cutsim::topology::PointId;
using cutsim::topology::Topology;

constexpr int kSide = 127;
constexpr double kThickness = 0.004;

struct Setup {
  std::unique_ptr<Simulation> sim;
  std::vector<double> x, v;
};

Setup make(bool fold, bool contact) {
  cutsim::core::GridSpec g;
  g.nx = g.ny = kSide;
  g.width = g.height = 1.0;
  g.origin = {-0.5, -0.5, 0.0};
  Setup s;
  s.sim = std::make_unique<Simulation>(std::make_unique<Topology>(cutsim::core::makeGrid(g)), 0.2);
  Simulation& sim = *s.sim;
  cutsim::forcefields::StretchParameters stretch;
  stretch.stiffness = 200.0;
  stretch.damping = 0.05;
  sim.addForceField(std::make_unique<cutsim::forcefields::StretchSprings>(sim.topology(), stretch));
  cutsim::forcefields::BendingParameters bending;
  bending.bendingStiffness = 1e-4;
  sim.addForceField(std::make_unique<cutsim::forcefields::FastTriangularBendingSprings>(sim.topology(), bending));
  sim.setGravity({0, 0, -9.81});
  // The configuration: positions from the rest grid.
  auto x = sim.state().x();
  const double R = 0.25, half = 0.5 * kThickness;
  for (PointId p : sim.topology().points()) {
    const auto r = sim.topology().restPosition(p);
    double X = r[0], Y = r[1], Z = 0;
    if (fold) {
      // The half x > 0 folded back over the other, half the thickness above it.
      if (X > 0) {
        X = -X;
        Z = half;
      }
      Z += half;
    } else {
      // Over the ball (centre (0, 0, R)) where it is below the cloth, else on the table.
      const double rr = std::hypot(X, Y);
      if (rr < R) {
        Z = R + std::sqrt(R * R - rr * rr) + half;
      } else {
        Z = half;
      }
    }
    x[3 * p] = X;
    x[3 * p + 1] = Y;
    x[3 * p + 2] = Z;
  }
  if (contact) {
    ContactParameters c;
    c.thickness = kThickness;
    c.stiffness = 0.5;
    c.friction = 0.3;
    std::vector<Obstacle> obstacles;
    if (!fold) {
      Obstacle ball;
      ball.shape = Obstacle::Shape::Sphere;
      ball.point = {0, 0, R};
      ball.radius = R;
      ball.friction = 0.2;
      Obstacle table;
      table.shape = Obstacle::Shape::Plane;
      table.friction = 0.4;
      obstacles = {ball, table};
    }
    sim.model().setContact(std::make_unique<cutsim::forcefields::Contact>(sim.topology(), c, obstacles));
  }
  SolverSettings st;
  st.kind = SolverSettings::Kind::ImplicitCG;
  st.cgMaxIterations = 20;
  st.cgTolerance = 1e-12;  // so that the cap decides the work
  st.cgWarmStart = false;
  st.rayleighMass = 0.1;
  st.onSolveFailure = cutsim::core::SolveFailurePolicy::Warn;
  sim.setSolver(st);
  s.x.assign(x.begin(), x.end());
  s.v.assign(s.x.size(), 0.0);
  return s;
}

void BM_ContactStep(benchmark::State& state, bool fold, bool contact) {
  Setup s = make(fold, contact);
  long clamped = 0, active = 0;
  for (auto _ : state) {
    std::copy(s.x.begin(), s.x.end(), s.sim->state().x().begin());
    std::copy(s.v.begin(), s.v.end(), s.sim->state().v().begin());
    const auto st = s.sim->step(1e-3);
    clamped += st.clamped;
    benchmark::DoNotOptimize(s.sim->state().x().data());
  }
  if (const auto* c = s.sim->model().contact()) active = long(c->lastStep().active);
  state.counters["clamped_per_step"] = double(clamped) / double(state.iterations());
  state.counters["pairs_in_contact"] = double(active);
  state.counters["vertices"] = double(kSide * kSide);
}

}  // namespace

BENCHMARK_CAPTURE(BM_ContactStep, drape_without_contact, false, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ContactStep, drape_with_contact, false, true)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ContactStep, fold_without_contact, true, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ContactStep, fold_with_contact, true, true)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
