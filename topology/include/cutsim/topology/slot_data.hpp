#pragma once
// SlotData: per-slot data that follows the topology by itself (after geometry-central's MeshData).
// A SlotData<PointId, T, W> holds W values of T per point slot (EdgeId, TriangleId: per edge or
// triangle slot) and subscribes to the topology, which keeps it in step:
//
//   created     it grows to the topology's capacity of its kind; a new slot gets the default
//               value, or (points, NewSlots::Interpolate) the weighted sum of its ancestors'
//               values (PointsCreated's ancestors and weights: a new point on an edge, a copy made
//               by an incision);
//   destroyed   the slot gets the default value back, at the end of the transaction (so that an
//               owner's own handlers can still read what a destroyed slot held);
//   renumbered  compaction permutes the values (dead slots dropped).
//
// An owner that subscribes AFTER constructing its SlotData members sees every event after them:
// its created handlers find the slots grown (and interpolated), its destroyed handlers still find
// the old values. No owner writes a resize or a renumbering loop of its own.
//
// The values live in a shared buffer that is never reallocated in place: growing past its
// capacity, or a renumbering, moves the values to a new buffer. buffer() hands out shared
// ownership of the current one, so that a view of the values held elsewhere (a numpy array in
// the Python module) stays readable memory after the table has moved on (it then shows the values
// as they were when the table left it).
#include <algorithm>
#include <cstddef>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "cutsim/topology/events.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::topology {

/// What a new point slot gets (edges and triangles always get the default).
enum class NewSlots { Default, Interpolate };

template <class IdT, class T, std::size_t Width = 1>
class SlotData final : public TopologyObserver {
  static_assert(std::is_same_v<IdT, PointId> || std::is_same_v<IdT, EdgeId> ||
                std::is_same_v<IdT, TriangleId>);

 public:
  /// Sized to the topology's capacity of IdT's kind, every slot at `defaultValue`; reserves 25%
  /// headroom so that the first cuts do not copy the table. Interpolate needs an arithmetic T.
  SlotData(Topology& topology, std::string name, T defaultValue = T{},
           NewSlots policy = NewSlots::Default)
      : name_(std::move(name)), default_(defaultValue), policy_(policy) {
    if (policy_ == NewSlots::Interpolate && !std::is_arithmetic_v<T>)
      throw std::logic_error(name_ + ": only numbers can be interpolated");
    const std::size_t slots = capacity(topology);
    values_ = std::make_shared<std::vector<T>>();
    values_->reserve(Width * (slots * 5 / 4 + 16));
    values_->assign(Width * slots, default_);
    subscription_ = topology.subscribe(*this);
  }
  SlotData(const SlotData&) = delete;
  SlotData& operator=(const SlotData&) = delete;

  std::size_t numSlots() const { return values_->size() / Width; }
  /// Every value, Width per slot, dead slots included (at the default).
  std::span<T> values() { return *values_; }
  std::span<const T> values() const { return *values_; }
  /// Shared ownership of the buffer that values() points into now (see the top of this file).
  std::shared_ptr<const void> buffer() const { return values_; }
  /// The Width values of slot id.
  std::span<T, Width> at(IdT id) {
    return std::span<T, Width>(values_->data() + Width * id.idx(), Width);
  }
  std::span<const T, Width> at(IdT id) const {
    return std::span<const T, Width>(values_->data() + Width * id.idx(), Width);
  }
  T& operator[](IdT id) requires(Width == 1) { return (*values_)[id.idx()]; }
  const T& operator[](IdT id) const requires(Width == 1) { return (*values_)[id.idx()]; }
  const T& defaultValue() const { return default_; }
  /// Sets every slot to the default value.
  void reset() { std::fill(values_->begin(), values_->end(), default_); }

  // ---- the events ----
  void onPointsCreated(const Topology& t, const PointsCreated& e) override {
    if constexpr (std::is_same_v<IdT, PointId>) {
      grow(t);
      if constexpr (std::is_arithmetic_v<T>) {
        if (policy_ != NewSlots::Interpolate) return;
        for (std::size_t i = 0; i < e.points.size(); ++i) {
          if (e.offsets[i] == e.offsets[i + 1]) continue;  // a free point: the default
          T sum[Width]{};
          for (auto k = e.offsets[i]; k < e.offsets[i + 1]; ++k)
            for (std::size_t c = 0; c < Width; ++c)
              sum[c] += e.weights[k] * (*values_)[Width * e.ancestors[k].idx() + c];
          for (std::size_t c = 0; c < Width; ++c)
            (*values_)[Width * e.points[i].idx() + c] = sum[c];
        }
      }
    }
  }
  void onEdgesCreated(const Topology& t, const EdgesCreated&) override {
    if constexpr (std::is_same_v<IdT, EdgeId>) grow(t);
  }
  void onTrianglesCreated(const Topology& t, const TrianglesCreated&) override {
    if constexpr (std::is_same_v<IdT, TriangleId>) grow(t);
  }
  void onPointsDestroyed(const Topology&, const PointsDestroyed& e) override {
    if constexpr (std::is_same_v<IdT, PointId>) remember(e.points);
  }
  void onEdgesDestroyed(const Topology&, const EdgesDestroyed& e) override {
    if constexpr (std::is_same_v<IdT, EdgeId>) remember(e.edges);
  }
  void onTrianglesDestroyed(const Topology&, const TrianglesDestroyed& e) override {
    if constexpr (std::is_same_v<IdT, TriangleId>) remember(e.triangles);
  }
  void onTransactionEnd(const Topology& t, const TransactionSummary&) override {
    // A slot made and freed within the transaction is never announced, but the capacity counts
    // it (found by the soak run: a repair's relocated point collapsed again at the end).
    grow(t);
    for (Index s : destroyed_)
      if (Width * std::size_t(s) < values_->size())
        std::fill_n(values_->begin() + std::ptrdiff_t(Width * s), Width, default_);
    destroyed_.clear();
  }
  void onPointsRenumbered(const Topology&, const Renumbering& r) override {
    if constexpr (std::is_same_v<IdT, PointId>) permute(r);
  }
  void onEdgesRenumbered(const Topology&, const Renumbering& r) override {
    if constexpr (std::is_same_v<IdT, EdgeId>) permute(r);
  }
  void onTrianglesRenumbered(const Topology&, const Renumbering& r) override {
    if constexpr (std::is_same_v<IdT, TriangleId>) permute(r);
  }
  std::string observerName() const override { return name_; }
  /// One value group per slot of the topology's capacity; dead slots at the default.
  void validate(const Topology& t, std::vector<std::string>& problems) const override {
    if (numSlots() != capacity(t)) {
      problems.push_back("holds " + std::to_string(numSlots()) + " slots, the topology " +
                         std::to_string(capacity(t)));
      return;
    }
    for (std::size_t s = 0; s < numSlots(); ++s) {
      if (alive(t, s)) continue;
      for (std::size_t c = 0; c < Width; ++c)
        if (!((*values_)[Width * s + c] == default_)) {
          problems.push_back("dead slot " + std::to_string(s) + " does not hold the default value");
          break;
        }
    }
  }

 private:
  static std::size_t capacity(const Topology& t) {
    if constexpr (std::is_same_v<IdT, PointId>)
      return t.pointCapacity();
    else if constexpr (std::is_same_v<IdT, EdgeId>)
      return t.edgeCapacity();
    else
      return t.triangleCapacity();
  }
  static bool alive(const Topology& t, std::size_t s) {
    if constexpr (std::is_same_v<IdT, PointId>)
      return t.isPointAlive(PointId(s));
    else if constexpr (std::is_same_v<IdT, EdgeId>)
      return t.isEdgeAlive(EdgeId(s));
    else
      return t.isTriangleAlive(TriangleId(s));
  }
  void grow(const Topology& t) {
    const std::size_t slots = capacity(t);
    if (slots <= numSlots()) return;
    const std::size_t size = Width * slots;
    if (size > values_->capacity()) {  // a new buffer, never a reallocation in place
      auto next = std::make_shared<std::vector<T>>();
      next->reserve(size + size / 4 + Width * 16);
      next->assign(values_->begin(), values_->end());
      values_ = std::move(next);
    }
    values_->resize(size, default_);
  }
  void remember(std::span<const IdT> ids) {
    for (IdT id : ids) destroyed_.push_back(id.idx());
  }
  void permute(const Renumbering& r) {
    std::vector<T> next(Width * r.newSize, default_);
    for (std::size_t o = 0; o < r.oldToNew.size() && o < numSlots(); ++o) {
      const Index n = r.oldToNew[o];
      if (n == kInvalidIndex) continue;
      std::copy_n(values_->begin() + std::ptrdiff_t(Width * o), Width,
                  next.begin() + std::ptrdiff_t(Width * n));
    }
    values_ = std::make_shared<std::vector<T>>(std::move(next));
  }

  std::string name_;
  T default_;
  NewSlots policy_;
  std::shared_ptr<std::vector<T>> values_;
  std::vector<Index> destroyed_;
  Subscription subscription_;
};

}  // namespace cutsim::topology
