// Must not compile (README.md): an edge where a point is expected.
#include "cutsim/topology/types.hpp"

cutsim::topology::Index pointOf(cutsim::topology::PointId p) {
  return p.idx();
}

int main() {
  return int(pointOf(cutsim::topology::EdgeId(7)));
}
