// The control of the compile-failure tests (README.md): ids used as intended.
#include <sstream>
#include <vector>

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
  const Index i = p.idx();  // an id is read as an integer by idx()
  const std::vector<double> x(3 * (i + 1), 0.0), mass(i + 1, 1.0);
  const double z = x[3 * p.idx() + 2] + mass[p.idx()];
  // Ids of one kind compare with each other, and print as their number.
  const bool ordered =
      PointId(1) < p && p == PointId(i) && p != PointId::invalid() && (p <=> PointId(i)) == 0;
  std::ostringstream out;
  out << p << ' ' << edge;
  return int(pointOf(PointId(i)) - pointOf(p)) + int(z) + (ordered ? 0 : 1) +
         (out.str() == "21 7" ? 0 : 1);
}
