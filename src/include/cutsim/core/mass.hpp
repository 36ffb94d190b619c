#pragma once
// Lumped (diagonal) mass, by one of two laws:
// - area density (the default; SOFA's DiagonalMass on triangles): each triangle gives
//   density * restArea / 3 to each of its vertices. It follows the triangle events (a created
//   triangle adds its share, a destroyed one takes back what it gave), so that cutting, which only
//   re-partitions triangles, conserves mass;
// - per point (SOFA's UniformMass): every live point carries the same mass, new points too (a cut
//   that duplicates points adds mass, as UniformMass's vertexMass does in SOFA).
// Its tables are SlotData: the topology resizes, resets and renumbers them.
#include <span>
#include <string>
#include <vector>

#include "cutsim/base/fwd.hpp"
#include "cutsim/topology/slot_data.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::core {

/// How the mass is spread over the points.
struct MassLaw {
  enum class Kind { AreaDensity, PerPoint };
  Kind kind = Kind::AreaDensity;
  double value = 0.0;  ///< mass per unit rest area, or mass per point
  static MassLaw areaDensity(double density) { return {Kind::AreaDensity, density}; }
  static MassLaw perPoint(double mass) { return {Kind::PerPoint, mass}; }
};

class LumpedMass : public topology::TopologyObserver {
 public:
  /// density: mass per unit rest area (> 0, finite).
  LumpedMass(topology::Topology& topology, double density);
  /// By either law (value > 0, finite).
  LumpedMass(topology::Topology& topology, MassLaw law);
  /// A density chosen so that the current mesh weighs totalMass (> 0, finite).
  static double densityForTotal(const topology::Topology& topology, double totalMass);

  /// Mass per unit rest area (0 with the per-point law).
  double density() const { return law_.kind == MassLaw::Kind::AreaDensity ? law_.value : 0.0; }
  const MassLaw& law() const { return law_; }
  /// Mass per point slot (0 for dead or isolated points).
  std::span<const double> perPoint() const { return mass_.values(); }
  double total() const;
  double restArea() const;

  void onTrianglesDestroyed(const topology::Topology&,
                            const topology::TrianglesDestroyed&) override;
  void onTrianglesCreated(const topology::Topology&, const topology::TrianglesCreated&) override;
  void onPointsCreated(const topology::Topology&, const topology::PointsCreated&) override;
  std::string observerName() const override { return "LumpedMass"; }
  void validate(const topology::Topology&, std::vector<std::string>& problems) const override;
  /// Checkpoints: the density and the per-slot masses and areas as stored (as they were summed).
  void saveState(ArchiveWriter& out) const;
  void loadState(ArchiveReader& in);

  static double triangleArea(const topology::Topology& t, topology::TriangleId f);

 private:
  template <class Archive, class Self>
  static void members(Archive& a, Self& s);  // the checkpointed members, for save and load
  MassLaw law_;
  double density_;  ///< law_.value with the area law, 0 with the per-point law
  topology::SlotData<topology::PointId, double> mass_;             // per point slot
  topology::SlotData<topology::TriangleId, double> triangleArea_;  // rest area given when created
  topology::Subscription subscription_;  // after the SlotData: notified after them
};

}  // namespace cutsim::core
