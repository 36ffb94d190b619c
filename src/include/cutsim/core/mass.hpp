#pragma once
// Lumped mass from triangle areas: each triangle gives density * restArea / 3 to each of its
// vertices. It follows the triangle events (a created triangle adds its share, a destroyed one
// takes back what it gave), so that cutting, which only re-partitions triangles, conserves mass.
// Its tables are SlotData: the topology resizes, resets and renumbers them.
#include <span>
#include <string>
#include <vector>

#include "cutsim/topology/slot_data.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::core {

class LumpedMass : public topology::TopologyObserver {
 public:
  /// density: mass per unit rest area (> 0, finite).
  LumpedMass(topology::Topology& topology, double density);
  /// A density chosen so that the current mesh weighs totalMass (> 0, finite).
  static double densityForTotal(const topology::Topology& topology, double totalMass);

  double density() const { return density_; }
  /// Mass per point slot (0 for dead or isolated points).
  std::span<const double> perPoint() const { return mass_.values(); }
  double total() const;
  double restArea() const;

  void onTrianglesDestroyed(const topology::Topology&, const topology::TrianglesDestroyed&) override;
  void onTrianglesCreated(const topology::Topology&, const topology::TrianglesCreated&) override;
  std::string observerName() const override { return "LumpedMass"; }
  void validate(const topology::Topology&, std::vector<std::string>& problems) const override;

  static double triangleArea(const topology::Topology& t, topology::TriangleId f);

 private:
  double density_;
  topology::SlotData<topology::PointId, double> mass_;             // per point slot
  topology::SlotData<topology::TriangleId, double> triangleArea_;  // rest area given when created
  topology::Subscription subscription_;  // after the SlotData: notified after them
};

}  // namespace cutsim::core
