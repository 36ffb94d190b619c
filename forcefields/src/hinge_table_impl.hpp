#pragma once
// The member functions of detail::HingeTable (cutsim/forcefields/detail/hinge_table.hpp), and the
// helpers the bending fields share to compute a hinge from the mesh. Included by the .cpp of each
// field, which instantiates the table explicitly for itself.
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "cutsim/forcefields/detail/hinge_table.hpp"

namespace cutsim::forcefields::detail {

inline std::string edgeName(topology::EdgeId e) {
  return "edge " + std::to_string(e);
}

/// The hinge of edge e: A, B (the vertices opposite e in edgeTriangles(e)[0] and [1]), C, D
/// (edgeVertices(e)); nothing for an edge with fewer than two triangles.
inline std::optional<std::array<topology::PointId, 4>> hingeVertices(const topology::Topology& t,
                                                                    topology::EdgeId e) {
  const std::array<topology::TriangleId, 2> tris = t.edgeTriangles(e);
  if (tris[0] == topology::kInvalidIndex || tris[1] == topology::kInvalidIndex) {
    return std::nullopt;
  }
  const topology::EdgeVertices ev = t.edgeVertices(e);
  return std::array<topology::PointId, 4>{t.oppositeVertex(tris[0], e),
                                          t.oppositeVertex(tris[1], e), ev[0], ev[1]};
}

/// One record per live edge of `t`, ascending id: make(e) for each.
template <class MakeRecord>
auto recordPerLiveEdge(const topology::Topology& t, MakeRecord make) {
  std::vector<decltype(make(topology::EdgeId{}))> records;
  const std::vector<topology::EdgeId> edges = t.edges();
  records.reserve(edges.size());
  for (topology::EdgeId e : edges) records.push_back(make(e));
  return records;
}

// ---------------------------------------------------------------------------------------------
// The table

template <class F, class T>
bool HingeTable<F, T>::flagOf(const Record& r) {
  if constexpr (kHasFlag) {
    return r.*T::kFlag;
  } else {
    return false;
  }
}

template <class F, class T>
void HingeTable<F, T>::countStatus(Counters& c, Status s, int delta) {
  if (const auto counter = T::counter(s)) {
    c.*counter = static_cast<std::size_t>(static_cast<long long>(c.*counter) + delta);
  }
}

template <class F, class T>
void HingeTable<F, T>::countFlag(Counters& c, int delta) {
  if constexpr (kHasFlag) {
    c.*T::kFlagCounter =
        static_cast<std::size_t>(static_cast<long long>(c.*T::kFlagCounter) + delta);
  }
}

template <class F, class T>
void HingeTable<F, T>::attach(topology::Topology& topology) {
  const std::vector<Record> records = F::buildFromScratch(topology, field().parameters());
  edgeSlot_.reserve(std::size_t(topology.edgeCapacity()) * 5 / 4);
  edgeSlot_.assign(topology.edgeCapacity(), encode(Status::DeadEdge));
  std::size_t active = 0;
  for (const Record& r : records) active += r.status == Status::Active ? 1 : 0;
  // A quarter more than the mesh has, as the topology reserves: the first cuts add entries
  // without copying the table (later growth is geometric, by push_back).
  entries_.reserve(active + active / 4);
  entryEdge_.reserve(active + active / 4);
  for (const Record& r : records) setEdge(r.edge, r);
  subscription_ = topology.subscribe(*this);
}

template <class F, class T>
void HingeTable<F, T>::ensureEdgeSlots(std::size_t n) {
  if (edgeSlot_.size() < n) edgeSlot_.resize(n, encode(Status::DeadEdge));
}

template <class F, class T>
void HingeTable<F, T>::removeEntry(std::uint32_t slot) {
  if (entryEdge_[slot] & kFlagBit) countFlag(counters_, -1);
  const std::uint32_t last = static_cast<std::uint32_t>(entries_.size() - 1);
  if (slot != last) {
    entries_[slot] = entries_[last];
    entryEdge_[slot] = entryEdge_[last];
    edgeSlot_[entryEdge_[slot] & kEdgeMask] = slot;
  }
  entries_.pop_back();
  entryEdge_.pop_back();
}

template <class F, class T>
void HingeTable<F, T>::setEdge(topology::EdgeId e, const Record& r) {
  if (e >= kEdgeLimit) throw std::length_error(std::string(T::kName) + ": edge id too large");
  ensureEdgeSlots(static_cast<std::size_t>(e) + 1);
  const std::uint32_t old = edgeSlot_[e];
  const bool wasActive = isEntrySlot(old);
  countStatus(counters_, wasActive ? Status::Active : decode(old), -1);
  countStatus(counters_, r.status, +1);
  if (r.status != Status::Active) {
    if (wasActive) removeEntry(old);
    edgeSlot_[e] = encode(r.status);
    return;
  }
  const Entry entry = F::toEntry(r);
  const bool flag = flagOf(r);
  const std::uint32_t edgeCode = e | (flag ? kFlagBit : 0u);
  if (flag) countFlag(counters_, +1);
  if (wasActive) {
    if (entryEdge_[old] & kFlagBit) countFlag(counters_, -1);
    entries_[old] = entry;
    entryEdge_[old] = edgeCode;
    return;
  }
  if (entries_.size() >= kStatusBase) {
    throw std::length_error(std::string(T::kName) + ": too many " + std::string(T::kNouns));
  }
  edgeSlot_[e] = static_cast<std::uint32_t>(entries_.size());
  entries_.push_back(entry);
  entryEdge_.push_back(edgeCode);
}

template <class F, class T>
void HingeTable<F, T>::setEdgeWithoutHinge(topology::EdgeId e, Status s) {
  Record r;
  r.edge = e;
  r.status = s;
  setEdge(e, r);
}

template <class F, class T>
void HingeTable<F, T>::recomputeEdge(const topology::Topology& t, topology::EdgeId e) {
  if (!t.isEdgeAlive(e)) return;  // its destruction event follows
  setEdge(e, F::hingeFromMesh(t, e, field().parameters()));
}

template <class F, class T>
auto HingeTable<F, T>::hinge(topology::EdgeId e) const -> Record {
  Record r;
  r.edge = e;
  if (e >= edgeSlot_.size()) {
    r.status = Status::DeadEdge;
    return r;
  }
  const std::uint32_t code = edgeSlot_[e];
  if (!isEntrySlot(code)) {
    r.status = decode(code);
    return r;
  }
  return entryRecord(code);
}

template <class F, class T>
auto HingeTable<F, T>::entryRecord(std::size_t i) const -> Record {
  Record r;
  r.edge = entryEdge_[i] & kEdgeMask;
  r.status = Status::Active;
  if constexpr (kHasFlag) r.*T::kFlag = (entryEdge_[i] & kFlagBit) != 0;
  field().fillRecord(entries_[i], r);
  return r;
}

template <class F, class T>
auto HingeTable<F, T>::liveRecords() const -> std::vector<Record> {
  std::vector<Record> out;
  for (topology::EdgeId e = 0; e < edgeSlot_.size(); ++e) {
    if (edgeSlot_[e] != encode(Status::DeadEdge)) out.push_back(hinge(e));
  }
  return out;
}

template <class F, class T>
double HingeTable<F, T>::bytesPerEdgeSlot() const {
  if (edgeSlot_.empty()) return 0.0;
  const double bytes = static_cast<double>(entries_.size() * sizeof(Entry) +
                                           entryEdge_.size() * sizeof(std::uint32_t) +
                                           edgeSlot_.size() * sizeof(std::uint32_t));
  return bytes / static_cast<double>(edgeSlot_.size());
}

// ---------------------------------------------------------------------------------------------
// Topology events. Handlers see the mesh in its final state (docs/topology-events.md).

template <class F, class T>
void HingeTable<F, T>::onTrianglesDestroyed(const topology::Topology& t,
                                            const topology::TrianglesDestroyed& ev) {
  // Each surviving edge of a removed triangle: recompute from the triangles it has now.
  for (const topology::TriangleEdges& te : ev.edges) {
    for (topology::EdgeId e : te) recomputeEdge(t, e);
  }
}

template <class F, class T>
void HingeTable<F, T>::onEdgesDestroyed(const topology::Topology&,
                                        const topology::EdgesDestroyed& ev) {
  for (topology::EdgeId e : ev.edges) {
    if (e >= edgeSlot_.size() || edgeSlot_[e] == encode(Status::DeadEdge)) {
      eventProblems_.push_back("edges destroyed: " + edgeName(e) + " was not in the table");
      continue;
    }
    setEdgeWithoutHinge(e, Status::DeadEdge);
  }
}

template <class F, class T>
void HingeTable<F, T>::onEdgesCreated(const topology::Topology& t,
                                      const topology::EdgesCreated& ev) {
  ensureEdgeSlots(t.edgeCapacity());
  for (topology::EdgeId e : ev.edges) {
    if (edgeSlot_[e] != encode(Status::DeadEdge)) {
      eventProblems_.push_back("edges created: " + edgeName(e) + " was already in the table");
    }
    setEdgeWithoutHinge(e, Status::NoHinge);
  }
}

template <class F, class T>
void HingeTable<F, T>::onTrianglesCreated(const topology::Topology& t,
                                          const topology::TrianglesCreated& ev) {
  ensureEdgeSlots(t.edgeCapacity());
  for (const topology::TriangleEdges& te : ev.edges) {
    for (topology::EdgeId e : te) recomputeEdge(t, e);
  }
}

template <class F, class T>
void HingeTable<F, T>::onPointsRenumbered(const topology::Topology&,
                                          const topology::Renumbering& ev) {
  const std::span<const topology::Index> map = ev.oldToNew;
  for (Entry& entry : entries_) {
    for (std::uint32_t& v : entry.v) {
      const topology::Index n = v < map.size() ? map[v] : topology::kInvalidIndex;
      if (n == topology::kInvalidIndex) {
        eventProblems_.push_back("points renumbered: a " + std::string(T::kNoun) +
                                 " references dead point " + std::to_string(v));
      } else {
        v = n;
      }
    }
  }
}

template <class F, class T>
void HingeTable<F, T>::onEdgesRenumbered(const topology::Topology&,
                                         const topology::Renumbering& ev) {
  // Entries move old -> new with their edges; the entries are re-laid out in the new edge order,
  // which restores the streaming locality of a fresh mesh.
  std::vector<std::uint32_t> slots(ev.newSize, encode(Status::DeadEdge));
  for (std::size_t old = 0; old < edgeSlot_.size(); ++old) {
    const topology::Index n = old < ev.oldToNew.size() ? ev.oldToNew[old] : topology::kInvalidIndex;
    if (n == topology::kInvalidIndex || n >= ev.newSize) {
      if (edgeSlot_[old] != encode(Status::DeadEdge)) {
        eventProblems_.push_back("edges renumbered: live " +
                                 edgeName(static_cast<topology::EdgeId>(old)) +
                                 " has no new index");
      }
      continue;
    }
    slots[n] = edgeSlot_[old];
  }
  std::vector<Entry> entries;
  std::vector<std::uint32_t> entryEdge;
  entries.reserve(entries_.size());
  entryEdge.reserve(entries_.size());
  for (topology::EdgeId e = 0; e < slots.size(); ++e) {
    if (!isEntrySlot(slots[e])) continue;
    const std::uint32_t old = slots[e];
    slots[e] = static_cast<std::uint32_t>(entries.size());
    entries.push_back(entries_[old]);
    entryEdge.push_back(e | (entryEdge_[old] & kFlagBit));
  }
  if (entries.size() != entries_.size()) {
    eventProblems_.push_back("edges renumbered: " + std::string(T::kNouns) +
                             " lost with their edges");
  }
  entries_ = std::move(entries);
  entryEdge_ = std::move(entryEdge);
  edgeSlot_ = std::move(slots);
  // Counters follow what is left.
  Counters c;
  for (const std::uint32_t code : edgeSlot_) {
    if (isEntrySlot(code)) {
      countStatus(c, Status::Active, +1);
      if (entryEdge_[code] & kFlagBit) countFlag(c, +1);
    } else {
      countStatus(c, decode(code), +1);
    }
  }
  counters_ = c;
}

// ---------------------------------------------------------------------------------------------
// Validation: the incremental table against a rebuild from scratch.

template <class F, class T>
void HingeTable<F, T>::validate(const topology::Topology& topology,
                                std::vector<std::string>& problems) const {
  const std::string who = std::string(T::kName) + ": ";
  const std::string noun(T::kNoun), nouns(T::kNouns);
  const std::size_t problemsBefore = problems.size();
  for (const std::string& p : eventProblems_) problems.push_back(who + p);

  // Internal consistency of the compact array and the edge map.
  if (entries_.size() != entryEdge_.size()) {
    problems.push_back(who + nouns + " and their edge back-references differ in size");
    return;
  }
  for (std::size_t s = 0; s < entries_.size(); ++s) {
    const std::uint32_t e = entryEdge_[s] & kEdgeMask;
    if (e >= edgeSlot_.size() || edgeSlot_[e] != s) {
      problems.push_back(who + noun + " " + std::to_string(s) + " of " + edgeName(e) +
                         " is not what the edge map points to");
    }
  }
  if (edgeSlot_.size() < topology.edgeCapacity()) {
    problems.push_back(who + "the table has " + std::to_string(edgeSlot_.size()) +
                       " edge slots, the topology " + std::to_string(topology.edgeCapacity()));
  }
  for (topology::EdgeId e = 0; e < edgeSlot_.size(); ++e) {
    const bool alive = e < topology.edgeCapacity() && topology.isEdgeAlive(e);
    const bool inTable = edgeSlot_[e] != encode(Status::DeadEdge);
    if (alive != inTable) {
      problems.push_back(who + edgeName(e) +
                         (alive ? " is alive but dead in the table"
                                : std::string(T::kDeadButInTable)));
    }
  }

  // Against the rebuild.
  const std::vector<Record> ref = F::buildFromScratch(topology, field().parameters());
  Counters refCounters;
  for (const Record& r : ref) {
    countStatus(refCounters, r.status, +1);
    if (r.status == Status::Active && flagOf(r)) countFlag(refCounters, +1);
    const Record mine = hinge(r.edge);
    if (!F::sameHinge(mine, r)) {
      problems.push_back(who + "table has " + F::describe(mine) + ", a rebuild gives " +
                         F::describe(r));
    }
  }
  if (!(refCounters == counters_)) {
    constexpr auto active = T::counter(Status::Active);
    std::string message = who + "counters differ from a rebuild (active " +
                          std::to_string(counters_.*active) + " vs " +
                          std::to_string(refCounters.*active) + ", degenerate " +
                          std::to_string(counters_.degenerate()) + " vs " +
                          std::to_string(refCounters.degenerate());
    if constexpr (kHasFlag) {
      message += ", " + std::string(T::kFlagName) + " " +
                 std::to_string(counters_.*T::kFlagCounter) + " vs " +
                 std::to_string(refCounters.*T::kFlagCounter);
    }
    problems.push_back(message + ")");
  }
  if constexpr (T::kChecksEntryCount) {
    const std::size_t refActive = refCounters.*T::counter(Status::Active);
    if (entries_.size() != refActive) {
      problems.push_back(who + std::to_string(entries_.size()) + " active " + nouns +
                         ", a rebuild has " + std::to_string(refActive));
    }
  }

  // Entries must reference live points only, then the same forces on the field's positions.
  const topology::Index cap = topology.pointCapacity();
  for (std::size_t s = 0; s < entries_.size(); ++s) {
    for (std::uint32_t v : entries_[s].v) {
      if (v >= cap || !topology.isPointAlive(v)) {
        problems.push_back(who + noun + " of " + edgeName(entryEdge_[s] & kEdgeMask) +
                           " references dead point " + std::to_string(v));
      }
    }
  }
  if (problems.size() != problemsBefore) return;
  std::vector<double> x(3 * static_cast<std::size_t>(cap), 0.0);
  field().fillValidationPositions(topology, x);
  std::vector<double> f(x.size(), 0.0), fRef(x.size(), 0.0);
  field().addTableForces(x, f);
  F::addForceOfRecords(ref, x, fRef);
  double scale = 0.0, diff = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    scale = std::max(scale, std::fabs(fRef[i]));
    diff = std::max(diff, std::fabs(f[i] - fRef[i]));
  }
  if (diff > 1e-10 * std::max(scale, 1e-300)) {
    std::ostringstream os;
    os.precision(3);
    os << who << "forces on a random x differ from a rebuild's by " << diff << " (max force "
       << scale << ")";
    problems.push_back(os.str());
  }
}

}  // namespace cutsim::forcefields::detail
