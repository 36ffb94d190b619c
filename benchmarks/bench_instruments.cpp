// World-space instruments' queries of the deformed surface (forcefields::SurfaceQuery), side by
// side with a CG20 step of the same cloth:
//   BM_Locate/N          10^4 world points located on a wavy N x N sheet (2 (N-1)^2 triangles;
//                        N = 225: 10^5 triangles): near it (within 2 mm) or far (up to 10 cm)
//   BM_Refit/N           the search structure following new positions
//   BM_ScalpelQuery/N    what a scalpel costs a step beyond its cut: the refit for the step's
//                        positions and the incision curves of a blade that moved 1 mm across it
//   BM_Cg20Step/N        one implicit Euler step with CG capped at 20 iterations, same cloth
//
//   cutsim_bench_instruments --benchmark_filter='/225$'
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "cutsim/core/simulation.hpp"
#include "cutsim/forcefields/stretch_springs.hpp"
#include "cutsim/forcefields/surface_query.hpp"

namespace {

using cutsim::core::Simulation;
using cutsim::core::SolverSettings;
using cutsim::topology::PointId;
using cutsim::topology::Topology;
using cutsim::topology::TriangleVertices;
using cutsim::topology::Vec3;

/// A 1 m sheet of n x n points in the xy plane, bent into waves, with stretch springs and a
/// CG20 implicit Euler (two corners fixed, gravity).
std::unique_ptr<Simulation> wavy(int n) {
  std::vector<Vec3> pts;
  std::vector<TriangleVertices> tris;
  const double h = 1.0 / (n - 1);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) pts.push_back({h * i, h * j, 0.0});
  auto id = [n](int i, int j) { return PointId(j * n + i); };
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      tris.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      tris.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  auto sim = std::make_unique<Simulation>(std::make_unique<Topology>(pts, tris), 0.2);
  cutsim::forcefields::StretchParameters stretch;
  stretch.stiffness = 200.0;
  stretch.damping = 0.05;
  sim->addForceField(
      std::make_unique<cutsim::forcefields::StretchSprings>(sim->topology(), stretch));
  sim->fixed().add(id(0, n - 1));
  sim->fixed().add(id(n - 1, n - 1));
  sim->setGravity({0, 0, -9.81});
  SolverSettings s;
  s.kind = SolverSettings::Kind::ImplicitCG;
  s.cgMaxIterations = 20;
  s.cgTolerance = 1e-10;
  s.rayleighMass = 0.1;
  s.onSolveFailure = cutsim::core::SolveFailurePolicy::Warn;
  sim->setSolver(s);
  auto x = sim->state().x();
  for (PointId p : sim->topology().points()) {
    const Vec3 r = sim->topology().restPosition(p);
    x[3 * p.idx() + 2] = 0.05 * std::sin(6.0 * r[0]) * std::cos(4.0 * r[1]);
  }
  return sim;
}

/// Locating 10^4 points: within 2 mm of the surface (what an instrument asks: near = true), or
/// anywhere up to 10 cm from it (far: the nearest point is then sought among every triangle
/// within that distance, thousands on a wavy sheet).
void BM_Locate(benchmark::State& st, bool near) {
  auto sim = wavy(int(st.range(0)));
  cutsim::forcefields::SurfaceQuery query(sim->topology(), sim->state().x());
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0.0, 1.0), z(-0.1, 0.1), off(-0.002, 0.002);
  std::vector<Vec3> q(10000);
  for (Vec3& p : q) {
    p = {u(rng), u(rng), z(rng)};
    if (near) p[2] = 0.05 * std::sin(6.0 * p[0]) * std::cos(4.0 * p[1]) + off(rng);
  }
  double sum = 0.0;
  for (auto _ : st)
    for (const auto& hit : query.closestPoints(q)) sum += hit->distance;
  benchmark::DoNotOptimize(sum);
  st.counters["triangles"] = double(query.size());
  st.counters["points"] = double(q.size());
}

void BM_ScalpelQuery(benchmark::State& st) {
  auto sim = wavy(int(st.range(0)));
  cutsim::forcefields::SurfaceQuery query(sim->topology(), sim->state().x());
  const std::vector<std::array<Vec3, 2>> poses = {
      {Vec3{0.400, 0.37, -0.1}, Vec3{0.400, 0.37, 0.1}},
      {Vec3{0.401, 0.37, -0.1}, Vec3{0.401, 0.37, 0.1}}};
  std::size_t points = 0;
  for (auto _ : st) {
    query.update(sim->state().x());
    for (const auto& c : query.sweptSegmentCurves(poses)) points += c.size();
  }
  benchmark::DoNotOptimize(points);
}

void BM_Cg20Step(benchmark::State& st) {
  auto sim = wavy(int(st.range(0)));
  for (int i = 0; i < 2; ++i) sim->step(2e-3);
  for (auto _ : st) sim->step(2e-3);
}

void BM_Refit(benchmark::State& st) {
  auto sim = wavy(int(st.range(0)));
  cutsim::forcefields::SurfaceQuery query(sim->topology(), sim->state().x());
  for (auto _ : st) query.update(sim->state().x());
}

BENCHMARK(BM_Refit)->Arg(101)->Arg(225)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Locate, near, true)->Arg(101)->Arg(225)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Locate, far, false)->Arg(101)->Arg(225)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ScalpelQuery)->Arg(101)->Arg(225)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Cg20Step)->Arg(101)->Arg(225)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
