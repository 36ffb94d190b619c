#include "cutsim/core/state.hpp"

#include <cmath>

#include "cutsim/base/archive.hpp"

namespace cutsim::core {

MechanicalState::MechanicalState(topology::Topology& topology)
    : x_(topology, "state x", 0.0, topology::NewSlots::Interpolate),
      v_(topology, "state v", 0.0, topology::NewSlots::Interpolate),
      rest_(topology, "state rest", 0.0, topology::NewSlots::Interpolate) {
  for (auto p : topology.points()) {
    auto r = topology.restPosition(p);
    for (int c = 0; c < 3; ++c)
      x_.at(p)[std::size_t(c)] = rest_.at(p)[std::size_t(c)] = r[std::size_t(c)];
  }
  subscription_ = topology.subscribe(*this);
}

void MechanicalState::onPointsCreated(const topology::Topology& t,
                                      const topology::PointsCreated& e) {
  // The SlotData have grown and interpolated the new points from their ancestors; a free point
  // (no ancestor) starts at rest at its rest position.
  for (std::size_t i = 0; i < e.points.size(); ++i) {
    if (e.offsets[i] != e.offsets[i + 1]) continue;
    const auto r = t.restPosition(e.points[i]);
    for (std::size_t c = 0; c < 3; ++c) {
      x_.at(e.points[i])[c] = rest_.at(e.points[i])[c] = r[c];
      v_.at(e.points[i])[c] = 0.0;
    }
  }
}

void MechanicalState::validate(const topology::Topology& t,
                               std::vector<std::string>& problems) const {
  if (x_.numSlots() != std::size_t(t.pointCapacity())) {
    problems.push_back("size " + std::to_string(x_.numSlots()) + " != point capacity " +
                       std::to_string(t.pointCapacity()));
    return;
  }
  for (topology::PointId p{0}; p.idx() < t.pointCapacity(); ++p) {
    if (!t.isPointAlive(p)) {
      for (int c = 0; c < 3; ++c)
        if (x()[3 * p.idx() + c] != 0.0 || v()[3 * p.idx() + c] != 0.0)
          problems.push_back("dead point " + std::to_string(p.idx()) + " has a non-zero state");
      continue;
    }
    auto r = t.restPosition(p);
    for (int c = 0; c < 3; ++c) {
      if (std::abs(r[c] - rest()[3 * p.idx() + c]) > 1e-9 * (1.0 + std::abs(r[c])))
        problems.push_back("point " + std::to_string(p.idx()) +
                           ": rest position differs from the topology's");
      if (!std::isfinite(x()[3 * p.idx() + c]) || !std::isfinite(v()[3 * p.idx() + c]))
        problems.push_back("point " + std::to_string(p.idx()) + ": non-finite state");
    }
  }
}

// (rest: interpolated for new points, within rounding of the topology's: kept as it is.)
template <class Archive, class Self>
void MechanicalState::members(Archive& a, Self& s) {
  fields(a, slots(s.x(), "positions"), slots(s.v(), "velocities"),
         slots(s.rest_.values(), "rest positions"));
}
void MechanicalState::saveState(ArchiveWriter& out) const {
  members(out, *this);
}
void MechanicalState::loadState(ArchiveReader& in) {
  members(in, *this);
}

}  // namespace cutsim::core
