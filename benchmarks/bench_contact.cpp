// The cost of contact: one implicit Euler step with CG capped at 20 iterations (CG20) of a 127 x
// 127 cloth (16,129 vertices) in three configurations, with contact and without it (the same
// positions and fields):
//   drape  a cover draped over a ball of radius 0.25 m standing on a table, at rest: from the
//          top it follows the ball to 70 degrees from the pole, leaves it along the tangent
//          down to the table and lies on it, half the contact thickness off both (this is its
//          rest shape: no elastic force, the penalty carries the weight) (obstacle contact);
//   fold   the cloth folded over on itself about its middle column, its two layers half the
//          thickness apart (self-contact): each upper point is over a lower point and each edge
//          over an edge, every pair at a feature's boundary;
//   fold_shifted  the same with the upper layer moved by (h/3, h/5) in its plane (h: the grid's
//          spacing), so that its points are over the lower layer's triangles, as a fold that
//          fell into place would lie;
//   cliff  a stress case: the cloth lifted onto the ball where the ball is below it and left
//          on the table elsewhere, a 0.25 m step at the ball's rim (far from equilibrium: the
//          solve proposes displacements of several edges, and the step splits).
// Each iteration restores the same state and takes one step, so every iteration does the same
// work: contact's cost (detection at the step's start, the penalty and friction in the solve,
// the displacement bound after it) is the difference of the two figures. A first step, outside
// the timing (its time is the counter first_step_ms), builds the search's cache, which every
// timed step then reuses; the *_searched_every_step variants turn the cache off.
//
//   cutsim_bench_contact --benchmark_min_time=2
//
// BM_ContactCgIterations counts the CG iterations of one step to a relative residual of 1e-6,
// with contact and without it.
#include <benchmark/benchmark.h>

#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <vector>

#include "cutsim/core/contact_step.hpp"
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

enum class Shape { Drape, Fold, FoldShifted, Cliff };

constexpr double kBallRadius = 0.25;

/// Where the configuration puts the grid's point (X, Y).
std::array<double, 3> placed(Shape shape, double X, double Y) {
  const double R = kBallRadius, half = 0.5 * kThickness;
  double Z = 0;
  if (shape == Shape::Fold || shape == Shape::FoldShifted) {
    // The half x > 0 folded back over the other, half the thickness above it (shifted: by a
    // third and a fifth of the grid's spacing).
    if (X > 0) {
      const double h = shape == Shape::FoldShifted ? 1.0 / (kSide - 1) : 0.0;
      X = -X + h / 3;
      Y += h / 5;
      Z = half;
    }
    Z += half;
  } else if (shape == Shape::Cliff) {
    // Over the ball (centre (0, 0, R)) where it is below the cloth, else on the table.
    const double rr = std::hypot(X, Y);
    Z = rr < R ? R + std::sqrt(R * R - rr * rr) + half : half;
  } else {
    // The profile in (distance from the axis, height) at arc length rho from the top: on the
    // ball (radius R + half) to theta0, then along the tangent, then on the table.
    const double rho = std::hypot(X, Y), Rh = R + half, theta0 = 70.0 * M_PI / 180.0;
    const double arc = Rh * theta0, r0 = Rh * std::sin(theta0), z0 = R + Rh * std::cos(theta0);
    const double line = (z0 - half) / std::sin(theta0);
    double r = 0;
    if (rho <= arc) {
      r = Rh * std::sin(rho / Rh);
      Z = R + Rh * std::cos(rho / Rh);
    } else if (rho <= arc + line) {
      r = r0 + (rho - arc) * std::cos(theta0);
      Z = z0 - (rho - arc) * std::sin(theta0);
    } else {
      r = r0 + line * std::cos(theta0) + (rho - arc - line);
      Z = half;
    }
    const double c = rho > 0 ? r / rho : 0.0;
    X *= c;
    Y *= c;
  }
  return {X, Y, Z};
}

Setup make(Shape shape, bool contact, double searchSlack = ContactParameters{}.searchSlack,
           int cgMaxIterations = 20, double cgTolerance = 1e-12) {
  const bool fold = shape == Shape::Fold || shape == Shape::FoldShifted;
  cutsim::core::GridSpec g;
  g.nx = g.ny = kSide;
  g.width = g.height = 1.0;
  g.origin = {-0.5, -0.5, 0.0};
  cutsim::topology::MeshData mesh = cutsim::core::makeGrid(g);
  // The drape is the cloth's rest shape (a tailored cover at rest on the ball: no elastic force,
  // the penalty carries the weight); the fold and the cliff are a flat cloth deformed.
  if (shape == Shape::Drape)
    for (auto& p : mesh.points) {
      const auto q = placed(shape, p[0], p[1]);
      p = {q[0], q[1], q[2]};
    }
  Setup s;
  s.sim = std::make_unique<Simulation>(std::make_unique<Topology>(std::move(mesh)), 0.2);
  Simulation& sim = *s.sim;
  cutsim::forcefields::StretchParameters stretch;
  stretch.stiffness = 200.0;
  stretch.damping = 0.05;
  sim.addForceField(std::make_unique<cutsim::forcefields::StretchSprings>(sim.topology(), stretch));
  cutsim::forcefields::BendingParameters bending;
  bending.bendingStiffness = 1e-4;
  sim.addForceField(
      std::make_unique<cutsim::forcefields::FastTriangularBendingSprings>(sim.topology(), bending));
  sim.setGravity({0, 0, -9.81});
  auto x = sim.state().x();
  const double R = kBallRadius;
  for (PointId p : sim.topology().points()) {
    const auto r = sim.topology().restPosition(p);
    const auto q =
        shape == Shape::Drape ? std::array<double, 3>{r[0], r[1], r[2]} : placed(shape, r[0], r[1]);
    for (int c = 0; c < 3; ++c) x[3 * p.idx() + std::size_t(c)] = q[std::size_t(c)];
  }
  if (contact) {
    ContactParameters c;
    c.thickness = kThickness;
    c.stiffness = 0.5;
    c.friction = 0.3;
    c.searchSlack = searchSlack;
    std::vector<Obstacle> obstacles;
    if (!fold) {
      Obstacle ball;
      ball.shape = cutsim::forcefields::sphereShape({0, 0, R}, R);
      ball.friction = 0.2;
      Obstacle table;
      table.shape = cutsim::forcefields::planeShape({0, 0, 0}, {0, 0, 1});
      table.friction = 0.4;
      obstacles = {ball, table};
    }
    cutsim::core::addContact(
        sim, std::make_unique<cutsim::forcefields::Contact>(sim.topology(), c, obstacles));
  }
  SolverSettings st;
  st.kind = SolverSettings::Kind::ImplicitCG;
  st.cgMaxIterations = cgMaxIterations;
  st.cgTolerance = cgTolerance;  // by default 1e-12, so that the cap of 20 decides the work
  st.cgWarmStart = false;
  st.rayleighMass = 0.1;
  st.onSolveFailure = cutsim::core::SolveFailurePolicy::Warn;
  sim.setSolver(st);
  s.x.assign(x.begin(), x.end());
  s.v.assign(s.x.size(), 0.0);
  return s;
}

void BM_ContactStep(benchmark::State& state, Shape shape, bool contact,
                    double searchSlack = ContactParameters{}.searchSlack) {
  Setup s = make(shape, contact, searchSlack);
  long clamped = 0, active = 0;
  // The first step builds the search's cache (when there is one): timed apart, so that the
  // figure is the step that reuses it, whatever the number of iterations the run settles on.
  const auto start = std::chrono::steady_clock::now();
  s.sim->step(1e-3);
  state.counters["first_step_ms"] =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  for (auto _ : state) {
    std::copy(s.x.begin(), s.x.end(), s.sim->state().x().begin());
    std::copy(s.v.begin(), s.v.end(), s.sim->state().v().begin());
    const auto st = s.sim->step(1e-3);
    clamped += st.clamped;
    benchmark::DoNotOptimize(s.sim->state().x().data());
  }
  if (const auto* c = cutsim::core::findContact(*s.sim)) active = long(c->lastStep().active);
  state.counters["clamped_per_step"] = double(clamped) / double(state.iterations());
  state.counters["pairs_in_contact"] = double(active);
  state.counters["vertices"] = double(kSide * kSide);
}

/// CG iterations to a relative residual of 1e-6 (no cap that binds, no warm start) in one step,
/// with contact and without it: how much contact's stiffness worsens the system's conditioning.
void BM_ContactCgIterations(benchmark::State& state, Shape shape, bool contact) {
  Setup s = make(shape, contact, ContactParameters{}.searchSlack, 5000, 1e-6);
  long iterations = 0;
  for (auto _ : state) {
    std::copy(s.x.begin(), s.x.end(), s.sim->state().x().begin());
    std::copy(s.v.begin(), s.v.end(), s.sim->state().v().begin());
    const auto st = s.sim->step(1e-3);
    iterations += long(st.iterations);
    benchmark::DoNotOptimize(s.sim->state().x().data());
  }
  state.counters["cg_iterations"] = double(iterations) / double(state.iterations());
}

}  // namespace

BENCHMARK_CAPTURE(BM_ContactCgIterations, drape_without_contact, Shape::Drape, false)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
BENCHMARK_CAPTURE(BM_ContactCgIterations, drape_with_contact, Shape::Drape, true)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
BENCHMARK_CAPTURE(BM_ContactCgIterations, fold_without_contact, Shape::Fold, false)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
BENCHMARK_CAPTURE(BM_ContactCgIterations, fold_with_contact, Shape::Fold, true)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
BENCHMARK_CAPTURE(BM_ContactCgIterations, fold_shifted_without_contact, Shape::FoldShifted, false)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
BENCHMARK_CAPTURE(BM_ContactCgIterations, fold_shifted_with_contact, Shape::FoldShifted, true)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
BENCHMARK_CAPTURE(BM_ContactStep, drape_without_contact, Shape::Drape, false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ContactStep, drape_with_contact, Shape::Drape, true)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ContactStep, fold_without_contact, Shape::Fold, false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ContactStep, fold_with_contact, Shape::Fold, true)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ContactStep, fold_shifted_without_contact, Shape::FoldShifted, false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ContactStep, fold_shifted_with_contact, Shape::FoldShifted, true)
    ->Unit(benchmark::kMillisecond);
// The same without the search's cache (searched at every step, as a cloth that keeps moving is).
BENCHMARK_CAPTURE(BM_ContactStep, drape_with_contact_searched_every_step, Shape::Drape, true, 0.0)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ContactStep, fold_with_contact_searched_every_step, Shape::Fold, true, 0.0)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ContactStep, cliff_without_contact, Shape::Cliff, false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ContactStep, cliff_with_contact, Shape::Cliff, true)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

BENCHMARK_MAIN();
