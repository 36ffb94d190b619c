// SceneRunner: builds the simulation a scene describes (its components through the registries)
// and plays its timeline (each action through its registry entry).
#include <algorithm>
#include <cmath>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/base/threads.hpp"
#include "cutsim/core/contact_step.hpp"
#include "cutsim/core/registries.hpp"
#include "cutsim/core/scene.hpp"
#include "cutsim/core/timeline.hpp"
#include "cutsim/topology/geometry.hpp"
#include "scene/scene_internal.hpp"

namespace cutsim::core {

using topology::geometry::dist2;

double detail::meanRestEdge(const topology::Topology& topology) {
  double sum = 0;
  std::size_t count = 0;
  for (topology::EdgeId e : topology.edges()) {
    const auto v = topology.edgeVertices(e);
    sum += std::sqrt(dist2(topology.restPosition(v[0]), topology.restPosition(v[1])));
    ++count;
  }
  return count ? sum / double(count) : 0.0;
}

namespace {
/// Throws the failures of the actions of one step: the one, or every message of several (none
/// is lost); an exception that is not a cutsim::Error first, as it is.
void throwFailures(const std::vector<std::exception_ptr>& failures) {
  if (failures.empty()) return;
  if (failures.size() == 1) std::rethrow_exception(failures.front());
  std::string all;
  for (const auto& f : failures) {
    try {
      std::rethrow_exception(f);
    } catch (const Error& e) {
      all += (all.empty() ? "" : "\n") + std::string(e.what());
    }
  }
  throw Error(all);
}
}  // namespace

/// What the running actions see of the runner.
class SceneRunner::Context final : public ActionContext {
 public:
  explicit Context(SceneRunner& r) : r_(r) {}
  Simulation& simulation() override { return *r_.sim_; }
  double time() const override { return r_.time(); }
  double timeStep() const override { return r_.timeStep_; }
  double meanRestEdge() const override { return r_.meanEdge_; }
  [[noreturn]] void fail(const std::string& message) const override {
    const SceneLocation& where = current->location;
    throw InvalidInput(where.where(r_.scene_.file.string()), located(message));
  }
  [[noreturn]] void failTopology(const std::string& message) const override {
    const SceneLocation& where = current->location;
    // In the scene check's rehearsal, a refusal is the scene's error (exit code 2).
    if (r_.rehearsal_) throw InvalidInput(where.where(r_.scene_.file.string()), located(message));
    throw TopologyError(where.where(r_.scene_.file.string()) + ": " + located(message));
  }
  std::string located(const std::string& message) const {
    const SceneLocation& where = current->location;
    return (where.pointer.empty() ? "/" : where.pointer) + ": at t = " + describeNumber(r_.time()) +
           " " + message;
  }
  void countCut() override { ++r_.cutsDone_; }
  void countTorn(long edges) override { r_.tornEdges_ += edges; }
  void recordIncision(const topology::IncisionResult& result) override {
    r_.incisions_.push_back(result);
  }
  const ActionSpec* current = nullptr;

 private:
  SceneRunner& r_;
};

SceneRunner::SceneRunner(const Scene& scene)
    : scene_(scene), context_(std::make_unique<Context>(*this)) {
  build(true);
}

SceneRunner::SceneRunner(const Scene& scene, Rehearsal)
    : rehearsal_(true), scene_(scene), context_(std::make_unique<Context>(*this)) {
  build(false);
}

void SceneRunner::rehearseTimeline(const Scene& scene) {
  SceneRunner r(scene, Rehearsal{});
  double end = 0.0;
  for (const ActionSpec& a : scene.timeline)
    end = std::max(end, a.timing.interval ? a.timing.to : a.timing.at);
  const long steps = std::min(r.numSteps_, long(std::ceil(end / r.timeStep_ - 1e-9)) + 1);
  r.start();
  while (r.step_ < steps) r.stepOnce();
}

void SceneRunner::build(bool physics, std::unique_ptr<topology::Topology> topo) {
  if (physics && scene_.threads > 0) setThreads(scene_.threads);  // (outputs do not depend on it)
  // A bad CUTSIM_THREADS is refused here, before any output, not at the first parallel loop.
  if (physics) (void)threads();
  if (!topo) topo = std::make_unique<topology::Topology>(scene_.mesh());
  const MassLaw mass = scene_.massLaw(*topo);
  // Mean rest edge length: the smallest piece a progressive cut makes is half of it.
  meanEdge_ = detail::meanRestEdge(*topo);

  sim_ = std::make_unique<Simulation>(std::move(topo), mass);
  sim_->setGravity(scene_.gravity);
  const std::vector<std::string> labels = scene_.forceFieldLabels();
  for (std::size_t i = 0; physics && i < scene_.forceFields.size(); ++i) {
    const ForceFieldSpec& f = scene_.forceFields[i];
    const auto* entry = forcefields::ForceFieldRegistry::instance().find(f.type);
    if (!entry)
      throw InvalidInput(f.location.where(scene_.file.string()),
                         "unknown force field type \"" + f.type + "\"");
    sim_->addForceField(entry->build(f.parameters, sim_->topology()), labels[i]);
    const std::string problem = sim_->forceField(i).problemAtRest();
    if (!problem.empty())
      throw InvalidInput(f.location.where(scene_.file.string()),
                         f.location.pointer + "/" + problem);
  }
  // The step hooks (contact), each with the label of the force field it may add (after the
  // scene's own).
  for (std::size_t i = 0; physics && i < scene_.stepHooks.size(); ++i) {
    const ComponentSpec& h = scene_.stepHooks[i];
    const auto* entry = StepHookRegistry::instance().find(h.type);
    if (!entry)
      throw InvalidInput(h.location.where(scene_.file.string()),
                         "unknown step hook \"" + h.type + "\"");
    sim_->addStepHook(entry->build(h.parameters, *sim_, labels[scene_.forceFields.size() + i]));
  }
  for (const ConstraintSpec& c : scene_.constraints) {
    const auto* entry = ConstraintRegistry::instance().find(c.type);
    if (!entry)
      throw InvalidInput(c.location.where(scene_.file.string()),
                         "unknown constraint type \"" + c.type + "\"");
    entry->build(c.parameters)->apply(*sim_);
  }
  if (physics) sim_->setIntegrator(makeIntegrator(scene_));
  if (physics && scene_.output.energy) sim_->enableEnergyAccounting();
  numSteps_ = scene_.numSteps();
  timeStep_ = scene_.timeStep;
}

SceneRunner::~SceneRunner() = default;

std::unique_ptr<Integrator> SceneRunner::makeIntegrator(const Scene& scene) {
  std::unique_ptr<LinearSolver> solver;
  if (scene.linearSolver) {
    const auto* entry = LinearSolverRegistry::instance().find(scene.linearSolver->type);
    if (!entry)
      throw InvalidInput("linearSolver",
                         "unknown linear solver type \"" + scene.linearSolver->type + "\"");
    solver = entry->build(scene.linearSolver->parameters);
  }
  const auto* entry = IntegratorRegistry::instance().find(scene.integrator.type);
  if (!entry)
    throw InvalidInput("integrator", "unknown integrator type \"" + scene.integrator.type + "\"");
  return entry->build(scene.integrator.parameters, std::move(solver));
}

double SceneRunner::time() const {
  return timeBase_ + double(step_ - stepBase_) * timeStep_;
}

void SceneRunner::setTimeStep(double dt) {
  requireFinitePositive("timeStep", dt);
  const double now = time();
  // The steps of dt that reach the duration (as Scene::numSteps rounds), after those taken.
  const double n = std::max(0.0, (scene_.duration - now) / dt);
  if (n > 1e12)
    throw InvalidInput(
        "timeStep", "more than 1e12 steps of " + describeNumber(dt) + " to the end of the scene");
  const double r = std::round(n);
  numSteps_ = step_ + (std::abs(n - r) <= 1e-9 * std::max(1.0, r) ? long(r) : long(std::ceil(n)));
  timeBase_ = now;
  stepBase_ = step_;
  timeStep_ = dt;
}

void SceneRunner::schedule(ActionSpec action) {
  edited_ = true;
  const double begins = action.startTime();
  auto at = std::upper_bound(
      scheduled_.begin() + std::ptrdiff_t(nextScheduled_), scheduled_.end(), begins,
      [](double t, const std::unique_ptr<ActionSpec>& a) { return t < a->startTime(); });
  scheduled_.insert(at, std::make_unique<ActionSpec>(std::move(action)));
  if (!started_)
    start();  // the scene's actions due at time 0 first
  else
    runDueActions(time());
}

void SceneRunner::replaceForceField(std::size_t i, const ForceFieldSpec& spec) {
  edited_ = true;
  const auto* entry = forcefields::ForceFieldRegistry::instance().find(spec.type);
  if (!entry)
    throw InvalidInput(spec.location.where(scene_.file.string()),
                       "unknown force field type \"" + spec.type + "\"");
  if (i >= scene_.forceFields.size())
    throw InvalidInput("forceFields", "the scene has " + std::to_string(scene_.forceFields.size()) +
                                          " force fields (asked for " + std::to_string(i) + ")");
  if (spec.type != scene_.forceFields[i].type)
    throw InvalidInput(spec.location.where(scene_.file.string()),
                       "/type: force field " + std::to_string(i) + " is a " +
                           scene_.forceFields[i].type +
                           ": its parameters can change, not its type (got \"" + spec.type + "\")");
  sim_->model().replaceForceField(i, entry->build(spec.parameters, sim_->topology()));
  scene_.forceFields[i].parameters = spec.parameters;
}

void SceneRunner::applyConstraint(const ConstraintSpec& constraint) {
  edited_ = true;
  const auto* entry = ConstraintRegistry::instance().find(constraint.type);
  if (!entry)
    throw InvalidInput(constraint.location.where(scene_.file.string()),
                       "unknown constraint type \"" + constraint.type + "\"");
  entry->build(constraint.parameters)->apply(*sim_);
}

const forcefields::FastTriangularBendingSprings* SceneRunner::bendingField() const {
  for (std::size_t i = 0; i < sim_->numForceFields(); ++i) {
    if (auto* f =
            dynamic_cast<const forcefields::FastTriangularBendingSprings*>(&sim_->forceField(i)))
      return f;
  }
  return nullptr;
}

void SceneRunner::start() {
  if (started_) return;
  started_ = true;
  runDueActions(0.0);
}

std::vector<std::array<Vec3, 2>> SceneRunner::instrumentSegments() const {
  std::vector<std::array<Vec3, 2>> out;
  for (const Running& r : running_) r.action->instruments(time(), out);
  return out;
}

StepStats SceneRunner::advance() {
  if (!started_) start();
  if (finished()) return lastStats_;
  return stepOnce();
}

StepStats SceneRunner::stepOnce() {
  if (!started_) start();
  if (rehearsal_)
    sim_->skipStep(timeStep_);  // the surface stays at rest
  else
    lastStats_ = sim_->step(timeStep_);
  ++step_;
  std::vector<std::exception_ptr> failures;
  for (auto it = running_.begin(); it != running_.end();) {
    context_->current = it->spec;
    try {
      it->action->afterStep(*context_);
      ++it;
    } catch (...) {
      failures.push_back(std::current_exception());
      it = running_.erase(it);  // a failed action does not go on
    }
  }
  try {
    runDueActions(time());
  } catch (...) {
    failures.push_back(std::current_exception());
  }
  throwFailures(failures);
  return lastStats_;
}

void SceneRunner::runDueActions(double t) {
  incisions_.clear();  // takeIncisions() gives what the actions played now made
  const double eps = 1e-9 * timeStep_;
  std::vector<std::exception_ptr> failures;  // the actions that fail; the others due still start
  // The scene's timeline and the actions given while running, merged by start time (the scene's
  // first at equal times).
  while (true) {
    const bool sceneDue =
        nextAction_ < scene_.timeline.size() && scene_.timeline[nextAction_].startTime() <= t + eps;
    const bool scheduledDue =
        nextScheduled_ < scheduled_.size() && scheduled_[nextScheduled_]->startTime() <= t + eps;
    if (!sceneDue && !scheduledDue) break;
    const bool fromScene =
        sceneDue && (!scheduledDue || scene_.timeline[nextAction_].startTime() <=
                                          scheduled_[nextScheduled_]->startTime());
    const ActionSpec& spec =
        fromScene ? scene_.timeline[nextAction_++] : *scheduled_[nextScheduled_++];
    std::unique_ptr<TimelineAction> action = spec.build();
    if (rehearsal_ && !action->rehearsed()) continue;
    running_.push_back({&spec, std::move(action)});
    context_->current = &spec;
    try {
      running_.back().action->start(*context_);
    } catch (...) {
      running_.pop_back();  // an action that could not start does not go on
      failures.push_back(std::current_exception());
    }
  }
  throwFailures(failures);
}

// ---- checkpoints ----

std::vector<std::string> SceneRunner::notSavableNow() const {
  std::vector<std::string> out = sim_->notCheckpointable();
  for (const Running& r : running_)
    if (!r.action->checkpointable())
      out.push_back("the " + r.spec->type + " action (" + r.spec->location.pointer + ")");
  if (rehearsal_) out.push_back("a rehearsal");
  if (edited_)
    out.push_back(
        "changes made while running (actions given, force fields replaced, constraints applied)");
  return out;
}

std::vector<std::string> SceneRunner::notCheckpointable() const {
  std::vector<std::string> out = notSavableNow();
  for (std::size_t i = nextAction_; i < scene_.timeline.size(); ++i) {
    const ActionSpec& a = scene_.timeline[i];
    if (!a.build()->checkpointable())
      out.push_back("the " + a.type + " action (" + a.location.pointer + ")");
  }
  return out;
}

template <class Archive, class Self>
void SceneRunner::members(Archive& a, Self& s) {
  fields(a, s.step_, s.numSteps_, s.nextAction_, s.started_, s.timeStep_, s.stepBase_, s.timeBase_,
         s.meanEdge_, s.tornEdges_, s.cutsDone_);
}

void SceneRunner::save(ArchiveWriter& out) const {
  // What is running now, not the actions still to come (notCheckpointable(), asked once before
  // a run): a checkpoint every N steps builds no action.
  const std::vector<std::string> missing = notSavableNow();
  if (!missing.empty()) {
    std::string list;
    for (const std::string& m : missing) list += (list.empty() ? "" : ", ") + m;
    throw Error("checkpoints: this run cannot be saved: " + list + " cannot be");
  }
  sim_->topology().save(out);
  sim_->saveState(out);
  out.begin("runner");
  members(out, *this);
  out.u64(running_.size());
  for (const Running& r : running_) {
    out.u64(std::uint64_t(r.spec - scene_.timeline.data()));
    out.str(r.spec->type);
    r.action->saveState(out);
  }
}

SceneRunner::SceneRunner(const Scene& scene, ArchiveReader& in)
    : scene_(scene), context_(std::make_unique<Context>(*this)) {
  auto topo = std::make_unique<topology::Topology>(topology::Topology::load(in));
  build(true, std::move(topo));
  sim_->loadState(in);
  in.open("runner");
  members(in, *this);
  if (step_ < 0 || numSteps_ < step_ || nextAction_ > scene_.timeline.size() || !(timeStep_ > 0) ||
      !std::isfinite(timeStep_) || stepBase_ < 0 || stepBase_ > step_ || !std::isfinite(timeBase_))
    in.fail("step " + std::to_string(step_) + " of " + std::to_string(numSteps_) +
            ", next action " + std::to_string(nextAction_) + " of " +
            std::to_string(scene_.timeline.size()) + ": not a run of this scene");
  const std::uint64_t n = in.u64();
  if (n > nextAction_)
    in.fail(std::to_string(n) + " started actions, " + std::to_string(nextAction_) + " due so far");
  for (std::uint64_t k = 0; k < n; ++k) {
    const std::uint64_t i = in.u64();
    const std::string type = in.str();
    if (i >= nextAction_ || type != scene_.timeline[i].type)
      in.fail("a started action " + type + " at " + std::to_string(i) +
              " that the scene's timeline does not have");
    running_.push_back({&scene_.timeline[i], scene_.timeline[i].build()});
    running_.back().action->loadState(in, *sim_);
  }
  in.close();
  if (std::abs(sim_->time() - time()) > 1e-9 * std::max(1.0, std::abs(time())) ||
      sim_->steps() != step_)
    in.fail("the simulation's clock (step " + std::to_string(sim_->steps()) +
            ") and the timeline's (step " + std::to_string(step_) + ") differ");
  const topology::ValidationReport report = sim_->topology().validate();
  if (!report.ok())
    in.fail("the restored simulation does not validate: " + report.problems.front());
}

}  // namespace cutsim::core
