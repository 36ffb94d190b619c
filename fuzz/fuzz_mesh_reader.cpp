// libFuzzer target: the bytes as an OBJ and as an OFF file (readObj, readOff), then checkManifold,
// the Topology and the bending springs on what was accepted. Only cutsim::Error may be thrown.
#include <cstdio>
#include <cstdlib>

#include "fuzz_targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    cutsim::fuzz::fuzzMeshReader(data, size);
  } catch (const cutsim::fuzz::FuzzFailure& e) {
    std::fprintf(stderr, "fuzz_mesh_reader: %s\n", e.what());
    std::abort();
  }
  return 0;
}
