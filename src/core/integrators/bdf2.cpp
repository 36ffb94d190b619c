// Second-order backward differentiation, linearised once per step (integrators/*.hpp,
// integrator.hpp).
#include "cutsim/core/integrators/bdf2.hpp"

#include <utility>

#include "cutsim/base/archive.hpp"

namespace cutsim::core {

bool BDF2::historyValid(const Model& model, const StepInput& in) const {
  if (!have_ || in.dt != dtLast_ || in.revision != revision_) return false;
  auto xs = model.state().x();
  auto vs = model.state().v();
  const Eigen::Index N = Eigen::Index(xs.size());
  if (xLast_.size() != N || xPrev_.size() != N) return false;
  // The state must be what the previous step returned: an edit between steps (a user moving
  // points, positions set by a script) makes the history meaningless.
  return Eigen::Map<const Eigen::VectorXd>(xs.data(), N) == xLast_ &&
         Eigen::Map<const Eigen::VectorXd>(vs.data(), N) == vLast_;
}

void BDF2::step(Model& model, const StepInput& in, StepOutput& out, StepStats& stats) {
  const double h = in.dt;
  const std::size_t n = model.numSlots();
  const Eigen::Index N = Eigen::Index(3 * n);
  auto xs = model.state().x();
  auto vs = model.state().v();
  Eigen::Map<const Eigen::VectorXd> x(xs.data(), N), v(vs.data(), N);
  auto m = model.mass().perPoint();
  const StepConstraints& c = *in.constraints;

  // Without a valid history this step is implicit Euler: beta = h and no history terms.
  const bool second = historyValid(model, in);
  restartsBefore_ = restarts_;
  if (!second) ++restarts_;
  const double beta = second ? 2.0 * h / 3.0 : h;

  const Eigen::VectorXd f = dampedForce(model);

  // w = (x_n - x_n-1) / 3 + beta v_n: the position change the right-hand side linearises about.
  Eigen::VectorXd w = beta * v;
  if (second) w += (x - xPrev_) / 3.0;
  Eigen::VectorXd Kw = Eigen::VectorXd::Zero(N);
  model.addDForce(xs, std::span<const double>(w.data(), std::size_t(N)),
                  std::span<double>(Kw.data(), std::size_t(N)), 1.0, 0.0);
  Eigen::VectorXd b = beta * (f + Kw);
  if (second)
    for (std::size_t p = 0; p < n; ++p)
      for (int k = 0; k < 3; ++k) {
        const Eigen::Index i = Eigen::Index(3 * p + k);
        b[i] += m[p] * (v[i] - vPrev_[i]) / 3.0;
      }

  // Prescribed points: the velocity that puts them on their target through the position update.
  Eigen::VectorXd dv = Eigen::VectorXd::Zero(N);
  for (std::size_t p = 0; p < n; ++p)
    if (c.constrained[p])
      for (int k = 0; k < 3; ++k) {
        const Eigen::Index i = Eigen::Index(3 * p + k);
        const double history = second ? (x[i] - xPrev_[i]) / 3.0 : 0.0;
        dv[i] = (c.target[std::size_t(i)] - x[i] - history) / beta - v[i];
      }
  const SystemOperator A = systemOperator(model, xs, beta, c);
  solve(A, b, dv, stats, vs);
  requireFinite(std::span<const double>(dv.data(), std::size_t(N)), "velocity change",
                std::string(name()));
  out.v = v + dv;
  if (second)
    out.x = (4.0 * x - xPrev_) / 3.0 + beta * out.v;
  else
    out.x = x + h * out.v;
  // Prescribed points are exactly on their targets (the formula above gets there to rounding):
  // what the simulation commits is then what the next step's history check expects.
  for (std::size_t p = 0; p < n; ++p)
    if (c.constrained[p])
      for (int k = 0; k < 3; ++k) out.x[Eigen::Index(3 * p + k)] = c.target[3 * p + std::size_t(k)];
  if (model.numGrasps() > 0) {
    Eigen::VectorXd Adv;
    A.apply(dv, Adv);
    out.reaction = (Adv - b) / beta;
  }
  // The history of the next step (the one it replaces kept for rewind()).
  swapHistory();
  rewindable_ = true;
  xPrev_ = x;
  vPrev_ = v;
  xLast_ = out.x;
  vLast_ = out.v;
  dtLast_ = h;
  revision_ = in.revision;
  have_ = true;
}

void BDF2::swapHistory() {
  xPrev_.swap(xPrevBefore_);
  vPrev_.swap(vPrevBefore_);
  xLast_.swap(xLastBefore_);
  vLast_.swap(vLastBefore_);
  std::swap(dtLast_, dtBefore_);
  std::swap(revision_, revisionBefore_);
  std::swap(have_, haveBefore_);
}

void BDF2::rewind() {
  if (!rewindable_) return;
  swapHistory();
  restarts_ = restartsBefore_;
  rewindable_ = false;
}

}  // namespace cutsim::core

// ---- registration ----
#include "cutsim/core/registries.hpp"

namespace cutsim::core {
namespace {
const bool registered = registerImplicitIntegrator<BDF2>(
    "bdf2", "second-order backward differentiation, linearised once per step (Choi and Ko)");
}  // namespace

template <class Archive, class Self>
void BDF2::members(Archive& a, Self& s) {
  fields(a, s.xPrev_, s.vPrev_, s.xLast_, s.vLast_, s.dtLast_, s.revision_, s.have_, s.restarts_);
}

void BDF2::saveState(ArchiveWriter& out) const {
  ImplicitIntegrator::saveState(out);
  members(out, *this);
}

void BDF2::loadState(ArchiveReader& in) {
  ImplicitIntegrator::loadState(in);
  members(in, *this);
  rewindable_ = false;
}

}  // namespace cutsim::core
