#include "cutsim/core/state.hpp"

#include <cmath>

namespace cutsim::core {

MechanicalState::MechanicalState(topology::Topology& topology) {
  // Headroom so that the first cuts do not copy the whole state (see Topology's constructor).
  const std::size_t room = 3 * (std::size_t(topology.pointCapacity()) * 5 / 4 + 16);
  x_.reserve(room);
  v_.reserve(room);
  rest_.reserve(room);
  resize(topology.pointCapacity());
  for (auto p : topology.points()) {
    auto r = topology.restPosition(p);
    for (int c = 0; c < 3; ++c) x_[3 * p + c] = rest_[3 * p + c] = r[c];
  }
  subscription_ = topology.subscribe(*this);
}

void MechanicalState::resize(std::size_t slots) {
  x_.resize(3 * slots, 0.0);
  v_.resize(3 * slots, 0.0);
  rest_.resize(3 * slots, 0.0);
}

void MechanicalState::onPointsCreated(const topology::Topology& t, const topology::PointsCreated& e) {
  resize(t.pointCapacity());
  for (std::size_t i = 0; i < e.points.size(); ++i) {
    const std::size_t p = e.points[i];
    if (e.offsets[i] == e.offsets[i + 1]) {  // a free point: at rest, at its rest position
      auto r = t.restPosition(topology::PointId(p));
      for (int c = 0; c < 3; ++c) {
        x_[3 * p + c] = rest_[3 * p + c] = r[c];
        v_[3 * p + c] = 0.0;
      }
      continue;
    }
    double x[3] = {0, 0, 0}, v[3] = {0, 0, 0}, r[3] = {0, 0, 0};
    for (auto k = e.offsets[i]; k < e.offsets[i + 1]; ++k) {
      const std::size_t a = e.ancestors[k];
      const double w = e.weights[k];
      for (int c = 0; c < 3; ++c) {
        x[c] += w * x_[3 * a + c];
        v[c] += w * v_[3 * a + c];
        r[c] += w * rest_[3 * a + c];
      }
    }
    for (int c = 0; c < 3; ++c) {
      x_[3 * p + c] = x[c];
      v_[3 * p + c] = v[c];
      rest_[3 * p + c] = r[c];
    }
  }
}

void MechanicalState::onPointsDestroyed(const topology::Topology&, const topology::PointsDestroyed& e) {
  for (auto p : e.points)
    for (int c = 0; c < 3; ++c) x_[3 * p + c] = v_[3 * p + c] = rest_[3 * p + c] = 0.0;
}

void MechanicalState::onPointsRenumbered(const topology::Topology&, const topology::Renumbering& r) {
  std::vector<double> x(3 * r.newSize), v(3 * r.newSize), rest(3 * r.newSize);
  for (std::size_t o = 0; o < r.oldToNew.size(); ++o) {
    auto n = r.oldToNew[o];
    if (n == topology::kInvalidIndex) continue;
    for (int c = 0; c < 3; ++c) {
      x[3 * n + c] = x_[3 * o + c];
      v[3 * n + c] = v_[3 * o + c];
      rest[3 * n + c] = rest_[3 * o + c];
    }
  }
  x_.swap(x);
  v_.swap(v);
  rest_.swap(rest);
}

void MechanicalState::validate(const topology::Topology& t, std::vector<std::string>& problems) const {
  if (x_.size() != 3 * std::size_t(t.pointCapacity())) {
    problems.push_back("size " + std::to_string(x_.size() / 3) + " != point capacity " +
                       std::to_string(t.pointCapacity()));
    return;
  }
  for (topology::PointId p = 0; p < t.pointCapacity(); ++p) {
    if (!t.isPointAlive(p)) {
      for (int c = 0; c < 3; ++c)
        if (x_[3 * p + c] != 0.0 || v_[3 * p + c] != 0.0)
          problems.push_back("dead point " + std::to_string(p) + " has a non-zero state");
      continue;
    }
    auto r = t.restPosition(p);
    for (int c = 0; c < 3; ++c) {
      if (std::abs(r[c] - rest_[3 * p + c]) > 1e-9 * (1.0 + std::abs(r[c])))
        problems.push_back("point " + std::to_string(p) + ": rest position differs from the topology's");
      if (!std::isfinite(x_[3 * p + c]) || !std::isfinite(v_[3 * p + c]))
        problems.push_back("point " + std::to_string(p) + ": non-finite state");
    }
  }
}

}  // namespace cutsim::core
