// libFuzzer target: the bytes as a sequence of topology operations on a small grid (splitEdge,
// splitTriangle, tear, incise, removeTriangles, cutPolyline, compact) with the bending springs, the
// mechanical state and a MirrorObserver subscribed; topology.validate() after every operation.
#include <cstdio>
#include <cstdlib>

#include "fuzz_targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    cutsim::fuzz::fuzzTopologyOps(data, size);
  } catch (const cutsim::fuzz::FuzzFailure& e) {
    std::fprintf(stderr, "fuzz_topology_ops: %s\n", e.what());
    std::abort();
  }
  return 0;
}
