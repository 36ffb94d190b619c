#pragma once
// DenseSlotTable: a dense table of entries indexed by slot, the container of the force fields'
// tables (the springs per edge, the hinges per edge, the elements per triangle).
//
// A DenseSlotTable<EdgeId, Entry, Traits> holds:
//
//   entries_[i]     the entries, compact (no holes, no status test): what the force passes stream;
//   slotOfEntry_[i] the slot of entries_[i]; with Traits::kHasFlag its top bit is a per-entry
//                   flag (then slot ids must stay below 2^31);
//   indexOfSlot_[s] per slot: the index of its entry, or kStatusBase + a status for a slot without
//                   an entry (Traits::Status, values below 16; Traits::kEmpty for a slot that is
//                   dead, new, or beyond the table).
//
// and does what every such table needs, so that its owner writes none of it:
//
//   set / setStatus  add an entry (appended), replace it in place, or remove it (the last entry
//                    moves into the hole: O(1), the order of the others is kept);
//   reset, grow      sized to the topology's capacity of IdT's kind with 25% headroom on the slot
//                    index and on the entries (the first cuts do not copy the table); later
//                    growth is geometric;
//   remapPoints      point renumbering: the point ids an entry stores (Traits::forEachPoint says
//                    where they are) mapped old -> new;
//   renumber         renumbering of IdT's kind: the slot index permuted and the entries re-laid
//                    out in the new slot order, which restores the streaming locality of a fresh
//                    mesh (entries appended by cuts and moved by removals are back in mesh order).
//
// Driven, not an observer: the owner's handlers call it. Unlike SlotData, whose values follow the
// slots by rule (default, interpolation), an entry is computed by its owner from the mesh and the
// owner's parameters, and the owner keeps counters of the statuses it writes; the owner decides
// when an entry goes, so its destruction handlers always find the entry they are about to drop
// (and report a slot that was not in the table), and the renumbering happens exactly when the
// owner's handler runs (after which it drops caches indexed by entry). A table of its own kind
// of renumbering is one call in the owner's handler: table.renumber(r, problems).
//
// Traits (a complete type):
//   Status                              an enum for slots without an entry, values below 16
//   static constexpr Status kEmpty      what a dead, new or out-of-range slot holds
//   static constexpr bool kHasFlag      one flag bit per entry
//   static constexpr std::string_view kNoun, kNouns   the entries' name in messages
//   template <class F> static void forEachPoint(Entry&, F&& f)   f(std::uint32_t&) on every
//                                       point id the entry stores
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "cutsim/base/archive.hpp"
#include "cutsim/topology/events.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::topology {

template <class IdT, class Entry, class Traits>
class DenseSlotTable {
  static_assert(std::is_same_v<IdT, PointId> || std::is_same_v<IdT, EdgeId> ||
                std::is_same_v<IdT, TriangleId>);

 public:
  using Status = typename Traits::Status;
  static constexpr bool kHasFlag = Traits::kHasFlag;
  /// find(): no entry.
  static constexpr Index kNoEntry = kInvalidIndex;
  /// Slot ids from here on do not fit the table (the flag bit, or the status codes).
  static constexpr Index kSlotLimit = kHasFlag ? 0x80000000u : 0xFFFFFFF0u;

  DenseSlotTable() = default;

  // ---- size ----
  /// Every slot empty, `slots` of them; reserves a quarter more than `slots` slots and
  /// `expectedEntries` entries, as the topology reserves (later growth is geometric).
  void reset(std::size_t slots, std::size_t expectedEntries) {
    ++revision_;
    entries_.clear();
    slotOfEntry_.clear();
    indexOfSlot_.clear();
    indexOfSlot_.reserve(slots + slots / 4);
    indexOfSlot_.assign(slots, encode(Traits::kEmpty));
    entries_.reserve(expectedEntries + expectedEntries / 4);
    slotOfEntry_.reserve(expectedEntries + expectedEntries / 4);
  }
  /// Grows the slot index to the topology's capacity of IdT's kind (new slots empty).
  void grow(const Topology& t) { growTo(capacity(t)); }
  void growTo(std::size_t slots) {
    if (indexOfSlot_.size() < slots) indexOfSlot_.resize(slots, encode(Traits::kEmpty));
  }

  // ---- reading ----
  std::size_t size() const { return entries_.size(); }
  /// Counts the changes to the entries (set, setStatus, renumbering, reset, load): what a cache
  /// derived from them (a split of the entries for threads) compares to know it is stale.
  std::uint64_t revision() const { return revision_; }
  std::size_t numSlots() const { return indexOfSlot_.size(); }
  /// The entries, compact (their order changes with removals and renumbering).
  std::span<const Entry> entries() const { return entries_; }
  const Entry& entry(std::size_t i) const { return entries_[i]; }
  IdT slotOf(std::size_t i) const { return IdT(slotOfEntry_[i] & kSlotMask); }
  bool flag(std::size_t i) const { return (slotOfEntry_[i] & kFlagBit) != 0; }
  /// The index of slot id's entry, or kNoEntry (none, or beyond the table).
  Index find(IdT id) const {
    if (id.idx() >= indexOfSlot_.size()) return kNoEntry;
    const Index code = indexOfSlot_[id.idx()];
    return isEntry(code) ? code : kNoEntry;
  }
  bool hasEntry(IdT id) const { return find(id) != kNoEntry; }
  /// The status of slot id if it has no entry (kEmpty beyond the table); undefined with one.
  Status status(IdT id) const {
    if (id.idx() >= indexOfSlot_.size()) return Traits::kEmpty;
    return decode(indexOfSlot_[id.idx()]);
  }
  /// Neither an entry nor a status other than kEmpty.
  bool isEmpty(IdT id) const {
    return id.idx() >= indexOfSlot_.size() || indexOfSlot_[id.idx()] == encode(Traits::kEmpty);
  }

  // ---- writing ----
  /// Slot id holds `entry` (with `flag`): replaced in place if it had one, else appended (the
  /// slot index grows to id + 1 if needed). Returns the entry's index.
  Index set(IdT id, const Entry& value, bool flagged = false) {
    const Index s = id.idx();
    if (s >= kSlotLimit)
      throw std::length_error(std::string(Traits::kNoun) + " table: id too large");
    growTo(std::size_t(s) + 1);
    ++revision_;
    const Index back = s | (flagged && kHasFlag ? kFlagBit : 0u);
    const Index code = indexOfSlot_[s];
    if (isEntry(code)) {
      entries_[code] = value;
      slotOfEntry_[code] = back;
      return code;
    }
    if (entries_.size() >= kStatusBase) {
      throw std::length_error("too many " + std::string(Traits::kNouns));
    }
    const Index i = static_cast<Index>(entries_.size());
    indexOfSlot_[s] = i;
    entries_.push_back(value);
    slotOfEntry_.push_back(back);
    return i;
  }
  /// Slot id holds status s and no entry: its entry, if any, is removed (the last entry moves
  /// into the hole). The slot index grows to id + 1 if needed.
  void setStatus(IdT id, Status st) {
    assert(static_cast<unsigned>(st) < 16u);
    const Index s = id.idx();
    if (s >= kSlotLimit)
      throw std::length_error(std::string(Traits::kNoun) + " table: id too large");
    growTo(std::size_t(s) + 1);
    ++revision_;
    const Index code = indexOfSlot_[s];
    if (isEntry(code)) removeEntry(code);
    indexOfSlot_[s] = encode(st);
  }

  // ---- renumbering ----
  /// Points renumbered: every point id the entries store mapped old -> new. An id without a new
  /// index (a dead point) is left as it was and reported to `problems`.
  void remapPoints(const Renumbering& r, std::vector<std::string>& problems) {
    const std::span<const Index> map = r.oldToNew;
    ++revision_;
    for (Entry& e : entries_) {
      Traits::forEachPoint(e, [&](std::uint32_t& p) {
        const Index n = p < map.size() ? map[p] : kInvalidIndex;
        if (n == kInvalidIndex) {
          problems.push_back("points renumbered: a " + std::string(Traits::kNoun) +
                             " references dead point " + std::to_string(p));
        } else {
          p = n;
        }
      });
    }
  }
  /// IdT's kind renumbered: slots move old -> new, the entries are re-laid out in the new slot
  /// order. A non-empty slot without a new index is dropped and reported to `problems`.
  void renumber(const Renumbering& r, std::vector<std::string>& problems) {
    ++revision_;
    std::vector<Index> slots(r.newSize, encode(Traits::kEmpty));
    for (std::size_t old = 0; old < indexOfSlot_.size(); ++old) {
      const Index n = old < r.oldToNew.size() ? r.oldToNew[old] : kInvalidIndex;
      if (n == kInvalidIndex || n >= r.newSize) {
        if (indexOfSlot_[old] != encode(Traits::kEmpty)) {
          problems.push_back(std::string(kindName()) + "s renumbered: live " +
                             slotName(static_cast<Index>(old)) + " has no new index");
        }
        continue;
      }
      slots[n] = indexOfSlot_[old];
    }
    std::vector<Entry> laidOut;
    std::vector<Index> back;
    laidOut.reserve(entries_.size());
    back.reserve(entries_.size());
    for (Index s = 0; s < slots.size(); ++s) {
      if (!isEntry(slots[s])) continue;
      const Index old = slots[s];
      slots[s] = static_cast<Index>(laidOut.size());
      laidOut.push_back(entries_[old]);
      back.push_back(s | (slotOfEntry_[old] & kFlagBit));
    }
    if (laidOut.size() != entries_.size()) {
      problems.push_back(std::string(kindName()) + "s renumbered: " + std::string(Traits::kNouns) +
                         " lost with their " + std::string(kindName()) + "s");
    }
    entries_ = std::move(laidOut);
    slotOfEntry_ = std::move(back);
    indexOfSlot_ = std::move(slots);
  }

  // ---- accounting and checks ----
  /// Bytes held per slot (sizes, not capacities): sizeof(Entry) + 4 per entry, 4 per slot.
  /// Checkpoints: the entries, their slots and the slot index exactly as stored (the entries'
  /// order is the order of every sum over them).
  void save(ArchiveWriter& out) const {
    static_assert(std::is_trivially_copyable_v<Entry>);
    fields(out, entries_, slotOfEntry_, indexOfSlot_);
  }
  /// Reads what save() wrote; refuses (ArchiveReader::fail) a table whose entries, back-references
  /// and slot index do not agree.
  void load(ArchiveReader& in) {
    std::vector<Entry> entries;
    std::vector<Index> back, slots;
    fields(in, entries, back, slots);
    ++revision_;
    if (entries.size() >= kStatusBase)
      in.fail(std::string(Traits::kNoun) + " table: " + std::to_string(entries.size()) +
              " entries");
    entries_ = std::move(entries);
    slotOfEntry_ = std::move(back);
    indexOfSlot_ = std::move(slots);
    std::vector<std::string> problems;
    checkConsistency(problems, "");
    if (!problems.empty()) in.fail(std::string(Traits::kNoun) + " table: " + problems.front());
  }

  double bytesPerSlot() const {
    if (indexOfSlot_.empty()) return 0.0;
    const double bytes = static_cast<double>(entries_.size() * (sizeof(Entry) + sizeof(Index)) +
                                             indexOfSlot_.size() * sizeof(Index));
    return bytes / static_cast<double>(indexOfSlot_.size());
  }
  /// The table's own consistency (`who` prefixes every message): the entries and the slot index
  /// point at each other, every entry's slot is its only one.
  void checkConsistency(std::vector<std::string>& problems, std::string_view who) const {
    if (entries_.size() != slotOfEntry_.size()) {
      problems.push_back(std::string(who) + std::string(Traits::kNouns) +
                         " and their back-references differ in size");
      return;
    }
    for (std::size_t i = 0; i < entries_.size(); ++i) {
      const Index s = slotOfEntry_[i] & kSlotMask;
      if (s >= indexOfSlot_.size() || indexOfSlot_[s] != i) {
        problems.push_back(std::string(who) + std::string(Traits::kNoun) + " " + std::to_string(i) +
                           " of " + slotName(s) + " is not what the slot index points to");
      }
    }
    std::size_t withEntry = 0;
    for (const Index code : indexOfSlot_) {
      if (!isEntry(code)) continue;
      ++withEntry;
      if (code >= entries_.size()) {
        problems.push_back(std::string(who) + "a slot points past the " +
                           std::string(Traits::kNouns));
      }
    }
    if (withEntry != entries_.size()) {
      problems.push_back(std::string(who) + std::to_string(withEntry) + " slots hold " +
                         std::to_string(entries_.size()) + " " + std::string(Traits::kNouns));
    }
  }
  /// checkConsistency, plus against the topology: a slot per slot of its capacity, a live slot
  /// never empty and a dead one always empty, entries on live points only.
  void validate(const Topology& t, std::vector<std::string>& problems, std::string_view who) const {
    const std::size_t before = problems.size();
    checkConsistency(problems, who);
    if (problems.size() != before) return;
    if (indexOfSlot_.size() < capacity(t)) {
      problems.push_back(std::string(who) + "the table has " + std::to_string(indexOfSlot_.size()) +
                         " " + kindName() + " slots, the topology " + std::to_string(capacity(t)));
    }
    for (Index s = 0; s < indexOfSlot_.size(); ++s) {
      const bool alive = s < capacity(t) && isAlive(t, s);
      const bool inTable = indexOfSlot_[s] != encode(Traits::kEmpty);
      if (alive != inTable) {
        problems.push_back(
            std::string(who) + slotName(s) +
            (alive ? " is alive but not in the table" : " is dead but in the table"));
      }
    }
    const Index points = t.pointCapacity();
    for (std::size_t i = 0; i < entries_.size(); ++i) {
      Entry e = entries_[i];
      Traits::forEachPoint(e, [&](std::uint32_t& p) {
        if (p >= points || !t.isPointAlive(PointId(p))) {
          problems.push_back(std::string(who) + std::string(Traits::kNoun) + " of " +
                             slotName(slotOfEntry_[i] & kSlotMask) + " references dead point " +
                             std::to_string(p));
        }
      });
    }
  }

 private:
  static constexpr Index kStatusBase = 0xFFFFFFF0u;
  static constexpr Index kFlagBit = kHasFlag ? 0x80000000u : 0u;
  static constexpr Index kSlotMask = ~kFlagBit;

  static constexpr Index encode(Status s) { return kStatusBase + static_cast<Index>(s); }
  static constexpr bool isEntry(Index code) { return code < kStatusBase; }
  static constexpr Status decode(Index code) { return static_cast<Status>(code - kStatusBase); }

  static constexpr const char* kindName() {
    if constexpr (std::is_same_v<IdT, PointId>)
      return "point";
    else if constexpr (std::is_same_v<IdT, EdgeId>)
      return "edge";
    else
      return "triangle";
  }
  static std::string slotName(Index s) { return std::string(kindName()) + " " + std::to_string(s); }
  static std::size_t capacity(const Topology& t) {
    if constexpr (std::is_same_v<IdT, PointId>)
      return t.pointCapacity();
    else if constexpr (std::is_same_v<IdT, EdgeId>)
      return t.edgeCapacity();
    else
      return t.triangleCapacity();
  }
  static bool isAlive(const Topology& t, Index s) {
    if constexpr (std::is_same_v<IdT, PointId>)
      return t.isPointAlive(PointId(s));
    else if constexpr (std::is_same_v<IdT, EdgeId>)
      return t.isEdgeAlive(EdgeId(s));
    else
      return t.isTriangleAlive(TriangleId(s));
  }

  void removeEntry(Index i) {
    const Index last = static_cast<Index>(entries_.size() - 1);
    if (i != last) {
      entries_[i] = entries_[last];
      slotOfEntry_[i] = slotOfEntry_[last];
      indexOfSlot_[slotOfEntry_[i] & kSlotMask] = i;
    }
    entries_.pop_back();
    slotOfEntry_.pop_back();
  }

  // Hot: the entries, streamed by every pass of the owner.
  std::vector<Entry> entries_;
  std::vector<Index> slotOfEntry_;
  std::vector<Index> indexOfSlot_;
  std::uint64_t revision_ = 0;  // (not saved: nothing derived from it is)
};

}  // namespace cutsim::topology
