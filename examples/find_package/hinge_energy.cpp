// Uses cutsim as an installed library: builds the spec's hinge H, folds wing B by 0.1 rad about
// the hinge edge and prints the bending energy (0.00111018549377 for bendingStiffness 1).
#include <cmath>
#include <cstdio>
#include <vector>

#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/topology/topology.hpp"

int main() {
  using namespace cutsim;
  // A, B, C, D; triangles (C, D, A) and (D, C, B) share the hinge edge C-D.
  std::vector<topology::Vec3> rest{{0.3, -1, 0}, {0.6, 2, 0}, {0, 0, 0}, {1, 0, 0}};
  using topology::PointId;  // (ids are made from integers explicitly)
  std::vector<topology::TriangleVertices> triangles{{PointId(2), PointId(3), PointId(0)},
                                                    {PointId(3), PointId(2), PointId(1)}};
  topology::Topology topo(rest, triangles);
  forcefields::BendingParameters params;
  forcefields::FastTriangularBendingSprings springs(topo, params);
  std::vector<double> x;
  for (const auto& p : rest) x.insert(x.end(), p.begin(), p.end());
  x[3 * 1 + 1] = 2 * std::cos(0.1);
  x[3 * 1 + 2] = 2 * std::sin(0.1);
  std::printf("bending energy of hinge H folded by 0.1 rad: %.15g\n", springs.potentialEnergy(x));
  return 0;
}
