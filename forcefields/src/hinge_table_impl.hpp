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
  return "edge " + std::to_string(e.idx());
}

/// The hinge of edge e: A, B (the vertices opposite e in edgeTriangles(e)[0] and [1]), C, D
/// (edgeVertices(e)); nothing for an edge with fewer than two triangles.
inline std::optional<std::array<topology::PointId, 4>> hingeVertices(const topology::Topology& t,
                                                                     topology::EdgeId e) {
  const std::array<topology::TriangleId, 2> tris = t.edgeTriangles(e);
  if (tris[0].idx() == topology::kInvalidIndex || tris[1].idx() == topology::kInvalidIndex) {
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
void HingeTable<F, T>::saveTable(ArchiveWriter& out) const {
  table_.save(out);
}

template <class F, class T>
void HingeTable<F, T>::loadTable(ArchiveReader& in, const topology::Topology& topology) {
  table_.load(in);
  counters_ = recount();
  eventProblems_.clear();
  std::vector<std::string> problems;
  validate(topology, problems);
  if (!problems.empty()) in.fail(field().typeName() + ": " + problems.front());
}

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
  std::size_t active = 0;
  for (const Record& r : records) active += r.status == Status::Active ? 1 : 0;
  table_.reset(topology.edgeCapacity(), active);
  for (const Record& r : records) setEdge(r.edge, r);
  subscription_ = topology.subscribe(*this);
}

template <class F, class T>
void HingeTable<F, T>::setEdge(topology::EdgeId e, const Record& r) {
  if (e.idx() >= Table::kSlotLimit) {
    throw std::length_error(std::string(T::kName) + ": edge id too large");
  }
  const topology::Index old = table_.find(e);
  const bool wasActive = old != Table::kNoEntry;
  countStatus(counters_, wasActive ? Status::Active : table_.status(e), -1);
  if (wasActive && table_.flag(old)) countFlag(counters_, -1);
  countStatus(counters_, r.status, +1);
  if (r.status != Status::Active) {
    table_.setStatus(e, r.status);  // an entry it had is removed (the last one fills the hole)
    return;
  }
  const bool flag = flagOf(r);
  if (flag) countFlag(counters_, +1);
  table_.set(e, F::toEntry(r), flag);  // in place if it had one, else appended
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
  const topology::Index i = table_.find(e);
  if (i != Table::kNoEntry) return entryRecord(i);
  Record r;
  r.edge = e;
  r.status = table_.status(e);  // DeadEdge beyond the table
  return r;
}

template <class F, class T>
auto HingeTable<F, T>::entryRecord(std::size_t i) const -> Record {
  Record r;
  r.edge = table_.slotOf(i);
  r.status = Status::Active;
  if constexpr (kHasFlag) r.*T::kFlag = table_.flag(i);
  field().fillRecord(table_.entry(i), r);
  return r;
}

template <class F, class T>
auto HingeTable<F, T>::liveRecords() const -> std::vector<Record> {
  std::vector<Record> out;
  for (topology::EdgeId e{0}; e.idx() < table_.numSlots(); ++e) {
    if (!table_.isEmpty(e)) out.push_back(hinge(e));
  }
  return out;
}

template <class F, class T>
auto HingeTable<F, T>::recount() const -> Counters {
  Counters c;
  for (topology::EdgeId e{0}; e.idx() < table_.numSlots(); ++e) {
    const topology::Index i = table_.find(e);
    if (i != Table::kNoEntry) {
      countStatus(c, Status::Active, +1);
      if (table_.flag(i)) countFlag(c, +1);
    } else {
      countStatus(c, table_.status(e), +1);
    }
  }
  return c;
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
    if (table_.isEmpty(e)) {
      eventProblems_.push_back("edges destroyed: " + edgeName(e) + " was not in the table");
      continue;
    }
    setEdgeWithoutHinge(e, Status::DeadEdge);
  }
}

template <class F, class T>
void HingeTable<F, T>::onEdgesCreated(const topology::Topology& t,
                                      const topology::EdgesCreated& ev) {
  table_.grow(t);
  for (topology::EdgeId e : ev.edges) {
    if (!table_.isEmpty(e)) {
      eventProblems_.push_back("edges created: " + edgeName(e) + " was already in the table");
    }
    setEdgeWithoutHinge(e, Status::NoHinge);
  }
}

template <class F, class T>
void HingeTable<F, T>::onTrianglesCreated(const topology::Topology& t,
                                          const topology::TrianglesCreated& ev) {
  table_.grow(t);
  for (const topology::TriangleEdges& te : ev.edges) {
    for (topology::EdgeId e : te) recomputeEdge(t, e);
  }
}

template <class F, class T>
void HingeTable<F, T>::onPointsRenumbered(const topology::Topology&,
                                          const topology::Renumbering& ev) {
  table_.remapPoints(ev, eventProblems_);
}

template <class F, class T>
void HingeTable<F, T>::onEdgesRenumbered(const topology::Topology&,
                                         const topology::Renumbering& ev) {
  // Entries move old -> new with their edges and are re-laid out in the new edge order, which
  // restores the streaming locality of a fresh mesh; the counters follow what is left.
  table_.renumber(ev, eventProblems_);
  counters_ = recount();
}

// ---------------------------------------------------------------------------------------------
// Validation: the incremental table against a rebuild from scratch.

template <class F, class T>
void HingeTable<F, T>::validate(const topology::Topology& topology,
                                std::vector<std::string>& problems) const {
  const std::string who = std::string(T::kName) + ": ";
  const std::string nouns(T::kNouns);
  const std::size_t problemsBefore = problems.size();
  for (const std::string& p : eventProblems_) problems.push_back(who + p);

  // The table's own consistency, the live edges against its slots, entries on live points only.
  table_.validate(topology, problems, who);

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
    std::string message =
        who + "counters differ from a rebuild (active " + std::to_string(counters_.*active) +
        " vs " + std::to_string(refCounters.*active) + ", degenerate " +
        std::to_string(counters_.degenerate()) + " vs " + std::to_string(refCounters.degenerate());
    if constexpr (kHasFlag) {
      message += ", " + std::string(T::kFlagName) + " " +
                 std::to_string(counters_.*T::kFlagCounter) + " vs " +
                 std::to_string(refCounters.*T::kFlagCounter);
    }
    problems.push_back(message + ")");
  }
  if constexpr (T::kChecksEntryCount) {
    const std::size_t refActive = refCounters.*T::counter(Status::Active);
    if (table_.size() != refActive) {
      problems.push_back(who + std::to_string(table_.size()) + " active " + nouns +
                         ", a rebuild has " + std::to_string(refActive));
    }
  }

  // Then the same forces on the field's positions.
  const topology::Index cap = topology.pointCapacity();
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
