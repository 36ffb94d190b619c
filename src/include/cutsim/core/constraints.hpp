#pragma once
// Point constraints: fixed points, and grasps that drag a set of points along a path over time.
// Both follow the topology: a copy made by an incision (a new point whose single ancestor is a
// constrained point) is constrained too; destroyed points drop out; compaction renumbers.
#include <array>
#include <span>
#include <string>
#include <vector>

#include "cutsim/base/fwd.hpp"
#include "cutsim/topology/slot_data.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::core {

using topology::PointId;
using topology::Vec3;

/// A set of points (per slot flags) that follows the topology, with a Vec3 of data per member
/// (a grasp's anchors) that new members inherit from their ancestors (weighted).
class PointSet : public topology::TopologyObserver {
 public:
  PointSet(topology::Topology& topology, std::string name);
  void add(PointId p, const Vec3& data = {0, 0, 0});
  void remove(PointId p);  ///< no effect if p is not a member
  void clear();
  bool contains(PointId p) const { return p.idx() < flags_.numSlots() && flags_[p]; }
  const Vec3& data(PointId p) const { return data_[p]; }
  void setData(PointId p, const Vec3& d) { data_[p] = d; }
  std::vector<PointId> points() const;  ///< ascending
  std::size_t size() const { return count_; }
  const std::string& name() const { return name_; }

  void onPointsCreated(const topology::Topology&, const topology::PointsCreated&) override;
  void onPointsDestroyed(const topology::Topology&, const topology::PointsDestroyed&) override;
  std::string observerName() const override { return "PointSet '" + name_ + "'"; }
  void validate(const topology::Topology&, std::vector<std::string>& problems) const override;
  /// Checkpoints: the members and their data as stored.
  void saveState(ArchiveWriter& out) const;
  void loadState(ArchiveReader& in);

 private:
  template <class Archive, class Self>
  static void members(Archive& a, Self& s);  // the checkpointed members, for save and load
  std::string name_;
  topology::SlotData<PointId, char> flags_;
  topology::SlotData<PointId, Vec3> data_;
  std::size_t count_ = 0;
  topology::Subscription subscription_;  // after the SlotData: notified after them
};

/// A rotation: a unit quaternion (w, x, y, z).
using Rotation = std::array<double, 4>;

/// A path of rigid motions: (time, displacement) keys, linear between keys, constant after the
/// last key and before the first (times strictly increasing). Optionally a rotation per key (a
/// turning instrument's): the points then turn about `pivot` (which the displacement moves),
/// along the shortest arc between keys at a constant rate (spherical linear interpolation).
struct DisplacementPath {
  std::vector<double> times;
  std::vector<Vec3> displacements;
  /// Empty: the points only translate. Else one per key (unit quaternions).
  std::vector<Rotation> rotations;
  Vec3 pivot{0, 0, 0};  ///< where the rotations turn about at time 0 (world)
  Vec3 at(double t) const;
  /// The rotation at time t (identity without rotations).
  Rotation rotationAt(double t) const;
  /// Where a point at `anchor` at time 0 is at time t: pivot + at(t) + R(t) (anchor - pivot).
  Vec3 move(const Vec3& anchor, double t) const;
  /// Throws InvalidInput (where = `who`) for keys of different counts, times not finite or not
  /// increasing, a displacement or pivot not finite, a rotation not of unit length (to 1e-9).
  void check(const std::string& who) const;
};

/// Grasped points follow path.move(anchor, t - startTime) (anchor + path(t - startTime) for a path
/// without rotations), where anchor is each point's position when
/// it was grasped (a copy made later by a cut inherits its original's anchor). The reaction force
/// is the force the grasp exerts on the surface (the sum over its points of what holds them on the
/// path), reported after each step.
class Grasp {
 public:
  Grasp(topology::Topology& topology, std::string name, double startTime, DisplacementPath path);
  const std::string& name() const { return points_.name(); }
  PointSet& points() { return points_; }
  const PointSet& points() const { return points_; }
  /// Grasps point p, anchored at its current position x_p (the path moves it from there).
  void add(PointId p, const Vec3& position) { points_.add(p, position); }
  /// Target position of point p at time t: its anchor plus the path's displacement.
  Vec3 target(PointId p, double t) const;
  const Vec3& reaction() const { return reaction_; }
  void setReaction(const Vec3& r) { reaction_ = r; }
  double startTime() const { return start_; }
  const DisplacementPath& path() const { return path_; }
  /// From time `now` on, the path moves the points by `delta` more over `duration` (>= 0; 0: at
  /// once), then holds them (turned as they are at `now`); the path's keys after `now` are
  /// dropped.
  void moveBy(double now, const Vec3& delta, double duration);

 private:
  PointSet points_;
  double start_;
  DisplacementPath path_;
  Vec3 reaction_{0, 0, 0};
};

}  // namespace cutsim::core
