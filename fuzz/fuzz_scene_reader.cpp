// libFuzzer target: the bytes as a scene's JSON text (core::parseScene, mesh files resolved against
// tests/data/scenes), then up to three steps of a scene that loads. Only cutsim::Error may be
// thrown.
#include <cstdio>
#include <cstdlib>

#include "fuzz_targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    cutsim::fuzz::fuzzSceneReader(data, size, CUTSIM_FUZZ_SCENE_DIR);
  } catch (const cutsim::fuzz::FuzzFailure& e) {
    std::fprintf(stderr, "fuzz_scene_reader: %s\n", e.what());
    std::abort();
  }
  return 0;
}
