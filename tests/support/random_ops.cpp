#include "support/random_ops.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <numbers>
#include <ostream>
#include <sstream>

#include "support/fixtures.hpp"

namespace cutsim::test {

using topology::EdgeId;
using topology::kInvalidIndex;
using topology::PointId;
using topology::Topology;
using topology::TriangleId;
using topology::Vec3;

namespace {

// The mix drawn from, one entry per chance in 15: edge splits most often (they are what cuts and
// refinement do all the time), then the cutting operations, and the rarer ones once each.
constexpr std::array<OpKind, 15> kMix = {
    OpKind::SplitEdge,     OpKind::SplitEdge,    OpKind::SplitEdge,   OpKind::SplitEdge,
    OpKind::Tear,          OpKind::Tear,         OpKind::Incise,      OpKind::Incise,
    OpKind::Carve,         OpKind::CutPolyline,  OpKind::CutPolyline, OpKind::Compact,
    OpKind::SplitTriangle, OpKind::AddTriangles, OpKind::Sew};

static_assert(static_cast<int>(OpKind::Sew) + 1 == kNumOpKinds, "one tally slot a kind");

// A sequence stops once this many triangles or fewer are left (see runRandomOps).
constexpr std::size_t kMinTriangles = 12;

}  // namespace

const char* opKindName(OpKind kind) {
  switch (kind) {
    case OpKind::SplitEdge:
      return "splitEdge";
    case OpKind::Tear:
      return "tear";
    case OpKind::Incise:
      return "incise";
    case OpKind::Carve:
      return "removeTriangles";
    case OpKind::CutPolyline:
      return "cutPolyline";
    case OpKind::Compact:
      return "compact";
    case OpKind::SplitTriangle:
      return "splitTriangle";
    case OpKind::AddTriangles:
      return "addTriangles";
    case OpKind::Sew:
      return "sew";
  }
  return "?";
}

RandomTopologyOps::RandomTopologyOps(Topology& t, std::uint64_t seed, double sheetSize)
    : t_(t), rng_(seed), size_(sheetSize), trace_(std::getenv("CUTSIM_TEST_TRACE") != nullptr) {}

RandomOp RandomTopologyOps::step() {
  RandomOp op;
  op.kind = kMix[static_cast<std::size_t>(pick(0, static_cast<int>(kMix.size()) - 1))];
  std::ostringstream what;
  what.precision(17);
  try {
    if (!apply(op.kind, what)) op.outcome = RandomOp::Outcome::Skipped;
  } catch (const TopologyError& err) {
    what << " rejected: " << err.what();
    op.outcome = RandomOp::Outcome::Rejected;
  }
  op.what = what.str();
  return op;
}

bool RandomTopologyOps::apply(OpKind kind, std::ostringstream& what) {
  switch (kind) {
    case OpKind::SplitEdge: {
      const EdgeId e = randomEdge(false);
      // A quarter at the exact midpoint, where both ancestors weigh the same.
      const double s =
          pick(0, 3) == 0 ? 0.5 : std::uniform_real_distribution<double>(0.2, 0.8)(rng_);
      what << "splitEdge(" << e << ", " << s << ")";
      announce(what);
      t_.splitEdge(e, s);
      return true;
    }
    case OpKind::Tear: {
      const EdgeId e = randomEdge(true);
      if (e.idx() == kInvalidIndex) {
        what << "tear skipped (no interior edge)";
        return false;
      }
      const topology::RepairOptions repair = maybeRepair();
      what << "tear(" << e << (repair.minAngle > 0 ? ", repair" : "") << ")";
      announce(what);
      t_.tear(e, repair);
      return true;
    }
    case OpKind::Incise: {
      const std::vector<PointId> path = randomPath();
      what << "incise(";
      for (PointId p : path) what << p << " ";
      what << ")";
      if (path.size() < 2) {
        what << " skipped (no interior edge)";
        return false;
      }
      announce(what);
      t_.incise(path);
      return true;
    }
    case OpKind::Carve: {
      std::vector<TriangleId> tris = t_.triangles();
      std::shuffle(tris.begin(), tris.end(), rng_);
      tris.resize(std::min<std::size_t>(tris.size(), static_cast<std::size_t>(pick(1, 3))));
      std::sort(tris.begin(), tris.end());
      const topology::RepairOptions repair = maybeRepair();
      what << "removeTriangles(";
      for (TriangleId tr : tris) what << tr << " ";
      what << (repair.minAngle > 0 ? "repair" : "") << ")";
      std::vector<topology::TriangleVertices> vertices;
      for (TriangleId tr : tris) vertices.push_back(t_.triangleVertices(tr));
      announce(what);
      t_.removeTriangles(tris, repair);
      removed_.insert(removed_.end(), vertices.begin(), vertices.end());
      return true;
    }
    case OpKind::CutPolyline: {
      // A short polyline of 1 or 2 segments, turning by any angle (it may double back), that
      // stays inside the sheet.
      const double lo = 0.03 * size_, hi = size_ - lo;
      std::uniform_real_distribution<double> u(lo, hi);
      std::uniform_real_distribution<double> len(0.05 * size_, 0.25 * size_);
      std::uniform_real_distribution<double> turn(-std::numbers::pi, std::numbers::pi);
      std::vector<Vec3> poly;
      const int n = pick(2, 3);
      Vec3 p{u(rng_), u(rng_), 0.0};
      double angle = std::uniform_real_distribution<double>(0.0, 2.0 * std::numbers::pi)(rng_);
      poly.push_back(p);
      for (int i = 1; i < n; ++i) {
        const double l = len(rng_);
        p = {p[0] + l * std::cos(angle), p[1] + l * std::sin(angle), 0.0};
        if (p[0] < lo || p[0] > hi || p[1] < lo || p[1] > hi) break;
        poly.push_back(p);
        angle += turn(rng_);
      }
      if (poly.size() < 2) {
        what << "cutPolyline skipped (left the sheet)";
        return false;
      }
      topology::CutOptions options;
      options.repair = maybeRepair();
      what << "cutPolyline(";
      for (const Vec3& q : poly) what << "(" << q[0] << "," << q[1] << ") ";
      what << (options.repair.minAngle > 0 ? "repair" : "") << ")";
      announce(what);
      t_.cutPolyline(poly, options);
      return true;
    }
    case OpKind::Compact: {
      what << "compact()";
      announce(what);
      t_.compact();
      removed_.clear();
      return true;
    }
    case OpKind::SplitTriangle: {
      const std::vector<TriangleId> tris = t_.triangles();
      const TriangleId tr =
          tris[static_cast<std::size_t>(pick(0, static_cast<int>(tris.size()) - 1))];
      std::uniform_real_distribution<double> u(0.1, 1.0);
      std::array<double, 3> b{u(rng_), u(rng_), u(rng_)};
      const double sum = b[0] + b[1] + b[2];
      for (double& c : b) c /= sum;
      what << "splitTriangle(" << tr << ", " << b[0] << " " << b[1] << " " << b[2] << ")";
      announce(what);
      t_.splitTriangle(tr, b);
      return true;
    }
    case OpKind::AddTriangles: {
      // Put back a carved triangle; the topology rejects it if its edges no longer allow it (a
      // cut or a tear may have taken its place).
      if (removed_.empty()) {
        what << "addTriangles skipped (nothing carved)";
        return false;
      }
      const std::size_t i =
          static_cast<std::size_t>(pick(0, static_cast<int>(removed_.size()) - 1));
      const topology::TriangleVertices tv = removed_[i];
      removed_.erase(removed_.begin() + static_cast<std::ptrdiff_t>(i));
      what << "addTriangles(" << tv[0] << " " << tv[1] << " " << tv[2] << ")";
      for (PointId p : tv) {
        if (p.idx() >= t_.pointCapacity() || !t_.isPointAlive(p)) {
          what << " skipped (dead point)";
          return false;
        }
      }
      announce(what);
      t_.addTriangles(std::vector<topology::TriangleVertices>{tv});
      return true;
    }
    case OpKind::Sew: {
      // Around a lip point (a border point off the sheet's outline), the lips as they are at rest:
      // those a cut, a tear or an incision opened meet there.
      std::vector<PointId> lips;
      const double eps = 1e-9 * size_;
      for (PointId p : t_.points()) {
        const Vec3 r = t_.restPosition(p);
        const bool outline = r[0] < eps || r[1] < eps || r[0] > size_ - eps || r[1] > size_ - eps;
        if (!outline && t_.isBoundaryPoint(p)) lips.push_back(p);
      }
      if (lips.empty()) {
        what << "sew skipped (no lip)";
        return false;
      }
      const Vec3 c = t_.restPosition(
          lips[static_cast<std::size_t>(pick(0, static_cast<int>(lips.size()) - 1))]);
      const double radius = std::uniform_real_distribution<double>(0.1, 0.5)(rng_) * size_;
      topology::SewOptions options;
      options.tolerance = 1e-6 * size_;
      options.repair = maybeRepair();
      options.within = [this, c, radius](PointId p) {
        const Vec3 r = t_.restPosition(p);
        return std::hypot(r[0] - c[0], r[1] - c[1]) <= radius;
      };
      std::vector<double> x(3 * t_.pointCapacity(), 0.0);
      for (PointId p : t_.points())
        for (int k = 0; k < 3; ++k) x[3 * p.idx() + k] = t_.restPosition(p)[k];
      what << "sew(around (" << c[0] << "," << c[1] << ") within " << radius
           << (options.repair.minAngle > 0 ? ", repair" : "") << ")";
      announce(what);
      t_.sew(x, options);
      return true;
    }
  }
  return false;
}

void RandomTopologyOps::announce(const std::ostringstream& what) const {
  if (trace_) std::cerr << "  op: " << what.str() << std::endl;
}

topology::RepairOptions RandomTopologyOps::maybeRepair() {
  topology::RepairOptions o;
  if (pick(0, 1) == 1) o.minAngle = 20.0;  // half of the cuts, tears and removals repair
  return o;
}

int RandomTopologyOps::pick(int lo, int hi) {
  return std::uniform_int_distribution<int>(lo, hi)(rng_);
}

EdgeId RandomTopologyOps::randomEdge(bool interior) {
  std::vector<EdgeId> edges = t_.edges();
  if (interior) std::erase_if(edges, [this](EdgeId e) { return t_.isBoundaryEdge(e); });
  if (edges.empty()) return EdgeId::invalid();
  return edges[static_cast<std::size_t>(pick(0, static_cast<int>(edges.size()) - 1))];
}

std::vector<PointId> RandomTopologyOps::randomPath() {
  const EdgeId e0 = randomEdge(true);
  if (e0.idx() == kInvalidIndex) return {};
  const auto ev = t_.edgeVertices(e0);
  std::vector<PointId> path{ev[0], ev[1]};
  const int len = pick(1, 4);
  while (static_cast<int>(path.size()) <= len) {
    std::vector<PointId> next;
    for (EdgeId e : t_.edgesAroundPoint(path.back())) {
      if (t_.isBoundaryEdge(e)) continue;
      const auto v = t_.edgeVertices(e);
      const PointId other = v[0] == path.back() ? v[1] : v[0];
      if (std::find(path.begin(), path.end(), other) == path.end()) next.push_back(other);
    }
    if (next.empty()) break;
    path.push_back(next[static_cast<std::size_t>(pick(0, static_cast<int>(next.size()) - 1))]);
  }
  return path;
}

void OpTally::add(const RandomOp& op) {
  const auto k = static_cast<std::size_t>(op.kind);
  switch (op.outcome) {
    case RandomOp::Outcome::Applied:
      ++applied[k];
      break;
    case RandomOp::Outcome::Rejected:
      ++rejected[k];
      break;
    case RandomOp::Outcome::Skipped:
      ++skipped[k];
      break;
  }
}

int OpTally::totalApplied() const {
  int n = 0;
  for (int a : applied) n += a;
  return n;
}

std::string OpTally::summary() const {
  std::ostringstream o;
  for (std::size_t k = 0; k < applied.size(); ++k) {
    o << (k ? ", " : "") << opKindName(static_cast<OpKind>(k)) << " " << applied[k] << "/"
      << rejected[k] << "/" << skipped[k];
  }
  o << " (applied/rejected/skipped)";
  return o.str();
}

void PrintTo(const SequenceCase& c, std::ostream* os) {
  *os << "seed " << c.seed << ", grid " << c.gridSide << ", " << c.steps << " steps";
}

topology::MeshData sequenceSheet(const SequenceCase& c) {
  return grid(c.gridSide, kSheetSize, 0.25, c.seed);
}

void runRandomOps(Topology& topo, std::uint64_t seed, int steps,
                  const std::function<void(const RandomOp&)>& check) {
  RandomTopologyOps ops(topo, seed);
  OpTally tally;
  for (int i = 0; i < steps && topo.numTriangles() > kMinTriangles; ++i) {
    const std::array<std::size_t, 3> before{topo.numPoints(), topo.numEdges(), topo.numTriangles()};
    const RandomOp op = ops.step();
    tally.add(op);
    const topology::ValidationReport r = topo.validate();
    ASSERT_TRUE(r.ok()) << "after step " << i << ": " << op.what << "\n" << r.summary();
    if (op.outcome == RandomOp::Outcome::Rejected) {
      const std::array<std::size_t, 3> after{topo.numPoints(), topo.numEdges(),
                                             topo.numTriangles()};
      ASSERT_EQ(after, before) << "a rejected request changed the mesh, step " << i << ": "
                               << op.what;
    }
    if (check) {
      SCOPED_TRACE("after step " + std::to_string(i) + ": " + op.what);
      check(op);
      if (::testing::Test::HasFatalFailure()) return;
    }
  }
  EXPECT_GT(tally.totalApplied(), steps / 4)
      << "too few operations were applied: " << tally.summary();
  // Every kind must actually have run, or the sequence silently tests less than it says. Putting
  // back a carved triangle is the exception: it needs a carve that later cuts left intact.
  for (int k = 0; k < kNumOpKinds; ++k) {
    if (static_cast<OpKind>(k) == OpKind::AddTriangles) continue;
    EXPECT_GT(tally.applied[static_cast<std::size_t>(k)], 0)
        << opKindName(static_cast<OpKind>(k)) << " never applied: " << tally.summary();
  }
}

}  // namespace cutsim::test
