// Must not compile (README.md): an id in integer arithmetic, here a coordinate's offset.
#include <vector>

#include "cutsim/topology/types.hpp"

int main() {
  const std::vector<double> x(9, 0.0);
  const cutsim::topology::PointId p(2);
  return int(x[3 * p]);
}
