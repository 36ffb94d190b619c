// FastTriangularBendingSprings: force pass, dForce and assembly on flat grids of about 50k, 1M
// and 4M active springs (grid sides 130, 580, 1160), with the vertex order of a fresh grid and
// with the vertex order shuffled. items_per_second = springs per CPU second (one core);
// bytes_per_edge = size of the spring table per edge slot.
//
//   cutsim_bench_bending --benchmark_filter='side:(130|580)/'    # 50k and 1M only
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>
#include <random>
#include <vector>

#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/topology/topology.hpp"

namespace {

using cutsim::forcefields::BendingParameters;
using cutsim::forcefields::FastTriangularBendingSprings;
using cutsim::forcefields::TripletAccumulator;
using cutsim::topology::PointId;
using cutsim::topology::Topology;
using cutsim::topology::TriangleVertices;
using cutsim::topology::Vec3;

/// A flat n x n grid on [0, 10]^2, quads split along (x,y)-(x+1,y+1), optionally with its vertices
/// renumbered at random; the field on it and a current configuration (rest + a random bend).
struct Scene {
  std::unique_ptr<Topology> topo;
  std::unique_ptr<FastTriangularBendingSprings> ff;
  std::vector<double> x, dx, f;
};

std::unique_ptr<Scene> makeScene(int n, bool shuffled) {
  std::vector<Vec3> pts;
  std::vector<TriangleVertices> tris;
  const double h = 10.0 / (n - 1);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) pts.push_back({h * i, h * j, 0.0});
  }
  std::vector<PointId> id(pts.size());
  std::iota(id.begin(), id.end(), PointId{0});
  std::mt19937_64 rng(42);
  if (shuffled) std::shuffle(id.begin(), id.end(), rng);
  std::vector<Vec3> placed(pts.size());
  for (std::size_t k = 0; k < pts.size(); ++k) placed[id[k].idx()] = pts[k];
  const auto v = [&](int i, int j) { return id[static_cast<std::size_t>(j * n + i)]; };
  for (int j = 0; j + 1 < n; ++j) {
    for (int i = 0; i + 1 < n; ++i) {
      tris.push_back({v(i, j), v(i + 1, j), v(i + 1, j + 1)});
      tris.push_back({v(i, j), v(i + 1, j + 1), v(i, j + 1)});
    }
  }
  auto s = std::make_unique<Scene>();
  s->topo = std::make_unique<Topology>(placed, tris);
  s->ff = std::make_unique<FastTriangularBendingSprings>(*s->topo, BendingParameters{});
  std::uniform_real_distribution<double> d(-0.01, 0.01);
  s->x.resize(3 * placed.size());
  s->dx.resize(s->x.size());
  for (std::size_t k = 0; k < placed.size(); ++k) {
    s->x[3 * k] = placed[k][0];
    s->x[3 * k + 1] = placed[k][1];
    s->x[3 * k + 2] = 0.1 * std::sin(placed[k][0]) + d(rng);
  }
  for (double& e : s->dx) e = d(rng);
  s->f.assign(s->x.size(), 0.0);
  return s;
}

/// One scene at a time is kept (the 4M one holds a few GB with its topology).
Scene& scene(int n, bool shuffled) {
  static std::unique_ptr<Scene> cached;
  static int cachedN = 0;
  static bool cachedShuffled = false;
  if (!cached || cachedN != n || cachedShuffled != shuffled) {
    cached.reset();
    cached = makeScene(n, shuffled);
    cachedN = n;
    cachedShuffled = shuffled;
  }
  return *cached;
}

void report(benchmark::State& state, const Scene& s) {
  const auto springs = static_cast<int64_t>(s.ff->numActiveSprings());
  state.SetItemsProcessed(state.iterations() * springs);
  state.counters["springs"] = static_cast<double>(springs);
  state.counters["bytes_per_edge"] = s.ff->bytesPerEdgeSlot();
}

void BM_Force(benchmark::State& state) {
  Scene& s = scene(static_cast<int>(state.range(0)), state.range(1) != 0);
  const std::vector<double> v(s.x.size(), 0.0);
  for (auto _ : state) {
    s.ff->addForce(s.x, v, s.f);
    benchmark::DoNotOptimize(s.f.data());
    benchmark::ClobberMemory();
  }
  report(state, s);
}

void BM_DForce(benchmark::State& state) {
  Scene& s = scene(static_cast<int>(state.range(0)), state.range(1) != 0);
  for (auto _ : state) {
    s.ff->addDForce(s.x, s.dx, s.f, 1.0, 0.0);
    benchmark::DoNotOptimize(s.f.data());
    benchmark::ClobberMemory();
  }
  report(state, s);
}

void BM_Energy(benchmark::State& state) {
  Scene& s = scene(static_cast<int>(state.range(0)), state.range(1) != 0);
  for (auto _ : state) benchmark::DoNotOptimize(s.ff->potentialEnergy(s.x));
  report(state, s);
}

/// Assembly into Eigen triplets (48 per spring, reserved once), then the sparse matrix.
void BM_AssembleTriplets(benchmark::State& state) {
  Scene& s = scene(static_cast<int>(state.range(0)), state.range(1) != 0);
  TripletAccumulator acc;
  acc.reserve(48 * s.ff->numActiveSprings());
  for (auto _ : state) {
    acc.clear();
    s.ff->addKToMatrix(s.x, acc, -1.0);
    benchmark::DoNotOptimize(acc.triplets().data());
  }
  report(state, s);
}

void BM_AssembleSparse(benchmark::State& state) {
  Scene& s = scene(static_cast<int>(state.range(0)), state.range(1) != 0);
  TripletAccumulator acc;
  acc.reserve(48 * s.ff->numActiveSprings());
  for (auto _ : state) {
    acc.clear();
    s.ff->addKToMatrix(s.x, acc, -1.0);
    auto m = acc.toSparse(s.topo->pointCapacity());
    benchmark::DoNotOptimize(m.valuePtr());
  }
  report(state, s);
}

}  // namespace

// Registered size by size (not benchmark by benchmark) so that each scene is built once.
int main(int argc, char** argv) {
  for (int n : {130, 580, 1160}) {
    for (int shuffled : {0, 1}) {
      const auto add = [&](const char* name, void (*fn)(benchmark::State&)) {
        benchmark::RegisterBenchmark(name, fn)
            ->Args({n, shuffled})
            ->ArgNames({"side", "shuffled"})
            ->Unit(benchmark::kMillisecond);  // rates per CPU second: the machine is shared
      };
      add("BM_Force", BM_Force);
      add("BM_DForce", BM_DForce);
      add("BM_Energy", BM_Energy);
      if (n <= 580) {  // 48 triplets per spring: 0.8 GB at 1M springs
        add("BM_AssembleTriplets", BM_AssembleTriplets);
        add("BM_AssembleSparse", BM_AssembleSparse);
      }
    }
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
