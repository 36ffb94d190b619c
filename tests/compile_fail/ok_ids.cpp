// The control of the compile-failure tests (README.md): ids used as intended.
#include "cutsim/topology/types.hpp"

using cutsim::topology::EdgeId;
using cutsim::topology::Index;
using cutsim::topology::PointId;

Index pointOf(PointId p) {
  return p.idx();
}

int main() {
  const EdgeId edge(7);
  const PointId p(3 * edge.idx());
  const Index i = p;  // an id reads as an integer
  return int(pointOf(PointId(i)) - pointOf(p));
}
