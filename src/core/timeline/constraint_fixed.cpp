// The "fixed" constraint: points that do not move.
#include "cutsim/core/timeline.hpp"

namespace cutsim::core {
namespace {

class FixedConstraint final : public SceneConstraint {
 public:
  explicit FixedConstraint(PointSelection s) : s_(std::move(s)) {}
  void dryRun(DryRunContext& c) const override {
    if (s_.kind == PointSelection::Kind::Points) {
      const std::size_t n = c.restMesh().points.size();
      for (std::size_t i = 0; i < s_.points.size(); ++i)
        if (s_.points[i].idx() >= n)
          c.fail("points/" + std::to_string(i), "must be between 0 and " +
                                                    std::to_string(long(n) - 1) + " (got " +
                                                    std::to_string(s_.points[i].idx()) + ")");
    }
    if (s_.resolve(c.topology()).empty())
      c.fail(std::string(s_.key()), "selects no point of the mesh");
  }
  void apply(Simulation& sim) const override {
    const std::vector<PointId> points = s_.resolve(sim.topology());
    // A point is held by one constraint: a grasped point cannot be fixed as well.
    for (PointId p : points)
      for (std::size_t g = 0; g < sim.numGrasps(); ++g)
        if (sim.grasp(g).points().contains(p))
          throw InvalidInput(std::string(s_.key()),
                             "point " + std::to_string(p.idx()) + " is held by the grasp \"" +
                                 sim.grasp(g).name() + "\": a point is held by one constraint");
    for (PointId p : points) sim.fixed().add(p);
  }

 private:
  PointSelection s_;
};

const bool registered = ConstraintRegistry::instance().add(
    {"fixed",
     "points that do not move",
     {{"points", KeyType::Integers, "[ids] of the mesh as loaded"},
      {"box", KeyType::Box,
       "[[xmin, ymin, zmin], [xmax, ymax, zmax]]: the points inside, in rest coordinates"},
      {"near", KeyType::Points,
       "[[x, y, z], ...]: the nearest point to each position, in rest coordinates"}},
     {},
     [](const ParameterSource& s) -> std::any { return PointSelection::read(s); },
     [](const std::any& p) -> std::unique_ptr<SceneConstraint> {
       return std::make_unique<FixedConstraint>(std::any_cast<const PointSelection&>(p));
     }});

}  // namespace
}  // namespace cutsim::core
