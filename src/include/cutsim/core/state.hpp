#pragma once
// The mechanical state of the surface: positions x, velocities v and a mirror of the rest
// positions, 3 doubles per point SLOT (size 3 * topology.pointCapacity()), that follows the
// topology's point events: new points interpolate x, v and rest from their ancestors; destroyed
// points are zeroed; compaction renumbers.
#include <span>
#include <string>
#include <vector>

#include "cutsim/topology/topology.hpp"

namespace cutsim::core {

class MechanicalState : public topology::TopologyObserver {
 public:
  /// x = rest positions, v = 0. Subscribes to the topology.
  explicit MechanicalState(topology::Topology& topology);

  std::span<double> x() { return x_; }
  std::span<const double> x() const { return x_; }
  std::span<double> v() { return v_; }
  std::span<const double> v() const { return v_; }
  std::span<const double> rest() const { return rest_; }
  std::size_t numSlots() const { return x_.size() / 3; }

  void onPointsCreated(const topology::Topology&, const topology::PointsCreated&) override;
  void onPointsDestroyed(const topology::Topology&, const topology::PointsDestroyed&) override;
  void onPointsRenumbered(const topology::Topology&, const topology::Renumbering&) override;
  std::string observerName() const override { return "MechanicalState"; }
  /// Sizes match the topology; rest equals the topology's rest positions; dead slots are zero.
  void validate(const topology::Topology&, std::vector<std::string>& problems) const override;

 private:
  void resize(std::size_t slots);
  std::vector<double> x_, v_, rest_;
  topology::Subscription subscription_;
};

}  // namespace cutsim::core
