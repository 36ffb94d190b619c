// The "tearing" action: from its time on, after each step, tears the interior edges whose two
// triangles are both strained across the edge above a threshold, the most strained first, each
// tear followed by the quality repair around it.
#include "cutsim/base/archive.hpp"
#include "cutsim/core/timeline.hpp"
#include "timeline/tearing.hpp"

namespace cutsim::core {
namespace {

class TearingAction final : public TimelineAction {
 public:
  explicit TearingAction(TearingParameters p) : p_(p) {}
  void dryRun(DryRunContext&) const override {}
  bool rehearsed() const override { return false; }  // at rest nothing tears
  void start(ActionContext&) override { on_ = true; }
  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override { fields(out, on_); }
  void loadState(ArchiveReader& in, const Simulation&) override { fields(in, on_); }
  void afterStep(ActionContext& c) override {
    if (!on_) return;
    Simulation& sim = c.simulation();
    c.countTorn(tearOverstrained(sim.topology(), sim.state().x(), p_.threshold, p_.maxPerStep,
                                 repairOptions(sim, p_.minAngle)));
  }

 private:
  TearingParameters p_;
  bool on_ = false;
};

const bool registered = ActionRegistry::instance().add(
    {"tearing",
     "from its time on, tears the edges strained across above a threshold after each step",
     {{"at", KeyType::Number, "time tearing starts"},
      {"threshold",
       KeyType::Number,
       "Green strain normal to an edge above which it tears, > 0 (required)",
       {},
       true},
      {"maxPerStep", KeyType::Integer, "edges torn per step at most, >= 1 (default 4)"},
      {"minAngle", KeyType::Number,
       "smallest-angle target (degrees) of the quality repair after each tear, in "
       "[0, 60) (default 20; 0 turns it off)"}},
     {},
     [](const ParameterSource& s) -> std::any {
       TearingParameters p;
       s.require("threshold");
       p.threshold = s.positive("threshold", 0.0);
       p.maxPerStep = int(s.integer("maxPerStep", 1, 1000000, p.maxPerStep));
       p.minAngle = readMinAngle(s);
       return p;
     },
     [](const std::any& p, const ActionTiming&) -> std::unique_ptr<TimelineAction> {
       return std::make_unique<TearingAction>(std::any_cast<const TearingParameters&>(p));
     }});

}  // namespace
}  // namespace cutsim::core
