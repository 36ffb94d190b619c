#pragma once
// Second-order backward differentiation, linearised once per step (the method:
// cutsim/core/integrator.hpp; registered as "bdf2" in src/core/integrators/).
#include <cstdint>

#include "cutsim/core/integrator.hpp"

namespace cutsim::core {

class BDF2 final : public ImplicitIntegrator {
 public:
  using ImplicitIntegrator::ImplicitIntegrator;
  std::string_view name() const override { return "bdf2"; }
  void step(Model& model, const StepInput& in, StepOutput& out, StepStats& stats) override;
  /// Steps taken as implicit Euler (the first, and after each restart).
  long restarts() const { return restarts_; }
  void saveState(ArchiveWriter& out) const override;
  void loadState(ArchiveReader& in) override;
  /// Puts back the history the last step replaced.
  void rewind() override;

 private:
  bool historyValid(const Model& model, const StepInput& in) const;
  /// Swaps the history with the one the last step replaced (the vectors' buffers, not copies).
  void swapHistory();
  // x_n-1, v_n-1 and the x_n, v_n the previous step returned (to detect an edit between steps).
  Eigen::VectorXd xPrev_, vPrev_, xLast_, vLast_;
  template <class Archive, class Self>
  static void members(Archive& a, Self& s);  // the checkpointed members, for save and load
  double dtLast_ = 0.0;
  std::uint64_t revision_ = 0;
  bool have_ = false;
  long restarts_ = 0;
  // What the last step replaced (rewind()): its vectors swapped in, not copied.
  Eigen::VectorXd xPrevBefore_, vPrevBefore_, xLastBefore_, vLastBefore_;
  double dtBefore_ = 0.0;
  std::uint64_t revisionBefore_ = 0;
  bool haveBefore_ = false, rewindable_ = false;
  long restartsBefore_ = 0;
};

}  // namespace cutsim::core
