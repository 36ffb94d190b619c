// The fuzz targets' bodies (fuzz/fuzz_targets.hpp) run by the ordinary test suite, so that CI
// (g++, release and sanitize) exercises them without clang's libFuzzer: every seed of
// fuzz/corpus/<target>/, then a few thousand inputs made by a fixed-seed generator (mutated seeds
// for the text readers, random bytes for the topology operations).
#include <gtest/gtest.h>

#include <algorithm>
#include <cfenv>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "../../fuzz/fuzz_targets.hpp"

namespace cutsim::test {
namespace {

namespace fs = std::filesystem;
using Input = std::vector<std::uint8_t>;
using Target = std::function<void(const Input&)>;

const fs::path kCorpus = fs::path(CUTSIM_TEST_DATA_DIR) / ".." / ".." / "fuzz" / "corpus";
const fs::path kScenes = fs::path(CUTSIM_TEST_DATA_DIR) / "scenes";

std::vector<Input> seeds(const std::string& target) {
  std::vector<Input> out;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(kCorpus / target)) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    std::ifstream in(f, std::ios::binary);
    out.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return out;
}

std::string describe(const Input& in) {
  std::ostringstream s;
  s << in.size() << " bytes: \"";
  for (std::size_t i = 0; i < in.size() && i < 400; ++i) {
    const char c = char(in[i]);
    if (c >= 32 && c < 127 && c != '\\' && c != '"') {
      s << c;
    } else {
      static const char* hex = "0123456789abcdef";
      s << "\\x" << hex[in[i] >> 4] << hex[in[i] & 15];
    }
  }
  s << (in.size() > 400 ? "...\"" : "\"");
  return s.str();
}

/// Runs the target on one input; a FuzzFailure or any exception is a test failure naming it.
void replay(const Target& target, const Input& in) {
  try {
    target(in);
  } catch (const fuzz::FuzzFailure& e) {
    ADD_FAILURE() << e.what() << "\n  input " << describe(in);
  } catch (const std::exception& e) {
    ADD_FAILURE() << "unexpected exception: " << e.what() << "\n  input " << describe(in);
  }
}

/// Small edits of a text seed: flip/replace/insert/delete bytes, insert tokens the readers care
/// about, duplicate or cut a chunk.
Input mutate(Input in, std::mt19937_64& rng) {
  static const std::vector<std::string> tokens = {
      "-",          "0",      "1e308", "1e-308", "nan",       "inf",       "-1",
      "4294967295", "/",      "\n",    " ",      "f 1 2 3\n", "v 0 0 0\n", "3 0 1 2\n",
      "OFF\n",      "{",      "}",     "[",      "]",         ",",         ":",
      "\"",         "\"at\"", "null",  "true",   "1e999",     "0.5",       "\"polyline\"",
      "-0",         "2000",   "1e8"};
  const int edits = 1 + int(rng() % 4);
  for (int k = 0; k < edits; ++k) {
    const std::size_t pos = in.empty() ? 0 : rng() % (in.size() + 1);
    switch (rng() % 6) {
      case 0:
        if (pos < in.size()) in[pos] ^= std::uint8_t(1u << (rng() % 8));
        break;
      case 1:
        if (pos < in.size()) in[pos] = std::uint8_t(rng() % 256);
        break;
      case 2:
        if (pos < in.size())
          in.erase(in.begin() + long(pos),
                   in.begin() + long(std::min(in.size(), pos + 1 + rng() % 8)));
        break;
      case 3: {
        const std::string& t = tokens[rng() % tokens.size()];
        in.insert(in.begin() + long(pos), t.begin(), t.end());
        break;
      }
      case 4: {
        if (in.empty()) break;
        const std::size_t from = rng() % in.size();
        const std::size_t len = std::min<std::size_t>(in.size() - from, 1 + rng() % 40);
        Input chunk(in.begin() + long(from), in.begin() + long(from + len));
        in.insert(in.begin() + long(pos), chunk.begin(), chunk.end());
        break;
      }
      default:
        in.resize(pos);
        break;
    }
  }
  if (in.size() > fuzz::kMaxInputSize) in.resize(fuzz::kMaxInputSize);
  return in;
}

void replaySeedsAndMutations(const std::string& name, const Target& target, int mutations) {
  const auto corpus = seeds(name);
  ASSERT_FALSE(corpus.empty()) << "no seed in " << (kCorpus / name);
  for (const auto& in : corpus) replay(target, in);
  std::mt19937_64 rng(20261122);
  for (int i = 0; i < mutations; ++i) {
    replay(target, mutate(corpus[rng() % corpus.size()], rng));
    if (::testing::Test::HasFailure()) break;  // the first failing input is enough
  }
}

TEST(FuzzReplay, MeshReader) {
  replaySeedsAndMutations(
      "fuzz_mesh_reader", [](const Input& in) { fuzz::fuzzMeshReader(in.data(), in.size()); },
      10000);
}

TEST(FuzzReplay, SceneReader) {
  // A scene may ask for a stiffness of 1e300: the run must stop with a SolverError, which the
  // simulation finds by computing the infinity, so the test main's FP traps are off here.
  struct NoFpTraps {
    int saved = fegetexcept();
    NoFpTraps() { fedisableexcept(FE_ALL_EXCEPT); }
    ~NoFpTraps() {
      feclearexcept(FE_ALL_EXCEPT);
      feenableexcept(saved);
    }
  } noTraps;
  replaySeedsAndMutations(
      "fuzz_scene_reader",
      [](const Input& in) { fuzz::fuzzSceneReader(in.data(), in.size(), kScenes); }, 2500);
}

TEST(FuzzReplay, TopologyOps) {
  const Target target = [](const Input& in) { fuzz::fuzzTopologyOps(in.data(), in.size()); };
  for (const auto& in : seeds("fuzz_topology_ops")) replay(target, in);
  std::mt19937_64 rng(7);
  for (int i = 0; i < 2500 && !HasFailure(); ++i) {
    Input in(4 + rng() % 300);
    for (auto& b : in) b = std::uint8_t(rng() % 256);
    replay(target, in);
  }
}

// Finding 4 of docs/robustness.md, found by fuzz_topology_ops: on a 5 x 3 alternating grid, after
//   splitEdge 11 t 0.087022, incise 9 14 8, splitTriangle, splitEdge 1 t 0.000580, splitTriangle,
//   cutPolyline (snap 0.1) {-0.125, 1.25, 1e-9} {0.4375, -0.25, 1e-9} {1.125, 1.25, 1e-9},
//   splitTriangle, tear 42, tear 40,
// cutPolyline (snap 0) {0.968750001, 0.06250000000001, 1e-6} {0.49999999999999, 0.56249999999999,
// 1e-14} threw TopologyError "internal error: cutPolyline's walk left the surface at point 22
// (the mesh stays valid)" AFTER changing the mesh, against the contract "a rejected request
// throws TopologyError and changes nothing" (which the fuzz body checks). The insertion is now
// planned on a patch first: the request is rejected before the mesh changes.
TEST(FuzzReplay, RejectedCutChangesNothing) {
  const Input in = {
      0x6c, 0x7e, 0x46, 0x18, 0x28, 0x48, 0x77, 0x16, 0x47, 0x0a, 0x12, 0x49, 0xc1, 0xd9,
      0xd7, 0x0c, 0x58, 0x4f, 0x49, 0xfb, 0x35, 0xb6, 0x31, 0x00, 0x00, 0x00, 0x00, 0x00,
      0x00, 0x00, 0x26, 0x4f, 0x0b, 0x24, 0xb5, 0x43, 0xb8, 0xaf, 0x6c, 0xaa, 0x64, 0x01,
      0x00, 0x00, 0x16, 0x70, 0xff, 0xff, 0xff, 0x12, 0x00, 0x00, 0x00, 0xff, 0xff, 0xff,
      0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff,
      0xa9, 0xcf, 0x24, 0xa9, 0x53, 0x80, 0xf1, 0x56, 0x43, 0x4d, 0x0c, 0xe3, 0x4b, 0x83,
      0x45, 0x4f, 0x81, 0x82, 0x94, 0x01, 0xbc, 0xcd, 0x67, 0x26, 0x37,
  };
  std::vector<std::string> log;
  replay([&](const Input& i) { fuzz::fuzzTopologyOps(i.data(), i.size(), &log); }, in);
  // The input still reaches the cut whose insertion cannot be planned: it is rejected as such.
  const auto target = std::find_if(log.begin(), log.end(), [](const std::string& l) {
    return l.rfind("cutPolyline snap 0.000000: {0.96875000099999997", 0) == 0;
  });
  ASSERT_NE(target, log.end());
  EXPECT_NE(target->find("cannot be inserted"), std::string::npos) << *target;
  EXPECT_NE(target->find("nothing was changed"), std::string::npos) << *target;
}

// The same defect on another path (found by the same fuzzer): 6 x 3 one-way grid, splitEdge 15
// t 0.251469, splitEdge 2 t 0.649866, compact, a cut, splitEdge 11 t 0.831373, then cutPolyline
// (snap 0.01) {0.399, 0.999999999999, 1e-12} {0.399999999999, 0.999999, 1e-14}
// {0.824999999999, 0.999999999999, 1e-12} {0.399999999999, 0.999999999999, 1e-12}: a polyline
// running along the top border and doubling back: "walk left the surface at point 28" after
// changing the mesh. Now rejected before any change.
TEST(FuzzReplay, RejectedCutAlongTheBorderChangesNothing) {
  const Input in = {
      0x40, 0x60, 0x17, 0x7b, 0x80, 0xda, 0x03, 0x40, 0x60, 0x00, 0x00, 0x2a, 0xa6, 0x5d, 0x9e,
      0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4,
      0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0x17, 0x00, 0x00, 0x00, 0xd4, 0x01, 0x00, 0x00, 0x00, 0x00,
      0x00, 0x00, 0x7a, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xbf, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4,
      0xd4, 0xd4, 0xd4, 0xd4, 0xdc, 0x5e, 0x0d, 0x25, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4,
      0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4, 0xd4,
      0xd4, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff,
      0xf7, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xd4, 0xd4, 0xe1,
      0x7a, 0xc1, 0xc9, 0x5e, 0x0d, 0x25, 0xd4,
  };
  std::vector<std::string> log;
  replay([&](const Input& i) { fuzz::fuzzTopologyOps(i.data(), i.size(), &log); }, in);
  // The input still reaches that cut. Its end snaps onto the vertex where the polyline comes
  // back, so the snapped variant touches itself and only the polyline as given is tried, whose
  // insertion cannot be planned: rejected before anything changes (the fuzz body checks that
  // nothing changed and that the message is not an internal error).
  // Since cuts also try the polyline unsnapped and with its ends pulled onto the border, the
  // cut may now be made (floating-point contraction decides between the builds); either way the
  // fuzz body has checked the mesh after it, and that a rejection changed nothing.
  const auto target = std::find_if(log.begin(), log.end(), [](const std::string& l) {
    return l.rfind("cutPolyline snap 0.010000: {0.39900000000000002", 0) == 0;
  });
  ASSERT_NE(target, log.end());
  // (The fuzz body checks that a rejected operation changed nothing.)
  EXPECT_EQ(target->find("internal error"), std::string::npos) << *target;
}

}  // namespace
}  // namespace cutsim::test
