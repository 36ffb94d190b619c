#pragma once
// The step seam: components that know time. The simulation calls its step hooks, in the order
// they were added, at three points of every integrator step (each half of a split step included):
//
//   beginStep   before the step's forces are evaluated, with the model at the step's start and
//               the step's start time and length (a hook may move obstacles, collect contact
//               pairs, freeze what the step's forces need);
//   afterSolve  after the integrator's solve, with the proposed end positions and velocities
//               (a hook may limit them in place, and may ask for the step to be redone as two
//               halves: the simulation then discards the proposal and calls beginStep again for
//               each half; or, once, for the step to be solved again as it is: contact's
//               friction held where it overshot);
//   endStep     after the step was committed, with the model at its end.
//
// Force fields stay timeless: time, paths, bounds on a step's motion and the split policy live
// in hooks. Simulation::advance names no hook; docs/architecture.md has the picture.
#include <cstddef>
#include <span>
#include <string_view>

namespace cutsim::core {

class Model;

/// A step about to be taken: from time t0 over dt, the model at t0.
struct StepStart {
  const Model& model;
  double t0 = 0.0;
  double dt = 0.0;
};

/// The integrator's proposal for a step, which hooks may limit.
struct StepProposal {
  const Model& model;
  double t0 = 0.0;
  double dt = 0.0;
  int depth = 0;                      ///< how many times this step was halved already
  std::span<const double> x0;         ///< positions at the step's start (3 per point slot)
  std::span<double> x1;               ///< proposed positions: a hook may change them
  std::span<double> v1;               ///< proposed velocities: a hook may change them
  std::span<const char> constrained;  ///< per point slot: 1 if the step prescribes the point
  bool implicit = false;              ///< the integrator solves for the step's end (not explicit)
  int solves = 1;                     ///< how many times this step (of this length) has been solved
};

/// What a hook made of a proposal.
struct StepVerdict {
  std::size_t limited = 0;  ///< points whose motion it limited (StepStats::clamped)
  bool split = false;       ///< redo the step as two halves
  /// Solve the step again from its start, once (the hook changed what the step's forces are:
  /// beginStep is not called again). Asked after a second solve, it is not heeded.
  bool again = false;
};

/// A step just committed: the model at time t.
struct StepEnd {
  const Model& model;
  double t = 0.0;
};

class StepHook {
 public:
  virtual ~StepHook();
  /// A short name for messages ("contact").
  virtual std::string_view name() const = 0;
  virtual void beginStep(const StepStart&) {}
  virtual StepVerdict afterSolve(const StepProposal&) { return {}; }
  virtual void endStep(const StepEnd&) {}
};

}  // namespace cutsim::core
