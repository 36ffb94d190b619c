// Backward Euler linearised once per step (integrators/*.hpp, integrator.hpp).
#include "cutsim/core/integrators/implicit_euler.hpp"

namespace cutsim::core {

void ImplicitEuler::step(Model& model, const StepInput& in, StepOutput& out, StepStats& stats) {
  const double h = in.dt;
  const std::size_t n = model.numSlots();
  const Eigen::Index N = Eigen::Index(3 * n);
  auto xs = model.state().x();
  auto vs = model.state().v();
  Eigen::Map<const Eigen::VectorXd> x(xs.data(), N), v(vs.data(), N);
  const StepConstraints& c = *in.constraints;

  const Eigen::VectorXd f = dampedForce(model);

  // b = h (f0 + h K v)
  Eigen::VectorXd Kv = Eigen::VectorXd::Zero(N);
  model.addDForce(xs, vs, std::span<double>(Kv.data(), std::size_t(N)), 1.0, 0.0);
  const Eigen::VectorXd b = h * (f + h * Kv);

  Eigen::VectorXd dv = Eigen::VectorXd::Zero(N);
  for (std::size_t p = 0; p < n; ++p)
    if (c.constrained[p])
      for (int k = 0; k < 3; ++k) {
        const Eigen::Index i = Eigen::Index(3 * p + k);
        dv[i] = (c.target[std::size_t(i)] - x[i]) / h - v[i];
      }
  const SystemOperator A = systemOperator(model, xs, h, c);
  solve(A, b, dv, stats, vs);
  requireFinite(std::span<const double>(dv.data(), std::size_t(N)), "velocity change",
                std::string(name()));
  out.v = v + dv;
  out.x = x + h * out.v;
  // Constraint forces: what the unconstrained equation misses at constrained DOFs, per time.
  if (model.numGrasps() > 0) {
    Eigen::VectorXd Adv;
    A.apply(dv, Adv);
    out.reaction = (Adv - b) / h;
  }
}

}  // namespace cutsim::core

// ---- registration ----
#include "cutsim/core/registries.hpp"

namespace cutsim::core {
namespace {
const bool registered = registerImplicitIntegrator<ImplicitEuler>(
    "implicit-euler",
    "backward Euler linearised once per step (Baraff and Witkin): first order, very stable");
}  // namespace
}  // namespace cutsim::core
