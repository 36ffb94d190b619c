// The "remove" action: carves out the triangles whose rest centroid lies in a sphere or a box.
#include "cutsim/base/errors.hpp"
#include "cutsim/core/timeline.hpp"

namespace cutsim::core {
namespace {

class RemoveAction final : public TimelineAction {
 public:
  explicit RemoveAction(RemoveParameters p) : p_(p) {}
  bool checkpointable() const override { return true; }  // done once started
  void dryRun(DryRunContext& c) const override {
    const std::string key = p_.region.kind == Region::Kind::Sphere ? "sphere" : "box";
    topology::RepairOptions repair;
    repair.minAngle = p_.minAngle;
    try {
      if (removeIn(c.topology(), repair) == 0)
        c.fail(key, p_.cutBoundary
                        ? "removes no triangle: no point of the rest mesh lies inside the region"
                        : "removes no triangle: no rest centroid lies inside");
    } catch (const TopologyError& e) {
      c.fail(key, std::string("the removal cannot be made: ") + e.what());
    }
  }
  void start(ActionContext& c) override {
    std::size_t removed = 0;
    try {
      removed = removeIn(c.simulation().topology(), repairOptions(c.simulation(), p_.minAngle));
    } catch (const TopologyError& e) {
      c.failTopology(std::string("the removal failed: ") + e.what());
    }
    if (removed == 0)
      c.fail(p_.cutBoundary
                 ? "the removal removes no triangle: no point of the surface lies inside the region"
                 : "the removal removes no triangle: no triangle's rest centroid lies inside the "
                   "region");
  }

 private:
  /// The removal; returns the number of triangles removed.
  std::size_t removeIn(topology::Topology& topo, const topology::RepairOptions& repair) const {
    if (p_.cutBoundary) {
      std::size_t removed = 0;
      const Region region = p_.region;
      topo.carve([region](const Vec3& x) { return region.levelSet(x); }, repair, &removed);
      return removed;
    }
    const auto tris = trianglesInRegion(topo, p_.region);
    if (!tris.empty()) topo.removeTriangles(tris, repair);
    return tris.size();
  }

  RemoveParameters p_;
};

const bool registered = ActionRegistry::instance().add(
    {"remove",
     "carves out the part of the surface inside a sphere or a box (cutting the triangles its "
     "boundary "
     "crosses), or the triangles whose rest centroid lies inside",
     {{"at", KeyType::Number, "time of the removal"},
      {"sphere", KeyType::Object, "{\"center\": [x, y, z], \"radius\": r} in rest coordinates"},
      {"box", KeyType::Box, "[[xmin, ymin, zmin], [xmax, ymax, zmax]] in rest coordinates"},
      {"boundary",
       KeyType::Choice,
       "\"cut\" (default): cut the triangles the region's boundary crosses, a clean hole; "
       "\"centroid\": remove whole triangles whose rest centroid is inside",
       {"cut", "centroid"}},
      {"minAngle", KeyType::Number,
       "smallest-angle target (degrees) of the quality repair around the hole, in [0, 60) "
       "(default 20; 0 turns the repair off)"}},
     {},
     [](const ParameterSource& s) -> std::any {
       RemoveParameters p;
       p.region = Region::read(s, s.oneOf({"sphere", "box"}));
       if (s.has("boundary")) {
         const std::string b = s.string("boundary");
         if (b != "cut" && b != "centroid")
           s.fail("boundary", "must be \"cut\" or \"centroid\" (got \"" + b + "\")");
         p.cutBoundary = b == "cut";
       }
       p.minAngle = readMinAngle(s);
       return p;
     },
     [](const std::any& p, const ActionTiming&) -> std::unique_ptr<TimelineAction> {
       return std::make_unique<RemoveAction>(std::any_cast<const RemoveParameters&>(p));
     }});

}  // namespace
}  // namespace cutsim::core
