// Must not compile (README.md): an integer where an id is expected.
#include "cutsim/topology/types.hpp"

cutsim::topology::Index pointOf(cutsim::topology::PointId p) {
  return p.idx();
}

int main() {
  return int(pointOf(7));
}
