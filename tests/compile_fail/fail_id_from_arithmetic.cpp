// Must not compile (README.md): an id made implicitly from an integer, here an edge's number
// times three (`3 * edge` alone no longer compiles: an id is read as an integer only by idx()).
#include "cutsim/topology/types.hpp"

int main() {
  const cutsim::topology::EdgeId edge(7);
  cutsim::topology::PointId p = 3 * edge.idx();
  return int(p.idx());
}
