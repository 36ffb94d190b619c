#pragma once
// Basic index and geometry types of the topology layer. Deliberately free of CGAL.
#include <array>
#include <cstdint>
#include <limits>

namespace cutsim::topology {

/// Indices of points (vertices), edges and triangles. They are slots: stable between compactions,
/// never reused before a compaction (see docs/topology-events.md, "Index policy").
using Index = std::uint32_t;
using PointId = Index;
using EdgeId = Index;
using TriangleId = Index;

inline constexpr Index kInvalidIndex = std::numeric_limits<Index>::max();

using Vec3 = std::array<double, 3>;
using TriangleVertices = std::array<PointId, 3>;
using TriangleEdges = std::array<EdgeId, 3>;
using EdgeVertices = std::array<PointId, 2>;

}  // namespace cutsim::topology
