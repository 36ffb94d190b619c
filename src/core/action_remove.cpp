// The "remove" action: carves out the triangles whose rest centroid lies in a sphere or a box.
#include "cutsim/core/timeline.hpp"
#include "cutsim/topology/errors.hpp"

namespace cutsim::core {
namespace {

class RemoveAction final : public TimelineAction {
 public:
  explicit RemoveAction(RemoveParameters p) : p_(p) {}
  void dryRun(DryRunContext& c) const override {
    const std::string key = p_.region.kind == Region::Kind::Sphere ? "sphere" : "box";
    const auto tris = trianglesInRegion(c.topology(), p_.region);
    if (tris.empty()) c.fail(key, "removes no triangle: no rest centroid lies inside");
    try {
      topology::RepairOptions repair;
      repair.minAngle = p_.minAngle;
      c.topology().removeTriangles(tris, repair);
    } catch (const TopologyError& e) {
      c.fail(key, std::string("the removal cannot be made: ") + e.what());
    }
  }
  void start(ActionContext& c) override {
    const auto tris = trianglesInRegion(c.simulation().topology(), p_.region);
    if (!tris.empty())
      c.simulation().topology().removeTriangles(tris, repairOptions(c.simulation(), p_.minAngle));
  }

 private:
  RemoveParameters p_;
};

const bool registered = ActionRegistry::instance().add({
    "remove",
    "carves out the triangles whose rest centroid lies in a sphere or a box",
    {{"at", "time of the removal"},
     {"sphere", "{\"center\": [x, y, z], \"radius\": r} in rest coordinates"},
     {"box", "[[xmin, ymin, zmin], [xmax, ymax, zmax]] in rest coordinates"},
     {"minAngle", "smallest-angle target (degrees) of the quality repair around the hole, in [0, 60) "
                  "(default 20; 0 turns the repair off)"}},
    {},
    [](const ParameterSource& s) -> std::any {
      RemoveParameters p;
      if (s.oneOf({"sphere", "box"}) == "sphere") {
        const auto sphere = s.object("sphere", {"center", "radius"});
        p.region.kind = Region::Kind::Sphere;
        sphere->require("center");
        sphere->require("radius");
        p.region.center = sphere->vec3("center");
        p.region.radius = sphere->positive("radius", 0.0);
      } else {
        p.region.kind = Region::Kind::Box;
        std::tie(p.region.boxMin, p.region.boxMax) = s.box("box");
      }
      p.minAngle = readMinAngle(s);
      return p;
    },
    [](const std::any& p, const ActionTiming&) -> std::unique_ptr<TimelineAction> {
      return std::make_unique<RemoveAction>(std::any_cast<const RemoveParameters&>(p));
    }});

}  // namespace
}  // namespace cutsim::core
