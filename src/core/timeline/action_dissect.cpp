// The "dissect" action: undermines the surface, releasing its Attachment (the tissue beneath)
// along a path with a width, or in a sphere or a box, all in rest coordinates: a flap stays on the
// tissue until it is undermined, then lifts.
#include <cmath>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/timeline.hpp"
#include "cutsim/forcefields/attachment.hpp"

namespace cutsim::core {
namespace {

struct DissectParameters {
  std::vector<Vec3> polyline;  ///< rest coordinates (or a region)
  double width = 0.0;          ///< of the path (m): points within width / 2 are released
  bool inRegion = false;
  Region region;
  std::string field;  ///< an Attachment's label ("": every Attachment)
};

class DissectAction final : public TimelineAction {
 public:
  explicit DissectAction(DissectParameters p) : p_(std::move(p)) {}
  bool checkpointable() const override { return true; }  // done once started
  /// The rehearsal of the timeline (the surface at rest, no force fields) has nothing to release:
  /// the dissection changes no topology, and dryRun has checked it.
  bool rehearsed() const override { return false; }

  void dryRun(DryRunContext& c) const override {
    if (const auto* fields = c.forceFields()) {
      bool found = false;
      for (const auto& [type, label] : *fields)
        found = found || (type == "Attachment" && (p_.field.empty() || label == p_.field));
      if (!found)
        c.fail(p_.field.empty() ? "" : "field",
               p_.field.empty() ? "the scene has no Attachment force field to release"
                                : "no Attachment force field is labelled \"" + p_.field + "\"");
    }
    const auto inside = selector();
    const topology::Topology& t = c.topology();
    for (PointId p : t.points()) {
      if (inside(t.restPosition(p))) return;
    }
    c.fail(p_.inRegion ? (p_.region.kind == Region::Kind::Box ? "box" : "sphere") : "polyline",
           p_.inRegion ? "releases nothing: no point of the surface lies in the region"
                       : "releases nothing: no point of the surface lies within width / 2 = " +
                             std::to_string(0.5 * p_.width) + " of the path (rest coordinates)");
  }

  void start(ActionContext& c) override {
    Model& model = c.simulation().model();
    const auto inside = selector();
    // An action given while the simulation runs had no check before: the same one now.
    const topology::Topology& t = c.simulation().topology();
    bool any = false;
    for (PointId p : t.points()) any = any || inside(t.restPosition(p));
    if (!any)
      c.fail(p_.inRegion ? "the dissection releases nothing: no point of the surface lies in the "
                           "region"
                         : "the dissection releases nothing: no point of the surface lies within "
                           "width / 2 = " +
                               std::to_string(0.5 * p_.width) + " of the path (rest coordinates)");
    bool found = false;
    for (std::size_t i = 0; i < model.numForceFields(); ++i) {
      auto* a = dynamic_cast<forcefields::Attachment*>(&model.forceField(i));
      if (!a || (!p_.field.empty() && model.forceFieldLabel(i) != p_.field)) continue;
      found = true;
      a->release(inside);
    }
    if (!found)
      c.fail(p_.field.empty() ? "the dissection finds no Attachment force field to release"
                              : "the dissection finds no Attachment labelled \"" + p_.field + "\"");
  }

 private:
  std::function<bool(const Vec3&)> selector() const {
    if (p_.inRegion) {
      const Region r = p_.region;
      return [r](const Vec3& x) { return r.contains(x); };
    }
    return forcefields::nearPolyline(p_.polyline, 0.5 * p_.width);
  }

  DissectParameters p_;
};

const bool registered = ActionRegistry::instance().add(
    {"dissect",
     "releases the surface from the tissue beneath (its Attachment force fields) along a path "
     "with a width, or in a sphere or a box (rest coordinates)",
     {{"at", KeyType::Number, "time of the dissection"},
      {"polyline", KeyType::Points, "the path, [[x, y, z], ...] in rest coordinates"},
      {"width", KeyType::Number, "of the path (m), > 0: the points within width / 2 are released"},
      {"sphere", KeyType::Object, "{\"center\": [x, y, z], \"radius\": r} in rest coordinates"},
      {"box", KeyType::Box, "[[xmin, ymin, zmin], [xmax, ymax, zmax]] in rest coordinates"},
      {"field", KeyType::String,
       "the label of the Attachment to release (default: every Attachment)"}},
     {},
     [](const ParameterSource& s) -> std::any {
       DissectParameters p;
       const std::string_view where = s.oneOf({"polyline", "sphere", "box"});
       if (where == "polyline") {
         p.polyline = s.points("polyline", 1);
         s.require("width");
         p.width = s.positive("width", 0.0);
       } else {
         if (s.has("width")) s.fail("width", "is for a polyline; a region has no width");
         p.inRegion = true;
         p.region = Region::read(s, where);
       }
       if (s.has("field")) p.field = s.string("field");
       return p;
     },
     [](const std::any& p, const ActionTiming&) -> std::unique_ptr<TimelineAction> {
       return std::make_unique<DissectAction>(std::any_cast<const DissectParameters&>(p));
     }});

}  // namespace
}  // namespace cutsim::core
