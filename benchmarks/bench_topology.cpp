// The cost of a topology change must follow the size of the change, not of the mesh: one incision
// along 20 edges, one polyline cut across 20 cells (located, checked, planned on a patch, then
// inserted and incised: about 40 crossings), and one triangle removal, with the events delivered
// to the bending springs' table (FastTriangularBendingSprings), to the edge springs
// (StretchSprings) and to the simulation state, on a 20k-triangle grid and on a 2M-triangle grid.
// Every iteration works on a fresh part of the grid.
//
//   cutsim_bench_topology                      # both sizes (the 2M grid takes a few seconds to
//   build) cutsim_bench_topology --benchmark_format=json > topology.json
#include <benchmark/benchmark.h>

#include <memory>
#include <vector>

#include "cutsim/core/state.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/forcefields/stretch_springs.hpp"
#include "cutsim/topology/topology.hpp"

namespace {

using cutsim::topology::PointId;
using cutsim::topology::Topology;
using cutsim::topology::TriangleVertices;
using cutsim::topology::Vec3;

struct Sheet {
  int n = 0;  // vertices per side
  std::unique_ptr<Topology> topo;
  std::unique_ptr<cutsim::forcefields::FastTriangularBendingSprings> springs;
  std::unique_ptr<cutsim::forcefields::StretchSprings> stretch;
  std::unique_ptr<cutsim::core::MechanicalState> state;
  int nextRow = 2, nextCol = 1;
  int cutRow = 3, cutCol = 1;  // polyline cuts run between the incisions' rows

  explicit Sheet(int side) : n(side) {
    std::vector<Vec3> pts;
    std::vector<TriangleVertices> tris;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) pts.push_back({double(i), double(j), 0.0});
    auto id = [&](int i, int j) { return PointId(j * n + i); };
    for (int j = 0; j + 1 < n; ++j)
      for (int i = 0; i + 1 < n; ++i) {
        tris.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
        tris.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      }
    topo = std::make_unique<Topology>(pts, tris);
    springs = std::make_unique<cutsim::forcefields::FastTriangularBendingSprings>(
        *topo, cutsim::forcefields::BendingParameters{});
    stretch = std::make_unique<cutsim::forcefields::StretchSprings>(
        *topo, cutsim::forcefields::StretchParameters{});
    state = std::make_unique<cutsim::core::MechanicalState>(*topo);
  }

  /// A path of 20 grid edges along row `nextRow`, in a part of the grid not cut yet.
  std::vector<PointId> nextPath() {
    if (nextCol + 21 >= n) {
      nextCol = 1;
      nextRow += 3;
    }
    std::vector<PointId> path;
    for (int i = 0; i <= 20; ++i) path.push_back(PointId(nextRow * n + nextCol + i));
    nextCol += 24;
    return path;
  }

  /// A slanted polyline across 20 cells, between rows cutRow and cutRow + 1, not cut yet.
  std::vector<Vec3> nextPolyline() {
    if (cutCol + 22 >= n) {
      cutCol = 1;
      cutRow += 3;
    }
    std::vector<Vec3> line{{cutCol + 0.5, cutRow + 0.3, 0.0}, {cutCol + 20.5, cutRow + 0.7, 0.0}};
    cutCol += 24;
    return line;
  }
};

/// The sheets the cuts work on, and separate uncut ones for the removals.
Sheet& sheet(int side, bool forRemovals = false) {
  static std::unique_ptr<Sheet> sheets[2][2];
  auto& s = sheets[forRemovals ? 1 : 0][side < 500 ? 0 : 1];
  if (!s) s = std::make_unique<Sheet>(side);
  return *s;
}

void BM_Incise20Edges(benchmark::State& st) {
  Sheet& s = sheet(int(st.range(0)));
  for (auto _ : st) {
    auto path = s.nextPath();
    auto r = s.topo->incise(path);
    benchmark::DoNotOptimize(r);
  }
  st.counters["triangles"] = double(s.topo->numTriangles());
  st.counters["active_springs"] = double(s.springs->numActiveSprings());
}

void BM_CutPolyline20Cells(benchmark::State& st) {
  Sheet& s = sheet(int(st.range(0)));
  // The first cut builds the triangle locator (once per topology, O(mesh)): not timed.
  s.topo->cutPolyline(s.nextPolyline());
  std::size_t pathEdges = 0;
  for (auto _ : st) {
    auto line = s.nextPolyline();
    auto r = s.topo->cutPolyline(line);
    pathEdges += r.path.size() - 1;
    benchmark::DoNotOptimize(r);
  }
  st.counters["path_edges"] = double(pathEdges) / double(st.iterations());
  st.counters["triangles"] = double(s.topo->numTriangles());
}

void BM_RemoveOneTriangle(benchmark::State& st) {
  Sheet& s = sheet(int(st.range(0)), true);
  // Triangles apart from each other (every third cell of every other row, from the top), one
  // per iteration, on a sheet of their own.
  std::vector<cutsim::topology::TriangleId> ids;
  const int n = s.n;
  for (int j = n - 2; j >= 1 && ids.size() < 4000; j -= 2)
    for (int i = 1; i + 2 < n && ids.size() < 4000; i += 3)
      ids.push_back(cutsim::topology::TriangleId(2 * (j * (n - 1) + i)));
  std::size_t k = 0;
  for (auto _ : st) {
    while (k < ids.size() && !s.topo->isTriangleAlive(ids[k])) ++k;
    if (k == ids.size()) {
      st.SkipWithError("no triangle left to remove");
      break;
    }
    std::vector<cutsim::topology::TriangleId> one{ids[k++]};
    s.topo->removeTriangles(one);
  }
  st.counters["triangles"] = double(s.topo->numTriangles());
}

// 101 x 101 vertices: 20,000 triangles; 1001 x 1001: 2,000,000 triangles.
BENCHMARK(BM_Incise20Edges)->Arg(101)->Arg(1001)->Iterations(120)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CutPolyline20Cells)
    ->Arg(101)
    ->Arg(1001)
    ->Iterations(120)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_RemoveOneTriangle)
    ->Arg(101)
    ->Arg(1001)
    ->Iterations(1000)
    ->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
