#pragma once
// HingeTable: the per-edge hinge table of the bending force fields (FastTriangularBendingSprings,
// DihedralBending), maintained incrementally from the topology events. Internal: a field derives
// from it (CRTP) and keeps only what is its own: what an entry stores, how a hinge is computed
// from the mesh, and the force, energy and derivative kernels over entries().
//
// The table (docs/bending-springs.md, "The table") is a topology::DenseSlotTable over edges:
//   entries        the ACTIVE hinges, compact (no holes, no status test): what the passes stream;
//   entry -> edge  with the per-entry flag in its top bit (see kFlag);
//   edge -> entry  an entry index, or the status of an edge without an entry (DeadEdge: empty).
// Deactivation swaps the last entry into the hole (O(1)); edges renumbered re-lay the entries out
// in the new edge order (both the container's). The counters (per status, plus the flag) are
// this class's and follow every change.
//
// Events (docs/bending-springs.md, "Events"): triangles destroyed or created -> the hinges of
// their live edges recomputed from the mesh; edges destroyed -> DeadEdge; edges created ->
// NoHinge; points renumbered -> vertex ids mapped old -> new; edges renumbered -> re-layout and
// recount. Points destroyed need nothing: a point is destroyed only with all its triangles,
// whose events already recomputed every hinge around it (validate() checks it).
//
// Traits (a complete type, declared before the field) says what is stored and how it is named:
//   Entry     the stored hinge; has std::array<std::uint32_t, 4> v (A, B, C, D)
//   Record    the unfolded hinge; has edge, status, vertices (as HingeRecord)
//   Status    an enum with Active, NoHinge and DeadEdge (values below 16)
//   Counters  has degenerate() and operator==
//   static constexpr Counter counter(Status)  the counter of a status (nullptr: none)
//   kName, kNoun, kNouns                       the field's name, "spring", "springs" (messages)
//   kChecksEntryCount                          validate() also compares the number of entries
//   kFlag, kFlagCounter, kFlagName             the per-entry flag of Record, its counter, its
//                                              name in messages (nullptr: no flag)
// Field provides (members, private with `friend` for the table):
//   static Record hingeFromMesh(const Topology&, EdgeId, const Parameters&)
//   static std::vector<Record> buildFromScratch(const Topology&, const Parameters&)
//   static void addForceOfRecords(std::span<const Record>, std::span<const double> x,
//                                 std::span<double> f)
//   const Parameters& parameters() const
//   static Entry toEntry(const Record&)               (an active record)
//   void fillRecord(const Entry&, Record&) const      (the record's hinge data from an entry)
//   static bool sameHinge(const Record&, const Record&)
//   static std::string describe(const Record&)
//   void fillValidationPositions(const Topology&, std::span<double> x) const
//   void addTableForces(std::span<const double> x, std::span<double> f) const
//
// The member functions are defined in forcefields/src/hinge_table_impl.hpp and instantiated
// explicitly once per field in the field's .cpp (hence the `extern template` in its header).
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "cutsim/topology/dense_slot_table.hpp"
#include "cutsim/topology/events.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::forcefields::detail {

/// The DenseSlotTable traits of a hinge table: an entry per active hinge, the other statuses in
/// the edge index (DeadEdge for an empty slot), the flag of Traits in the entry's back reference.
template <class Traits>
struct HingeSlotTraits {
  using Status = typename Traits::Status;
  static constexpr Status kEmpty = Status::DeadEdge;
  static constexpr bool kHasFlag = Traits::kFlag != nullptr;
  static constexpr std::string_view kNoun = Traits::kNoun;
  static constexpr std::string_view kNouns = Traits::kNouns;
  template <class F>
  static void forEachPoint(typename Traits::Entry& e, F&& f) {
    for (std::uint32_t& v : e.v) f(v);
  }
};

template <class Field, class Traits>
class HingeTable : public topology::TopologyObserver {
 public:
  using Entry = typename Traits::Entry;
  using Record = typename Traits::Record;
  using Status = typename Traits::Status;
  using Counters = typename Traits::Counters;

  HingeTable(const HingeTable&) = delete;
  HingeTable& operator=(const HingeTable&) = delete;

  // ---- TopologyObserver ----
  void onTrianglesDestroyed(const topology::Topology&,
                            const topology::TrianglesDestroyed&) override;
  void onEdgesDestroyed(const topology::Topology&, const topology::EdgesDestroyed&) override;
  void onEdgesCreated(const topology::Topology&, const topology::EdgesCreated&) override;
  void onTrianglesCreated(const topology::Topology&, const topology::TrianglesCreated&) override;
  void onPointsRenumbered(const topology::Topology&, const topology::Renumbering&) override;
  void onEdgesRenumbered(const topology::Topology&, const topology::Renumbering&) override;
  std::string observerName() const override { return std::string(Traits::kName); }
  /// Compares the table with Field::buildFromScratch on `topology`: the compact array against the
  /// edge map, the live edges, the status of every edge and its hinge (Field::sameHinge), the
  /// counters, the live points of the entries, and the forces on Field's validation positions.
  void validate(const topology::Topology& topology,
                std::vector<std::string>& problems) const override;

  /// The record of edge e (status DeadEdge for a slot that is dead or beyond the table).
  Record hinge(topology::EdgeId e) const;
  /// The counters of the table (the current state, not a history).
  const Counters& counters() const { return counters_; }
  std::size_t numEdgeSlots() const { return table_.numSlots(); }

 protected:
  HingeTable() = default;
  ~HingeTable() override = default;

  /// Builds the table once from the current mesh and subscribes to `topology`.
  void attach(topology::Topology& topology);
  /// Checkpoints: the table as stored (its entries' order included).
  void saveTable(ArchiveWriter& out) const;
  /// Replaces the table by the saved one, its counters recounted; refuses (ArchiveReader::fail)
  /// a table that validate() finds wrong for `topology`.
  void loadTable(ArchiveReader& in, const topology::Topology& topology);
  /// The active entries, compact (their order changes with removals and compaction).
  std::span<const Entry> entries() const { return table_.entries(); }
  /// Changes with every change to the entries (DenseSlotTable::revision).
  std::uint64_t tableRevision() const { return table_.revision(); }
  /// The record of entry i (0 <= i < entries().size()).
  Record entryRecord(std::size_t i) const;
  /// Records of every live edge of the table, ascending edge id.
  std::vector<Record> liveRecords() const;
  /// Bytes held by the table per edge slot (sizes, not capacities).
  double bytesPerEdgeSlot() const { return table_.bytesPerSlot(); }

 private:
  using Table = topology::DenseSlotTable<topology::EdgeId, Entry, HingeSlotTraits<Traits>>;
  static constexpr bool kHasFlag = Traits::kFlag != nullptr;

  static bool flagOf(const Record& r);
  static void countStatus(Counters& c, Status s, int delta);
  static void countFlag(Counters& c, int delta);

  const Field& field() const { return static_cast<const Field&>(*this); }
  void setEdge(topology::EdgeId e, const Record& r);
  /// setEdge with a record of status s (NoHinge, DeadEdge): no entry.
  void setEdgeWithoutHinge(topology::EdgeId e, Status s);
  void recomputeEdge(const topology::Topology& t, topology::EdgeId e);
  /// The counters recomputed from the table.
  Counters recount() const;

  // The active entries (hot: streamed by every pass of the field), their edges (and flags), and
  // per edge slot an entry or a status.
  Table table_;
  Counters counters_;
  std::vector<std::string> eventProblems_;  // inconsistencies seen while handling events
  topology::Subscription subscription_;
};

}  // namespace cutsim::forcefields::detail
