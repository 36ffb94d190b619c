// Contact as a force field: forces against finite differences of the energy, the stiffness
// (Gauss-Newton, exact along the normal) symmetric, negative semi-definite and equal to its
// matrix, the friction's damping against finite differences in the velocities, the pairs against
// a brute force over every primitive pair (distances by CGAL), the BVH against a rebuild, and the
// lips of a cut excluded until they separate.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <iomanip>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>

#include "cutsim/core/scene.hpp"
#include "cutsim/forcefields/contact.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/ids.hpp"
#include "support/intersection_oracle.hpp"

namespace cutsim::forcefields {
namespace {

using topology::MeshData;
using topology::PointId;
using topology::Topology;
using topology::Vec3;

/// A crumpled sheet: a grid whose points are displaced randomly and folded so that parts come
/// close to other parts (rest = current positions at the start).
struct Crumpled {
  std::unique_ptr<Topology> topo;
  std::vector<double> x;
};

Crumpled crumpled(unsigned seed, int n = 9, double fold = 0.97) {
  core::GridSpec g;
  g.nx = g.ny = n;
  g.width = g.height = 1.0;
  MeshData m = core::makeGrid(g);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Crumpled c;
  c.topo = std::make_unique<Topology>(m);
  c.x.assign(3 * c.topo->pointCapacity(), 0.0);
  for (PointId p : c.topo->points()) {
    Vec3 r = c.topo->restPosition(p);
    // Fold the sheet about x = 0.5 so that the right half comes back over the left one.
    double X = r[0], Z = 0.0;
    if (X > 0.5) {
      const double a = fold * M_PI * std::min(1.0, (X - 0.5) / 0.06);
      const double rad = 0.06 / (fold * M_PI);
      if (X - 0.5 < 0.06) {
        X = 0.5 + rad * std::sin(a);
        Z = rad * (1 - std::cos(a));
      } else {
        X = 0.5 + rad * std::sin(a) + (r[0] - 0.56) * std::cos(fold * M_PI);
        Z = rad * (1 - std::cos(a)) + (r[0] - 0.56) * std::sin(fold * M_PI);
      }
    }
    c.x[3 * p.idx()] = X + 0.01 * u(rng);
    c.x[3 * p.idx() + 1] = r[1] + 0.01 * u(rng);
    c.x[3 * p.idx() + 2] = Z + 0.01 * u(rng);
  }
  return c;
}

ContactParameters params(double d = 0.05, double k = 1e3, double mu = 0.0) {
  ContactParameters p;
  p.thickness = d;
  p.stiffness = k;
  p.friction = mu;
  return p;
}

Eigen::MatrixXd denseK(const Contact& c, std::span<const double> x, std::size_t n) {
  TripletAccumulator acc;
  c.addKToMatrix(x, acc, 1.0);
  return Eigen::MatrixXd(acc.toSparse(topology::Index(n)));
}

TEST(Contact, ForcesAreMinusTheEnergyGradient) {
  for (unsigned seed = 1; seed <= 4; ++seed) {
    Crumpled c = crumpled(seed);
    Contact contact(*c.topo, params(), {});
    std::vector<double> v(c.x.size(), 0.0);
    contact.beginStep(c.x, v, 1e-3);
    std::vector<double> f(c.x.size(), 0.0);
    contact.addForce(c.x, v, f);
    double fmax = 0;
    for (double a : f) fmax = std::max(fmax, std::abs(a));
    ASSERT_GT(fmax, 0.0) << "seed " << seed << ": no pair is within the thickness";
    const double h = 1e-7;
    double worst = 0;
    for (std::size_t i = 0; i < c.x.size(); ++i) {
      if (f[i] == 0.0) continue;
      std::vector<double> xp = c.x, xm = c.x;
      xp[i] += h;
      xm[i] -= h;
      const double fd = -(contact.potentialEnergy(xp) - contact.potentialEnergy(xm)) / (2 * h);
      worst = std::max(worst, std::abs(fd - f[i]));
    }
    EXPECT_LT(worst, 1e-5 * fmax) << "seed " << seed;
  }
}

TEST(Contact, StiffnessIsSymmetricNegativeSemidefiniteAndEqualToItsMatrix) {
  for (unsigned seed = 1; seed <= 3; ++seed) {
    Crumpled c = crumpled(seed);
    Contact contact(*c.topo, params(), {});
    std::vector<double> v(c.x.size(), 0.0);
    contact.beginStep(c.x, v, 1e-3);
    const Eigen::MatrixXd K = denseK(contact, c.x, c.topo->pointCapacity());
    EXPECT_LT((K - K.transpose()).norm(), 1e-12 * K.norm());
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (K + K.transpose()));
    EXPECT_LT(es.eigenvalues().maxCoeff(), 1e-9 * K.norm()) << "K must be negative semi-definite";
    std::mt19937 rng(seed);
    std::normal_distribution<double> g;
    std::vector<double> dx(c.x.size()), df(c.x.size(), 0.0);
    for (double& a : dx) a = g(rng);
    contact.addDForce(c.x, dx, df, 1.0, 0.0);
    const Eigen::VectorXd ref =
        K * Eigen::Map<const Eigen::VectorXd>(dx.data(), Eigen::Index(dx.size()));
    EXPECT_LT((Eigen::Map<const Eigen::VectorXd>(df.data(), Eigen::Index(df.size())) - ref).norm(),
              1e-10 * ref.norm());
  }
}

TEST(Contact, TheSolvesProductsEqualTheMatricesWhateverTheFactors) {
  // The products the solves ask for (penalty and friction packed together per pair, two packs
  // kept) against the assembled matrices kFactor K + bFactor B:
  // - at the step's start, with factors asked in turn as an implicit step does (its right-hand
  //   side at (1, 0), then its own, many times) and as others do;
  // - away from it (as Newton asks: the penalty's weights there differ from friction's, frozen
  //   at the start, and the two are packed apart), then back at the start;
  // - after the next step's start with other velocities (new friction);
  // with every pair sticking, then every pair sliding; and a preconditioner's diagonal
  // (only the diagonal blocks asked for) against the full matrices' diagonal.
  struct Diagonal : MatrixAccumulator {
    explicit Diagonal(std::size_t n) : d(Eigen::VectorXd::Zero(Eigen::Index(3 * n))) {}
    void addBlock(PointId i, PointId j, const Eigen::Matrix3d& b) override {
      ASSERT_TRUE(i == j) << "a block off the diagonal was added for a diagonal only";
      for (int a = 0; a < 3; ++a) d[3 * Eigen::Index(i.idx()) + a] += b(a, a);
    }
    bool diagonalOnly() const override { return true; }
    Eigen::VectorXd d;
  };
  for (unsigned seed = 1; seed <= 3; ++seed) {
    Crumpled c = crumpled(seed);
    ContactParameters prm = params(0.05, 1e3, 0.4);
    prm.stickVelocity = 1e-3;
    Contact contact(*c.topo, prm, {});
    std::mt19937 rng(seed);
    std::normal_distribution<double> g;
    const std::size_t n = c.topo->pointCapacity();
    // Still, every pair sticks (no relative velocity); moving at 5 cm/s, every pair slides.
    auto velocities = [&](bool still) {
      std::vector<double> v(c.x.size(), 0.0);
      if (!still)
        for (double& a : v) a = 0.05 * g(rng);
      return v;
    };
    auto matrices = [&](std::span<const double> at) {
      TripletAccumulator k, b;
      contact.addKToMatrix(at, k, 1.0);
      contact.addBToMatrix(at, b, 1.0);
      return std::pair<Eigen::MatrixXd, Eigen::MatrixXd>(k.toSparse(topology::Index(n)),
                                                         b.toSparse(topology::Index(n)));
    };
    auto check = [&](std::span<const double> at, const Eigen::MatrixXd& K, const Eigen::MatrixXd& B,
                     const std::vector<std::pair<double, double>>& factors, const char* where) {
      for (const auto& [kf, bf] : factors) {
        std::vector<double> dx(c.x.size()), df(c.x.size(), 0.0);
        for (double& a : dx) a = g(rng);
        contact.addDForce(at, dx, df, kf, bf);
        const Eigen::VectorXd ref = (kf * K + bf * B) * Eigen::Map<const Eigen::VectorXd>(
                                                            dx.data(), Eigen::Index(dx.size()));
        EXPECT_LT(
            (Eigen::Map<const Eigen::VectorXd>(df.data(), Eigen::Index(df.size())) - ref).norm(),
            1e-10 * ref.norm())
            << "seed " << seed << ", " << where << ", factors " << kf << ", " << bf;
      }
    };
    const std::vector<std::pair<double, double>> implicit{{1, 0},   {-2e-6, -1e-3}, {-2e-6, -1e-3},
                                                          {1, 0},   {-2e-6, -1e-3}, {0, 1},
                                                          {3, 0.5}, {-2e-6, -1e-3}};
    contact.beginStep(c.x, velocities(true), 1e-3);
    const ContactMeasure m0 = contact.measure(c.x, std::vector<double>(c.x.size(), 0.0));
    ASSERT_GT(m0.active, 10u);
    const auto [K, B] = matrices(c.x);
    ASSERT_GT(K.norm(), 0.0);
    ASSERT_GT(B.norm(), 0.0);
    check(c.x, K, B, implicit, "at the start, sticking");
    std::vector<double> moved = c.x;
    for (double& a : moved) a += 2e-3 * g(rng);
    const auto [K1, B1] = matrices(moved);
    EXPECT_GT((K1 - K).norm(), 1e-6 * K.norm()) << "the stiffness must differ away from the start";
    check(moved, K1, B1, {{-2e-6, -1e-3}, {1, 1}, {-2e-6, -1e-3}}, "away from the start");
    check(c.x, K, B, {{-2e-6, -1e-3}, {1, 0}}, "back at the start");
    contact.beginStep(c.x, velocities(false), 1e-3);
    const auto [K2, B2] = matrices(c.x);
    EXPECT_GT((B2 - B).norm(), 1e-6 * B.norm()) << "sliding friction must differ from sticking";
    check(c.x, K2, B2, implicit, "at the next step's start, sliding");
    Diagonal dk(n), db(n);
    contact.addKToMatrix(c.x, dk, 1.0);
    contact.addBToMatrix(c.x, db, 1.0);
    EXPECT_LT((dk.d - K2.diagonal()).norm(), 1e-12 * K2.diagonal().norm()) << "seed " << seed;
    EXPECT_LT((db.d - B2.diagonal()).norm(), 1e-12 * B2.diagonal().norm()) << "seed " << seed;
  }
}

TEST(Contact, StiffnessAgainstAPlaneIsExact) {
  // A point-plane pair has no curvature term: K is the exact derivative of the force.
  core::GridSpec g;
  g.nx = g.ny = 4;
  g.origin = {0, 0, 0.03};
  Topology topo(core::makeGrid(g));
  std::vector<double> x(3 * topo.pointCapacity());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.02, 0.02);
  for (PointId p : topo.points())
    for (int k = 0; k < 3; ++k)
      x[3 * p.idx() + std::size_t(k)] = topo.restPosition(p)[std::size_t(k)] + u(rng);
  Obstacle plane;
  plane.shape = planeShape({0, 0, 0}, {0.1, 0.2, 1.0});
  ContactParameters p = params(0.05, 1e3);
  p.selfContact = false;
  Contact contact(topo, p, {plane});
  std::vector<double> v(x.size(), 0.0);
  contact.beginStep(x, v, 1e-3);
  const Eigen::MatrixXd K = denseK(contact, x, topo.pointCapacity());
  ASSERT_GT(K.norm(), 0.0);
  const double h = 1e-7;
  for (std::size_t i = 0; i < x.size(); ++i) {
    std::vector<double> xp = x, xm = x, fp(x.size(), 0.0), fm(x.size(), 0.0);
    xp[i] += h;
    xm[i] -= h;
    contact.addForce(xp, v, fp);
    contact.addForce(xm, v, fm);
    for (std::size_t j = 0; j < x.size(); ++j)
      EXPECT_NEAR(K(Eigen::Index(j), Eigen::Index(i)), (fp[j] - fm[j]) / (2 * h), 1e-5 * K.norm())
          << i << ", " << j;
  }
}

TEST(Contact, FrictionDampingMatchesFiniteDifferencesInTheVelocities) {
  core::GridSpec g;
  g.nx = g.ny = 3;
  g.origin = {0, 0, 0.02};
  Topology topo(core::makeGrid(g));
  std::vector<double> x(3 * topo.pointCapacity());
  for (PointId p : topo.points())
    for (int k = 0; k < 3; ++k)
      x[3 * p.idx() + std::size_t(k)] = topo.restPosition(p)[std::size_t(k)];
  Obstacle plane;
  plane.shape = planeShape({0, 0, 0}, {0, 0, 1});
  plane.friction = 0.5;
  ContactParameters prm = params(0.05, 1e3);
  prm.selfContact = false;
  prm.stickVelocity = 0.01;
  for (double speed : {0.003, 0.2}) {  // below and above the stick velocity
    Contact contact(topo, prm, {plane});
    std::vector<double> v(x.size(), 0.0);
    std::mt19937 rng(7);
    std::normal_distribution<double> n;
    for (PointId p : topo.points()) {
      const double a = n(rng);
      v[3 * p.idx()] = speed * std::cos(a);
      v[3 * p.idx() + 1] = speed * std::sin(a);
      v[3 * p.idx() + 2] = 0.1 * speed * n(rng);
    }
    contact.beginStep(x, v, 1e-3);
    TripletAccumulator acc;
    contact.addBToMatrix(x, acc, 1.0);
    const Eigen::MatrixXd B(acc.toSparse(topo.pointCapacity()));
    ASSERT_GT(B.norm(), 0.0);
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (B + B.transpose()));
    EXPECT_LT(es.eigenvalues().maxCoeff(), 1e-9 * B.norm());
    const double h = 1e-8;
    for (std::size_t i = 0; i < x.size(); ++i) {
      std::vector<double> vp = v, vm = v, fp(x.size(), 0.0), fm(x.size(), 0.0);
      vp[i] += h;
      vm[i] -= h;
      contact.addForce(x, vp, fp);
      contact.addForce(x, vm, fm);
      for (std::size_t j = 0; j < x.size(); ++j)
        EXPECT_NEAR(B(Eigen::Index(j), Eigen::Index(i)), (fp[j] - fm[j]) / (2 * h), 1e-4 * B.norm())
            << "speed " << speed << ": " << i << ", " << j;
    }
    // addDForce's damping part is B.
    std::vector<double> dv(x.size()), df(x.size(), 0.0);
    for (double& a : dv) a = n(rng);
    contact.addDForce(x, dv, df, 0.0, 1.0);
    const Eigen::VectorXd ref =
        B * Eigen::Map<const Eigen::VectorXd>(dv.data(), Eigen::Index(dv.size()));
    EXPECT_LT((Eigen::Map<const Eigen::VectorXd>(df.data(), Eigen::Index(df.size())) - ref).norm(),
              1e-10 * ref.norm());
  }
}

/// Two sets of pairs of the sheet at c.x, each against every pair of primitives with CGAL's
/// distances:
/// - the displacement bound's (closePairs): every point-triangle and edge-edge pair within d;
/// - the penalty's (the step's candidates): each point with the closest feature of the surface
///   near it, once: a triangle's interior; an edge, when it is the closest feature of each
///   triangle beside it; a corner, when it is the closest feature of each triangle around it
///   and the point is the other's (counted once per two points); and two edges whose closest
///   points are inside both. Primitives of one triangle (a point and its triangle's edges, two
///   points joined by an edge) make no pair. A closest point within a relative 1e-11 of the
///   distance to a corner or an edge is at that corner or edge (as where two layers are
///   aligned, point over point: rounding must not make a point meet a corner's triangles and
///   edges besides the corner).
void expectPairsEqualBruteForce(const Crumpled& c, double d, const std::string& what,
                                bool expectFlatPairs = false, std::size_t* touchingFlat = nullptr,
                                std::size_t* partial = nullptr) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  const double within = d;
  Contact contact(*c.topo, params(d), {});
  std::vector<double> v(c.x.size(), 0.0);
  contact.beginStep(c.x, v, 1e-3);  // at rest: every margin is d / 2, pairs are kept within d
  auto P = [&](PointId p) {
    return K::Point_3(c.x[3 * p.idx()], c.x[3 * p.idx() + 1], c.x[3 * p.idx() + 2]);
  };
  auto dist = [](const auto& a, const auto& b) {
    return std::sqrt(CGAL::to_double(CGAL::squared_distance(a, b)));
  };
  const auto tris = c.topo->triangles();
  std::vector<std::array<PointId, 3>> T;
  for (topology::TriangleId t : tris) T.push_back(c.topo->triangleVertices(t));
  auto triangle = [&](std::size_t t) { return K::Triangle_3(P(T[t][0]), P(T[t][1]), P(T[t][2])); };
  auto holds = [&](std::size_t t, PointId p) {
    return T[t][0] == p || T[t][1] == p || T[t][2] == p;
  };
  // Triangles around each point and each edge (by its sorted points).
  std::map<PointId, std::vector<std::size_t>> around;
  std::map<std::pair<PointId, PointId>, std::vector<std::size_t>> beside;
  for (std::size_t t = 0; t < T.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      around[T[t][std::size_t(k)]].push_back(t);
      beside[std::minmax(T[t][std::size_t(k)], T[t][std::size_t((k + 1) % 3)])].push_back(t);
    }
  const double tol = 1e-11;  // (the code's kFeatureTolerance)
  std::size_t all = 0, features = 0;
  // The law's force at distance s (E = k/3 (d - s)^3 / s, k = params' stiffness), summed over
  // the penalty's pairs, each times its share: the layers' normal force measure() reports.
  const double stiffness = params(d).stiffness;
  auto law = [&](double s) {
    return s >= d
               ? 0.0
               : stiffness * (d - s) * (d - s) / s + stiffness / 3 * std::pow(d - s, 3) / (s * s);
  };
  double normal = 0.0;
  std::set<std::pair<PointId, std::pair<PointId, PointId>>> edgeFeatures;
  std::set<std::pair<PointId, PointId>> cornerFeatures;
  for (std::size_t t = 0; t < T.size(); ++t) {
    const K::Triangle_3 tri = triangle(t);
    for (PointId p : c.topo->points()) {
      if (holds(t, p)) continue;
      const double dt = dist(P(p), tri);
      if (!(dt < within)) continue;
      ++all;
      // Its closest feature: a corner, else an edge, else the interior: the feature that holds
      // the triangle's closest point (to rounding), or one within tol of the distance to the
      // triangle's plane.
      const double dp = std::min(dt, dist(P(p), tri.supporting_plane()));
      auto snaps = [&](double df) { return df <= dt * (1 + 1e-12) || df <= dp * (1 + tol); };
      int corner = -1, edge = -1;
      for (int k = 0; k < 3 && corner < 0; ++k)
        if (snaps(dist(P(p), P(T[t][std::size_t(k)])))) corner = k;
      for (int k = 0; k < 3 && corner < 0 && edge < 0; ++k)
        if (snaps(dist(P(p),
                       K::Segment_3(P(T[t][std::size_t(k)]), P(T[t][std::size_t((k + 1) % 3)])))))
          edge = k;
      if (corner >= 0)
        cornerFeatures.insert({p, T[t][std::size_t(corner)]});
      else if (edge >= 0)
        edgeFeatures.insert(
            {p, std::minmax(T[t][std::size_t(edge)], T[t][std::size_t((edge + 1) % 3)])});
      else {
        ++features;
        normal += law(dt);
      }
    }
  }
  for (const auto& [p, e] : edgeFeatures) {
    const double de = dist(P(p), K::Segment_3(P(e.first), P(e.second)));
    bool kept = true;
    for (std::size_t u : beside[e])
      kept = kept && !holds(u, p) && dist(P(p), triangle(u)) >= de * (1 - tol);
    if (kept) {
      ++features;
      normal += law(de);
    }
  }
  for (const auto& [p, q] : cornerFeatures) {
    if (q < p) continue;  // once per two points (from the lower)
    const double dq = dist(P(p), P(q));
    bool kept = true;
    for (std::size_t u : around[q])
      kept = kept && !holds(u, p) && dist(P(p), triangle(u)) >= dq * (1 - tol);
    for (std::size_t u : around[p])
      kept = kept && (holds(u, q) || dist(P(q), triangle(u)) >= dq * (1 - tol));
    if (kept) {
      ++features;
      normal += law(dq);
    }
  }
  // An edge's flatness (docs/contact.md): how far its bend lifts the far corner of one triangle
  // beside it off the other's plane, h sin(theta) (h the larger altitude over the edge, theta
  // the bend: pi less the angle between the far corners seen across the edge), 1 up to 0.05 d,
  // 0 from 0.25 d on, for a border and for a bend of 90 degrees or more, a smooth step between.
  // A pair of two edges gets 1 - the product of theirs when their triangles share no point
  // (else 1); none when that is 0.
  auto flatness = [&](PointId p, PointId q) {
    const auto& ts = beside[std::minmax(p, q)];
    if (ts.size() != 2) return 0.0;
    const K::Vector_3 e = P(q) - P(p);
    std::array<K::Vector_3, 2> u;  // the far corners' offsets across the edge
    for (int j = 0; j < 2; ++j) {
      PointId far = p;
      for (PointId r : T[ts[std::size_t(j)]])
        if (r != p && r != q) far = r;
      const K::Vector_3 w = P(far) - P(p);
      u[std::size_t(j)] = w - (CGAL::to_double(w * e) / CGAL::to_double(e * e)) * e;
    }
    const double l0 = std::sqrt(CGAL::to_double(u[0].squared_length())),
                 l1 = std::sqrt(CGAL::to_double(u[1].squared_length()));
    const double open = std::acos(std::clamp(CGAL::to_double(u[0] * u[1]) / (l0 * l1), -1.0, 1.0));
    const double bend = M_PI - open;
    if (!(bend < M_PI / 2)) return 0.0;
    const double lift = std::max(l0, l1) * std::sin(bend), t = (0.25 * d - lift) / (0.2 * d);
    return t >= 1 ? 1.0 : t <= 0 ? 0.0 : t * t * (3 - 2 * t);
  };
  const auto edges = c.topo->edges();
  std::size_t flatPairs = 0, touchingFlatPairs = 0, partialPairs = 0;
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const auto a = c.topo->edgeVertices(edges[i]);
    const K::Segment_3 sa(P(a[0]), P(a[1]));
    for (std::size_t j = i + 1; j < edges.size(); ++j) {
      const auto b = c.topo->edgeVertices(edges[j]);
      if (a[0] == b[0] || a[0] == b[1] || a[1] == b[0] || a[1] == b[1]) continue;
      const K::Segment_3 sb(P(b[0]), P(b[1]));
      const double de = dist(sa, sb);
      if (!(de < within)) continue;
      ++all;
      const double ends =
          std::min({dist(P(a[0]), sb), dist(P(a[1]), sb), dist(P(b[0]), sa), dist(P(b[1]), sa)});
      if (!(de < ends * (1 - tol))) continue;
      // (and only when their triangles share no point: else their corners' pairs may not exist)
      bool apart = true;
      for (std::size_t ta : beside[std::minmax(a[0], a[1])])
        for (std::size_t tb : beside[std::minmax(b[0], b[1])])
          for (PointId q : T[ta]) apart = apart && !holds(tb, q);
      const double fa = flatness(a[0], a[1]), fb = flatness(b[0], b[1]);
      const double share = apart ? 1 - fa * fb : 1.0;
      if (share == 0.0) {
        ++flatPairs;
        continue;
      }
      ++features;
      normal += share * law(de);
      if (share < 1.0) ++partialPairs;
      if (fa == 1.0 && fb == 1.0) ++touchingFlatPairs;
    }
  }
  if (expectFlatPairs) {
    EXPECT_GT(flatPairs, 0u) << what;
  }
  if (touchingFlat) *touchingFlat = touchingFlatPairs;
  if (partial) *partial = partialPairs;
  EXPECT_GT(all, 100u) << what;
  EXPECT_GT(features, 50u) << what;
  EXPECT_LT(features, all) << what;
  const ContactMeasure m = contact.measure(c.x, v);
  EXPECT_EQ(m.candidates, features) << what;
  EXPECT_NEAR(m.selfNormal, normal, 1e-9 * normal) << what;
  EXPECT_EQ(contact.closePairs(c.x, within, std::size_t(-1)).size(), all) << what;
  const auto report = c.topo->validate();
  EXPECT_TRUE(report.ok()) << report.summary();
}

TEST(Contact, PairsEqualABruteForceOverEveryPrimitivePair) {
  std::size_t partial = 0;
  for (unsigned seed = 1; seed <= 3; ++seed) {
    std::size_t p = 0;
    expectPairsEqualBruteForce(crumpled(seed, 11), 0.06, "seed " + std::to_string(seed), false,
                               nullptr, &p);
    partial += p;
  }
  EXPECT_GT(partial, 0u) << "some pairs of edges must have a share between 0 and 1";
}

/// An 11 x 11 grid of side 1 about the origin, its points x > 0 (the upper half) placed by
/// place(rest position, upper) and the others by place too (a fold about the middle column).
template <class Place>
Crumpled foldedGrid(bool alternating, Place place) {
  core::GridSpec g;
  g.nx = g.ny = 11;
  g.width = g.height = 1.0;
  g.origin = {-0.5, -0.5, 0.0};
  g.alternating = alternating;
  Crumpled c;
  c.topo = std::make_unique<Topology>(core::makeGrid(g));
  c.x.assign(3 * c.topo->pointCapacity(), 0.0);
  for (PointId p : c.topo->points()) {
    const Vec3 r = c.topo->restPosition(p);
    const std::array<double, 3> q = place(r, r[0] > 1e-9);
    for (int k = 0; k < 3; ++k) c.x[3 * p.idx() + std::size_t(k)] = q[std::size_t(k)];
  }
  return c;
}

TEST(Contact, PairsEqualABruteForceWhereTwoLayersAreAligned) {
  // A grid folded flat onto itself about its middle column, d/2 above: each point of the upper
  // layer is over a point of the lower one and each edge over an edge, every pair at a feature's
  // boundary, where rounding decides which side of it the closest points fall. Each point must
  // still meet the point under it once (not also its triangles and edges), as in the brute force.
  const double d = 0.06;
  for (const bool alternating : {true, false}) {  // (the diagonals over each other, or crossing)
    const Crumpled c = foldedGrid(alternating, [&](const Vec3& r, bool upper) {
      return std::array<double, 3>{upper ? -r[0] : r[0], r[1], upper ? d : 0.5 * d};
    });
    expectPairsEqualBruteForce(c, d, alternating ? "alternating diagonals" : "one way");
  }
}

TEST(Contact, PairsEqualABruteForceWhereTwoFlatLayersLieAcrossEachOther) {
  // The fold above with its upper layer moved by (h/3, h/5) in its plane, as a fold that fell
  // into place lies: each upper point over a lower triangle and the edges of the two layers
  // crossing. Two flat edges make no pair; the fold's bent edges and the layers' borders keep
  // theirs.
  const double d = 0.06, h = 0.1;
  const Crumpled c = foldedGrid(false, [&](const Vec3& r, bool upper) {
    return upper ? std::array<double, 3>{-r[0] + h / 3, r[1] + h / 5, d}
                 : std::array<double, 3>{r[0], r[1], 0.5 * d};
  });
  expectPairsEqualBruteForce(c, d, "shifted fold", true);
}

TEST(Contact, PairsEqualABruteForceInATightFold) {
  // A grid folded about its middle column by 180 - 11 degrees: two flat halves in a thin wedge.
  // Near the fold the diagonals of the cells on either side cross within d, both flat, but
  // their triangles share the fold's points: such a pair is kept (the pairs of their corners,
  // which would make it redundant, cannot exist between primitives that share points; in a
  // tight wrinkle of the drape_cut scene, dropping them let the cloth collapse between them).
  const double d = 0.06, alpha = 0.2;
  std::size_t touching = 0;
  for (const bool alternating : {true, false}) {
    const Crumpled c = foldedGrid(alternating, [&](const Vec3& r, bool upper) {
      return upper ? std::array<double, 3>{-r[0] * std::cos(alpha), r[1], r[0] * std::sin(alpha)}
                   : std::array<double, 3>{r[0], r[1], 0.0};
    });
    std::size_t t = 0;
    expectPairsEqualBruteForce(c, d, alternating ? "alternating diagonals" : "one way", true, &t);
    touching += t;
  }
  EXPECT_GT(touching, 0u);
}

/// Two copies of a side x side grid (side * side points each), the second moved by (dx, dy, dz).
MeshData twoSheets(double dx, double dy, double dz, int side = 9) {
  core::GridSpec g;
  g.nx = g.ny = side;
  const MeshData one = core::makeGrid(g);
  MeshData two = one;
  const auto n = topology::Index(one.points.size());
  for (const auto& t : one.triangles)
    two.triangles.push_back(tri(t[0].idx() + n, t[1].idx() + n, t[2].idx() + n));
  for (auto q : one.points) two.points.push_back({q[0] + dx, q[1] + dy, q[2] + dz});
  return two;
}

TEST(Contact, EachPointOfASheetOverAnAlignedSheetMeetsOnePair) {
  // Two copies of one grid, the upper s above the lower (s < d), each point over a point and
  // each edge over an edge: each point meets the point under it once, so the penalty pushes it
  // with the law's force at s, -E'(s) for E = k/3 (d - s)^3 / s (written out here), straight
  // up; its edges and triangles add nothing. The upper points are moved sideways by about
  // 1e-13 m, as rounding would place them (a fold's mirrored coordinates): exactly over, the
  // closest points are exact; a rounding's width off, they must still be the corners (before
  // the pairs were snapped to their features, a point then also met the corner's edges and
  // triangles).
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> jitter(-1e-13, 1e-13);
  const double d = 0.05, k = 2.0;
  const auto n = topology::Index(81);
  Topology topo(twoSheets(0.0, 0.0, 2 * d));  // (apart at rest: no exclusion)
  for (const double s : {0.2 * d, 0.6 * d}) {
    std::vector<double> x(3 * topo.pointCapacity(), 0.0), v(x.size(), 0.0), f(x.size(), 0.0);
    for (PointId p : topo.points())
      for (int c = 0; c < 3; ++c)
        x[3 * p.idx() + std::size_t(c)] =
            topo.restPosition(p)[std::size_t(c)] + (p.idx() < n ? 0.0
                                                    : c == 2    ? s - 2 * d
                                                                : jitter(rng));
    Contact contact(topo, params(d, k), {});
    contact.beginStep(x, v, 1e-3);
    contact.addForce(x, v, f);
    const double law = k * (d - s) * (d - s) / s + k / 3 * std::pow(d - s, 3) / (s * s);
    for (PointId p : topo.points()) {
      const double up = p.idx() >= n ? law : -law;
      EXPECT_NEAR(f[3 * p.idx() + 2], up, 1e-9 * law) << "point " << p << ", s " << s;
      EXPECT_NEAR(f[3 * p.idx()], 0.0, 1e-9 * law) << "point " << p << ", s " << s;
      EXPECT_NEAR(f[3 * p.idx() + 1], 0.0, 1e-9 * law) << "point " << p << ", s " << s;
    }
    EXPECT_EQ(contact.measure(x, v).active, std::size_t(n)) << "s " << s;
  }
}

TEST(Contact, APointNearAnEdgeOrACornerKeepsOnePairWhereverItIsWithinTheTolerance) {
  // A point s above a flat square of two triangles, moved off their shared diagonal (or off a
  // corner of it) by delta: inside the snapping's band (delta up to sqrt(2e-11) s, about 4.5e-6
  // s, a feature within a relative 1e-11 of the distance), across its edge and beyond. Whichever
  // triangle the point is over and whichever feature it is snapped to, it keeps one pair, pushed
  // by the law's force at its distance. The point is a corner of a small upright triangle whose
  // other corners are out of reach.
  const double d = 0.05, k = 2.0, s = 0.5 * d;
  MeshData m;
  m.points = {{0, 0, 0},         {1, 0, 0},         {1, 1, 0},         {0, 1, 0},
              {0.5, 0.5, 2 * d}, {0.5, 0.5, 5 * d}, {0.52, 0.5, 5 * d}};
  m.triangles = {tri(0, 1, 2), tri(0, 2, 3), tri(4, 6, 5)};
  Topology topo(m);
  const double law = k * (d - s) * (d - s) / s + k / 3 * std::pow(d - s, 3) / (s * s);
  const Eigen::Vector3d across = Eigen::Vector3d(1, -1, 0).normalized();  // (off the diagonal 0-2)
  for (const bool corner : {false, true})
    for (const double delta :
         {0.0, 1e-13, 2e-6, 3.2e-6, 3.9e-6, 4.4e-6, 4.6e-6, 5.5e-6, 6e-6, 8e-6, 1e-4, 1e-3}) {
      for (const double side : {1.0, -1.0}) {
        // Over the diagonal's middle, or near its corner 2 (inside the square).
        Eigen::Vector3d at = corner ? Eigen::Vector3d(1 - 0.3 * delta * s, 1 - 0.7 * delta * s, s)
                                    : Eigen::Vector3d(0.5, 0.5, s) + side * delta * s * across;
        if (corner && side < 0) at = Eigen::Vector3d(1 - 0.7 * delta * s, 1 - 0.3 * delta * s, s);
        std::vector<double> x(3 * topo.pointCapacity(), 0.0), v(x.size(), 0.0), f(x.size(), 0.0);
        for (PointId p : topo.points())
          for (int c = 0; c < 3; ++c)
            x[3 * p.idx() + std::size_t(c)] = topo.restPosition(p)[std::size_t(c)];
        const Eigen::Vector3d shift = at - Eigen::Vector3d(0.5, 0.5, 2 * d);
        for (PointId p : {PointId(4), PointId(5), PointId(6)})
          for (int c = 0; c < 3; ++c) x[3 * p.idx() + std::size_t(c)] += shift[c];
        Contact contact(topo, params(d, k), {});
        contact.beginStep(x, v, 1e-3);
        contact.addForce(x, v, f);
        const std::string where = std::string(corner ? "near the corner" : "off the diagonal") +
                                  ", delta " + std::to_string(delta) + " s, side " +
                                  std::to_string(side);
        EXPECT_EQ(contact.measure(x, v).active, 1u) << where;
        EXPECT_NEAR(f[3 * 4 + 2], law, 1e-6 * law) << where;
      }
    }
}

TEST(Contact, TheSearchCacheGivesTheSamePairsAsASearch) {
  // A crumpled sheet jittered, then its folded layer brought down onto the other:
  // the penalty's pairs, forces and stiffness from the cache equal a fresh search's at every
  // step, and the cache is both reused and rebuilt along the way.
  Crumpled c = crumpled(4, 11);
  const double d = 0.04;
  ContactParameters cached = params(d, 1e3, 0.3), fresh = cached;
  fresh.searchSlack = 0.0;
  Contact a(*c.topo, cached, {}), b(*c.topo, fresh, {});
  std::mt19937 rng(3);
  std::normal_distribution<double> n;
  std::vector<double> x = c.x, v(x.size(), 0.0);
  for (double& q : v) q = 0.05 * n(rng);
  for (int step = 0; step < 40; ++step) {
    a.beginStep(x, v, 1e-3);
    b.beginStep(x, v, 1e-3);
    const ContactMeasure ma = a.measure(x, v), mb = b.measure(x, v);
    ASSERT_EQ(ma.candidates, mb.candidates) << "step " << step;
    ASSERT_EQ(ma.active, mb.active) << "step " << step;
    EXPECT_GT(mb.active, 0u);
    std::vector<double> fa(x.size(), 0.0), fb(x.size(), 0.0), dx(x.size()), da(x.size(), 0.0),
        db(x.size(), 0.0);
    a.addForce(x, v, fa);
    b.addForce(x, v, fb);
    for (double& q : dx) q = n(rng);
    a.addDForce(x, dx, da, 1.0, 1.0);
    b.addDForce(x, dx, db, 1.0, 1.0);
    double scale = 0.0, worst = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      scale = std::max({scale, std::abs(fb[i]), std::abs(db[i])});
      worst = std::max({worst, std::abs(fa[i] - fb[i]), std::abs(da[i] - db[i])});
    }
    EXPECT_LE(worst, 1e-12 * scale) << "step " << step;
    // Jitter, then the folded layer coming down onto the other 1.5 mm a step (past the slack:
    // the cache is searched again).
    for (double& q : x) q += 2e-4 * n(rng);
    if (step >= 20)
      for (PointId p : c.topo->points())
        if (c.topo->restPosition(p)[0] > 0.56) x[3 * p.idx() + 2] -= 1.5e-3;
  }
  EXPECT_GT(a.searchesReused(), 10u);
  EXPECT_GT(a.searches(), 3u);
  EXPECT_EQ(b.searchesReused(), 0u);
}

TEST(Contact, TheBoundFromTheCacheEqualsTheBoundFromASearch) {
  // Two sheets 0.1 d apart, every point moving a little and three points of the upper one
  // moving through the lower (0.12 d down): slow enough for the cache, so the bound takes their
  // pairs from the cache's index of the pairs of each point; it must clamp them as a search by
  // swept boxes (no cache) does. (Each round from a fresh cache: from an older one, the two
  // may find other pairs that the continuous collision detection cannot prove apart, and bound
  // a point a little differently, both safely.)
  const double d = 0.05;
  const auto n = topology::Index(81);
  Topology topo(twoSheets(0.3 * d, 0.2 * d, 2 * d));  // (apart at rest: no exclusion)
  std::vector<double> x(3 * topo.pointCapacity(), 0.0), v(x.size(), 0.0);
  for (PointId p : topo.points())
    for (int c = 0; c < 3; ++c)
      x[3 * p.idx() + std::size_t(c)] =
          topo.restPosition(p)[std::size_t(c)] - (p.idx() >= n && c == 2 ? 1.9 * d : 0.0);
  ContactParameters cached = params(d), fresh = cached;
  fresh.searchSlack = 0.0;
  std::mt19937 rng(11);
  std::normal_distribution<double> jitter;
  for (const std::array<topology::Index, 3> far :
       {std::array<topology::Index, 3>{20, 40, 41}, {10, 11, 70}, {30, 50, 60}}) {
    Contact a(topo, cached, {}), b(topo, fresh, {});
    a.beginStep(x, v, 1e-3);
    b.beginStep(x, v, 1e-3);
    std::vector<double> xa = x, va(x.size(), 0.0), vb(x.size(), 0.0);
    for (double& q : xa) q += 1e-4 * d * jitter(rng);
    for (const topology::Index p : far) xa[3 * (n + p) + 2] -= 0.12 * d;
    std::vector<double> xb = xa;
    const std::size_t ca = a.limitDisplacement(x, xa, va, 1e-3, {}),
                      cb = b.limitDisplacement(x, xb, vb, 1e-3, {});
    EXPECT_GE(ca, 3u) << "points " << far[0] << ", " << far[1] << ", " << far[2];
    EXPECT_EQ(ca, cb) << "points " << far[0] << ", " << far[1] << ", " << far[2];
    for (std::size_t i = 0; i < x.size(); ++i) {
      ASSERT_NEAR(xa[i], xb[i], 1e-12) << "coordinate " << i;
      ASSERT_NEAR(va[i], vb[i], 1e-9) << "coordinate " << i;
    }
    // (the step searched once, building the cache; that the bound took its pairs through the
    // cache's index shows in this test failing when the index misses pairs)
    EXPECT_EQ(a.searches(), 1u);
  }
}

TEST(Contact, ThreadsChangeNothingBitForBit) {
  // A 61 x 61 grid folded onto itself with its upper layer shifted (h/3, h/5), jittered and
  // brought down step by step: a search cache of some 10^5 pairs, which one thread, two and
  // three classify (in runs of records, their pairs appended in order), and which the bound
  // scans so when every point moves. Pairs, forces, products and bounds must be equal, bit for
  // bit, at every step.
  core::GridSpec g;
  g.nx = g.ny = 61;
  g.width = g.height = 1.0;
  g.origin = {-0.5, -0.5, 0.0};
  const double h = 1.0 / 60, d = 0.6 * h;
  Topology topo(core::makeGrid(g));
  std::vector<double> x(3 * topo.pointCapacity(), 0.0), v(x.size(), 0.0);
  for (PointId p : topo.points()) {
    const Vec3 r = topo.restPosition(p);
    const bool upper = r[0] > 1e-9;
    const std::array<double, 3> q =
        upper ? std::array<double, 3>{-r[0] + h / 3, r[1] + h / 5, 1.5 * d}
              : std::array<double, 3>{r[0], r[1], 0.5 * d};
    for (int c = 0; c < 3; ++c) x[3 * p.idx() + std::size_t(c)] = q[std::size_t(c)];
  }
  ContactParameters one = params(d, 1e3, 0.3), two = one, three = one;
  one.threads = 1;
  two.threads = 2;
  three.threads = 3;
  Contact a(topo, one, {}), b(topo, two, {}), c3(topo, three, {});
  std::mt19937 rng(5);
  std::normal_distribution<double> n;
  for (double& q : v) q = 0.02 * n(rng);
  auto same = [](const std::vector<double>& p, const std::vector<double>& q) {
    return p.size() == q.size() && std::memcmp(p.data(), q.data(), p.size() * sizeof(double)) == 0;
  };
  std::size_t largest = 0, cached = 0;
  for (int step = 0; step < 12; ++step) {
    a.beginStep(x, v, 1e-3);
    b.beginStep(x, v, 1e-3);
    c3.beginStep(x, v, 1e-3);
    cached = std::max(cached, a.cachedPairs());
    const ContactMeasure ma = a.measure(x, v);
    for (const Contact* o : {&b, &c3}) {
      const ContactMeasure mb = o->measure(x, v);
      ASSERT_EQ(ma.candidates, mb.candidates) << "step " << step;
      ASSERT_EQ(ma.active, mb.active) << "step " << step;
      ASSERT_EQ(ma.selfNormal, mb.selfNormal) << "step " << step;
      ASSERT_EQ(ma.selfFriction, mb.selfFriction) << "step " << step;
    }
    largest = std::max(largest, ma.candidates);
    std::vector<double> fa(x.size(), 0.0), dx(x.size()), da(x.size(), 0.0);
    a.addForce(x, v, fa);
    for (double& q : dx) q = n(rng);
    a.addDForce(x, dx, da, 1.0, 1.0);
    for (const Contact* o : {&b, &c3}) {
      std::vector<double> fb(x.size(), 0.0), db(x.size(), 0.0);
      o->addForce(x, v, fb);
      ASSERT_TRUE(same(fa, fb)) << "forces, step " << step;
      o->addDForce(x, dx, db, 1.0, 1.0);
      ASSERT_TRUE(same(da, db)) << "products, step " << step;
    }
    // The solve's proposal: every point down by a quarter of d, jittered; bounded alike.
    std::vector<double> xa = x, va(x.size(), 0.0);
    for (std::size_t i = 0; i < x.size(); ++i)
      xa[i] += (i % 3 == 2 ? -0.25 * d : 0.0) + 0.05 * d * n(rng);
    const std::vector<double> proposal = xa;
    const std::size_t ca = a.limitDisplacement(x, xa, va, 1e-3, {});
    for (Contact* o : {&b, &c3}) {
      std::vector<double> xb = proposal, vb(x.size(), 0.0);
      ASSERT_EQ(ca, o->limitDisplacement(x, xb, vb, 1e-3, {})) << "step " << step;
      ASSERT_TRUE(same(xa, xb) && same(va, vb)) << "bounded positions, step " << step;
    }
    // On: the upper layer comes down by a tenth of d a step, everything jittered a little.
    for (double& q : x) q += 1e-3 * d * n(rng);
    for (PointId p : topo.points())
      if (topo.restPosition(p)[0] > 1e-9) x[3 * p.idx() + 2] -= 0.1 * d;
  }
  EXPECT_GT(largest, 2000u) << "the layers must be in contact";
  EXPECT_GE(cached, 3u * 16384u) << "the cache must be long enough for three runs";
  EXPECT_GT(a.searchesReused(), 3u) << "the pairs must come from the cache";
}

TEST(Contact, ThreadsChangeNothingOnARoundObstacle) {
  // A 92 x 92 sheet (16,562 triangles, measured against the ball in two runs of triangles, each
  // feature kept once, from the first triangle that meets it) draped over a ball half the
  // thickness off it where it is over the ball, flat beyond: the ball's pairs, forces, products
  // and bounds with one thread and with two must be equal, bit for bit.
  core::GridSpec g;
  g.nx = g.ny = 92;
  g.width = g.height = 1.0;
  g.origin = {-0.5, -0.5, 0.0};
  const double d = 0.006, R = 0.3;
  Topology topo(core::makeGrid(g));
  std::vector<double> x(3 * topo.pointCapacity(), 0.0), v(x.size(), 0.0);
  for (PointId p : topo.points()) {
    const Vec3 r = topo.restPosition(p);
    const double rr = std::hypot(r[0], r[1]), Rh = R + 0.5 * d;
    const double z = rr < Rh ? std::sqrt(Rh * Rh - rr * rr) : 0.0;
    x[3 * p.idx()] = r[0];
    x[3 * p.idx() + 1] = r[1];
    x[3 * p.idx() + 2] = z;
  }
  Obstacle ball;
  ball.shape = sphereShape({0, 0, 0}, R);
  ball.friction = 0.3;
  ContactParameters one = params(d, 1e3, 0.0), two = one;
  one.selfContact = two.selfContact = false;
  one.threads = 1;
  two.threads = 2;
  Contact a(topo, one, {ball}), b(topo, two, {ball});
  std::mt19937 rng(8);
  std::normal_distribution<double> n;
  auto same = [](const std::vector<double>& p, const std::vector<double>& q) {
    return p.size() == q.size() && std::memcmp(p.data(), q.data(), p.size() * sizeof(double)) == 0;
  };
  for (int step = 0; step < 3; ++step) {
    for (double& q : v) q = 0.01 * n(rng);
    a.beginStep(x, v, 1e-3);
    b.beginStep(x, v, 1e-3);
    const ContactMeasure ma = a.measure(x, v), mb = b.measure(x, v);
    ASSERT_EQ(ma.candidates, mb.candidates) << "step " << step;
    ASSERT_EQ(ma.active, mb.active) << "step " << step;
    EXPECT_GT(ma.active, 1000u) << "the sheet must lie on the ball";
    ASSERT_EQ(ma.obstacleNormal, mb.obstacleNormal) << "step " << step;
    ASSERT_EQ(ma.obstacleFriction, mb.obstacleFriction) << "step " << step;
    std::vector<double> fa(x.size(), 0.0), fb(x.size(), 0.0), dx(x.size()), da(x.size(), 0.0),
        db(x.size(), 0.0);
    a.addForce(x, v, fa);
    b.addForce(x, v, fb);
    ASSERT_TRUE(same(fa, fb)) << "forces, step " << step;
    for (double& q : dx) q = n(rng);
    a.addDForce(x, dx, da, 1.0, 1.0);
    b.addDForce(x, dx, db, 1.0, 1.0);
    ASSERT_TRUE(same(da, db)) << "products, step " << step;
    // The solve's proposal: every point a third of d towards the ball's centre, jittered;
    // bounded alike (the ball's triangles, measured in two runs).
    std::vector<double> xa = x, va(x.size(), 0.0), vb(x.size(), 0.0);
    for (std::size_t i = 0; i < x.size(); i += 3) {
      const Eigen::Vector3d q(x[i], x[i + 1], x[i + 2]);
      const Eigen::Vector3d dxp =
          -d / 3 * q.normalized() + 0.05 * d * Eigen::Vector3d(n(rng), n(rng), n(rng));
      for (int c = 0; c < 3; ++c) xa[i + std::size_t(c)] += dxp[c];
    }
    std::vector<double> xb = xa;
    const std::size_t ca = a.limitDisplacement(x, xa, va, 1e-3, {}),
                      cb = b.limitDisplacement(x, xb, vb, 1e-3, {});
    ASSERT_EQ(ca, cb) << "step " << step;
    EXPECT_GT(ca, 100u) << "the ball must bound points";
    ASSERT_TRUE(same(xa, xb) && same(va, vb)) << "bounded positions, step " << step;
    for (double& q : x) q += 1e-3 * d * n(rng);
  }
}

TEST(Contact, ASolvesHeldPositionsAreEvaluatedAgainOnceReleased) {
  // Between beginProducts(x) and endProducts(x) the products skip comparing x; after it, x
  // changed in place must be evaluated again (as a fresh contact at the new x is), and an
  // operator built at other positions meanwhile must not stand for x's.
  const Crumpled c = crumpled(2, 11);
  const double d = 0.06;
  Contact a(*c.topo, params(d, 1e3, 0.3), {});
  std::vector<double> x = c.x, v(x.size(), 0.0), dx(x.size());
  std::mt19937 rng(9);
  std::normal_distribution<double> n;
  for (double& q : dx) q = n(rng);
  a.beginStep(x, v, 1e-3);
  auto product = [&](const Contact& k, const std::vector<double>& at) {
    std::vector<double> out(at.size(), 0.0);
    k.addDForce(at, dx, out, 1.0, 0.0);
    return out;
  };
  a.beginProducts(x);
  const std::vector<double> held = product(a, x);
  std::vector<double> y = x;  // (another operator's positions, nested)
  for (double& q : y) q += 0.2 * d * n(rng);
  a.beginProducts(y);
  const std::vector<double> atY = product(a, y);
  a.endProducts(y);
  EXPECT_EQ(product(a, x), held) << "x, held, after an evaluation elsewhere";
  a.endProducts(x);
  for (double& q : x) q += 0.2 * d * n(rng);  // (in place: the same memory)
  const std::vector<double> moved = product(a, x);
  Contact fresh(*c.topo, params(d, 1e3, 0.3), {});
  fresh.beginStep(c.x, v, 1e-3);
  EXPECT_EQ(moved, product(fresh, x)) << "x, changed in place after its release";
  EXPECT_NE(moved, held) << "the change must change the products";
  EXPECT_EQ(atY, product(fresh, y));
}

TEST(Contact, CollisionStructureEqualsItsRebuildAfterTopologyChanges) {
  Crumpled c = crumpled(5, 13);
  Contact contact(*c.topo, params(0.04), {});
  std::vector<double> v(c.x.size(), 0.0);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.1, 0.9);
  for (int op = 0; op < 8; ++op) {
    contact.beginStep(c.x, v, 1e-3);
    auto report = c.topo->validate();
    ASSERT_TRUE(report.ok()) << "before operation " << op << ": " << report.summary();
    // A cut across part of the sheet (rest coordinates); new points take their ancestors' x.
    const std::vector<Vec3> line{{u(rng), 0.02, 0}, {u(rng), u(rng), 0}};
    topology::CutOptions o;
    o.repair.minAngle = 20;
    try {
      c.topo->cutPolyline(line, o);
    } catch (const TopologyError&) {
      continue;
    }
    c.x.resize(3 * c.topo->pointCapacity(), 0.0);
    v.resize(c.x.size(), 0.0);
    for (PointId p : c.topo->points())
      if (c.x[3 * p.idx()] == 0.0 && c.x[3 * p.idx() + 1] == 0.0 && c.x[3 * p.idx() + 2] == 0.0)
        for (int k = 0; k < 3; ++k)
          c.x[3 * p.idx() + std::size_t(k)] = c.topo->restPosition(p)[std::size_t(k)];
  }
  contact.beginStep(c.x, v, 1e-3);
  const auto report = c.topo->validate();
  EXPECT_TRUE(report.ok()) << report.summary();
}

TEST(Contact, TheLipsOfACutAreExcludedUntilTheySeparate) {
  core::GridSpec g;
  g.nx = g.ny = 11;
  Topology topo(core::makeGrid(g));
  Contact contact(topo, params(0.02), {});
  auto xOf = [&] {
    std::vector<double> x(3 * topo.pointCapacity());
    for (PointId p : topo.points())
      for (int k = 0; k < 3; ++k)
        x[3 * p.idx() + std::size_t(k)] = topo.restPosition(p)[std::size_t(k)];
    return x;
  };
  std::vector<double> x = xOf(), v(x.size(), 0.0);
  contact.beginStep(x, v, 1e-3);
  EXPECT_EQ(contact.measure(x, v).active, 0u) << "a flat sheet is free of contact";
  const auto cut = topo.cutPolyline(std::vector<Vec3>{{0, 0.5, 0}, {0.6, 0.5, 0}});
  x = xOf();
  v.assign(x.size(), 0.0);
  contact.beginStep(x, v, 1e-3);
  ContactMeasure m = contact.measure(x, v);
  EXPECT_GT(m.excluded, 0u);
  EXPECT_EQ(m.active, 0u) << "the lips start at distance zero: excluded";
  std::vector<double> f(x.size(), 0.0);
  contact.addForce(x, v, f);
  for (double a : f) EXPECT_EQ(a, 0.0);
  // Open the cut: the part above y = 0.5 moves up by 3 d; its lips are no longer excluded.
  for (PointId p : topo.points())
    if (topo.restPosition(p)[1] > 0.5 + 1e-9 ||
        std::find(cut.copies.begin(), cut.copies.end(), p) != cut.copies.end())
      x[3 * p.idx() + 2] += 0.06;
  contact.beginStep(x, v, 1e-3);
  m = contact.measure(x, v);
  EXPECT_EQ(m.excluded, 0u);
  // Close it again: now the lips push each other apart.
  x = xOf();
  contact.beginStep(x, v, 1e-3);
  m = contact.measure(x, v);
  EXPECT_EQ(m.excluded, 0u);
  EXPECT_GT(m.active, 0u);
}

TEST(Contact, DisplacementBoundKeepsEveryPairApart) {
  // Every point moves at most gamma times its smallest pair distance: two primitives at distance
  // D cannot meet, whatever the solve proposed.
  Crumpled c = crumpled(2, 11);
  Contact contact(*c.topo, params(0.03), {});
  std::vector<double> v(c.x.size(), 0.0);
  contact.beginStep(c.x, v, 1e-2);
  std::mt19937 rng(9);
  std::normal_distribution<double> n;
  std::vector<double> x1 = c.x, v1(c.x.size(), 0.0);
  for (double& a : x1) a += 0.2 * n(rng);  // a wild proposal
  const std::size_t clamped = contact.limitDisplacement(c.x, x1, v1, 1e-2, {});
  EXPECT_GT(clamped, 0u);
  const auto& b = contact.bounds();
  for (PointId p : c.topo->points()) {
    const double moved =
        std::hypot(x1[3 * p.idx()] - c.x[3 * p.idx()], x1[3 * p.idx() + 1] - c.x[3 * p.idx() + 1],
                   x1[3 * p.idx() + 2] - c.x[3 * p.idx() + 2]);
    EXPECT_LE(moved, b[p.idx()] * (1 + 1e-12));
    if (moved >= b[p.idx()] * (1 - 1e-12))
      EXPECT_NEAR(v1[3 * p.idx()] * 1e-2, x1[3 * p.idx()] - c.x[3 * p.idx()], 1e-15)
          << "velocity of a clamped point";
  }
  // The oracle: the crumpled sheet did not intersect itself, and does not after the step.
  auto soup = [&](const std::vector<double>& x) {
    std::vector<std::array<double, 3>> pts(c.topo->pointCapacity());
    for (PointId p : c.topo->points())
      pts[p.idx()] = {x[3 * p.idx()], x[3 * p.idx() + 1], x[3 * p.idx() + 2]};
    std::vector<std::array<std::size_t, 3>> tris;
    for (topology::TriangleId t : c.topo->triangles()) {
      const auto v = c.topo->triangleVertices(t);
      tris.push_back({std::size_t(v[0].idx()), std::size_t(v[1].idx()), std::size_t(v[2].idx())});
    }
    return test::findIntersections(pts, tris).size();
  };
  ASSERT_EQ(soup(c.x), 0u);
  EXPECT_EQ(soup(x1), 0u);
}

/// The smallest distance between a triangle of the first sheet and one of the second (CGAL's,
/// every pair: the two sheets of twoSheets, points [0, n) and [n, 2n)).
double sheetGap(const Topology& topo, const std::vector<double>& x, topology::Index n) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  std::vector<K::Triangle_3> lower, upper;
  for (topology::TriangleId t : topo.triangles()) {
    const auto v = topo.triangleVertices(t);
    auto P = [&](PointId p) {
      return K::Point_3(x[3 * p.idx()], x[3 * p.idx() + 1], x[3 * p.idx() + 2]);
    };
    (v[0].idx() < n ? lower : upper).push_back(K::Triangle_3(P(v[0]), P(v[1]), P(v[2])));
  }
  double gap = std::numeric_limits<double>::infinity();
  for (const auto& a : lower)
    for (const auto& b : upper) gap = std::min(gap, CGAL::to_double(CGAL::squared_distance(a, b)));
  return std::sqrt(gap);
}

TEST(Contact, TwoSheetsPressedHarderThanAnyLawKeepTheFloorUnderTheirGapAndStillPart) {
  // Two sheets, the upper one jittered sideways, are pressed together by proposals that would
  // take each of them 0.15 d towards the other every step, far more than the gap (no force
  // acts: as a pressure no law holds). Step after step the bound must keep the sheets at least
  // the floor apart (a thousandth of the thickness), or, found below it, no closer than they
  // started (less a millionth per step, as also once on the floor): without the floor they closed
  // by most of the gap every step, down to rounding's scale, where a triangle turned through the
  // other layer. Then the sheets must part by the whole of a separating proposal.
  const double d = 0.05, floor = 1e-3 * d, dt = 1e-2;
  const int side = 5;
  const auto n = topology::Index(side * side);
  Topology topo(twoSheets(0.0, 0.0, 2 * d, side));  // (apart at rest: no exclusion)
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> jitter(-1e-3 * d, 1e-3 * d);
  for (const double start : {0.3 * d, 0.5 * floor}) {
    std::vector<double> x(3 * topo.pointCapacity(), 0.0), v(x.size(), 0.0);
    for (PointId p : topo.points())
      for (int c = 0; c < 3; ++c)
        x[3 * p.idx() + std::size_t(c)] =
            topo.restPosition(p)[std::size_t(c)] + (p.idx() < n ? 0.0
                                                    : c == 2    ? start - 2 * d
                                                                : jitter(rng));
    const double gap0 = sheetGap(topo, x, n);
    ASSERT_NEAR(gap0, start, 1e-12);
    Contact contact(topo, params(d), {});
    const int steps = 60;
    double gap = gap0;
    for (int s = 0; s < steps; ++s) {
      contact.beginStep(x, v, dt);
      std::vector<double> x1 = x, v1(x.size(), 0.0);
      for (PointId p : topo.points()) {
        x1[3 * p.idx() + 2] += p.idx() < n ? 0.15 * d : -0.15 * d;
        if (p.idx() >= n) x1[3 * p.idx()] += jitter(rng);
      }
      contact.limitDisplacement(x, x1, v1, dt, {});
      x = x1;
      gap = sheetGap(topo, x, n);
      // (A pair that lands on the floor may be found a rounding below it: it then closes by at
      // most a millionth of its gap per step.)
      const double least = std::min(start, floor) * (1 - 1e-6 * (s + 1));
      ASSERT_GE(gap, least * (1 - 1e-9))
          << std::setprecision(17) << gap << ", start " << start << ", step " << s;
    }
    // The press was real: the sheets reached the floor (or stayed where they were found).
    EXPECT_LT(gap, start > floor ? 1.5 * floor : start) << "start " << start;
    // Parting: the upper sheet lifted by d, the lower one still, moves by all of it.
    contact.beginStep(x, v, dt);
    std::vector<double> x1 = x, v1(x.size(), 0.0);
    for (PointId p : topo.points())
      if (p.idx() >= n) x1[3 * p.idx() + 2] += d;
    const std::vector<double> proposed = x1;
    contact.limitDisplacement(x, x1, v1, dt, {});
    EXPECT_EQ(x1, proposed) << "start " << start;
  }
}

}  // namespace
}  // namespace cutsim::forcefields
