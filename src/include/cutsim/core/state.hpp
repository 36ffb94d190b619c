#pragma once
// The mechanical state of the surface: positions x, velocities v and a mirror of the rest
// positions, 3 doubles per point SLOT (size 3 * topology.pointCapacity()), held in SlotData that
// follow the topology's point events by themselves: new points interpolate x, v and rest from
// their ancestors; destroyed points are zeroed; compaction renumbers. The state itself only
// places a free point (addPoints: no ancestors) at its rest position.
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "cutsim/base/fwd.hpp"
#include "cutsim/topology/slot_data.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::core {

class MechanicalState : public topology::TopologyObserver {
 public:
  /// x = rest positions, v = 0. Subscribes to the topology.
  explicit MechanicalState(topology::Topology& topology);

  std::span<double> x() { return x_.values(); }
  std::span<const double> x() const { return x_.values(); }
  std::span<double> v() { return v_.values(); }
  std::span<const double> v() const { return v_.values(); }
  std::span<const double> rest() const { return rest_.values(); }
  std::size_t numSlots() const { return x_.numSlots(); }
  /// Shared ownership of the buffers x(), v() and rest() point into now: they stay readable after
  /// a topology change has moved the state to new buffers (topology::SlotData::buffer).
  std::shared_ptr<const void> xBuffer() const { return x_.buffer(); }
  std::shared_ptr<const void> vBuffer() const { return v_.buffer(); }
  std::shared_ptr<const void> restBuffer() const { return rest_.buffer(); }

  void onPointsCreated(const topology::Topology&, const topology::PointsCreated&) override;
  std::string observerName() const override { return "MechanicalState"; }
  /// Sizes match the topology; rest equals the topology's rest positions; dead slots are zero.
  void validate(const topology::Topology&, std::vector<std::string>& problems) const override;
  /// Checkpoints: x, v and rest as stored; loadState refuses values for another number of slots.
  void saveState(ArchiveWriter& out) const;
  void loadState(ArchiveReader& in);

 private:
  template <class Archive, class Self>
  static void members(Archive& a, Self& s);  // the checkpointed members, for save and load
  using PointVectors = topology::SlotData<topology::PointId, double, 3>;
  PointVectors x_, v_, rest_;
  topology::Subscription subscription_;  // after the SlotData: notified after them
};

}  // namespace cutsim::core
