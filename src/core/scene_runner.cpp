// SceneRunner: builds the simulation a scene describes (its components through the registries)
// and plays its timeline.
#include <algorithm>
#include <cmath>

#include "cutsim/core/registries.hpp"
#include "cutsim/core/scene.hpp"
#include "cutsim/topology/errors.hpp"
#include "cutsim/topology/geometry.hpp"
#include "scene_internal.hpp"
#include "scene_json.hpp"
#include "tearing.hpp"

namespace cutsim::core {

using detail::Reader;
using detail::trianglesInRegion;
using topology::geometry::dist2;


struct SceneRunner::Progressive {
  const SceneAction* action;
  std::vector<double> arc;  // cumulative length at each polyline vertex
  double done = 0.0;        // arc length cut so far
  bool started = false, finished = false;
  double minPiece = 0.0;
  // Where the previous piece really ended (its last path vertex, which snapping may have put a
  // little off the polyline): the next piece starts there, so that it continues from the cut's
  // tip instead of starting beside it.
  std::optional<Vec3> tip;

  Vec3 pointAt(double s) const {
    const auto& p = action->polyline;
    std::size_t i = 1;
    while (i + 1 < arc.size() && arc[i] < s) ++i;
    const double len = arc[i] - arc[i - 1];
    const double t = len > 0 ? std::clamp((s - arc[i - 1]) / len, 0.0, 1.0) : 1.0;
    return {p[i - 1][0] + t * (p[i][0] - p[i - 1][0]), p[i - 1][1] + t * (p[i][1] - p[i - 1][1]),
            p[i - 1][2] + t * (p[i][2] - p[i - 1][2])};
  }
  /// The polyline between arc lengths s0 < s1.
  std::vector<Vec3> piece(double s0, double s1) const {
    std::vector<Vec3> out{pointAt(s0)};
    for (std::size_t i = 1; i + 1 < arc.size(); ++i) {
      if (arc[i] > s0 && arc[i] < s1) out.push_back(action->polyline[i]);
    }
    out.push_back(s1 >= arc.back() ? action->polyline.back() : pointAt(s1));
    return out;
  }
};

SceneRunner::SceneRunner(const Scene& scene) : scene_(scene) {
  const topology::MeshData mesh = scene_.mesh();
  auto topo = std::make_unique<topology::Topology>(mesh);
  const double density =
      scene_.massByTotal ? LumpedMass::densityForTotal(*topo, scene_.totalMass) : scene_.density;
  // Mean rest edge length: the smallest piece a progressive cut makes is half of it.
  double edgeSum = 0;
  std::size_t edgeCount = 0;
  for (topology::EdgeId e : topo->edges()) {
    const auto v = topo->edgeVertices(e);
    edgeSum += std::sqrt(dist2(topo->restPosition(v[0]), topo->restPosition(v[1])));
    ++edgeCount;
  }
  const double meanEdge = edgeCount ? edgeSum / double(edgeCount) : 0.0;

  sim_ = std::make_unique<Simulation>(std::move(topo), density);
  sim_->setGravity(scene_.gravity);
  const std::vector<std::string> labels = scene_.forceFieldLabels();
  for (std::size_t i = 0; i < scene_.forceFields.size(); ++i) {
    const ForceFieldSpec& f = scene_.forceFields[i];
    const auto* entry = forcefields::ForceFieldRegistry::instance().find(f.type);
    if (!entry) throw InvalidInput(f.location.where(scene_.file.string()), "unknown force field type \"" + f.type + "\"");
    sim_->addForceField(entry->build(f.parameters, sim_->topology()), labels[i]);
  }
  for (const FixedSpec& f : scene_.fixed) {
    for (PointId p : f.selection.resolve(sim_->topology())) sim_->fixed().add(p);
  }
  sim_->setIntegrator(makeIntegrator(scene_));
  numSteps_ = scene_.numSteps();
  for (const SceneAction& a : scene_.timeline) {
    if (a.kind != SceneAction::Kind::ProgressiveCut) continue;
    Progressive pc;
    pc.action = &a;
    pc.arc.push_back(0.0);
    for (std::size_t i = 1; i < a.polyline.size(); ++i) {
      pc.arc.push_back(pc.arc.back() + std::sqrt(dist2(a.polyline[i - 1], a.polyline[i])));
    }
    pc.minPiece = 0.5 * meanEdge;
    progressive_.push_back(std::move(pc));
  }
}

SceneRunner::~SceneRunner() = default;

std::unique_ptr<Integrator> SceneRunner::makeIntegrator(const Scene& scene) {
  std::unique_ptr<LinearSolver> solver;
  if (scene.linearSolver) {
    const auto* entry = LinearSolverRegistry::instance().find(scene.linearSolver->type);
    if (!entry) throw InvalidInput("linearSolver", "unknown linear solver type \"" + scene.linearSolver->type + "\"");
    solver = entry->build(scene.linearSolver->parameters);
  }
  const auto* entry = IntegratorRegistry::instance().find(scene.integrator.type);
  if (!entry) throw InvalidInput("integrator", "unknown integrator type \"" + scene.integrator.type + "\"");
  return entry->build(scene.integrator.parameters, std::move(solver));
}

double SceneRunner::time() const {
  return double(step_) * scene_.timeStep;
}

const forcefields::FastTriangularBendingSprings* SceneRunner::bendingField() const {
  for (std::size_t i = 0; i < sim_->numForceFields(); ++i) {
    if (auto* f =
            dynamic_cast<const forcefields::FastTriangularBendingSprings*>(&sim_->forceField(i))) {
      return f;
    }
  }
  return nullptr;
}

void SceneRunner::start() {
  if (started_) return;
  started_ = true;
  runDueActions(0.0);
}

StepStats SceneRunner::advance() {
  if (!started_) start();
  if (finished()) return lastStats_;
  lastStats_ = sim_->step(scene_.timeStep);
  ++step_;
  const double t = time();
  advanceProgressive(t);
  if (tearing_) {
    tornEdges_ +=
        tearOverstrained(sim_->topology(), sim_->state().x(), tearThreshold_, tearMaxPerStep_);
  }
  runDueActions(t);
  return lastStats_;
}

void SceneRunner::runDueActions(double t) {
  const double eps = 1e-9 * scene_.timeStep;
  while (nextAction_ < scene_.timeline.size() &&
         scene_.timeline[nextAction_].startTime() <= t + eps) {
    runAction(scene_.timeline[nextAction_]);
    ++nextAction_;
  }
}

topology::IncisionResult SceneRunner::cut(std::span<const Vec3> polyline, double snap,
                                          const SceneLocation& where) {
  topology::CutOptions options;
  options.snapTolerance = snap;
  try {
    topology::IncisionResult result = sim_->topology().cutPolyline(polyline, options);
    ++cutsDone_;
    return result;
  } catch (const TopologyError& e) {
    throw Error(where.where(scene_.file.string()) + ": " + where.pointer +
                ": at t = " + Reader::text(time()) + " the cut failed: " + e.what());
  }
}

void SceneRunner::runAction(const SceneAction& a) {
  const std::string file = scene_.file.string();
  switch (a.kind) {
    case SceneAction::Kind::Cut:
      cut(a.polyline, a.snapTolerance, a.location);
      break;
    case SceneAction::Kind::ProgressiveCut:
      for (Progressive& p : progressive_) {
        if (p.action == &a) p.started = true;
      }
      advanceProgressive(time());
      break;
    case SceneAction::Kind::Remove: {
      const auto tris = trianglesInRegion(sim_->topology(), a.region);
      if (!tris.empty()) sim_->topology().removeTriangles(tris);
      break;
    }
    case SceneAction::Kind::Tearing:
      tearing_ = true;
      tearThreshold_ = a.threshold;
      tearMaxPerStep_ = a.maxPerStep;
      break;
    case SceneAction::Kind::Grasp: {
      const std::vector<PointId> points = a.selection.resolve(sim_->topology());
      if (points.empty()) {
        throw Error(a.location.where(file) + ": " + a.location.pointer +
                    ": at t = " + Reader::text(time()) + " the grasp selects no live point");
      }
      sim_->addGrasp(a.name, points, a.path);
      break;
    }
    case SceneAction::Kind::Release:
      sim_->releaseGrasp(a.name);
      break;
  }
}

void SceneRunner::advanceProgressive(double t) {
  for (Progressive& p : progressive_) {
    if (!p.started || p.finished) continue;
    const SceneAction& a = *p.action;
    const double total = p.arc.back();
    double s = total * std::clamp((t - a.from) / (a.to - a.from), 0.0, 1.0);
    if (t >= a.to - 1e-9 * scene_.timeStep) s = total;
    // Never leave a remainder shorter than the smallest piece; never cut a piece shorter than it
    // (except a whole polyline that is shorter).
    if (s < total && total - s < p.minPiece) s = total;
    if (s < total && s - p.done < p.minPiece) continue;
    if (!(s > p.done)) continue;
    std::vector<Vec3> piece = p.piece(p.done, s);
    if (p.tip) piece.front() = *p.tip;
    topology::IncisionResult result;
    if (s < total) {
      // A piece that the topology refuses without changing anything (for example one that ends
      // exactly on an edge in a way its walk does not handle) is tried again, longer, at the next
      // step; only the last piece must succeed where the scalpel is.
      topology::Topology& topo = sim_->topology();
      const topology::Index points = topo.pointCapacity(), triangles = topo.triangleCapacity();
      try {
        topology::CutOptions options;
        options.snapTolerance = a.snapTolerance;
        result = topo.cutPolyline(piece, options);
        ++cutsDone_;
      } catch (const TopologyError& e) {
        if (topo.pointCapacity() == points && topo.triangleCapacity() == triangles) continue;
        throw Error(a.location.where(scene_.file.string()) + ": " + a.location.pointer +
                    ": at t = " + Reader::text(time()) + " the cut failed: " + e.what());
      }
    } else {
      result = cut(piece, a.snapTolerance, a.location);
    }
    if (!result.path.empty()) p.tip = sim_->topology().restPosition(result.path.back());
    p.done = s;
    if (s >= total) p.finished = true;
  }
}

}  // namespace cutsim::core
