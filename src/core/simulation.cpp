// Simulation: state, mass, force fields, constraints, and the time integrators:
//  - explicit: symplectic Euler;
//  - implicit Euler linearised once per step (Baraff and Witkin 1998), with Rayleigh damping,
//      (M (1 + h rM) - h B - (h^2 + h rK) K) dv = h (f0 + h K v0),
//    f0 = F(x, v) + M g - rM M v + rK K v, solved by matrix-free conjugate gradients (Jacobi
//    preconditioned, the diagonal gathered from the fields without assembly) or by CHOLMOD
//    (supernodal Cholesky through Eigen's CholmodSupport) on the matrix assembled in place in a
//    pattern kept, with its symbolic analysis, until the topology changes (system_matrix.hpp).
// Constrained points (fixed, grasped, and points without mass) get a prescribed velocity change.
#include "cutsim/core/simulation.hpp"

#include <dlfcn.h>

#include <Eigen/CholmodSupport>
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <sstream>

#include "cutsim/forcefields/parameters.hpp"
#include "cutsim/topology/errors.hpp"
#include "system_matrix.hpp"

namespace cutsim::core {

using Vec = Eigen::VectorXd;
using VecMap = Eigen::Map<Vec>;
using ConstVecMap = Eigen::Map<const Vec>;

namespace {

/// OpenBLAS (which CHOLMOD's supernodal factorisation uses when it is the installed BLAS) and
/// OpenMP (which Debian's CHOLMOD is built with) would pick their thread counts from the machine;
/// one thread keeps results identical from run to run (and avoids spinning threads on a busy
/// machine).
void pinBlasThreads() {
  static bool done = false;
  if (done) return;
  done = true;
  using SetThreads = void (*)(int);
  if (auto fn = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) fn(1);
  if (auto fn = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "omp_set_num_threads"))) fn(1);
}

/// Keeps only the diagonal entries of the blocks it is given.
struct DiagonalAccumulator : forcefields::MatrixAccumulator {
  explicit DiagonalAccumulator(Eigen::Index n) : diagonal(Vec::Zero(n)) {}
  void addBlock(PointId i, PointId j, const Eigen::Matrix3d& b) override {
    if (i != j) return;
    for (int a = 0; a < 3; ++a) diagonal[3 * Eigen::Index(i) + a] += b(a, a);
  }
  void addScaledIdentity(PointId i, PointId j, double s) override {
    if (i != j) return;
    for (int a = 0; a < 3; ++a) diagonal[3 * Eigen::Index(i) + a] += s;
  }
  Vec diagonal;
};

}  // namespace

void SolverSettings::validate() const {
  if (cgMaxIterations < 1)
    throw InvalidInput("solver.iterations", "must be >= 1 (got " + std::to_string(cgMaxIterations) + ")");
  forcefields::requireFinitePositive("solver.tolerance", cgTolerance);
  forcefields::requireFiniteNonNegative("solver.rayleighMass", rayleighMass);
  forcefields::requireFiniteNonNegative("solver.rayleighStiffness", rayleighStiffness);
}

std::string_view toString(SolverSettings::Kind kind) {
  switch (kind) {
    case SolverSettings::Kind::Explicit: return "explicit";
    case SolverSettings::Kind::ImplicitCG: return "implicit-cg";
    case SolverSettings::Kind::ImplicitCholmod: return "implicit-cholmod";
  }
  return "?";
}

SolverSettings::Kind parseSolverKind(std::string_view name) {
  if (name == "explicit") return SolverSettings::Kind::Explicit;
  if (name == "implicit-cg") return SolverSettings::Kind::ImplicitCG;
  if (name == "implicit-cholmod") return SolverSettings::Kind::ImplicitCholmod;
  throw InvalidInput("solver.type", "unknown solver '" + std::string(name) +
                                        "' (explicit, implicit-cg, implicit-cholmod)");
}

// Ordering policy of the CHOLMOD system's pattern (see step()).
constexpr int kShortLivedPattern = 10;
constexpr int kReorderAfter = 20;

struct Simulation::Solver {
  Solver() {
    // The system matrix is numbered in a fill-reducing order already (METIS on the point graph).
    cholmod.cholmod().nmethods = 1;
    cholmod.cholmod().method[0].ordering = CHOLMOD_NATURAL;
  }
  Vec warm;  // previous velocity change (CG warm start)
  Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Lower> cholmod;
  SystemMatrix system;
  std::uint64_t revision = 0;  // the topology's revision the pattern was built for
  std::size_t numFields = 0;
  int stepsOnPattern = 0;  // steps solved with the current pattern
  bool analysed = false;
};

Simulation::Simulation(std::unique_ptr<topology::Topology> topology, double density)
    : topology_(std::move(topology)) {
  if (!topology_) throw InvalidInput("mesh", "no topology");
  state_ = std::make_unique<MechanicalState>(*topology_);
  if (density > 0) mass_ = std::make_unique<LumpedMass>(*topology_, density);
  fixed_ = std::make_unique<PointSet>(*topology_, "fixed");
  solverImpl_ = std::make_unique<Solver>();
}

Simulation::~Simulation() {
  // Fields and constraints unsubscribe before the topology goes.
  fields_.clear();
  grasps_.clear();
  fixed_.reset();
  mass_.reset();
  state_.reset();
}

forcefields::ForceField& Simulation::addForceField(std::unique_ptr<forcefields::ForceField> field,
                                                   std::string label) {
  if (label.empty()) label = field->typeName();
  fields_.push_back({std::move(field), std::move(label)});
  return *fields_.back().field;
}

Grasp& Simulation::addGrasp(const std::string& name, std::span<const PointId> points, DisplacementPath path) {
  if (findGrasp(name)) throw InvalidInput("grasp '" + name + "'", "a grasp of that name is already active");
  auto g = std::make_unique<Grasp>(*topology_, name, time_, std::move(path));
  auto x = state_->x();
  for (PointId p : points) {
    if (!topology_->isPointAlive(p)) throw InvalidInput("grasp '" + name + "'", "point " + std::to_string(p) + " does not exist");
    g->add(p, {x[3 * p], x[3 * p + 1], x[3 * p + 2]});
  }
  grasps_.push_back(std::move(g));
  return *grasps_.back();
}

void Simulation::releaseGrasp(const std::string& name) {
  auto it = std::find_if(grasps_.begin(), grasps_.end(), [&](auto& g) { return g->name() == name; });
  if (it == grasps_.end()) throw InvalidInput("grasp '" + name + "'", "no active grasp of that name to release");
  grasps_.erase(it);
}

Grasp* Simulation::findGrasp(const std::string& name) {
  for (auto& g : grasps_)
    if (g->name() == name) return g.get();
  return nullptr;
}

void Simulation::setSolver(const SolverSettings& s) {
  s.validate();
  solver_ = s;
  solverImpl_ = std::make_unique<Solver>();
}

double Simulation::kineticEnergy() const {
  if (!mass_) return 0.0;
  auto m = mass_->perPoint();
  auto v = state_->v();
  double e = 0;
  for (std::size_t p = 0; p < m.size(); ++p)
    e += 0.5 * m[p] * (v[3 * p] * v[3 * p] + v[3 * p + 1] * v[3 * p + 1] + v[3 * p + 2] * v[3 * p + 2]);
  return e;
}

double Simulation::gravityEnergy() const {
  if (!mass_) return 0.0;
  auto m = mass_->perPoint();
  auto x = state_->x();
  double e = 0;
  for (std::size_t p = 0; p < m.size(); ++p)
    e -= m[p] * (gravity_[0] * x[3 * p] + gravity_[1] * x[3 * p + 1] + gravity_[2] * x[3 * p + 2]);
  return e;
}

double Simulation::potentialEnergy(std::size_t i) const { return fields_.at(i).field->potentialEnergy(state_->x()); }

std::vector<double> Simulation::totalForce() const {
  std::vector<double> f(state_->x().size(), 0.0);
  for (auto& fl : fields_) fl.field->addForce(state_->x(), state_->v(), f);
  if (mass_) {
    auto m = mass_->perPoint();
    for (std::size_t p = 0; p < m.size(); ++p)
      for (int c = 0; c < 3; ++c) f[3 * p + c] += m[p] * gravity_[c];
  }
  return f;
}

void Simulation::checkFinite(std::span<const double> a, const char* what, const std::string& component) const {
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!std::isfinite(a[i])) {
      std::ostringstream s;
      s << "step " << steps_ + 1 << " (t = " << time_ << "): non-finite " << what;
      if (!component.empty()) s << " from " << component;
      s << " at point " << i / 3;
      if (solver_.kind == SolverSettings::Kind::Explicit)
        s << "; the explicit integrator is unstable at this time step: try a smaller one or an implicit solver";
      throw SolverError(s.str());
    }
}

StepStats Simulation::step(double dt) {
  forcefields::requireFinitePositive("timeStep", dt);
  if (!mass_) throw SolverError("the simulation has no mass: give a density or a total mass");
  pinBlasThreads();
  const std::size_t n = state_->numSlots();
  const Eigen::Index N = Eigen::Index(3 * n);
  auto xs = state_->x();
  auto vs = state_->v();
  VecMap x(xs.data(), N), v(vs.data(), N);
  auto ms = mass_->perPoint();
  const double rM = solver_.rayleighMass, rK = solver_.rayleighStiffness;
  const double tNext = time_ + dt;

  // Constrained degrees of freedom and their target velocities.
  std::vector<char> constrained(n, 0);
  Vec vTarget = Vec::Zero(N);
  for (std::size_t p = 0; p < n; ++p)
    if (!(ms[p] > 0) || !topology_->isPointAlive(topology::PointId(p)) || fixed_->contains(topology::PointId(p)))
      constrained[p] = 1;
  for (auto& g : grasps_)
    for (PointId p : g->points().points()) {
      constrained[p] = 1;
      Vec3 target = g->target(p, tNext);
      for (int c = 0; c < 3; ++c) vTarget[3 * p + c] = (target[c] - x[3 * p + c]) / dt;
    }

  // Forces at the start of the step.
  Vec f = Vec::Zero(N);
  std::span<double> fs(f.data(), std::size_t(N));
  for (auto& fl : fields_) {
    fl.field->addForce(xs, vs, fs);
    checkFinite(fs, "force", fl.label);
  }
  for (std::size_t p = 0; p < n; ++p)
    for (int c = 0; c < 3; ++c) f[3 * p + c] += ms[p] * (gravity_[c] - rM * v[3 * p + c]);
  if (rK > 0)
    for (auto& fl : fields_) fl.field->addDForce(xs, vs, fs, rK, 0.0);
  checkFinite(fs, "force", "");

  StepStats stats;
  Vec vNew(N);
  Vec reactionForce = Vec::Zero(N);  // force the constraints exert, per DOF
  if (solver_.kind == SolverSettings::Kind::Explicit) {
    for (std::size_t p = 0; p < n; ++p)
      for (int c = 0; c < 3; ++c) {
        const Eigen::Index i = Eigen::Index(3 * p + c);
        if (constrained[p]) {
          vNew[i] = vTarget[i];
          reactionForce[i] = ms[p] * (vNew[i] - v[i]) / dt - f[i];
        } else {
          vNew[i] = v[i] + dt * f[i] / ms[p];
        }
      }
  } else {
    // b = h (f0 + h K v)
    Vec Kv = Vec::Zero(N);
    std::span<double> kvs(Kv.data(), std::size_t(N));
    for (auto& fl : fields_) fl.field->addDForce(xs, vs, kvs, 1.0, 0.0);
    Vec b = dt * (f + dt * Kv);
    const double kFactor = dt * dt + dt * rK, bFactor = dt;
    auto applyA = [&](const Vec& p, Vec& out) {
      out.resize(N);
      for (std::size_t q = 0; q < n; ++q)
        for (int c = 0; c < 3; ++c) out[3 * q + c] = (1 + dt * rM) * ms[q] * p[3 * q + c];
      Vec df = Vec::Zero(N);
      std::span<double> dfs(df.data(), std::size_t(N));
      std::span<const double> ps(p.data(), std::size_t(N));
      for (auto& fl : fields_) fl.field->addDForce(xs, ps, dfs, kFactor, bFactor);
      out -= df;
    };
    Vec dv = Vec::Zero(N);
    for (std::size_t p = 0; p < n; ++p)
      if (constrained[p])
        for (int c = 0; c < 3; ++c) dv[3 * p + c] = vTarget[3 * p + c] - v[3 * p + c];
    auto project = [&](Vec& a) {
      for (std::size_t p = 0; p < n; ++p)
        if (constrained[p]) a.segment<3>(Eigen::Index(3 * p)).setZero();
    };
    Vec bFree = b;  // the right-hand side on the free DOFs: residuals are relative to it
    project(bFree);
    const double bNorm = bFree.norm();
    if (solver_.kind == SolverSettings::Kind::ImplicitCG) {
      auto& S = *solverImpl_;
      if (solver_.cgWarmStart && S.warm.size() == N)
        for (std::size_t p = 0; p < n; ++p)
          if (!constrained[p]) dv.segment<3>(Eigen::Index(3 * p)) = S.warm.segment<3>(Eigen::Index(3 * p));
      // Jacobi preconditioner: the diagonal of A (mass and the diagonal of the stiffness and
      // damping blocks, gathered without assembling the matrix).
      DiagonalAccumulator diagK(N);
      for (auto& fl : fields_) {
        fl.field->addKToMatrix(xs, diagK, -kFactor);
        fl.field->addBToMatrix(xs, diagK, -bFactor);
      }
      Vec invDiag(N);
      for (std::size_t p = 0; p < n; ++p)
        for (int c = 0; c < 3; ++c) {
          const Eigen::Index i = Eigen::Index(3 * p + c);
          const double d = (1 + dt * rM) * ms[p] + diagK.diagonal[i];
          invDiag[i] = constrained[p] || !(d > 0) ? 0.0 : 1.0 / d;
        }
      Vec Ap;
      applyA(dv, Ap);
      Vec r = b - Ap;
      project(r);
      Vec z = invDiag.cwiseProduct(r);
      Vec pdir = z;
      double rz = r.dot(z);
      double rNorm = r.norm();
      int it = 0;
      const double stop = solver_.cgTolerance * std::max(bNorm, 1e-300);
      while (it < solver_.cgMaxIterations && rNorm > stop) {
        applyA(pdir, Ap);
        project(Ap);
        const double pAp = pdir.dot(Ap);
        if (!(pAp > 0)) break;  // not positive definite along pdir (or zero): stop
        const double alpha = rz / pAp;
        dv += alpha * pdir;
        r -= alpha * Ap;
        z = invDiag.cwiseProduct(r);
        const double rzNew = r.dot(z);
        pdir = z + (rzNew / rz) * pdir;
        rz = rzNew;
        rNorm = r.norm();
        ++it;
      }
      stats.iterations = it;
      stats.residual = bNorm > 0 ? rNorm / bNorm : 0.0;
      S.warm = dv;
    } else {
      auto& S = *solverImpl_;
      SystemMatrix::Fields fl;
      for (auto& field : fields_) fl.push_back(field.field.get());
      // The pattern follows the topology and the list of fields; a field that adds a block
      // outside it (it should not) gets the pattern rediscovered, once.
      bool rebuild = !S.system.built() || S.revision != topology_->revision() ||
                     S.numFields != fields_.size() || S.system.numSlots() != n;
      // Nested dissection costs more to compute but factorises faster: worth it for a pattern
      // that lasts. A pattern that lasted only a few steps (a progressive cut) is followed by
      // minimum-degree ones, until one of those has lasted long enough to be worth reordering.
      using Ordering = SystemMatrix::Ordering;
      Ordering ordering = Ordering::NestedDissection;
      if (rebuild && S.system.built() && S.stepsOnPattern < kShortLivedPattern) ordering = Ordering::MinimumDegree;
      if (!rebuild && S.system.ordering() == Ordering::MinimumDegree && S.stepsOnPattern >= kReorderAfter)
        rebuild = true;
      if (rebuild) S.stepsOnPattern = 0;
      ++S.stepsOnPattern;
      std::vector<double> diagonalMass(n);
      for (std::size_t p = 0; p < n; ++p) diagonalMass[p] = (1 + dt * rM) * ms[p];
      for (int attempt = 0;; ++attempt) {
        if (rebuild) {
          S.system.build(fl, xs, n, ordering);
          S.revision = topology_->revision();
          S.numFields = fields_.size();
          S.analysed = false;
        }
        if (S.system.fill(fl, xs, kFactor, bFactor, diagonalMass)) break;
        if (attempt > 0) throw SolverError("internal error: a force field's matrix blocks left the pattern it gave");
        rebuild = true;
      }
      const Vec rhs = S.system.eliminate(constrained, b, dv);
      auto& A = S.system.matrix();
      if (!S.analysed) {
        // CHOLMOD keeps the numbering's fill-reducing order (only postordering its elimination
        // tree, which changes no fill).
        S.cholmod.analyzePattern(A);
        S.analysed = true;
        stats.analysed = true;
      }
      S.cholmod.factorize(A);
      if (S.cholmod.info() != Eigen::Success) {
        std::ostringstream s;
        s << "step " << steps_ + 1 << " (t = " << time_ << "): CHOLMOD could not factorise the system "
          << "matrix (not positive definite): check the stiffness and damping parameters";
        throw SolverError(s.str());
      }
      dv = S.system.toOriginal(S.cholmod.solve(rhs));
      Vec check;
      applyA(dv, check);
      Vec res = b - check;
      project(res);
      stats.iterations = 1;
      stats.residual = bNorm > 0 ? res.norm() / bNorm : 0.0;
    }
    checkFinite(std::span<const double>(dv.data(), std::size_t(N)), "velocity change", std::string(toString(solver_.kind)));
    vNew = v + dv;
    // Constraint forces: what the unconstrained equation misses at constrained DOFs, per time.
    if (!grasps_.empty()) {
      Vec Adv;
      applyA(dv, Adv);
      reactionForce = (Adv - b) / dt;
    }
  }

  Vec xNew = x + dt * vNew;
  checkFinite(std::span<const double>(vNew.data(), std::size_t(N)), "velocity", "");
  checkFinite(std::span<const double>(xNew.data(), std::size_t(N)), "position", "");
  // Dead points and points without mass (isolated) do not move.
  for (std::size_t p = 0; p < n; ++p)
    if (!(ms[p] > 0) || !topology_->isPointAlive(topology::PointId(p))) {
      vNew.segment<3>(Eigen::Index(3 * p)).setZero();
      xNew.segment<3>(Eigen::Index(3 * p)) = x.segment<3>(Eigen::Index(3 * p));
    }
  v = vNew;
  x = xNew;
  for (auto& g : grasps_) {
    Vec3 r{0, 0, 0};
    for (PointId p : g->points().points())
      for (int c = 0; c < 3; ++c) r[c] += reactionForce[3 * p + c];
    g->setReaction(r);
  }
  time_ = tNext;
  ++steps_;
  return stats;
}

}  // namespace cutsim::core
