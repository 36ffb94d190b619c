// One time step of a hanging cloth (StretchSprings + FastTriangularBendingSprings, two corners
// fixed, gravity) per integrator, and the stretch force pass, over mesh sizes.
// items_per_second = vertices per second.
//
//   cutsim_bench_solver                                   # all sizes (CHOLMOD up to 100k vertices)
//   cutsim_bench_solver --benchmark_filter='/101$'        # the 10k-vertex cloth only
//   cutsim_bench_solver --benchmark_format=json > solver.json
#include <benchmark/benchmark.h>

#include <functional>
#include <memory>
#include <vector>

#include "cutsim/core/integrators/bdf2.hpp"
#include "cutsim/core/integrators/newton.hpp"
#include "cutsim/core/simulation.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/forcefields/stretch_springs.hpp"

namespace {

using cutsim::core::Simulation;
using cutsim::core::SolverSettings;
using cutsim::topology::PointId;
using cutsim::topology::Topology;
using cutsim::topology::TriangleVertices;
using cutsim::topology::Vec3;

/// A 1 m square cloth of n x n vertices in the xz plane (alternating diagonals), 0.2 kg/m^2,
/// fixed at its two top corners, stepped a few times so that it is moving and stretched.
std::unique_ptr<Simulation> cloth(int n, SolverSettings::Kind kind, int cgIterations) {
  std::vector<Vec3> pts;
  std::vector<TriangleVertices> tris;
  const double h = 1.0 / (n - 1);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) pts.push_back({h * i, 0.0, -h * j});
  auto id = [n](int i, int j) { return PointId(j * n + i); };
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      if ((i + j) % 2 == 0) {
        tris.push_back({id(i, j), id(i + 1, j + 1), id(i + 1, j)});
        tris.push_back({id(i, j), id(i, j + 1), id(i + 1, j + 1)});
      } else {
        tris.push_back({id(i, j), id(i, j + 1), id(i + 1, j)});
        tris.push_back({id(i + 1, j), id(i, j + 1), id(i + 1, j + 1)});
      }
    }
  auto sim = std::make_unique<Simulation>(std::make_unique<Topology>(pts, tris), 0.2);
  cutsim::forcefields::StretchParameters stretch;
  stretch.stiffness = 200.0;
  stretch.damping = 0.05;
  sim->addForceField(
      std::make_unique<cutsim::forcefields::StretchSprings>(sim->topology(), stretch));
  cutsim::forcefields::BendingParameters bending;
  bending.bendingStiffness = 1e-4;
  sim->addForceField(std::make_unique<cutsim::forcefields::FastTriangularBendingSprings>(
      sim->topology(), bending));
  sim->fixed().add(id(0, 0));
  sim->fixed().add(id(n - 1, 0));
  sim->setGravity({0, 0, -9.81});
  SolverSettings s;
  s.kind = kind;
  s.cgMaxIterations = cgIterations;
  s.cgTolerance = 1e-10;  // so that the cap decides the work
  s.rayleighMass = 0.1;
  // A capped CG is kept as it is (flagged): the step does the same work as before the failure
  // policy existed, so that the figures compare.
  s.onSolveFailure = cutsim::core::SolveFailurePolicy::Warn;
  sim->setSolver(s);
  return sim;
}

double stepFor(SolverSettings::Kind kind) {
  return kind == SolverSettings::Kind::Explicit ? 1e-5 : 2e-3;
}

void BM_Step(benchmark::State& st, SolverSettings::Kind kind, int cgIterations) {
  const int n = int(st.range(0));
  auto sim = cloth(n, kind, cgIterations);
  const double dt = stepFor(kind);
  for (int i = 0; i < 3; ++i) sim->step(dt);
  int iterations = 0, analyses = 0;
  for (auto _ : st) {
    auto stats = sim->step(dt);
    iterations += stats.iterations;
    analyses += stats.analysed ? 1 : 0;
  }
  st.counters["symbolic_analyses"] = analyses;
  st.SetItemsProcessed(st.iterations() * std::int64_t(n) * n);
  st.counters["vertices"] = double(n) * n;
  st.counters["solver_iterations"] =
      benchmark::Counter(iterations, benchmark::Counter::kAvgIterations);
}

/// One step of an integrator that the shorthand settings do not describe (BDF2, Newton).
void BM_StepWith(benchmark::State& st,
                 std::function<std::unique_ptr<cutsim::core::Integrator>()> make) {
  const int n = int(st.range(0));
  auto sim = cloth(n, SolverSettings::Kind::ImplicitCholmod, 1);
  sim->setIntegrator(make());
  const double dt = 2e-3;
  for (int i = 0; i < 3; ++i) sim->step(dt);
  int newton = 0;
  for (auto _ : st) newton += sim->step(dt).newtonIterations;
  st.SetItemsProcessed(st.iterations() * std::int64_t(n) * n);
  st.counters["newton_iterations"] = benchmark::Counter(newton, benchmark::Counter::kAvgIterations);
}

cutsim::core::ImplicitSettings damped() {
  cutsim::core::ImplicitSettings s;
  s.rayleighMass = 0.1;
  return s;
}

void BM_StretchForce(benchmark::State& st) {
  const int n = int(st.range(0));
  auto sim = cloth(n, SolverSettings::Kind::Explicit, 1);
  std::vector<double> f(sim->state().x().size());
  const auto& field = sim->forceField(0);
  for (auto _ : st) {
    field.addForce(sim->state().x(), sim->state().v(), f);
    benchmark::DoNotOptimize(f.data());
  }
  st.SetItemsProcessed(st.iterations() * std::int64_t(sim->topology().numEdges()));  // springs/s
}

// 33^2 ~ 1k, 101^2 ~ 10k, 317^2 ~ 100k vertices.
BENCHMARK_CAPTURE(BM_Step, explicit, SolverSettings::Kind::Explicit, 1)
    ->Arg(33)
    ->Arg(101)
    ->Arg(317)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Step, implicit_cg20, SolverSettings::Kind::ImplicitCG, 20)
    ->Arg(33)
    ->Arg(101)
    ->Arg(317)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Step, implicit_cg100, SolverSettings::Kind::ImplicitCG, 100)
    ->Arg(33)
    ->Arg(101)
    ->Arg(317)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Step, implicit_cholmod, SolverSettings::Kind::ImplicitCholmod, 1)
    ->Arg(33)
    ->Arg(101)
    ->Arg(317)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_StepWith, bdf2_cholmod,
                  [] {
                    return std::make_unique<cutsim::core::BDF2>(
                        damped(), std::make_unique<cutsim::core::CholmodSolver>());
                  })
    ->Arg(33)
    ->Arg(101)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_StepWith, newton_cholmod,
                  [] {
                    return std::make_unique<cutsim::core::NewtonImplicitEuler>(
                        damped(), cutsim::core::NewtonSettings{},
                        std::make_unique<cutsim::core::CholmodSolver>());
                  })
    ->Arg(33)
    ->Arg(101)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_StretchForce)->Arg(101)->Arg(317)->Arg(1001)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
