// Must not compile (README.md): an id passed where an integer is expected.
#include "cutsim/topology/types.hpp"

cutsim::topology::Index twice(cutsim::topology::Index i) {
  return 2 * i;
}

int main() {
  return int(twice(cutsim::topology::PointId(3)));
}
