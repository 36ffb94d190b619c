// A known answer for the prestrain of TriangularFEM (restScale): a straight incision in a sheet
// under a resting equibiaxial tension gapes as a Griffith crack does.
//
// A square sheet of side L, its border held at its mesh positions, with restScale = 1 / (1 + eps):
// the held sheet is under the equibiaxial strain eps, i.e. (plane stress) the stress
// sigma = E eps / (1 - nu). A cut of length 2a along y = L/2, centred, frees its lips; at the
// static equilibrium the crack's centre opens by (Inglis, Griffith; an infinite plate under a
// remote equibiaxial stress sigma, only the stress across the crack opens it)
//
//   COD = 4 sigma a / E = 4 a eps / (1 - nu).
//
// The equilibrium is found by Newton's method on the field's energy with its exact Hessian, over
// the in-plane coordinates of the free points (the sheet is flat and the loads in its plane, so z
// stays 0), each linear system solved by Eigen's SimplicialLDLT.
#include <gtest/gtest.h>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <vector>

#include "cutsim/forcefields/triangular_fem.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/field_helpers.hpp"
#include "support/force_field_harness.hpp"

namespace cutsim::forcefields {
namespace {

using topology::MeshData;
using topology::PointId;
using topology::Topology;
using topology::Vec3;

/// Coordinates from 0 to `side`: the spacing h within `fine` of the centre side/2 (fine a multiple
/// of h), then growing by the factor `growth` per cell up to the border, the last cell ending on
/// it. Symmetric about the centre, which is a coordinate. growth = 1 and fine = side/2: uniform.
std::vector<double> gradedCoordinates(double side, double h, double fine, double growth) {
  const double half = 0.5 * side;
  std::vector<double> offsets;  // from the centre, increasing
  const int fineCells = static_cast<int>(std::lround(fine / h));
  for (int k = 0; k <= fineCells; ++k) offsets.push_back(k * h);
  double step = h;
  while (half - offsets.back() > 1e-9 * side) {
    step *= growth;
    // The last cell ends on the border: take it whole if less than half a cell would be left.
    const double next = offsets.back() + step;
    offsets.push_back(half - next < 0.5 * step * growth ? half : next);
  }
  offsets.back() = half;
  std::vector<double> coords;
  for (auto it = offsets.rbegin(); it != offsets.rend(); ++it) coords.push_back(half - *it);
  for (std::size_t k = 1; k < offsets.size(); ++k) coords.push_back(half + offsets[k]);
  return coords;
}

/// A flat sheet through the grid lines xs (x) and ys (y), each cell split along alternating
/// diagonals ((i + j) even: along (i, j)-(i + 1, j + 1)), which makes the mesh symmetric about
/// every grid line. Vertex (i, j) has index j * xs.size() + i.
MeshData tensorGrid(const std::vector<double>& xs, const std::vector<double>& ys) {
  MeshData m;
  const int nx = static_cast<int>(xs.size()), ny = static_cast<int>(ys.size());
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) m.points.push_back({xs[i], ys[j], 0.0});
  }
  const auto id = [nx](int i, int j) { return static_cast<PointId>(j * nx + i); };
  for (int j = 0; j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      const PointId a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      if ((i + j) % 2 == 0) {
        m.triangles.push_back({a, b, c});
        m.triangles.push_back({a, c, d});
      } else {
        m.triangles.push_back({a, b, d});
        m.triangles.push_back({b, c, d});
      }
    }
  }
  return m;
}

/// -K restricted to the in-plane coordinates of the free points, as triplets (dof[3 p + k] is the
/// unknown of coordinate k of point p, or -1 for a fixed one).
class ReducedMatrix : public MatrixAccumulator {
 public:
  explicit ReducedMatrix(const std::vector<int>& dof) : dof_(dof) {}
  void addBlock(PointId i, PointId j, const Eigen::Matrix3d& b) override {
    for (int k = 0; k < 2; ++k) {
      const int r = dof_[3 * i.idx() + k];
      if (r < 0) continue;
      for (int l = 0; l < 2; ++l) {
        const int c = dof_[3 * j.idx() + l];
        if (c >= 0) triplets.emplace_back(r, c, -b(k, l));
      }
    }
  }
  std::vector<Eigen::Triplet<double>> triplets;

 private:
  const std::vector<int>& dof_;
};

struct Equilibrium {
  int iterations = 0;
  double initialResidual = 0.0;  ///< max |f| over the unknowns at the start
  double residual = 0.0;         ///< max |f| over the unknowns at the end
  bool converged = false;
};

/// Newton's method on the field's energy: the points with held[p] stay where x has them, the
/// others move in the plane z = const until max |f| over their in-plane coordinates is below
/// `tolerance` times its value at the start (at most 30 iterations). With the exact Hessian it
/// converges quadratically down to rounding, about 1e-10 of the start on these meshes.
Equilibrium staticEquilibrium(const TriangularFEM& ff, const Topology& topo,
                              const std::vector<bool>& held, std::vector<double>& x,
                              double tolerance) {
  std::vector<int> dof(x.size(), -1);
  int n = 0;
  for (PointId p : topo.points()) {
    if (held[p.idx()]) continue;
    dof[3 * p.idx()] = n++;
    dof[3 * p.idx() + 1] = n++;
  }
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver;
  Eigen::VectorXd r(n);
  Equilibrium out;
  for (;; ++out.iterations) {
    const std::vector<double> f = test::forceAt(ff, x);
    out.residual = 0.0;  // a plain loop: GCC 12 warns falsely inside Eigen's vectorised max
    for (std::size_t i = 0; i < dof.size(); ++i) {
      if (dof[i] < 0) continue;
      r[dof[i]] = f[i];
      out.residual = std::max(out.residual, std::fabs(f[i]));
    }
    if (out.iterations == 0) out.initialResidual = out.residual;
    out.converged = out.residual <= tolerance * out.initialResidual;
    if (out.converged || out.iterations == 30) return out;
    ReducedMatrix a(dof);
    ff.addKToMatrix(x, a, 1.0);
    Eigen::SparseMatrix<double> m(n, n);
    m.setFromTriplets(a.triplets.begin(), a.triplets.end());
    if (out.iterations == 0) solver.analyzePattern(m);
    solver.factorize(m);
    if (solver.info() != Eigen::Success) return out;
    const Eigen::VectorXd dx = solver.solve(r);  // (-K) dx = f
    for (std::size_t i = 0; i < dof.size(); ++i) {
      if (dof[i] >= 0) x[i] += dx[dof[i]];
    }
  }
}

struct CrackCase {
  double side = 1.0;         ///< L
  double halfLength = 0.05;  ///< a
  double eps = 0.01;         ///< the equibiaxial prestrain: restScale = 1 / (1 + eps)
  double nu = 0.3;
  double h = 1.0 / 80.0;  ///< the spacing along the crack (a and L/2 multiples of it)
  double fine = 0.5;      ///< the half-width of the uniformly fine zone (L/2: uniform)
  double growth = 1.0;    ///< beyond it, the spacing grows by this factor per cell
};

struct CrackResult {
  double opening = 0.0;   ///< the distance between the lips at the crack's centre
  double expected = 0.0;  ///< 4 a eps / (1 - nu)
  std::size_t points = 0;
  Equilibrium equilibrium;
};

/// The distance at x between the centre point of the cut and its copy (the two lips).
double centreOpening(const Topology& topo, const topology::IncisionResult& cut, Vec3 centre,
                     const std::vector<double>& x) {
  for (std::size_t i = 0; i < cut.copies.size(); ++i) {
    const Vec3 p = topo.restPosition(cut.copiedFrom[i]);
    if (std::hypot(p[0] - centre[0], p[1] - centre[1]) > 1e-12) continue;
    const PointId a = cut.copiedFrom[i], b = cut.copies[i];
    return std::hypot(x[3 * b.idx()] - x[3 * a.idx()], x[3 * b.idx() + 1] - x[3 * a.idx() + 1],
                      x[3 * b.idx() + 2] - x[3 * a.idx() + 2]);
  }
  ADD_FAILURE() << "the crack's centre was not copied";
  return 0.0;
}

/// Builds the sheet, cuts it, finds the equilibrium and measures the opening.
CrackResult openCrack(const CrackCase& c) {
  const std::vector<double> coords = gradedCoordinates(c.side, c.h, c.fine, c.growth);
  Topology topo(tensorGrid(coords, coords));
  TriangularFEMParameters p;
  p.youngModulus = 1000.0;
  p.poissonRatio = c.nu;
  p.restScale = 1.0 / (1.0 + c.eps);
  p.exactHessian = true;  // Newton's method: quadratic convergence
  TriangularFEM ff(topo, p);
  // The border, held (before the cut the held sheet is in equilibrium everywhere inside:
  // HeldSheetIsUnderEquibiaxialTension).
  std::vector<bool> held(topo.pointCapacity(), false);
  for (PointId q : topo.points()) held[q.idx()] = topo.isBoundaryPoint(q);
  const double mid = 0.5 * c.side, a = c.halfLength;
  const std::vector<Vec3> polyline = {{mid - a, mid, 0.0}, {mid + a, mid, 0.0}};
  const topology::IncisionResult cut = topo.cutPolyline(polyline);
  // The cut runs along grid edges from grid vertex to grid vertex: nothing inserted, its ends
  // exactly where asked, every vertex but the two tips copied.
  EXPECT_TRUE(cut.insertedPoints.empty());
  EXPECT_EQ(cut.path.size(), static_cast<std::size_t>(std::lround(2.0 * a / c.h)) + 1);
  EXPECT_EQ(cut.copies.size() + 2, cut.path.size());
  const Vec3 first = topo.restPosition(cut.path.front()), last = topo.restPosition(cut.path.back());
  EXPECT_NEAR(std::min(first[0], last[0]), mid - a, 1e-12);
  EXPECT_NEAR(std::max(first[0], last[0]), mid + a, 1e-12);
  EXPECT_NEAR(first[1], mid, 1e-12);
  EXPECT_NEAR(last[1], mid, 1e-12);
  held.resize(topo.pointCapacity(), false);    // the copies are free
  std::vector<double> x = test::restOf(topo);  // the mesh positions: the held, tense sheet
  CrackResult r;
  r.points = topo.numPoints();
  r.equilibrium = staticEquilibrium(ff, topo, held, x, 1e-8);
  r.opening = centreOpening(topo, cut, {mid, mid, 0.0}, x);
  r.expected = 4.0 * a * c.eps / (1.0 - c.nu);
  return r;
}

TEST(TriangularFemPrestrain, HeldSheetIsUnderEquibiaxialTension) {
  // Before any cut: uniform strain eps, interior points in equilibrium, and the border pulled in
  // by sigma h per unit of (scaled) rest length.
  const CrackCase c;
  const std::vector<double> coords = gradedCoordinates(c.side, 0.1, 0.5, 1.0);
  Topology topo(tensorGrid(coords, coords));
  TriangularFEMParameters p;
  p.poissonRatio = c.nu;
  p.thickness = 0.5;
  p.restScale = 1.0 / (1.0 + c.eps);
  TriangularFEM ff(topo, p);
  const std::vector<double> x = test::restOf(topo);
  const std::vector<double> f = test::forceAt(ff, x);
  const double sigma = p.youngModulus * c.eps / (1.0 - c.nu);
  double rightBorder = 0.0;
  for (PointId q : topo.points()) {
    const Vec3 r = topo.restPosition(q);
    if (!topo.isBoundaryPoint(q)) {
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(f[3 * q.idx() + k], 0.0, 1e-12 * sigma);
    }
    if (std::fabs(r[0] - c.side) < 1e-12) rightBorder += f[3 * q.idx()];
  }
  EXPECT_NEAR(rightBorder, -sigma * p.thickness * p.restScale * c.side, 1e-12 * sigma);
  // The energy: sigma eps / 2 per unit of rest volume, times 2 (two equal principal strains).
  const double volume = p.restScale * p.restScale * c.side * c.side * p.thickness;
  EXPECT_NEAR(ff.potentialEnergy(x), volume * sigma * c.eps, 1e-12 * volume * sigma * c.eps);
}

TEST(TriangularFemPrestrain, CrackOpensAsInAnInfinitePlate) {
  // L = 20 a, eps = 1%, nu = 0.3: COD = 4 a eps / (1 - nu) = 2.857e-3 L. The spacing a / 16
  // within 2a of the centre, growing by 10% per cell beyond: 14192 points, three Newton steps.
  // The opening comes out about 6.6% short, the sum of three effects, each measured by changing
  // one thing (see docs/forcefields.md): the mesh (first order in the spacing: -2% here, -12% on a
  // uniform a / 4 mesh), the finite plate held at its border (-1.5% at L = 20 a, none left at
  // L = 100 a), and the geometric nonlinearity of a membrane stretched by eps (the formula is
  // linear: about -3 eps).
  CrackCase c;
  c.h = c.halfLength / 16.0;
  c.fine = 2.0 * c.halfLength;
  c.growth = 1.1;
  const CrackResult r = openCrack(c);
  ASSERT_TRUE(r.equilibrium.converged)
      << r.equilibrium.iterations << " iterations, residual " << r.equilibrium.residual << " from "
      << r.equilibrium.initialResidual;
  EXPECT_LE(r.equilibrium.iterations, 6);
  EXPECT_NEAR(r.opening, r.expected, 0.1 * r.expected)
      << "opening " << r.opening << ", 4 a eps / (1 - nu) = " << r.expected;
  test::recordError("opening", r.opening);
  test::recordError("opening_formula", r.expected);
  test::recordError("relative_error", (r.opening - r.expected) / r.expected);
}

}  // namespace
}  // namespace cutsim::forcefields
