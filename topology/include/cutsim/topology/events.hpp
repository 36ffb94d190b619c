#pragma once
// The nine topology events and the observer interface. The contract (order of delivery, what the
// mesh holds when each event is delivered, the index policy) is written in docs/topology-events.md;
// the short version is repeated here.
//
// One operation is one transaction. Its events are delivered after the mesh has reached its
// final state, in this order:
//   1. triangles destroyed   2. edges destroyed   3. points destroyed
//   4. points created        5. edges created     6. triangles created
//   7. transaction end
// Each list is sorted by ascending index; an empty list is not delivered. Renumbering events
// (points, then edges, then triangles, then transaction end) come only from compaction, which is
// a transaction of its own. Elements created and destroyed within one transaction are never
// announced. Destroyed indices are dead (not reused) until the next compaction.
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "cutsim/topology/types.hpp"

namespace cutsim::topology {

class Topology;

struct PointsCreated {
  std::span<const PointId> points;
  /// Interpolation of each new point: points[i] = sum_k weights[k] * ancestors[k] for k in
  /// [offsets[i], offsets[i+1]). Ancestors are always points that existed BEFORE the transaction
  /// (chains within a transaction are composed), so state vectors can be filled in any order. An
  /// ancestor may have been destroyed by the same transaction (a point relocated by the quality
  /// repair): its data must stay readable until the transaction ends (SlotData keeps it).
  /// A free point (addPoints) has no ancestors; its rest position is the topology's.
  std::span<const std::uint32_t> offsets;  ///< size points.size() + 1
  std::span<const PointId> ancestors;
  std::span<const double> weights;  ///< sum to 1 for each point that has ancestors
};

struct PointsDestroyed {
  std::span<const PointId> points;
};

struct EdgesCreated {
  std::span<const EdgeId> edges;
  std::span<const EdgeVertices> vertices;
};

struct EdgesDestroyed {
  std::span<const EdgeId> edges;
  std::span<const EdgeVertices> vertices;  ///< the endpoints the edge had
};

struct TrianglesCreated {
  std::span<const TriangleId> triangles;
  std::span<const TriangleVertices> vertices;  ///< counter-clockwise
  std::span<const TriangleEdges> edges;        ///< edges[i] is opposite vertices[i]
};

struct TrianglesDestroyed {
  std::span<const TriangleId> triangles;
  std::span<const TriangleVertices> vertices;  ///< what the triangle had
  std::span<const TriangleEdges> edges;        ///< what the triangle had (some may be dead now)
};

/// Compaction: oldToNew[old] is the new index of slot `old`, or kInvalidIndex for a dead slot.
/// New indices are dense: 0 .. newSize-1, in the order of the old ones.
struct Renumbering {
  std::span<const Index> oldToNew;
  Index newSize = 0;
};

/// What one transaction did, delivered last.
struct TransactionSummary {
  std::string_view operation;  ///< "addTriangles", "incise", "compact", ...
  std::size_t pointsCreated = 0, pointsDestroyed = 0;
  std::size_t edgesCreated = 0, edgesDestroyed = 0;
  std::size_t trianglesCreated = 0, trianglesDestroyed = 0;
  bool renumbered = false;
};

/// Observers follow the topology. Handlers receive the topology in its final state (see above)
/// and may query it, but must not modify it. Default handlers do nothing.
class TopologyObserver {
 public:
  virtual ~TopologyObserver() = default;

  virtual void onTrianglesDestroyed(const Topology&, const TrianglesDestroyed&) {}
  virtual void onEdgesDestroyed(const Topology&, const EdgesDestroyed&) {}
  virtual void onPointsDestroyed(const Topology&, const PointsDestroyed&) {}
  virtual void onPointsCreated(const Topology&, const PointsCreated&) {}
  virtual void onEdgesCreated(const Topology&, const EdgesCreated&) {}
  virtual void onTrianglesCreated(const Topology&, const TrianglesCreated&) {}
  virtual void onPointsRenumbered(const Topology&, const Renumbering&) {}
  virtual void onEdgesRenumbered(const Topology&, const Renumbering&) {}
  virtual void onTrianglesRenumbered(const Topology&, const Renumbering&) {}
  virtual void onTransactionEnd(const Topology&, const TransactionSummary&) {}

  /// A name for messages ("FastTriangularBendingSprings", "state", ...).
  virtual std::string observerName() const { return "observer"; }

  /// Appends to `problems` every way in which this observer's tables disagree with `topology`
  /// (typically by comparing with a from-scratch rebuild). Called by Topology::validate().
  virtual void validate(const Topology& /*topology*/,
                        std::vector<std::string>& /*problems*/) const {}
};

}  // namespace cutsim::topology
