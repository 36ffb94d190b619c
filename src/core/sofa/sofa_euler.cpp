// sofa-euler: SOFA's EulerImplicitSolver with its CGLinearSolver, operation for operation
// (docs/sofa.md). implicit-euler with sofa-cg solves the same system; this integrator also keeps
// SOFA's order of every sum (forces and products accumulated component by component in the
// scene's order, dot products point by point, its factors computed as it computes them) and is
// compiled without fused multiply-adds (-ffp-contract=off), so that a scene whose result depends on
// every rounding gives SOFA's numbers.
#include <cmath>
#include <memory>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/core/integrator.hpp"
#include "cutsim/core/linear_solver.hpp"
#include "cutsim/core/model.hpp"
#include "cutsim/core/registries.hpp"

namespace cutsim::core {
namespace {

struct SofaEulerSettings {
  double rayleighMass = 0.0, rayleighStiffness = 0.0;
  /// The mass's place among the force fields in SOFA's node (0: before them all): SOFA sums the
  /// forces and the products of its system component by component in that order.
  int massAt = 0;
};

/// SOFA's MechanicalObject::vDot: point by point, each point's dot product summed in order.
double vDot(const std::vector<double>& a, const std::vector<double>& b) {
  double r = 0.0;
  for (std::size_t i = 0; i + 2 < a.size(); i += 3)
    r += a[i] * b[i] + a[i + 1] * b[i + 1] + a[i + 2] * b[i + 2];
  return r;
}

class SofaEuler final : public Integrator {
 public:
  SofaEuler(SofaEulerSettings s, std::unique_ptr<LinearSolver> solver)
      : s_(s), solver_(std::move(solver)) {
    cg_ = dynamic_cast<SofaConjugateGradient*>(solver_.get());
    if (!cg_)
      throw InvalidInput("linearSolver",
                         "sofa-euler solves with sofa-cg (SOFA's CGLinearSolver), not " +
                             std::string(solver_ ? solver_->name() : "none"));
  }
  std::string_view name() const override { return "sofa-euler"; }
  LinearSolver* linearSolver() const override { return solver_.get(); }
  std::array<double, 2> rayleigh() const override {
    return {s_.rayleighMass, s_.rayleighStiffness};
  }
  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override {
    solver_->saveState(out);
    fields(out, solves_, warm_);
  }
  void loadState(ArchiveReader& in) override {
    solver_->loadState(in);
    fields(in, solves_, warm_);
  }

  void step(Model& model, const StepInput& in, StepOutput& out, StepStats& stats) override {
    const double h = in.dt, tr = 1.0;
    const std::size_t n = model.numSlots(), N = 3 * n;
    const auto xs = model.state().x(), vs = model.state().v();
    const auto m = model.mass().perPoint();
    const bool uniform = model.mass().law().kind == MassLaw::Kind::PerPoint;
    const auto fields = model.fields();
    const StepConstraints& c = *in.constraints;
    const Vec3 g = model.gravity();
    const std::size_t massAt =
        std::min<std::size_t>(std::size_t(std::max(0, s_.massAt)), fields.size());

    // The mass's product res += M dx * factor, as SOFA's masses compute it.
    auto addMDx = [&](std::vector<double>& res, std::span<const double> dx, double factor) {
      for (std::size_t p = 0; p < n; ++p)
        for (int k = 0; k < 3; ++k) {
          const std::size_t i = 3 * p + std::size_t(k);
          if (factor == 1.0)
            res[i] += dx[i] * m[p];
          else if (uniform)
            res[i] += dx[i] * (m[p] * factor);  // UniformMass
          else
            res[i] += (dx[i] * m[p]) * factor;  // DiagonalMass
        }
    };
    // Each component in the node's order: the mass at its place among the force fields.
    auto inOrder = [&](auto&& massPart, auto&& fieldPart) {
      for (std::size_t i = 0; i <= fields.size(); ++i) {
        if (i == massAt) massPart();
        if (i < fields.size()) fieldPart(*fields[i]);
      }
    };
    auto project = [&](std::vector<double>& a) {
      for (std::size_t p = 0; p < n; ++p)
        if (c.constrained[p]) a[3 * p] = a[3 * p + 1] = a[3 * p + 2] = 0.0;
    };

    // f: the mass's weight and the fields' forces.
    std::vector<double> f(N, 0.0);
    inOrder(
        [&] {
          for (std::size_t p = 0; p < n; ++p)
            for (int k = 0; k < 3; ++k) f[3 * p + std::size_t(k)] += g[std::size_t(k)] * m[p];
        },
        [&](forcefields::ForceField& ff) { ff.addForce(xs, vs, f); });
    requireFinite(f, "force", "");
    // b = h (f + (-rm M + (h + rs) K) v), projected.
    std::vector<double> b = f;
    const double rm = s_.rayleighMass, rs = s_.rayleighStiffness;
    inOrder(
        [&] {
          if (-rm != 0.0) addMDx(b, vs, -rm);
        },
        [&](forcefields::ForceField& ff) { ff.addDForce(xs, vs, b, h * tr + rs, 0.0); });
    for (double& bi : b) bi *= h;
    project(b);

    // A = P ((1 + h rm) M - h (h + rs) K) P, SOFA's factors.
    const double mFact = 1 + tr * h * rm;
    const double kFact = -tr * h * (tr * h + rs);
    auto apply = [&](const std::vector<double>& p, std::vector<double>& q) {
      std::fill(q.begin(), q.end(), 0.0);
      inOrder([&] { addMDx(q, p, mFact); },
              [&](forcefields::ForceField& ff) { ff.addDForce(xs, p, q, kFact, -tr * h); });
      project(q);
    };

    // The prescribed velocity changes (zero for points held still, as SOFA's projective
    // constraints make them); a grasp's, moved to the right-hand side.
    std::vector<double> dv(N, 0.0);
    bool prescribed = false;
    for (std::size_t p = 0; p < n; ++p)
      if (c.constrained[p])
        for (int k = 0; k < 3; ++k) {
          const std::size_t i = 3 * p + std::size_t(k);
          dv[i] = (c.target[i] - xs[i]) / h - vs[i];
          prescribed = prescribed || dv[i] != 0.0;
        }
    std::vector<double> r = b, pdir(N, 0.0), q(N, 0.0);
    if (prescribed) {
      std::vector<double> only(N, 0.0);
      for (std::size_t p = 0; p < n; ++p)
        if (c.constrained[p])
          for (int k = 0; k < 3; ++k) only[3 * p + std::size_t(k)] = dv[3 * p + std::size_t(k)];
      apply(only, q);
      for (std::size_t i = 0; i < N; ++i) r[i] -= q[i];
    }

    // SOFA's CGLinearSolver (linear_solver.hpp: SofaConjugateGradient), on these vectors.
    const SofaCGSettings& cs = cg_->settings();
    const bool firstSolve = solves_++ == 0;
    const double normb = std::sqrt(vDot(r, r));
    int iterations = 0;
    double rho = vDot(r, r), rho1 = 0.0;
    bool indefinite = false;
    std::vector<double> x(N, 0.0);
    if (cs.warmStart && warm_.size() == N) {  // SOFA: x from the last solve, r = b - A x
      for (std::size_t p = 0; p < n; ++p)
        if (!c.constrained[p])
          for (int k = 0; k < 3; ++k) x[3 * p + std::size_t(k)] = warm_[3 * p + std::size_t(k)];
      apply(x, q);
      for (std::size_t i = 0; i < N; ++i) r[i] = r[i] - q[i];
    }
    if (normb != 0.0) {
      for (int it = 1; it <= cs.maxIterations; ++it) {
        rho = vDot(r, r);
        if (std::sqrt(rho) / normb <= cs.tolerance && !(it == 1 && firstSolve)) break;
        if (it == 1)
          pdir = r;
        else {
          const double beta = rho / rho1;
          for (std::size_t i = 0; i < N; ++i) pdir[i] = r[i] + pdir[i] * beta;
        }
        apply(pdir, q);
        const double den = vDot(pdir, q);
        if (den == 0.0) break;
        if (std::abs(den) <= cs.threshold && !(it == 1 && firstSolve)) break;
        if (den < 0) indefinite = true;
        const double alpha = rho / den;
        for (std::size_t i = 0; i < N; ++i) x[i] += pdir[i] * alpha;
        for (std::size_t i = 0; i < N; ++i) r[i] += q[i] * -alpha;
        rho1 = rho;
        ++iterations;
      }
    }
    warm_ = x;
    const double residual = normb > 0 ? std::sqrt(vDot(r, r)) / normb : std::sqrt(vDot(r, r));
    stats.iterations += iterations;
    ++stats.solves;
    stats.residual = residual;
    if (!(residual <= stats.worstResidual)) stats.worstResidual = residual;
    if (!std::isfinite(residual))
      throw StepFailure{"the linear solve (sofa-cg) overflowed the range of doubles", false};
    if (!(residual <= cs.tolerance)) stats.flags |= StepStats::MissedTolerance;
    if (indefinite) stats.flags |= StepStats::Indefinite;

    // v += dv, x += h v (SOFA's VMultiOp).
    out.v.resize(Eigen::Index(N));
    out.x.resize(Eigen::Index(N));
    for (std::size_t i = 0; i < N; ++i) {
      const double d = x[i] + dv[i];  // dv: the prescribed part (zero on the free points)
      out.v[Eigen::Index(i)] = vs[i] + d;
    }
    for (std::size_t i = 0; i < N; ++i) out.x[Eigen::Index(i)] = xs[i] + out.v[Eigen::Index(i)] * h;
    requireFinite(std::span<const double>(out.v.data(), N), "velocity", std::string(name()));
  }

 private:
  SofaEulerSettings s_;
  std::unique_ptr<LinearSolver> solver_;
  SofaConjugateGradient* cg_ = nullptr;
  long solves_ = 0;
  std::vector<double> warm_;  // the last solution, for warmStart
};

const bool registered = IntegratorRegistry::instance().add(
    {"sofa-euler",
     "SOFA's EulerImplicitSolver with its CGLinearSolver (sofa-cg), operation for operation: "
     "SOFA's numbers to the last bit where SOFA's order is kept",
     {{"rayleighMass", KeyType::Number, "mass-proportional damping factor, >= 0 (default 0)"},
      {"rayleighStiffness", KeyType::Number,
       "stiffness-proportional damping factor, >= 0 (default 0)"},
      {"massAt", KeyType::Integer,
       "the mass's place among the force fields in SOFA's node, >= 0 (default 0: first)"}},
     {"linearSolver"},
     [](const ParameterSource& s) -> std::any {
       SofaEulerSettings p;
       p.rayleighMass = s.nonNegative("rayleighMass", p.rayleighMass);
       p.rayleighStiffness = s.nonNegative("rayleighStiffness", p.rayleighStiffness);
       p.massAt = int(s.integer("massAt", 0, 1000, p.massAt));
       return p;
     },
     [](const std::any& p, std::unique_ptr<LinearSolver> ls) -> std::unique_ptr<Integrator> {
       return std::make_unique<SofaEuler>(std::any_cast<const SofaEulerSettings&>(p),
                                          std::move(ls));
     }});

}  // namespace

}  // namespace cutsim::core
