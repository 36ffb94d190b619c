#pragma once
// Strain of the surface's triangles in their rest plane, and tearing: after a step, the interior
// edges whose two triangles are stretched across the edge beyond a threshold are torn with
// Topology::tear, most strained first, a bounded number per step, so that cracks run across the
// direction of the pull.
#include <array>
#include <span>
#include <vector>

#include "cutsim/topology/topology.hpp"

namespace cutsim::core {

/// Green strain E = (F^T F - I) / 2 of triangle t (positions x, 3 doubles per point slot) in an
/// orthonormal frame of its rest plane, as (E11, E12, E22); the frame's first axis runs from the
/// triangle's vertex 0 to vertex 1. Zero for a degenerate rest triangle.
std::array<double, 3> triangleGreenStrain(const topology::Topology& topology,
                                          std::span<const double> x, topology::TriangleId t);

/// The largest principal value of triangleGreenStrain (0 for a degenerate rest triangle).
double maxPrincipalStrain(const topology::Topology& topology, std::span<const double> x,
                          topology::TriangleId t);

/// Green strain of triangle t along the in-plane rest direction normal to its edge e (e must be
/// an edge of t): m^T E m with m the unit rest-plane vector perpendicular to e.
double strainNormalToEdge(const topology::Topology& topology, std::span<const double> x,
                          topology::TriangleId t, topology::EdgeId e);

struct TearCandidate {
  topology::EdgeId edge;
  double strain;  ///< the smaller of the two triangles' strains normal to the edge
};

/// Interior edges whose two triangles both exceed `threshold` normal to the edge, most strained
/// first (ties: lowest edge id).
std::vector<TearCandidate> tearCandidates(const topology::Topology& topology,
                                          std::span<const double> x, double threshold);

/// Tears at most maxPerStep of the candidates (skipping edges that an earlier tear of this call,
/// or its repair, destroyed or made a border edge, and edges the topology refuses to tear), each
/// followed by the quality repair around it (`repair`; minAngle 0: none). Returns how many.
int tearOverstrained(topology::Topology& topology, std::span<const double> x, double threshold,
                     int maxPerStep, const topology::RepairOptions& repair = {});

}  // namespace cutsim::core
