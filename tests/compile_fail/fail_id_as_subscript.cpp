// Must not compile (README.md): an id used as an array's subscript.
#include <vector>

#include "cutsim/topology/types.hpp"

int main() {
  const std::vector<double> mass(3, 1.0);
  const cutsim::topology::PointId p(2);
  return int(mass[p]);
}
