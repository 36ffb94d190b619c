#pragma once
// Scene texts for the parser's tests (tests/core/test_scene.cpp,
// tests/robustness/test_bad_input.cpp).
#include <filesystem>
#include <string>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/scene.hpp"

namespace cutsim::test {

/// The test data's scene folder (relative mesh paths in inline scenes resolve there).
inline const std::filesystem::path kSceneDir =
    std::filesystem::path(CUTSIM_TEST_DATA_DIR) / "scenes";

/// The message of the InvalidInput that parsing `text` (as "inline.json") throws ("" if none).
inline std::string parseError(const std::string& text) {
  try {
    core::parseScene(text, "inline.json", kSceneDir);
  } catch (const InvalidInput& e) {
    return e.what();
  }
  return "";
}

/// A valid scene with `extra` appended inside the top-level object (one line each).
inline std::string scene(const std::string& extra = "") {
  return "{\n"
         "  \"mesh\": {\"grid\": {\"nx\": 5, \"ny\": 5}},\n"
         "  \"mass\": {\"density\": 1},\n"
         "  \"timeStep\": 0.01,\n"
         "  \"duration\": 0.1" +
         (extra.empty() ? "" : ",\n  " + extra) + "\n}\n";
}

}  // namespace cutsim::test
