#include "cutsim/core/constraints.hpp"

#include <Eigen/Geometry>
#include <cmath>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"

namespace cutsim::core {

PointSet::PointSet(topology::Topology& topology, std::string name)
    : name_(std::move(name)),
      flags_(topology, "PointSet '" + name_ + "' flags", 0),
      data_(topology, "PointSet '" + name_ + "' data", Vec3{0, 0, 0}) {
  subscription_ = topology.subscribe(*this);
}

void PointSet::add(PointId p, const Vec3& data) {
  if (p.idx() >= flags_.numSlots())
    throw TopologyError(name_ + ": point " + std::to_string(p.idx()) + " does not exist");
  if (!flags_[p]) ++count_;
  flags_[p] = 1;
  data_[p] = data;
}

void PointSet::remove(PointId p) {
  if (p.idx() >= flags_.numSlots() || !flags_[p]) return;
  flags_[p] = 0;
  data_[p] = {0, 0, 0};
  --count_;
}

void PointSet::clear() {
  flags_.reset();
  count_ = 0;
}

std::vector<PointId> PointSet::points() const {
  std::vector<PointId> out;
  const auto f = flags_.values();
  for (std::size_t p = 0; p < f.size(); ++p)
    if (f[p]) out.push_back(PointId(p));
  return out;
}

void PointSet::onPointsCreated(const topology::Topology&, const topology::PointsCreated& e) {
  for (std::size_t i = 0; i < e.points.size(); ++i) {
    // A copy of a member (one ancestor, weight 1) is a member, with the member's data.
    if (e.offsets[i + 1] - e.offsets[i] != 1) continue;
    PointId a = e.ancestors[e.offsets[i]];
    if (contains(a) && e.weights[e.offsets[i]] == 1.0) {
      flags_[e.points[i]] = 1;
      data_[e.points[i]] = data_[a];
      ++count_;
    }
  }
}

void PointSet::onPointsDestroyed(const topology::Topology&, const topology::PointsDestroyed& e) {
  // The SlotData clear the flags at the transaction's end; the count follows now.
  for (auto p : e.points)
    if (contains(p)) --count_;
}

void PointSet::validate(const topology::Topology& t, std::vector<std::string>& problems) const {
  if (flags_.numSlots() != t.pointCapacity())
    problems.push_back("size differs from the point capacity");
  std::size_t n = 0;
  const auto f = flags_.values();
  for (std::size_t p = 0; p < f.size(); ++p) {
    if (!f[p]) continue;
    ++n;
    if (!t.isPointAlive(PointId(p))) problems.push_back("holds dead point " + std::to_string(p));
  }
  if (n != count_) problems.push_back("count is wrong");
}

Vec3 DisplacementPath::at(double t) const {
  if (times.empty()) return {0, 0, 0};
  if (t <= times.front()) return displacements.front();
  if (t >= times.back()) return displacements.back();
  std::size_t k = 1;
  while (times[k] < t) ++k;
  double s = (t - times[k - 1]) / (times[k] - times[k - 1]);
  Vec3 out;
  for (int c = 0; c < 3; ++c) out[c] = (1 - s) * displacements[k - 1][c] + s * displacements[k][c];
  return out;
}

namespace {
Eigen::Quaterniond quaternion(const Rotation& r) {
  return Eigen::Quaterniond(r[0], r[1], r[2], r[3]);
}
}  // namespace

Rotation DisplacementPath::rotationAt(double t) const {
  if (rotations.empty() || times.empty()) return {1, 0, 0, 0};
  if (t <= times.front()) return rotations.front();
  if (t >= times.back()) return rotations.back();
  std::size_t k = 1;
  while (times[k] < t) ++k;
  const double s = (t - times[k - 1]) / (times[k] - times[k - 1]);
  // (Eigen's slerp takes the shorter arc)
  const Eigen::Quaterniond q = quaternion(rotations[k - 1]).slerp(s, quaternion(rotations[k]));
  return {q.w(), q.x(), q.y(), q.z()};
}

Vec3 DisplacementPath::move(const Vec3& anchor, double t) const {
  const Vec3 d = at(t);
  if (rotations.empty()) return {anchor[0] + d[0], anchor[1] + d[1], anchor[2] + d[2]};
  const Eigen::Vector3d arm =
      quaternion(rotationAt(t)) *
      Eigen::Vector3d(anchor[0] - pivot[0], anchor[1] - pivot[1], anchor[2] - pivot[2]);
  return {pivot[0] + d[0] + arm[0], pivot[1] + d[1] + arm[1], pivot[2] + d[2] + arm[2]};
}

void DisplacementPath::check(const std::string& who) const {
  if (times.size() != displacements.size())
    throw InvalidInput(who, "path times and displacements differ in number");
  if (!rotations.empty() && rotations.size() != times.size())
    throw InvalidInput(who, "path times and rotations differ in number");
  for (std::size_t i = 0; i < times.size(); ++i) {
    if (!std::isfinite(times[i]) || (i > 0 && !(times[i] > times[i - 1])))
      throw InvalidInput(who, "path times must be finite and increasing");
    for (double c : displacements[i])
      if (!std::isfinite(c)) throw InvalidInput(who, "non-finite displacement");
  }
  for (const Rotation& r : rotations) {
    const double n2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3];
    if (!(std::abs(n2 - 1) <= 1e-9))
      throw InvalidInput(who, "a rotation of the path is not a unit quaternion");
  }
  for (double c : pivot)
    if (!std::isfinite(c)) throw InvalidInput(who, "non-finite pivot");
}

Grasp::Grasp(topology::Topology& topology, std::string name, double startTime,
             DisplacementPath path)
    : points_(topology, std::move(name)), start_(startTime), path_(std::move(path)) {
  path_.check("grasp '" + points_.name() + "'");
}

void Grasp::moveBy(double now, const Vec3& delta, double duration) {
  if (!std::isfinite(now) || !(duration >= 0) || !std::isfinite(duration))
    throw InvalidInput("grasp '" + points_.name() + "'", "a move needs a finite duration >= 0");
  for (double c : delta)
    if (!std::isfinite(c))
      throw InvalidInput("grasp '" + points_.name() + "'", "non-finite displacement");
  const double tau = now - start_;
  const Vec3 d0 = path_.at(tau);
  const Rotation r0 = path_.rotationAt(tau);
  const bool turns = !path_.rotations.empty();
  DisplacementPath next;
  next.pivot = path_.pivot;
  for (std::size_t i = 0; i < path_.times.size() && path_.times[i] < tau; ++i) {
    next.times.push_back(path_.times[i]);
    next.displacements.push_back(path_.displacements[i]);
    if (turns) next.rotations.push_back(path_.rotations[i]);
  }
  next.times.push_back(tau);
  next.displacements.push_back(d0);
  if (turns) next.rotations.push_back(r0);
  const Vec3 d1{d0[0] + delta[0], d0[1] + delta[1], d0[2] + delta[2]};
  if (duration > 0) {
    next.times.push_back(tau + duration);
    next.displacements.push_back(d1);
    if (turns) next.rotations.push_back(r0);
  } else {
    next.displacements.back() = d1;
  }
  path_ = std::move(next);
}

Vec3 Grasp::target(PointId p, double t) const {
  return path_.move(points_.data(p), t - start_);
}

template <class Archive, class Self>
void PointSet::members(Archive& a, Self& s) {
  fields(a, slots(s.flags_.values(), s.name_ + ": members"),
         slots(s.data_.values(), s.name_ + ": data"));
}
void PointSet::saveState(ArchiveWriter& out) const {
  members(out, *this);
}
void PointSet::loadState(ArchiveReader& in) {
  members(in, *this);
  count_ = 0;
  for (char f : flags_.values()) count_ += f ? 1 : 0;
}

}  // namespace cutsim::core
