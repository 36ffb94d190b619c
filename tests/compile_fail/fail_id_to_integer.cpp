// Must not compile (README.md): an id read as an integer implicitly.
#include "cutsim/topology/types.hpp"

int main() {
  const cutsim::topology::PointId p(3);
  const cutsim::topology::Index i = p;
  return int(i);
}
