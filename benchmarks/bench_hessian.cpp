// The exact stiffness against the default one: DihedralBending (Gauss-Newton K vs the exact
// Hessian) and TriangularFEM (corotational K vs the exact Jacobian), addDForce and assembly into
// triplets, on a bent n x n grid (sides 40 and 130: about 4.6k and 50k hinges, 3k and 33k
// triangles). items_per_second = hinges (or triangles) per CPU second (one core).
// The default K is measured with exact:0, the exact one with exact:1.
//
//   cutsim_bench_hessian --benchmark_filter='side:40/'
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "cutsim/forcefields/dihedral_bending.hpp"
#include "cutsim/forcefields/triangular_fem.hpp"
#include "cutsim/topology/topology.hpp"

namespace {

using cutsim::forcefields::DihedralBending;
using cutsim::forcefields::DihedralBendingParameters;
using cutsim::forcefields::ForceField;
using cutsim::forcefields::TriangularFEM;
using cutsim::forcefields::TriangularFEMParameters;
using cutsim::forcefields::TripletAccumulator;
using cutsim::topology::PointId;
using cutsim::topology::Topology;
using cutsim::topology::TriangleVertices;
using cutsim::topology::Vec3;

/// A flat n x n grid on [0, 10]^2, both fields on it, and a current configuration far from rest
/// (bent by a few radians overall, stretched, jittered).
struct Scene {
  std::unique_ptr<Topology> topo;
  std::unique_ptr<DihedralBending> dihedral;
  std::unique_ptr<TriangularFEM> fem;
  std::vector<double> x, dx, f;
};

std::unique_ptr<Scene> makeScene(int n) {
  std::vector<Vec3> pts;
  std::vector<TriangleVertices> tris;
  const double h = 10.0 / (n - 1);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) pts.push_back({h * i, h * j, 0.0});
  }
  const auto v = [&](int i, int j) { return static_cast<PointId>(j * n + i); };
  for (int j = 0; j + 1 < n; ++j) {
    for (int i = 0; i + 1 < n; ++i) {
      tris.push_back({v(i, j), v(i + 1, j), v(i + 1, j + 1)});
      tris.push_back({v(i, j), v(i + 1, j + 1), v(i, j + 1)});
    }
  }
  auto s = std::make_unique<Scene>();
  s->topo = std::make_unique<Topology>(pts, tris);
  s->dihedral = std::make_unique<DihedralBending>(*s->topo, DihedralBendingParameters{});
  s->fem = std::make_unique<TriangularFEM>(*s->topo, TriangularFEMParameters{});
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> d(-0.1 * h, 0.1 * h);
  s->x.resize(3 * pts.size());
  s->dx.resize(s->x.size());
  for (std::size_t k = 0; k < pts.size(); ++k) {
    s->x[3 * k] = 1.1 * pts[k][0] + d(rng);
    s->x[3 * k + 1] = pts[k][1] + d(rng);
    s->x[3 * k + 2] = std::sin(pts[k][0]) * std::cos(0.5 * pts[k][1]) + d(rng);
  }
  for (double& e : s->dx) e = d(rng);
  s->f.assign(s->x.size(), 0.0);
  return s;
}

Scene& scene(int n) {
  static std::unique_ptr<Scene> cached;
  static int cachedN = 0;
  if (!cached || cachedN != n) {
    cached.reset();
    cached = makeScene(n);
    cachedN = n;
  }
  return *cached;
}

/// range(0): grid side; range(1): 0 DihedralBending, 1 TriangularFEM; range(2): exact K or not.
ForceField& field(benchmark::State& state, Scene& s) {
  ForceField& ff = state.range(1) == 0 ? static_cast<ForceField&>(*s.dihedral)
                                       : static_cast<ForceField&>(*s.fem);
  ff.setExactStiffness(state.range(2) != 0);
  return ff;
}

void report(benchmark::State& state, const Scene& s) {
  const auto items = static_cast<int64_t>(state.range(1) == 0 ? s.dihedral->numActiveHinges()
                                                              : s.fem->numElements());
  state.SetItemsProcessed(state.iterations() * items);
  state.counters["items"] = static_cast<double>(items);
}

void BM_DForce(benchmark::State& state) {
  Scene& s = scene(static_cast<int>(state.range(0)));
  ForceField& ff = field(state, s);
  for (auto _ : state) {
    ff.addDForce(s.x, s.dx, s.f, 1.0, 0.0);
    benchmark::DoNotOptimize(s.f.data());
    benchmark::ClobberMemory();
  }
  report(state, s);
}

void BM_AssembleTriplets(benchmark::State& state) {
  Scene& s = scene(static_cast<int>(state.range(0)));
  ForceField& ff = field(state, s);
  TripletAccumulator acc;
  // 16 blocks per hinge, 9 per triangle, 9 triplets per block (reserved once).
  acc.reserve(
      (state.range(1) == 0 ? 144 * s.dihedral->numActiveHinges() : 81 * s.fem->numElements()));
  for (auto _ : state) {
    acc.clear();
    ff.addKToMatrix(s.x, acc, -1.0);
    benchmark::DoNotOptimize(acc.triplets().data());
  }
  report(state, s);
}

}  // namespace

int main(int argc, char** argv) {
  for (int n : {40, 130}) {
    for (int which : {0, 1}) {
      for (int exact : {0, 1}) {
        using Benchmark = void (*)(benchmark::State&);
        const std::pair<const char*, Benchmark> benchmarks[] = {
            {"BM_DForce", BM_DForce}, {"BM_AssembleTriplets", BM_AssembleTriplets}};
        for (const auto& [name, fn] : benchmarks) {
          benchmark::RegisterBenchmark(name, fn)
              ->Args({n, which, exact})
              ->ArgNames({"side", "fem", "exact"})
              ->Unit(benchmark::kMicrosecond);
        }
      }
    }
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
