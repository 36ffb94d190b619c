// The player's page without a browser: the run reader against the writer of the same run, the
// frame packer against the frames it packs (decoded from the blob by the meta's offsets), the
// choice of frames within a size budget, and bad run folders.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/output.hpp"
#include "cutsim/core/scene.hpp"
#include "cutsim/view/player.hpp"

namespace {

using namespace cutsim;
using namespace cutsim::view;
using nlohmann::json;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

const fs::path kScenes = fs::path(CUTSIM_TEST_DATA_DIR) / "scenes";

fs::path freshDir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("cutsim_test_player_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string readText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// What a run's state was at each frame, recorded while the writer wrote it.
struct Recorded {
  double time;
  std::size_t triangles;
  std::vector<double> x;  // live points in ascending slot order
};

/// Runs tests/data/scenes/small.json (a cut, a removal, a grasp, tearing) into `dir`; `finish`
/// false leaves it as a run that was stopped (partial collections, temporary CSV).
std::vector<Recorded> runSmall(const fs::path& dir, bool finish = true, long stopAfter = -1) {
  core::Scene scene = core::loadScene(kScenes / "small.json");
  core::SceneRunner runner(scene);
  std::vector<Recorded> frames;
  core::OutputWriter writer(dir, scene.output, scene.forceFieldLabels(), scene.graspNames());
  auto record = [&](const core::StepRecord& r) {
    const bool frame = r.step % scene.output.every == 0 || runner.finished();
    writer.record(runner.simulation(), r, runner.finished());
    if (!frame) return;
    Recorded rec{r.time, runner.simulation().topology().numTriangles(), {}};
    const auto x = runner.simulation().state().x();
    for (topology::PointId p : runner.simulation().topology().points())
      for (int k = 0; k < 3; ++k) rec.x.push_back(x[3 * p.idx() + std::size_t(k)]);
    frames.push_back(std::move(rec));
  };
  runner.start();
  record({0, 0.0, {}});
  while (!runner.finished() && (stopAfter < 0 || runner.currentStep() < stopAfter)) {
    const core::StepStats stats = runner.advance();
    record({runner.currentStep(), runner.time(), stats});
  }
  if (finish) writer.finish();
  return frames;
}

/// The text between `<script ... id="ID">` and its `</script>`.
std::string scriptText(const std::string& page, const std::string& id) {
  const std::size_t open = page.find("id=\"" + id + "\">");
  if (open == std::string::npos) return {};
  const std::size_t start = open + id.size() + 6;
  return page.substr(start, page.find("</script>", start) - start);
}

/// An independent base64 decoder (RFC 4648).
std::string unbase64(const std::string& text) {
  std::string out;
  int value = 0, bits = -8;
  for (char c : text) {
    const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    const char* at = std::strchr(alphabet, c);
    if (c == '=' || at == nullptr || c == '\0') break;
    value = (value << 6) | int(at - alphabet);
    bits += 6;
    if (bits >= 0) {
      out.push_back(char((value >> bits) & 0xff));
      bits -= 8;
    }
  }
  return out;
}

/// The page's three <script> elements (meta, data, player), and no "<!--" that would make the
/// HTML parser read on past a "</script>" (the script data escaped state).
void expectThreeScripts(const std::string& page) {
  std::string lower = page;
  for (char& c : lower) c = char(std::tolower(static_cast<unsigned char>(c)));
  std::size_t opens = 0, closes = 0;
  for (std::size_t at = lower.find("<script"); at != std::string::npos;
       at = lower.find("<script", at + 1))
    ++opens;
  for (std::size_t at = lower.find("</script"); at != std::string::npos;
       at = lower.find("</script", at + 1))
    ++closes;
  EXPECT_EQ(opens, 3u);
  EXPECT_EQ(closes, 3u);
  EXPECT_EQ(lower.find("<!--"), std::string::npos);
}

template <typename T>
std::vector<T> decode(const std::string& blob, const json& ref) {
  const std::size_t offset = ref.at(0).get<std::size_t>(), count = ref.at(1).get<std::size_t>();
  EXPECT_EQ(offset % 8, 0u) << "arrays start at 8-byte boundaries (a Float64Array needs it)";
  EXPECT_LE(offset + count * sizeof(T), blob.size());
  std::vector<T> out(count);
  if (count) std::memcpy(out.data(), blob.data() + offset, count * sizeof(T));
  return out;
}

Frame syntheticFrame(double t, std::size_t n, std::vector<std::uint32_t> triangles, float shift) {
  Frame f;
  f.time = t;
  for (std::size_t p = 0; p < n; ++p) {
    f.x.insert(f.x.end(), {float(p) + shift, float(p % 3) * 0.5f, -shift * float(p)});
    f.rest.insert(f.rest.end(), {float(p), float(p % 3) * 0.5f, 0.0f});
    f.v.insert(f.v.end(), {0.1f * float(p), -0.2f, shift});
    f.held.push_back(std::uint8_t(p == 0 ? 1 : p == 1 ? 2 : 0));
  }
  f.triangles = std::move(triangles);
  for (std::size_t k = 0; k < f.triangles.size() / 3; ++k)
    f.strain.push_back(0.01f * float(k) + shift);
  f.borders = {0, 1, 1, 2};
  f.lips = {0, 1};
  f.hasBorders = true;
  f.springs = {0, 2};
  return f;
}

TEST(PlayerPacker, ArraysDecodeToTheFramesAndUnchangedOnesAreShared) {
  const std::vector<Frame> frames = {syntheticFrame(0.0, 5, {0, 1, 2, 2, 3, 4}, 0.0f),
                                     syntheticFrame(0.5, 5, {0, 1, 2, 2, 3, 4}, 0.25f),
                                     syntheticFrame(1.0, 6, {0, 1, 2, 2, 3, 5, 3, 4, 5}, 0.5f)};
  FramePacker packer;
  for (const Frame& f : frames) packer.add(f);
  const json& meta = packer.meta();
  const std::string& blob = packer.blob();
  ASSERT_EQ(meta["frames"].size(), 3u);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const Frame& f = frames[i];
    const json& m = meta["frames"][i];
    EXPECT_EQ(m["t"].get<double>(), f.time);
    EXPECT_EQ(m["points"].get<std::size_t>(), f.x.size() / 3);
    EXPECT_EQ(m["triangles"].get<std::size_t>(), f.triangles.size() / 3);
    EXPECT_EQ(decode<float>(blob, m["x"]), f.x);
    EXPECT_EQ(decode<std::uint32_t>(blob, m["tri"]), f.triangles);
    EXPECT_EQ(decode<float>(blob, m["strain"]), f.strain);
    EXPECT_EQ(decode<std::uint8_t>(blob, m["held"]), f.held);
    EXPECT_EQ(decode<std::uint32_t>(blob, m["border"]), f.borders);
    EXPECT_EQ(decode<std::uint8_t>(blob, m["lip"]), f.lips);
    EXPECT_EQ(decode<std::uint32_t>(blob, m["spring"]), f.springs);
    EXPECT_EQ(m["lipEdges"].get<std::size_t>(), 1u);
    EXPECT_EQ(m["fixed"].get<std::size_t>(), 1u);
    EXPECT_EQ(m["grasped"].get<std::size_t>(), 1u);
    // Per-triangle speed and displacement: the means of their points' norms (brute force).
    const auto speed = decode<float>(blob, m["speed"]),
               disp = decode<float>(blob, m["displacement"]);
    ASSERT_EQ(speed.size(), f.triangles.size() / 3);
    for (std::size_t k = 0; k < speed.size(); ++k) {
      double s = 0, d = 0;
      for (int c = 0; c < 3; ++c) {
        const std::size_t p = f.triangles[3 * k + std::size_t(c)];
        s += std::hypot(f.v[3 * p], f.v[3 * p + 1], f.v[3 * p + 2]) / 3;
        d += std::hypot(f.x[3 * p] - f.rest[3 * p], f.x[3 * p + 1] - f.rest[3 * p + 1],
                        f.x[3 * p + 2] - f.rest[3 * p + 2]) /
             3;
      }
      EXPECT_NEAR(speed[k], s, 1e-6 * (1 + s));
      EXPECT_NEAR(disp[k], d, 1e-6 * (1 + d));
    }
  }
  // The triangles of the first two frames are stored once; the third frame's (a "cut") anew.
  EXPECT_EQ(meta["frames"][0]["tri"], meta["frames"][1]["tri"]);
  EXPECT_NE(meta["frames"][1]["tri"], meta["frames"][2]["tri"]);
  EXPECT_EQ(meta["frames"][0]["border"], meta["frames"][2]["border"]);
  EXPECT_NE(meta["frames"][0]["x"], meta["frames"][1]["x"]);
}

TEST(PlayerPacker, Base64IsRfc4648) {
  // The test vectors of RFC 4648, section 10.
  const std::pair<const char*, const char*> vectors[] = {{"", ""},
                                                         {"f", "Zg=="},
                                                         {"fo", "Zm8="},
                                                         {"foo", "Zm9v"},
                                                         {"foob", "Zm9vYg=="},
                                                         {"fooba", "Zm9vYmE="},
                                                         {"foobar", "Zm9vYmFy"}};
  for (const auto& [in, out] : vectors) EXPECT_EQ(base64(in), out) << in;
  std::string bytes;
  for (int i = 0; i < 1000; ++i) bytes.push_back(char((i * 37 + 11) & 0xff));
  EXPECT_EQ(unbase64(base64(bytes)), bytes);
}

TEST(PlayerPacker, ChosenFramesFitTheBudgetWithTheFirstAndTheLast) {
  for (std::size_t count : {1u, 2u, 7u, 100u, 1001u}) {
    for (double perFrame : {1.0, 1000.0, 123456.0}) {
      for (std::size_t budget : {std::size_t(1000), std::size_t(1) << 20, std::size_t(48) << 20}) {
        const std::vector<std::size_t> chosen = chooseFrames(count, perFrame, budget);
        ASSERT_FALSE(chosen.empty());
        EXPECT_EQ(chosen.front(), 0u);
        EXPECT_EQ(chosen.back(), count - 1);
        for (std::size_t i = 1; i < chosen.size(); ++i) EXPECT_LT(chosen[i - 1], chosen[i]);
        if (double(count) * perFrame <= double(budget)) {
          EXPECT_EQ(chosen.size(), count);
        } else {
          // Within the budget, or two frames (the first and the last) when one frame exceeds it.
          EXPECT_LE(double(chosen.size()) * perFrame, std::max(double(budget), 2 * perFrame))
              << count << " frames of " << perFrame << " in " << budget;
          EXPECT_GE(double(chosen.size() + 1) * perFrame * 2,
                    std::min(double(budget), double(count) * perFrame))
              << "not needlessly few";
        }
      }
    }
  }
}

TEST(PlayerPacker, LongSeriesKeepEveryKthRowTheLastAndTheFramesRows) {
  Series s;
  s.names = {"time", "kinetic_energy"};
  s.columns.resize(2);
  for (std::size_t r = 0; r <= 50000; ++r) {
    s.columns[0].push_back(double(r) * 1e-4);
    s.columns[1].push_back(std::sin(double(r)));
  }
  FramePacker packer;
  const std::size_t frameRows[] = {0, 12345, 33333, 50000};
  for (std::size_t r : frameRows) packer.add(syntheticFrame(double(r) * 1e-4, 3, {0, 1, 2}, 0.0f));
  packer.setSeries(s, 1000);
  const json& meta = packer.meta();
  const std::size_t rows = meta["series"]["rows"].get<std::size_t>();
  EXPECT_LE(rows, 1000u + 4u);
  EXPECT_GE(rows, 900u);
  EXPECT_EQ(meta["series"]["rowsInRun"].get<std::size_t>(), 50001u);
  const auto time = decode<double>(packer.blob(), meta["series"]["columns"][0]);
  const auto kinetic = decode<double>(packer.blob(), meta["series"]["columns"][1]);
  ASSERT_EQ(time.size(), rows);
  EXPECT_EQ(time.front(), 0.0);
  EXPECT_EQ(time.back(), s.columns[0].back());
  for (std::size_t i = 1; i < time.size(); ++i) ASSERT_LT(time[i - 1], time[i]);
  for (std::size_t i = 0; i < time.size(); ++i) {
    const std::size_t r = std::size_t(std::llround(time[i] / 1e-4));
    ASSERT_EQ(kinetic[i], s.columns[1][r]) << "row " << r << " keeps its values together";
  }
  for (std::size_t k = 0; k < 4; ++k) {
    const json& f = meta["frames"][k];
    EXPECT_EQ(f["csvRow"].get<std::size_t>(), frameRows[k]);
    EXPECT_EQ(time[f["row"].get<std::size_t>()], f["t"].get<double>());
  }
}

TEST(PlayerRun, ReaderGivesBackWhatTheWriterWrote) {
  const fs::path dir = freshDir("reader");
  const std::vector<Recorded> recorded = runSmall(dir);
  const RunFolder run = scanRun(dir);
  EXPECT_FALSE(run.partial);
  ASSERT_EQ(run.surface.size(), recorded.size());
  ASSERT_EQ(run.borders.size(), recorded.size());
  ASSERT_TRUE(run.csv.has_value());
  bool someLips = false, someGrasped = false;
  for (std::size_t i = 0; i < recorded.size(); ++i) {
    const Frame f = readFrame(run, i);
    EXPECT_EQ(f.time, recorded[i].time);
    EXPECT_EQ(f.triangles.size(), 3 * recorded[i].triangles);
    ASSERT_EQ(f.x.size(), recorded[i].x.size());
    for (std::size_t k = 0; k < f.x.size(); ++k) EXPECT_EQ(f.x[k], float(recorded[i].x[k]));
    EXPECT_EQ(f.strain.size(), recorded[i].triangles);
    EXPECT_EQ(f.lips.size() * 2, f.borders.size());
    EXPECT_FALSE(f.springs.empty());
    for (std::uint8_t l : f.lips) someLips |= l == 1;
    for (std::uint8_t h : f.held) someGrasped |= h == 2;
  }
  EXPECT_TRUE(someLips);
  EXPECT_TRUE(someGrasped);
  const Series s = readSeries(*run.csv);
  EXPECT_EQ(s.rows(), 31u);  // steps 0..30
  EXPECT_THAT(s.names, ::testing::Contains("triangles"));
  EXPECT_THAT(s.names, ::testing::Not(::testing::Contains("solver_flags")));  // text, left out
  fs::remove_all(dir);
}

TEST(PlayerRun, PageEmbedsEveryFrameWithItsCsvRow) {
  const fs::path dir = freshDir("page");
  const std::vector<Recorded> recorded = runSmall(dir);
  const PlayerReport r = writePlayer(dir, dir / "player.html");
  EXPECT_EQ(r.framesInRun, recorded.size());
  EXPECT_EQ(r.framesShown, recorded.size());
  const std::string page = readText(dir / "player.html");
  EXPECT_EQ(r.bytes, page.size());
  EXPECT_THAT(page, HasSubstr("<!DOCTYPE html>"));
  // Nothing to fetch: the only addresses in the page are XML namespaces (SVG's, XHTML's).
  for (const char* scheme : {"http://", "https://", "//cdn", "src=\"", "href=\""}) {
    for (std::size_t at = page.find(scheme); at != std::string::npos;
         at = page.find(scheme, at + 1))
      EXPECT_EQ(page.compare(at, 18, "http://www.w3.org/"), 0) << page.substr(at, 60);
  }
  expectThreeScripts(page);
  const json meta = json::parse(scriptText(page, "cutsim-meta"));
  const std::string blob = unbase64(scriptText(page, "cutsim-data"));
  ASSERT_EQ(meta["frames"].size(), recorded.size());
  const Series s = readSeries(dir / "steps.csv");
  const auto column = [&](const std::string& name) {
    return s
        .columns[std::size_t(std::find(s.names.begin(), s.names.end(), name) - s.names.begin())];
  };
  for (std::size_t i = 0; i < recorded.size(); ++i) {
    const json& f = meta["frames"][i];
    EXPECT_EQ(f["t"].get<double>(), recorded[i].time);
    const std::vector<float> x = decode<float>(blob, f["x"]);
    ASSERT_EQ(x.size(), recorded[i].x.size());
    for (std::size_t k = 0; k < x.size(); ++k) EXPECT_EQ(x[k], float(recorded[i].x[k]));
    const long row = f["row"].get<long>();
    ASSERT_GE(row, 0);
    EXPECT_EQ(column("time")[std::size_t(row)], recorded[i].time);
    EXPECT_EQ(column("triangles")[std::size_t(row)], double(recorded[i].triangles));
  }
  // The series, whole: the CSV's triangles column, decoded.
  const auto& names = meta["series"]["names"];
  const std::size_t c =
      std::size_t(std::find(names.begin(), names.end(), "triangles") - names.begin());
  EXPECT_EQ(decode<double>(blob, meta["series"]["columns"][c]), column("triangles"));
  EXPECT_FALSE(meta["run"]["partial"].get<bool>());
  fs::remove_all(dir);
}

TEST(PlayerRun, ABudgetKeepsEveryKthFrameAndTheLast) {
  const fs::path dir = freshDir("budget");
  const std::vector<Recorded> recorded = runSmall(dir);
  PlayerOptions options;
  options.budgetBytes = std::size_t(playerScript().size()) + 70000;  // room for a few frames only
  const PlayerReport r = writePlayer(dir, dir / "small.html", options);
  EXPECT_LT(r.framesShown, recorded.size());
  EXPECT_GE(r.framesShown, 2u);
  EXPECT_LE(r.bytes, options.budgetBytes) << "the page is within its budget";
  EXPECT_GE(r.stride, 2u);
  const json meta = json::parse(scriptText(readText(dir / "small.html"), "cutsim-meta"));
  EXPECT_EQ(meta["frames"].back()["t"].get<double>(), recorded.back().time);
  EXPECT_EQ(meta["frames"].front()["t"].get<double>(), 0.0);
  EXPECT_EQ(meta["run"]["framesShown"].get<std::size_t>(), r.framesShown);
  const auto indices = meta["run"]["frameIndices"].get<std::vector<std::size_t>>();
  ASSERT_EQ(indices.size(), r.framesShown);
  for (std::size_t i = 1; i + 1 < indices.size(); ++i)
    EXPECT_EQ(indices[i] - indices[i - 1], r.stride);
  fs::remove_all(dir);
}

TEST(PlayerRun, AStoppedRunPlaysAsPartial) {
  const fs::path dir = freshDir("partial");
  runSmall(dir, /*finish=*/false, /*stopAfter=*/12);
  ASSERT_FALSE(fs::exists(dir / "surface.pvd"));
  const PlayerReport r = writePlayer(dir, dir / "player.html");
  EXPECT_TRUE(r.partial);
  EXPECT_GE(r.framesShown, 2u);
  const json meta = json::parse(scriptText(readText(dir / "player.html"), "cutsim-meta"));
  EXPECT_TRUE(meta["run"]["partial"].get<bool>());
  fs::remove_all(dir);
}

TEST(PlayerRun, TextThatWouldCloseTheScriptIsEscaped) {
  FramePacker packer;
  packer.add(syntheticFrame(0.0, 3, {0, 1, 2}, 0.0f));
  json meta = packer.meta();
  meta["run"] = {{"name", "a </script><b>"},
                 {"description", "</SCRIPT> and </script > x <!--<script> y"}};
  std::ostringstream out;
  writePlayerPage(out, meta, packer.blob());
  const std::string page = out.str();
  const json back = json::parse(scriptText(page, "cutsim-meta"));
  EXPECT_EQ(back["run"]["name"], "a </script><b>");
  EXPECT_EQ(back["run"]["description"], "</SCRIPT> and </script > x <!--<script> y");
  expectThreeScripts(page);
  EXPECT_THAT(page, HasSubstr("<title>a &lt;/script&gt;&lt;b&gt; - cutsim</title>"));
}

/// A frame of one triangle: `pointData` (DataArray lines) inside <PointData> unless empty (its
/// first array on line 6), `positions` the nine numbers of its corners.
void writeTriangleFrame(const fs::path& file, const std::string& pointData,
                        const std::string& positions) {
  std::ofstream(file) << "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\">\n<PolyData>\n"
                         "<Piece NumberOfPoints=\"3\" NumberOfPolys=\"1\">\n"
                      << (pointData.empty() ? "" : "<PointData>\n" + pointData + "</PointData>\n")
                      << "<Points>\n<DataArray type=\"Float64\" Name=\"position\" "
                         "NumberOfComponents=\"3\" format=\"ascii\">\n"
                      << positions
                      << "\n</DataArray>\n</Points>\n<Polys>\n"
                         "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">0 1 "
                         "2</DataArray>\n</Polys>\n</Piece>\n</PolyData>\n</VTKFile>\n";
}

TEST(PlayerRun, BadFoldersAreNamedWithWhatIsWrong) {
  const fs::path dir = freshDir("bad");
  auto message = [](const fs::path& d) {
    try {
      scanRun(d);
    } catch (const InvalidInput& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(message(dir / "missing"), HasSubstr("missing: no such folder"));
  std::ofstream(dir / "file.txt") << "x\n";
  EXPECT_THAT(message(dir / "file.txt"), HasSubstr("not a folder"));
  EXPECT_THAT(message(dir), HasSubstr("not a cutsim run folder"));
  std::ofstream(dir / "steps.csv") << "time\n0\n";
  EXPECT_THAT(message(dir), HasSubstr("the run wrote no frames"));
  std::ofstream(dir / "surface.pvd")
      << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\">\n<Collection>\n"
         "</Collection>\n</VTKFile>\n";
  EXPECT_THAT(message(dir), HasSubstr("surface.pvd: the collection lists no frames"));
  std::ofstream(dir / "surface.pvd")
      << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\">\n<Collection>\n"
         "<DataSet timestep=\"zero\" file=\"surface_000000.vtp\"/>\n"
         "</Collection>\n</VTKFile>\n";
  EXPECT_THAT(message(dir), HasSubstr("surface.pvd:4: timestep \"zero\" is not a finite number"));
  std::ofstream(dir / "surface.pvd")
      << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\">\n<Collection>\n"
         "<DataSet timestep=\"0\" file=\"surface_000000.vtp\"/>\n"
         "</Collection>\n</VTKFile>\n";
  // A frame whose arrays are cut short: its file and line.
  std::ofstream(dir / "surface_000000.vtp")
      << "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\">\n<PolyData>\n"
         "<Piece NumberOfPoints=\"3\" NumberOfPolys=\"1\">\n<Points>\n"
         "<DataArray type=\"Float64\" Name=\"position\" NumberOfComponents=\"3\" "
         "format=\"ascii\">\n"
         "0 0 0 1 0 0 0 1\n</DataArray>\n</Points>\n</Piece>\n</PolyData>\n</VTKFile>\n";
  const RunFolder run = scanRun(dir);
  try {
    readFrame(run, 0);
    ADD_FAILURE() << "a short array was read";
  } catch (const InvalidInput& e) {
    EXPECT_THAT(
        e.what(),
        HasSubstr("surface_000000.vtp:6: DataArray position has 8 values, the piece needs 9"));
  }
  // A flag beyond a byte is an error, not wrapped to another flag.
  writeTriangleFrame(dir / "surface_000000.vtp",
                     "<DataArray type=\"Int32\" Name=\"constraint\" format=\"ascii\">0 1 "
                     "257</DataArray>\n",
                     "0 0 0 1 0 0 0 1 0");
  try {
    readFrame(scanRun(dir), 0);
    ADD_FAILURE() << "a flag of 257 was read";
  } catch (const InvalidInput& e) {
    EXPECT_THAT(e.what(), HasSubstr("surface_000000.vtp:6: DataArray constraint: \"257\" is not an "
                                    "index or flag in range"));
  }
  // A position beyond single precision (a run that blew up) is quoted whole: its first 20
  // characters, "7.962843447621331e+7", would look like a fine number.
  writeTriangleFrame(dir / "surface_000000.vtp", "", "0 0 0 1 0 0 7.962843447621331e+70 1 0");
  try {
    readFrame(scanRun(dir), 0);
    ADD_FAILURE() << "a position of 8e70 was read";
  } catch (const InvalidInput& e) {
    EXPECT_THAT(e.what(), HasSubstr("DataArray position: \"7.962843447621331e+70\" is not a finite "
                                    "number (in single precision)"));
  }
  fs::remove_all(dir);
}

}  // namespace
