// Must not compile (README.md): an id made implicitly from an integer.
#include "cutsim/topology/types.hpp"

int main() {
  const cutsim::topology::EdgeId edge(7);
  cutsim::topology::PointId p = 3 * edge;
  return int(p.idx());
}
