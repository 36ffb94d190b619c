// Backward Euler solved to convergence by Newton's method with a line search (integrators/*.hpp,
// integrator.hpp).
#include "cutsim/core/integrators/newton.hpp"

#include <cmath>

#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"

namespace cutsim::core {

void NewtonSettings::validate() const {
  if (maxIterations < 1)
    throw InvalidInput("maxIterations", "must be >= 1 (got " + std::to_string(maxIterations) + ")");
  requireRelativeTolerance("tolerance", tolerance);
}

NewtonImplicitEuler::NewtonImplicitEuler(ImplicitSettings settings, NewtonSettings newton,
                                         std::unique_ptr<LinearSolver> solver)
    : ImplicitIntegrator(settings, std::move(solver)), newton_(newton) {
  newton_.validate();
}

namespace {

/// Asks the fields for their exact stiffness for one step, and gives each back the stiffness it
/// had before when the step ends, however it ends.
struct ExactStiffness {
  ExactStiffness(Model& m, bool on) : model(m), active(on) {
    for (std::size_t i = 0; i < model.numForceFields(); ++i)
      before.push_back(model.forceField(i).stiffnessIsExact());
    if (active) model.setExactStiffness(true);
  }
  ~ExactStiffness() {
    for (std::size_t i = 0; i < before.size(); ++i)
      model.forceField(i).setExactStiffness(before[i]);
  }
  /// The fields' positive semi-definite stiffness for the rest of the step (an iteration whose
  /// exact system is indefinite).
  void off() {
    model.setExactStiffness(false);
    active = false;
  }
  Model& model;
  bool active;
  std::vector<bool> before;
};

}  // namespace

namespace {

using Vec = Eigen::VectorXd;

/// One step's nonlinear problem in the velocities v_n+1 (see integrator.hpp): the incremental
/// potential Phi, its negative gradient (the residual r, zero on the prescribed points) and the
/// constraint forces.
class IncrementalPotential {
 public:
  IncrementalPotential(const Model& model, const StepConstraints& c, double h,
                       const ImplicitSettings& s)
      : model_(model),
        c_(c),
        h_(h),
        rM_(s.rayleighMass),
        rK_(s.rayleighStiffness),
        n_(model.numSlots()),
        N_(Eigen::Index(3 * n_)),
        m_(model.mass().perPoint()),
        xn_(Eigen::Map<const Vec>(model.state().x().data(), N_)),
        vn_(Eigen::Map<const Vec>(model.state().v().data(), N_)),
        zero_(Vec::Zero(N_)),
        lag_(Vec::Zero(N_)) {
    // Forces that are not linear in the velocities (contact friction) enter linearised about
    // v_n, as in the linearised integrators: F(x, v) ~ F(x, 0) + [F(x_n, v_n) - F(x_n, 0) -
    // B(x_n) v_n] + B(x_n) v. The bracket is zero for linear damping; for Coulomb friction it is
    // the sliding force, which B (zero along the sliding direction) does not give.
    Vec withV = Vec::Zero(N_), withoutV = Vec::Zero(N_), bv = Vec::Zero(N_);
    model_.addForce(span(xn_), span(vn_), std::span<double>(withV.data(), withV.size()));
    model_.addForce(span(xn_), span(zero_), std::span<double>(withoutV.data(), withoutV.size()));
    model_.addDForce(span(xn_), span(vn_), std::span<double>(bv.data(), bv.size()), 0.0, 1.0);
    lag_ = withV - withoutV - bv;
    if (lag_.lpNorm<Eigen::Infinity>() <= 1e-12 * std::max(withV.lpNorm<Eigen::Infinity>(), 1e-300))
      lag_.setZero();
  }

  /// v_n on the free points, the velocity that reaches the target on the prescribed ones.
  Vec start() const {
    Vec v = vn_;
    for (std::size_t p = 0; p < n_; ++p)
      if (c_.constrained[p])
        for (int k = 0; k < 3; ++k) {
          const Eigen::Index i = Eigen::Index(3 * p + k);
          v[i] = (c_.target[std::size_t(i)] - xn_[i]) / h_;
        }
    return v;
  }
  Vec position(const Vec& v) const { return xn_ + h_ * v; }
  double phi(const Vec& v) const {
    const Vec dvn = v - vn_;
    return 0.5 * massDot(dvn, dvn) + 0.5 * h_ * rM_ * massDot(v, v) +
           model_.potentialEnergy(span(position(v))) - 0.5 * h_ * v.dot(damping(v)) -
           h_ * lag_.dot(v);
  }
  /// r = h (F(x) + M g - rM M v + D v) - M (v - v_n); with `all`, on the prescribed points too.
  Vec residual(const Vec& v, bool all = false) const {
    Vec r = Vec::Zero(N_);
    model_.addForce(span(position(v)), span(zero_), std::span<double>(r.data(), r.size()));
    r += damping(v) + lag_;
    for (std::size_t p = 0; p < n_; ++p)
      for (int k = 0; k < 3; ++k) {
        const Eigen::Index i = Eigen::Index(3 * p + k);
        r[i] = h_ * (r[i] - rM_ * m_[p] * v[i]) - m_[p] * (v[i] - vn_[i]);
        if (!all && c_.constrained[p]) r[i] = 0.0;
      }
    requireFinite(std::span<const double>(r.data(), std::size_t(r.size())), "force", "");
    return r;
  }
  /// Below this the residual is rounding: the step's momentum scale, to 1e-14.
  double floor() const {
    const Vec3& g = model_.gravity();
    const double gNorm = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    double scale = 0;
    for (std::size_t p = 0; p < n_; ++p)
      scale += m_[p] * (vn_.segment<3>(Eigen::Index(3 * p)).norm() + h_ * gNorm);
    return 1e-14 * std::max(scale, 1e-300);
  }
  Eigen::Index size() const { return N_; }

 private:
  std::span<const double> span(const Vec& a) const { return {a.data(), std::size_t(a.size())}; }
  double massDot(const Vec& a, const Vec& b) const {
    double s = 0;
    for (std::size_t p = 0; p < n_; ++p)
      s += m_[p] * a.segment<3>(Eigen::Index(3 * p)).dot(b.segment<3>(Eigen::Index(3 * p)));
    return s;
  }
  /// D v: the damping force, lagged at the step's start, (B(x_n) + rK K(x_n)) v.
  Vec damping(const Vec& v) const {
    Vec d = Vec::Zero(N_);
    model_.addDForce(span(xn_), span(v), std::span<double>(d.data(), d.size()), rK_, 1.0);
    return d;
  }

  const Model& model_;
  const StepConstraints& c_;
  double h_, rM_, rK_;
  std::size_t n_;
  Eigen::Index N_;
  std::span<const double> m_;
  Vec xn_, vn_, zero_;
  Vec lag_;  // the velocity-nonlinear forces' part that B misses (see the constructor)
};

/// A Newton iterate: the velocities, the potential there and the residual.
struct Iterate {
  Vec v, r;
  double phi = 0.0;
};

/// Backtracking (Armijo) along delta from `at`; false if Phi does not decrease (rounding).
/// Near the solution, where the decrease of Phi falls below its rounding, the full step is taken
/// when it reduces the residual.
bool lineSearch(const IncrementalPotential& P, const Iterate& at, const Vec& delta, Iterate& next) {
  const double slope = -at.r.dot(delta);  // d Phi / d alpha at 0
  double alpha = 1.0;
  next.v = at.v + delta;
  next.phi = P.phi(next.v);
  const double roundoff = 1e-12 * (std::abs(at.phi) + std::abs(next.phi)) + 1e-300;
  if (!(next.phi <= at.phi + 1e-4 * slope) && std::abs(next.phi - at.phi) <= roundoff &&
      std::abs(slope) <= roundoff) {
    next.r = P.residual(next.v);
    if (next.r.norm() < at.r.norm()) return true;
  }
  for (int halvings = 0; !(next.phi <= at.phi + 1e-4 * alpha * slope); ++halvings) {
    if (halvings == 30) return false;
    alpha *= 0.5;
    next.v = at.v + alpha * delta;
    next.phi = P.phi(next.v);
  }
  next.r = P.residual(next.v);
  return true;
}

}  // namespace

void NewtonImplicitEuler::step(Model& model, const StepInput& in, StepOutput& out,
                               StepStats& stats) {
  const double h = in.dt;
  const StepConstraints& c = *in.constraints;
  const IncrementalPotential P(model, c, h, settings_);
  // The fields' stiffness for the step first: the damping term of Phi and of the residual uses it.
  ExactStiffness exact(model, newton_.exactStiffness);
  // From v_n the first iteration is the linearised implicit Euler step about x_n + h v_n.
  Iterate it;
  it.v = P.start();
  it.r = P.residual(it.v);
  it.phi = newton_.lineSearch ? P.phi(it.v) : 0.0;
  const double r0 = it.r.norm(), floor = P.floor();
  residuals_.assign(1, r0);
  bool converged = r0 <= floor;
  int k = 0;
  // Drops the exact stiffness for the rest of the step; Phi and r change with it (the damping).
  auto dropExact = [&] {
    exact.off();
    it.r = P.residual(it.v);
    if (newton_.lineSearch) it.phi = P.phi(it.v);
  };
  while (!converged && k < newton_.maxIterations) {
    ++k;
    Vec delta = Vec::Zero(P.size());
    const Vec x = P.position(it.v);
    const std::uint8_t flagsBefore = stats.flags;
    try {
      solve(systemOperator(model, {x.data(), std::size_t(x.size())}, h, c), it.r, delta, stats,
            {it.v.data(), std::size_t(it.v.size())});
    } catch (const StepFailure& e) {
      if (!exact.active || !e.indefinite) throw;
      // The exact stiffness is indefinite here: the fields' default one for the rest of the step
      // (an expected turn of the method, not a failed solve: the step is not flagged for it).
      dropExact();
      stats.flags = flagsBefore;
      delta.setZero();
      solve(systemOperator(model, {x.data(), std::size_t(x.size())}, h, c), it.r, delta, stats,
            {it.v.data(), std::size_t(it.v.size())});
    }
    requireFinite({delta.data(), std::size_t(delta.size())}, "velocity change",
                  std::string(name()));
    Iterate next;
    if (newton_.lineSearch) {
      if (!(it.r.dot(delta) > 0) && exact.active) {
        // Not a descent direction (an indefinite exact stiffness): solve with the default one
        // (again an expected turn, not flagged).
        dropExact();
        stats.flags = flagsBefore;
        --k;
        continue;
      }
      if (!lineSearch(P, it, delta, next)) {  // no decrease along delta: rounding level
        residuals_.push_back(it.r.norm());
        break;
      }
    } else {
      next.v = it.v + delta;
      next.r = P.residual(next.v);
    }
    it = std::move(next);
    residuals_.push_back(it.r.norm());
    converged = residuals_.back() <= newton_.tolerance * r0 || residuals_.back() <= floor;
  }
  stats.newtonIterations = k;
  stats.newtonResidual = r0 > 0 ? it.r.norm() / r0 : 0.0;
  if (!converged) {
    stats.flags |= StepStats::NewtonNotConverged;
    if (settings_.onSolveFailure == SolveFailurePolicy::Fail)
      throw StepFailure{"Newton's method missed its tolerance: relative residual " +
                        std::to_string(stats.newtonResidual) + " after " + std::to_string(k) +
                        " iterations (the scene's onSolveFailure is \"fail\")"};
  }
  out.x = P.position(it.v);
  // What holds the prescribed points: the residual of their own rows, per time.
  if (model.numGrasps() > 0) out.reaction = -P.residual(it.v, true) / h;
  out.v = std::move(it.v);
}

}  // namespace cutsim::core

// ---- registration ----
#include "cutsim/core/registries.hpp"

namespace cutsim::core {
namespace {
std::vector<KeyInfo> newtonKeys() {
  std::vector<KeyInfo> keys = implicitKeys();
  keys.push_back(
      {"maxIterations", KeyType::Integer, "Newton iterations per step at most, >= 1 (default 20)"});
  keys.push_back({"tolerance", KeyType::Number,
                  "relative residual that ends the iterations, > 0 (default 1e-8)"});
  keys.push_back({"exactStiffness", KeyType::Boolean,
                  "use the fields' exact K where they have one (default true)"});
  keys.push_back({"lineSearch", KeyType::Boolean,
                  "backtracking line search on the incremental potential (default true)"});
  return keys;
}

const bool registered = IntegratorRegistry::instance().add(
    {"newton",
     "backward Euler solved to convergence by Newton's method with a line search",
     newtonKeys(),
     {"linearSolver"},
     [](const ParameterSource& s) -> std::any {
       NewtonParameters p;
       p.implicit = readImplicitSettings(s);
       p.newton.maxIterations = int(s.integer("maxIterations", 1, 1000000, p.newton.maxIterations));
       p.newton.tolerance = s.positive("tolerance", p.newton.tolerance);
       p.newton.exactStiffness = s.boolean("exactStiffness", p.newton.exactStiffness);
       p.newton.lineSearch = s.boolean("lineSearch", p.newton.lineSearch);
       s.check([&] { p.newton.validate(); });
       return p;
     },
     [](const std::any& a, std::unique_ptr<LinearSolver> ls) -> std::unique_ptr<Integrator> {
       const auto& p = std::any_cast<const NewtonParameters&>(a);
       return std::make_unique<NewtonImplicitEuler>(p.implicit, p.newton, std::move(ls));
     }});
}  // namespace
}  // namespace cutsim::core
