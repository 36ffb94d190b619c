// Symplectic (semi-implicit) Euler (integrators/*.hpp, integrator.hpp).
#include "cutsim/core/integrators/explicit_euler.hpp"

namespace cutsim::core {

void ExplicitEuler::step(Model& model, const StepInput& in, StepOutput& out, StepStats& /*stats*/) {
  const double h = in.dt;
  const std::size_t n = model.numSlots();
  const Eigen::Index N = Eigen::Index(3 * n);
  auto xs = model.state().x();
  auto vs = model.state().v();
  Eigen::Map<const Eigen::VectorXd> x(xs.data(), N), v(vs.data(), N);
  auto m = model.mass().perPoint();
  const StepConstraints& c = *in.constraints;

  Eigen::VectorXd f = Eigen::VectorXd::Zero(N);
  model.addForce(xs, vs, std::span<double>(f.data(), std::size_t(N)));
  requireFinite(std::span<const double>(f.data(), std::size_t(N)), "force", "");

  out.v.resize(N);
  out.reaction = Eigen::VectorXd::Zero(N);
  for (std::size_t p = 0; p < n; ++p)
    for (int k = 0; k < 3; ++k) {
      const Eigen::Index i = Eigen::Index(3 * p + k);
      if (c.constrained[p]) {
        out.v[i] = (c.target[std::size_t(i)] - x[i]) / h;
        out.reaction[i] = m[p] * (out.v[i] - v[i]) / h - f[i];
      } else {
        out.v[i] = v[i] + h * f[i] / m[p];
      }
    }
  out.x = x + h * out.v;
}

}  // namespace cutsim::core

// ---- registration ----
#include "cutsim/core/registries.hpp"

namespace cutsim::core {
namespace {
const bool registered = IntegratorRegistry::instance().add(
    {"explicit-euler",
     "symplectic Euler: cheap steps, stable only below a time step set by the stiffest spring",
     {},
     {},
     [](const ParameterSource&) -> std::any { return {}; },
     [](const std::any&, std::unique_ptr<LinearSolver>) -> std::unique_ptr<Integrator> {
       return std::make_unique<ExplicitEuler>();
     }});
}  // namespace
}  // namespace cutsim::core
