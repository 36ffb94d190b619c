// Every registered force field's passes, one by one, on the same deformed sheet: the force
// (addForce), the product of a conjugate-gradient iteration (addDForce at the same x, as every
// iteration of a step calls it), the energy, and the Jacobi preconditioner's diagonal
// (addKToMatrix into a diagonal-only accumulator, once a step). A field added to the registry is
// timed here without a line of this file changing; one whose required keys are not plain numbers
// is skipped (it says so on stderr).
//
// The sheet: n x n points on a 1 m square (alternating diagonals), every point moved by up to a
// fifth of the spacing in the plane and bent out of it, so that the stretch fields hold stretched
// and compressed springs both (the stable Jacobian's clamp is exercised) and the bending fields
// see curvature. Parameters: the field's defaults; a required number key is given 100.
// items_per_second = points per second; per_element = the time per spring, hinge or triangle.
//
//   cutsim_bench_fields                                               # every field, n = 64..256
//   cutsim_bench_fields --benchmark_filter='StretchSprings/dforce/'   # one pass of one field
//   benchmarks/compare.py OLD/cutsim_bench_fields NEW/cutsim_bench_fields 'dforce' --rounds 5
#include <benchmark/benchmark.h>

#include <any>
#include <cmath>
#include <iostream>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "cutsim/base/registry.hpp"
#include "cutsim/forcefields/registry.hpp"
#include "cutsim/topology/topology.hpp"

namespace {

using cutsim::KeyType;
using cutsim::ScalarParameters;
using cutsim::forcefields::DiagonalAccumulator;
using cutsim::forcefields::ForceField;
using cutsim::forcefields::ForceFieldRegistry;
using cutsim::topology::PointId;
using cutsim::topology::Topology;
using cutsim::topology::TriangleVertices;
using cutsim::topology::Vec3;

struct Sheet {
  std::unique_ptr<Topology> topo;
  std::unique_ptr<ForceField> field;
  std::vector<double> x, v, dx, out;
  std::size_t elements = 0;  // springs, hinges or triangles: edges for the edge fields, else
                             // interior edges or triangles as the name says (see elementsOf)
};

std::unique_ptr<Topology> grid(int n) {
  std::vector<Vec3> pts;
  std::vector<TriangleVertices> tris;
  const double h = 1.0 / (n - 1);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) pts.push_back({h * i, h * j, 0.0});
  auto id = [n](int i, int j) { return PointId(j * n + i); };
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      if ((i + j) % 2 == 0) {
        tris.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
        tris.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      } else {
        tris.push_back({id(i, j), id(i + 1, j), id(i, j + 1)});
        tris.push_back({id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)});
      }
    }
  return std::make_unique<Topology>(pts, tris);
}

/// What the field is made of, for the time per element: triangles for the membranes, interior
/// edges (hinges) for the bending fields, edges otherwise.
std::size_t elementsOf(const std::string& type, const Topology& t) {
  if (type.find("FEM") != std::string::npos) return t.numTriangles();
  if (type.find("Bending") != std::string::npos) {
    std::size_t interior = 0;
    for (auto e : t.edges()) interior += t.isBoundaryEdge(e) ? 0 : 1;
    return interior;
  }
  return t.numEdges();
}

/// The field built with its defaults (a required number key given 100); null when it needs a
/// key of another kind.
std::unique_ptr<Sheet> makeSheet(const std::string& type, int n) {
  const auto& entry = *ForceFieldRegistry::instance().find(type);
  std::map<std::string, ScalarParameters::Value, std::less<>> values;
  for (const auto& k : entry.keys) {
    if (!k.required) continue;
    if (k.type != KeyType::Number) return nullptr;
    values[k.name] = 100.0;
  }
  auto s = std::make_unique<Sheet>();
  s->topo = grid(n);
  s->field = entry.build(entry.readValues(ScalarParameters("bench " + type, values)), *s->topo);
  s->elements = elementsOf(type, *s->topo);
  const std::size_t slots = s->topo->pointCapacity();
  s->x.resize(3 * slots);
  s->v.resize(3 * slots);
  s->dx.resize(3 * slots);
  s->out.assign(3 * slots, 0.0);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double h = 1.0 / (n - 1);
  for (std::size_t p = 0; p < slots; ++p) {
    const Vec3 r = s->topo->restPosition(PointId(cutsim::topology::Index(p)));
    s->x[3 * p] = r[0] + 0.2 * h * u(rng);
    s->x[3 * p + 1] = r[1] + 0.2 * h * u(rng);
    s->x[3 * p + 2] = 0.05 * std::sin(6.0 * r[0]) * std::cos(4.0 * r[1]);
    for (int c = 0; c < 3; ++c) {
      s->v[3 * p + std::size_t(c)] = 0.01 * u(rng);
      s->dx[3 * p + std::size_t(c)] = 1e-3 * u(rng);
    }
  }
  return s;
}

void report(benchmark::State& st, const Sheet& s, int n) {
  st.SetItemsProcessed(st.iterations() * std::int64_t(n) * n);
  st.counters["per_element"] =
      benchmark::Counter(double(st.iterations()) * double(s.elements),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

enum class Pass { Force, DForce, Energy, Diagonal };

void BM_Field(benchmark::State& st, std::string type, Pass pass) {
  const int n = int(st.range(0));
  auto s = makeSheet(type, n);
  const double h = 1e-3;  // an implicit step's factors: K h^2, B h
  switch (pass) {
    case Pass::Force:
      for (auto _ : st) {
        s->field->addForce(s->x, s->v, s->out);
        benchmark::DoNotOptimize(s->out.data());
      }
      break;
    case Pass::DForce:
      s->field->beginProducts(s->x);
      s->field->addDForce(s->x, s->dx, s->out, -h * h, -h);  // (a linearisation made once)
      for (auto _ : st) {
        s->field->addDForce(s->x, s->dx, s->out, -h * h, -h);
        benchmark::DoNotOptimize(s->out.data());
      }
      s->field->endProducts(s->x);
      break;
    case Pass::Energy:
      for (auto _ : st) benchmark::DoNotOptimize(s->field->potentialEnergy(s->x));
      break;
    case Pass::Diagonal: {
      DiagonalAccumulator d(Eigen::Index(s->x.size()));
      for (auto _ : st) {
        s->field->addKToMatrix(s->x, d, -h * h);
        s->field->addBToMatrix(s->x, d, -h);
        benchmark::DoNotOptimize(d.diagonal.data());
      }
      break;
    }
  }
  report(st, *s, n);
}

}  // namespace

int main(int argc, char** argv) {
  const std::pair<const char*, Pass> passes[] = {{"force", Pass::Force},
                                                 {"dforce", Pass::DForce},
                                                 {"energy", Pass::Energy},
                                                 {"diagonal", Pass::Diagonal}};
  for (const std::string& type : ForceFieldRegistry::instance().names()) {
    if (!makeSheet(type, 4)) {
      std::cerr << "cutsim_bench_fields: " << type << " skipped (a required key is not a number)\n";
      continue;
    }
    for (const auto& [name, pass] : passes) {
      benchmark::RegisterBenchmark(("BM_Field/" + type + "/" + name).c_str(), BM_Field, type, pass)
          ->Arg(64)
          ->Arg(128)
          ->Arg(256)
          ->Unit(benchmark::kMicrosecond);
    }
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
