// The "tear" action: tears one interior edge open at a time, named by its two end points (ids of
// the mesh as loaded), then repairs the triangles around it; what Python's sim.tear schedules.
#include <array>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/timeline.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::core {
namespace {

struct TearParameters {
  std::array<PointId, 2> points{};     ///< the edge's two points (ids of the mesh as loaded)
  double minAngle = kDefaultMinAngle;  ///< quality repair target after the tear (degrees, 0: off)
};

std::string edgeText(const TearParameters& p) {
  return "the edge of points " + std::to_string(topology::Index(p.points[0])) + " and " +
         std::to_string(topology::Index(p.points[1]));
}

class TearAction final : public TimelineAction {
 public:
  explicit TearAction(TearParameters p) : p_(p) {}

  void dryRun(DryRunContext& c) const override {
    topology::Topology& t = c.topology();
    const topology::EdgeId e = edgeOf(t);
    if (topology::Index(e) == topology::kInvalidIndex)
      c.fail("points", edgeText(p_) + " is not an edge of the surface at that time");
    try {
      topology::RepairOptions repair;
      repair.minAngle = p_.minAngle;
      t.tear(e, repair);
    } catch (const TopologyError& ex) {
      c.fail("points", edgeText(p_) + " cannot be torn: " + ex.what());
    }
  }

  void start(ActionContext& c) override {
    Simulation& sim = c.simulation();
    const topology::EdgeId e = edgeOf(sim.topology());
    if (topology::Index(e) == topology::kInvalidIndex)
      c.failTopology(edgeText(p_) + " is not an edge of the surface");
    try {
      const topology::IncisionResult result =
          sim.topology().tear(e, repairOptions(sim, p_.minAngle));
      c.countTorn(1);
      c.recordIncision(result);
    } catch (const TopologyError& ex) {
      c.failTopology(std::string("the tear failed: ") + ex.what());
    }
  }

 private:
  topology::EdgeId edgeOf(const topology::Topology& t) const {
    for (PointId p : p_.points)
      if (topology::Index(p) >= t.pointCapacity() || !t.isPointAlive(p))
        return topology::EdgeId(topology::kInvalidIndex);
    return t.findEdge(p_.points[0], p_.points[1]);
  }

  TearParameters p_;
};

const bool registered = ActionRegistry::instance().add(
    {"tear",
     "tears one interior edge open, named by its two points, then repairs around it",
     {{"at", KeyType::Number, "time of the tear"},
      {"points",
       KeyType::Integers,
       "[a, b]: the edge's two points (ids of the mesh as loaded)",
       {},
       true},
      {"minAngle", KeyType::Number,
       "smallest-angle target (degrees) of the quality repair after the tear, in [0, 60) "
       "(default 20; 0 turns it off)"}},
     {},
     [](const ParameterSource& s) -> std::any {
       TearParameters p;
       s.require("points");
       const std::vector<long> ids = s.integers("points", 0, long(topology::kInvalidIndex) - 1);
       if (ids.size() != 2) s.fail("points", "expected the edge's two points [a, b]");
       if (ids[0] == ids[1]) s.fail("points", "the edge's two points must differ");
       p.points = {PointId(topology::Index(ids[0])), PointId(topology::Index(ids[1]))};
       p.minAngle = readMinAngle(s);
       return p;
     },
     [](const std::any& p, const ActionTiming&) -> std::unique_ptr<TimelineAction> {
       return std::make_unique<TearAction>(std::any_cast<const TearParameters&>(p));
     }});

}  // namespace
}  // namespace cutsim::core
