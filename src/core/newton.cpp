// Backward Euler solved to convergence by Newton's method with a line search (integrator.hpp).
#include <cmath>

#include "cutsim/core/integrator.hpp"

namespace cutsim::core {

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
    for (std::size_t i = 0; i < before.size(); ++i) model.forceField(i).setExactStiffness(before[i]);
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

void NewtonImplicitEuler::step(Model& model, const StepInput& in, StepOutput& out, StepStats& stats) {
  using Vec = Eigen::VectorXd;
  const double h = in.dt;
  const std::size_t n = model.numSlots();
  const Eigen::Index N = Eigen::Index(3 * n);
  const std::size_t Ns = std::size_t(N);
  auto xs = model.state().x();
  auto vs = model.state().v();
  const Vec xn = Eigen::Map<const Vec>(xs.data(), N);
  const Vec vn = Eigen::Map<const Vec>(vs.data(), N);
  auto m = model.mass().perPoint();
  const StepConstraints& c = *in.constraints;
  const double rM = settings_.rayleighMass, rK = settings_.rayleighStiffness;
  auto span = [&](const Vec& a) { return std::span<const double>(a.data(), Ns); };
  auto mspan = [&](Vec& a) { return std::span<double>(a.data(), Ns); };
  auto massDot = [&](const Vec& a, const Vec& b) {
    double s = 0;
    for (std::size_t p = 0; p < n; ++p) s += m[p] * a.segment<3>(Eigen::Index(3 * p)).dot(b.segment<3>(Eigen::Index(3 * p)));
    return s;
  };
  auto project = [&](Vec& a) {
    for (std::size_t p = 0; p < n; ++p)
      if (c.constrained[p]) a.segment<3>(Eigen::Index(3 * p)).setZero();
  };
  const Vec zero = Vec::Zero(N);

  // D v: the damping force, lagged at the step's start (B(x_n) + rK K(x_n)) v.
  auto damping = [&](const Vec& v) {
    Vec d = Vec::Zero(N);
    model.addDForce(xs, span(v), mspan(d), rK, 1.0);
    return d;
  };
  // The incremental potential (see integrator.hpp) and its negative gradient r (the residual).
  auto potential = [&](const Vec& v, const Vec& x) {
    const Vec dvn = v - vn;
    return 0.5 * massDot(dvn, dvn) + 0.5 * h * rM * massDot(v, v) + model.potentialEnergy(span(x)) -
           0.5 * h * v.dot(damping(v));
  };
  auto residual = [&](const Vec& v, const Vec& x) {
    Vec r = Vec::Zero(N);
    model.addForce(span(x), span(zero), mspan(r));  // elastic forces and gravity
    r += damping(v);
    for (std::size_t p = 0; p < n; ++p)
      for (int k = 0; k < 3; ++k) {
        const Eigen::Index i = Eigen::Index(3 * p + k);
        r[i] = h * (r[i] - rM * m[p] * v[i]) - m[p] * (v[i] - vn[i]);
      }
    project(r);
    requireFinite(span(r), "force", "");
    return r;
  };

  // Start from v_n (prescribed points from their targets): the first iteration is then the
  // linearised implicit Euler step about x_n + h v_n.
  Vec v = vn;
  for (std::size_t p = 0; p < n; ++p)
    if (c.constrained[p])
      for (int k = 0; k < 3; ++k) {
        const Eigen::Index i = Eigen::Index(3 * p + k);
        v[i] = (c.target[std::size_t(i)] - xn[i]) / h;
      }
  Vec x = xn + h * v;
  Vec r = residual(v, x);
  const double r0 = r.norm();
  residuals_.assign(1, r0);
  // Below this the residual is rounding: the momentum of the step, to 1e-14.
  double scale = 0;
  const Vec3& g = model.gravity();
  const double gNorm = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
  for (std::size_t p = 0; p < n; ++p) scale += m[p] * (vn.segment<3>(Eigen::Index(3 * p)).norm() + h * gNorm);
  const double floor = 1e-14 * std::max(scale, 1e-300);
  ExactStiffness exact(model, newton_.exactStiffness);
  bool converged = r0 <= floor;
  double phi = newton_.lineSearch ? potential(v, x) : 0.0;
  int it = 0;
  while (!converged && it < newton_.maxIterations) {
    ++it;
    Vec delta = Vec::Zero(N);
    {
      const SystemOperator A = systemOperator(model, span(x), h, c);
      const std::uint8_t flagsBefore = stats.flags;
      try {
        solve(A, r, delta, stats);
      } catch (const StepFailure&) {
        if (!exact.active) throw;
        // The exact stiffness is indefinite here: the fields' default one for the rest of the step
        // (an expected turn of the method, not a failed solve: the step is not flagged for it).
        exact.off();
        stats.flags = flagsBefore;
        delta.setZero();
        const SystemOperator B = systemOperator(model, span(x), h, c);
        solve(B, r, delta, stats);
      }
    }
    requireFinite(span(delta), "velocity change", std::string(name()));
    double alpha = 1.0;
    if (newton_.lineSearch) {
      const double slope = -r.dot(delta);  // d Phi / d alpha at 0
      if (!(slope < 0) && exact.active) {
        // Not a descent direction (an indefinite exact stiffness): solve with the default one.
        exact.off();
        --it;
        continue;
      }
      Vec vTry = v + delta, xTry = xn + h * vTry;
      double phiTry = potential(vTry, xTry);
      // Near the solution the decrease of Phi falls below its rounding: there the full step is
      // taken when it reduces the residual.
      const double roundoff = 1e-12 * (std::abs(phi) + std::abs(phiTry)) + 1e-300;
      if (!(phiTry <= phi + 1e-4 * slope) && std::abs(phiTry - phi) <= roundoff &&
          std::abs(slope) <= roundoff) {
        const Vec rTry = residual(vTry, xTry);
        if (rTry.norm() < r.norm()) {
          v = std::move(vTry);
          x = std::move(xTry);
          phi = phiTry;
          r = rTry;
          const double rn = r.norm();
          residuals_.push_back(rn);
          converged = rn <= newton_.tolerance * r0 || rn <= floor;
          continue;
        }
      }
      int halvings = 0;
      while (!(phiTry <= phi + 1e-4 * alpha * slope) && halvings < 30) {
        alpha *= 0.5;
        ++halvings;
        vTry = v + alpha * delta;
        xTry = xn + h * vTry;
        phiTry = potential(vTry, xTry);
      }
      if (halvings == 30) {  // no decrease along delta: rounding level, stop here
        residuals_.push_back(r.norm());
        break;
      }
      v = std::move(vTry);
      x = std::move(xTry);
      phi = phiTry;
    } else {
      v += delta;
      x = xn + h * v;
    }
    r = residual(v, x);
    const double rn = r.norm();
    residuals_.push_back(rn);
    converged = rn <= newton_.tolerance * r0 || rn <= floor;
  }
  stats.newtonIterations = it;
  stats.newtonResidual = r0 > 0 ? r.norm() / r0 : 0.0;
  if (!converged) {
    stats.flags |= StepStats::NewtonNotConverged;
    if (settings_.onSolveFailure == SolveFailurePolicy::Fail)
      throw StepFailure{"Newton's method missed its tolerance: relative residual " +
                        std::to_string(stats.newtonResidual) + " after " + std::to_string(it) +
                        " iterations (the scene's onSolveFailure is \"fail\")"};
  }
  out.v = std::move(v);
  out.x = std::move(x);
  if (model.numGrasps() > 0) {
    // The residual without the constraints' rows removed is what holds the prescribed points.
    Vec f = Vec::Zero(N);
    model.addForce(span(out.x), span(zero), mspan(f));
    f += damping(out.v);
    out.reaction.resize(N);
    for (std::size_t p = 0; p < n; ++p)
      for (int k = 0; k < 3; ++k) {
        const Eigen::Index i = Eigen::Index(3 * p + k);
        out.reaction[i] = m[p] * (out.v[i] - vn[i]) / h - (f[i] - rM * m[p] * out.v[i]);
      }
  }
}

}  // namespace cutsim::core

// ---- registration ----
#include "cutsim/core/registries.hpp"

namespace cutsim::core {
namespace {
struct NewtonParameters {
  ImplicitSettings implicit;
  NewtonSettings newton;
};

std::vector<KeyInfo> newtonKeys() {
  std::vector<KeyInfo> keys = implicitKeys();
  keys.push_back({"maxIterations", "Newton iterations per step at most, >= 1 (default 20)"});
  keys.push_back({"tolerance", "relative residual that ends the iterations, > 0 (default 1e-8)"});
  keys.push_back({"exactStiffness", "use the fields' exact K where they have one (default true)"});
  keys.push_back({"lineSearch", "backtracking line search on the incremental potential (default true)"});
  return keys;
}

const bool registered = IntegratorRegistry::instance().add({
    "newton",
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
