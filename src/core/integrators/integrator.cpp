// What the integrators share: step flags, the failure policy, the implicit base, the shorthand
// settings of the first scenes (integrators/*.hpp, integrator.hpp).
#include "cutsim/core/integrator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/core/integrators/explicit_euler.hpp"
#include "cutsim/core/integrators/implicit_euler.hpp"
#include "cutsim/core/registries.hpp"

namespace cutsim::core {

Integrator::~Integrator() = default;

std::string StepStats::flagText() const {
  if (!flags) return "ok";
  std::string s;
  auto add = [&](std::uint8_t bit, const char* name) {
    if (!(flags & bit)) return;
    if (!s.empty()) s.push_back('+');
    s.append(name);
  };
  add(MissedTolerance, "missed-tolerance");
  add(Indefinite, "indefinite");
  add(FellBack, "fallback");
  add(NewtonNotConverged, "newton");
  add(ResidualEnergy, "residual-energy");
  return s;
}

std::string_view toString(SolveFailurePolicy p) {
  switch (p) {
    case SolveFailurePolicy::Warn:
      return "warn";
    case SolveFailurePolicy::Fail:
      return "fail";
    case SolveFailurePolicy::Fallback:
      return "fallback";
  }
  return "?";
}

SolveFailurePolicy parseSolveFailurePolicy(std::string_view name) {
  if (name == "warn") return SolveFailurePolicy::Warn;
  if (name == "fail") return SolveFailurePolicy::Fail;
  if (name == "fallback") return SolveFailurePolicy::Fallback;
  throw InvalidInput("onSolveFailure",
                     "unknown value \"" + std::string(name) + "\" (warn, fail, fallback)");
}

void ImplicitSettings::validate() const {
  requireFiniteNonNegative("rayleighMass", rayleighMass);
  requireFiniteNonNegative("rayleighStiffness", rayleighStiffness);
  requireFinitePositive("fallbackAbove", fallbackAbove);
}

ImplicitIntegrator::ImplicitIntegrator(ImplicitSettings settings,
                                       std::unique_ptr<LinearSolver> solver)
    : settings_(settings), solver_(std::move(solver)) {
  settings_.validate();
  if (!solver_) throw InvalidInput("linearSolver", "an implicit integrator needs a linear solver");
}
ImplicitIntegrator::~ImplicitIntegrator() = default;

SystemOperator ImplicitIntegrator::systemOperator(const Model& model, std::span<const double> x,
                                                  double c, const StepConstraints& constraints) {
  auto m = model.mass().perPoint();
  diagonalMass_.resize(m.size());
  for (std::size_t p = 0; p < m.size(); ++p)
    diagonalMass_[p] = (1 + c * settings_.rayleighMass) * m[p];
  return SystemOperator(model.fields(), x, diagonalMass_, constraints.constrained,
                        c * c + c * settings_.rayleighStiffness, c, model.topology().revision());
}

Eigen::VectorXd ImplicitIntegrator::dampedForce(const Model& model) const {
  auto xs = model.state().x();
  auto vs = model.state().v();
  auto m = model.mass().perPoint();
  Eigen::VectorXd f = Eigen::VectorXd::Zero(Eigen::Index(xs.size()));
  std::span<double> fs(f.data(), xs.size());
  model.addForce(xs, vs, fs);
  for (std::size_t p = 0; p < m.size(); ++p)
    for (std::size_t k = 0; k < 3; ++k)
      fs[3 * p + k] -= settings_.rayleighMass * m[p] * vs[3 * p + k];
  if (settings_.rayleighStiffness > 0)
    model.addDForce(xs, vs, fs, settings_.rayleighStiffness, 0.0);
  requireFinite(fs, "force", "");
  return f;
}

namespace {
std::string describe(const LinearSolver& s, const SolveReport& r) {
  std::ostringstream o;
  o << "the linear solve (" << s.name() << ") ";
  if (r.indefinite)
    o << (s.direct() ? "found the system matrix not positive definite (check the stiffness and "
                       "damping parameters)"
                     : "met a direction of non-positive curvature p^T A p <= 0");
  else
    o << "missed its tolerance";
  o << ": relative residual " << r.residual << " after " << r.iterations
    << (r.iterations == 1 ? " iteration" : " iterations");
  return o.str();
}
}  // namespace

namespace {
// The residual's kinetic energy that an iterative solve may leave: a hundredth of the motion's
// kinetic energy, at least that of a velocity of kVelocityFloor over the free points.
constexpr double kResidualEnergyShare = 1e-2;
constexpr double kVelocityFloor = 1e-6;  // m/s

// What the residual's kinetic energy is compared with: a hundredth of the larger of the kinetic
// energies of v and v + dv over the free points (mass m'), plus the floor. Infinite (nothing to
// compare) when the velocities are beyond the range where their squares are doubles.
double motionEnergy(const SystemOperator& A, std::span<const double> v, const Eigen::VectorXd& dv) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const Eigen::Map<const Eigen::VectorXd> v0(v.data(), Eigen::Index(v.size()));
  if (!dv.array().isFinite().all() || !v0.array().isFinite().all()) return inf;
  if (std::max(v0.cwiseAbs().maxCoeff(), dv.cwiseAbs().maxCoeff()) > 1e100) return inf;
  const auto m = A.diagonalMass();
  double before = 0.0, after = 0.0, mass = 0.0;
  for (std::size_t p = 0; p < m.size(); ++p) {
    if (A.isConstrained(p) || !(m[p] > 0)) continue;
    const auto i = Eigen::Index(3 * p);
    mass += m[p];
    before += m[p] * v0.segment<3>(i).squaredNorm();
    after += m[p] * (v0.segment<3>(i) + dv.segment<3>(i)).squaredNorm();
  }
  return 0.5 * std::max(before, after) * kResidualEnergyShare +
         0.5 * mass * kVelocityFloor * kVelocityFloor;
}

std::string describeResidualEnergy(const LinearSolver& s, const SolveReport& r, double allowed) {
  std::ostringstream o;
  o << "the linear solve (" << s.name() << ") "
    << (r.converged ? "met its tolerance" : "missed its tolerance") << " (relative residual "
    << r.residual << " after " << r.iterations << (r.iterations == 1 ? " iteration" : " iterations")
    << ") " << (r.converged ? "but" : "and") << " its residual could carry " << r.residualEnergy
    << " J of kinetic energy, above the " << allowed
    << " J allowed (a hundredth of the step's motion)";
  if (r.converged)
    o << ": forces that nearly cancel dominate the system (a damping or a stiffness very large "
         "against the masses); the direct solver (cholmod) or a much tighter tolerance solves it";
  else
    o << ": the answer may be further from the system's than the motion it solves for; more "
         "iterations or the direct solver (cholmod) solve it";
  return o.str();
}
}  // namespace

void ImplicitIntegrator::solve(const SystemOperator& A, const Eigen::VectorXd& b,
                               Eigen::VectorXd& dv, StepStats& stats,
                               std::span<const double> velocity) {
  const Eigen::VectorXd guess = dv;
  SolveReport r = solver_->solve(A, b, dv);
  stats.iterations += r.iterations;
  ++stats.solves;
  stats.analysed = stats.analysed || r.analysed;
  auto record = [&](const SolveReport& rep) {
    stats.residual = rep.residual;
    if (!(rep.residual <= stats.worstResidual)) stats.worstResidual = rep.residual;
  };
  // A residual that is not a number says that the system's values overflow the range of doubles:
  // no policy can keep such a step (and it must not reach an output).
  if (!std::isfinite(r.residual))
    throw StepFailure{
        describe(*solver_, r) + ": the linear system's values overflow the range of doubles",
        false};
  record(r);
  // An iterative solve's answer, to be kept if it met its tolerance (or came close): is its
  // residual small against the motion?
  double allowed = 0.0;
  bool energy = false;
  if (!r.indefinite && !solver_->direct()) {
    allowed = motionEnergy(A, velocity, dv);
    energy = !(std::isfinite(r.residualEnergy) && r.residualEnergy <= allowed);
  }
  if (r.converged && !r.indefinite && !energy) return;
  if (r.indefinite) stats.flags |= StepStats::Indefinite;
  if (!r.converged) stats.flags |= StepStats::MissedTolerance;
  if (energy) stats.flags |= StepStats::ResidualEnergy;
  // (The message is made only for a step that stops.)
  auto failure = [&] {
    return energy ? describeResidualEnergy(*solver_, r, allowed) : describe(*solver_, r);
  };
  const bool far = !(r.residual <= settings_.fallbackAbove) || energy;
  switch (settings_.onSolveFailure) {
    case SolveFailurePolicy::Warn:
      if (solver_->direct() && r.indefinite) throw StepFailure{failure(), true};
      return;
    case SolveFailurePolicy::Fail:
      throw StepFailure{failure() + " (the scene's onSolveFailure is \"fail\")", r.indefinite};
    case SolveFailurePolicy::Fallback:
      break;
  }
  // A capped solve that got close is kept (flagged); non-positive curvature always falls back.
  if (!far && !r.indefinite) return;
  if (solver_->direct()) throw StepFailure{failure(), r.indefinite};
  if (!fallback_) fallback_ = makeFallbackSolver(settings_.fallbackSolver);
  const Eigen::VectorXd first = dv;
  dv = guess;
  const SolveReport f = fallback_->solve(A, b, dv);
  stats.iterations += f.iterations;
  ++stats.solves;
  stats.analysed = stats.analysed || f.analysed;
  stats.flags |= StepStats::FellBack;
  record(f);
  if (f.indefinite || !std::isfinite(f.residual))
    throw StepFailure{failure() + ", and the fallback " + describe(*fallback_, f).substr(4),
                      f.indefinite};
  if (f.converged) return;
  // Both missed: the better of the two answers is kept, the step flagged (missed-tolerance and
  // fallback); the run's warning says what to change.
  stats.flags |= StepStats::MissedTolerance;
  if (!r.indefinite && !energy && r.residual < f.residual) {
    dv = first;
    stats.residual = r.residual;
  }
}

// ---- the shorthand of the first scenes ----

void SolverSettings::validate() const {
  if (cgMaxIterations < 1)
    throw InvalidInput("solver.iterations",
                       "must be >= 1 (got " + std::to_string(cgMaxIterations) + ")");
  requireRelativeTolerance("solver.tolerance", cgTolerance);
  requireFiniteNonNegative("solver.rayleighMass", rayleighMass);
  requireFiniteNonNegative("solver.rayleighStiffness", rayleighStiffness);
  requireFinitePositive("solver.fallbackAbove", fallbackAbove);
}

std::string_view toString(SolverSettings::Kind kind) {
  switch (kind) {
    case SolverSettings::Kind::Explicit:
      return "explicit";
    case SolverSettings::Kind::ImplicitCG:
      return "implicit-cg";
    case SolverSettings::Kind::ImplicitCholmod:
      return "implicit-cholmod";
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

std::unique_ptr<Integrator> makeIntegrator(const SolverSettings& s) {
  s.validate();
  if (s.kind == SolverSettings::Kind::Explicit) return std::make_unique<ExplicitEuler>();
  ImplicitSettings is;
  is.rayleighMass = s.rayleighMass;
  is.rayleighStiffness = s.rayleighStiffness;
  is.onSolveFailure = s.onSolveFailure;
  is.fallbackAbove = s.fallbackAbove;
  std::unique_ptr<LinearSolver> ls;
  if (s.kind == SolverSettings::Kind::ImplicitCG)
    ls = std::make_unique<ConjugateGradient>(
        CGSettings{s.cgMaxIterations, s.cgTolerance, s.cgWarmStart});
  else
    ls = std::make_unique<CholmodSolver>();
  return std::make_unique<ImplicitEuler>(is, std::move(ls));
}

// ---- registration: the keys the implicit integrators share ----

std::vector<KeyInfo> implicitKeys() {
  return {
      {"rayleighMass", KeyType::Number, "mass-proportional damping factor, >= 0 (default 0)"},
      {"rayleighStiffness", KeyType::Number,
       "stiffness-proportional damping factor, >= 0 (default 0)"},
      {"onSolveFailure",
       KeyType::Choice,
       "warn, fail or fallback (default): what a linear solve that misses its tolerance does",
       {"fallback", "warn", "fail"}},
      {"fallbackAbove", KeyType::Number,
       "relative residual above which fallback re-solves with the fallbackSolver (default 1e-3)"},
      {"fallbackSolver",
       KeyType::String,
       "the linear solver that re-solves, by name, with its defaults (default cholmod)",
       {"cholmod", "cg"}}};
}

std::unique_ptr<LinearSolver> makeFallbackSolver(const std::string& name) {
  const auto* entry = LinearSolverRegistry::instance().find(name);
  if (!entry) throw InvalidInput("fallbackSolver", "unknown linear solver \"" + name + "\"");
  return entry->build(entry->readValues(ScalarParameters("fallbackSolver")));
}

ImplicitSettings readImplicitSettings(const ParameterSource& s) {
  ImplicitSettings p;
  p.rayleighMass = s.nonNegative("rayleighMass", p.rayleighMass);
  p.rayleighStiffness = s.nonNegative("rayleighStiffness", p.rayleighStiffness);
  p.onSolveFailure =
      parseSolveFailurePolicy(s.choice("onSolveFailure", "fallback", {"warn", "fail", "fallback"}));
  p.fallbackAbove = s.positive("fallbackAbove", p.fallbackAbove);
  for (const char* key : {"fallbackAbove", "fallbackSolver"})
    if (s.has(key) && p.onSolveFailure != SolveFailurePolicy::Fallback)
      s.fail(key, "is used only with \"onSolveFailure\": \"fallback\" (here \"" +
                      std::string(toString(p.onSolveFailure)) + "\")");
  if (s.has("fallbackSolver")) {
    p.fallbackSolver = s.string("fallbackSolver");
    if (!LinearSolverRegistry::instance().find(p.fallbackSolver)) {
      std::string names;
      for (const std::string& n : LinearSolverRegistry::instance().names())
        names += (names.empty() ? "" : ", ") + n;
      s.fail("fallbackSolver",
             "unknown linear solver \"" + p.fallbackSolver + "\" (" + names + ")");
    }
  }
  s.check([&] { p.validate(); });
  return p;
}

// The fallback's record: 0 (not made), 1 (made, CHOLMOD: what every checkpoint held before the
// fallback was chosen by name, so that those load and the default writes the same bytes), or 2
// followed by the solver's name; then its state.
void ImplicitIntegrator::saveState(ArchiveWriter& out) const {
  out.str(solver_->name());
  solver_->saveState(out);
  if (!fallback_) {
    out.u64(0);
    return;
  }
  const std::string name(fallback_->name());
  if (name == "cholmod") {
    out.u64(1);
  } else {
    out.u64(2);
    out.str(name);
  }
  fallback_->saveState(out);
}

void ImplicitIntegrator::loadState(ArchiveReader& in) {
  const std::string name = in.str();
  if (name != solver_->name())
    in.fail("the saved linear solver is " + name + ", the scene's " + std::string(solver_->name()));
  solver_->loadState(in);
  const std::uint64_t made = in.u64();
  if (made > 2) in.fail("a fallback record of " + std::to_string(made));
  if (made == 0) return;
  const std::string saved = made == 1 ? std::string("cholmod") : in.str();
  if (saved != settings_.fallbackSolver)
    in.fail("the saved fallback solver is " + saved + ", the scene's " + settings_.fallbackSolver);
  fallback_ = makeFallbackSolver(settings_.fallbackSolver);
  fallback_->loadState(in);
}

bool ImplicitIntegrator::checkpointable() const {
  // The fallback is made on first use: it must be saveable before it exists.
  return solver_->checkpointable() &&
         (fallback_ ? fallback_->checkpointable()
                    : makeFallbackSolver(settings_.fallbackSolver)->checkpointable());
}

}  // namespace cutsim::core
