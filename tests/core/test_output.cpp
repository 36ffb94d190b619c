// Outputs: VTP and PVD are well formed (counts parsed back), numbers round-trip, the CSV has its
// columns, frames appear under their final names only when complete, --dump-final's files.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/output.hpp"
#include "cutsim/core/scene.hpp"

namespace cutsim::core {
namespace {

using ::testing::HasSubstr;

const std::filesystem::path kScenes = std::filesystem::path(CUTSIM_TEST_DATA_DIR) / "scenes";

/// A fresh empty folder under the system's temporary folder.
std::filesystem::path freshDir(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      ("cutsim_test_output_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

std::string readText(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The integer value of attribute `name` in the first element that has it.
long attribute(const std::string& xml, const std::string& name) {
  const std::regex re(name + "=\"([0-9]+)\"");
  std::smatch m;
  if (!std::regex_search(xml, m, re)) return -1;
  return std::stol(m[1]);
}

/// The whitespace-separated values of the DataArray named `name` (the first one when name is
/// "", for the unnamed points array).
std::vector<std::string> dataArray(const std::string& xml, const std::string& name) {
  const std::string open = "<DataArray";
  std::size_t pos = 0;
  while ((pos = xml.find(open, pos)) != std::string::npos) {
    const std::size_t tagEnd = xml.find('>', pos);
    const std::string tag = xml.substr(pos, tagEnd - pos);
    if (tag.find("Name=\"" + name + "\"") != std::string::npos) {
      const std::size_t close = xml.find("</DataArray>", tagEnd);
      std::istringstream body(xml.substr(tagEnd + 1, close - tagEnd - 1));
      std::vector<std::string> values;
      std::string v;
      while (body >> v) values.push_back(v);
      return values;
    }
    pos = tagEnd;
  }
  ADD_FAILURE() << "no DataArray " << name;
  return {};
}

/// Tags open and close in order (a minimal well-formedness check).
void expectBalanced(const std::string& xml) {
  std::vector<std::string> stack;
  const std::regex tag("<(/?)([A-Za-z]+)[^>]*?(/?)>");
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), tag); it != std::sregex_iterator();
       ++it) {
    const std::smatch& m = *it;
    if (m[3] == "/") continue;  // self-closing
    if (m[1] == "/") {
      ASSERT_FALSE(stack.empty()) << "closing " << m[2] << " with nothing open";
      EXPECT_EQ(stack.back(), m[2]);
      stack.pop_back();
    } else {
      stack.push_back(m[2]);
    }
  }
  EXPECT_TRUE(stack.empty());
  EXPECT_EQ(xml.rfind("<?xml version=\"1.0\"?>\n<VTKFile ", 0), 0u);
}

/// The small scene, run for `steps` steps (the whole scene when negative).
struct SmallRun {
  Scene scene;
  std::unique_ptr<SceneRunner> runner;
  explicit SmallRun(long steps = -1) : scene(loadScene(kScenes / "small.json")) {
    runner = std::make_unique<SceneRunner>(scene);
    runner->start();
    while (!runner->finished() && (steps < 0 || runner->currentStep() < steps)) runner->advance();
  }
};

TEST(Output, NumbersRoundTrip) {
  for (double v : {0.0, 0.1, -1.5, 1e-300, 123456789.123456789, 1.0 / 3.0, -2.5e17}) {
    EXPECT_EQ(std::strtod(formatNumber(v).c_str(), nullptr), v) << formatNumber(v);
  }
  EXPECT_EQ(formatNumber(0.1), "0.1");
  EXPECT_EQ(formatNumber(2.0), "2");
}

TEST(Output, SurfaceVtpParsesBack) {
  SmallRun run(12);  // after the first cut and the removal
  const Simulation& sim = run.runner->simulation();
  std::ostringstream out;
  writeSurfaceVtp(out, sim);
  const std::string xml = out.str();
  expectBalanced(xml);
  const std::size_t n = sim.topology().numPoints(), t = sim.topology().numTriangles();
  EXPECT_EQ(attribute(xml, "NumberOfPoints"), long(n));
  EXPECT_EQ(attribute(xml, "NumberOfPolys"), long(t));
  EXPECT_EQ(dataArray(xml, "position").size(), 3 * n);
  EXPECT_EQ(dataArray(xml, "velocity").size(), 3 * n);
  EXPECT_EQ(dataArray(xml, "rest_position").size(), 3 * n);
  EXPECT_EQ(dataArray(xml, "slot").size(), n);
  EXPECT_EQ(dataArray(xml, "strain").size(), t);
  const auto connectivity = dataArray(xml, "connectivity");
  const auto offsets = dataArray(xml, "offsets");
  ASSERT_EQ(connectivity.size(), 3 * t);
  ASSERT_EQ(offsets.size(), t);
  EXPECT_EQ(offsets.back(), std::to_string(3 * t));
  for (const std::string& c : connectivity) EXPECT_LT(std::stoul(c), n);
  // Positions round-trip: the first point's x is the state's.
  const std::vector<PointId> live = sim.topology().points();
  EXPECT_EQ(std::strtod(dataArray(xml, "position")[0].c_str(), nullptr),
            sim.state().x()[3 * live[0].idx()]);
}

TEST(Output, BordersAreTheEdgesOfOneTriangleAndLipsTheOpenedOnes) {
  // Before any action: the border is the unit square's outline, with no lip; after the cut from
  // the side (t = 0.05) and the removal of a disc (t = 0.1): lips, all inside the square.
  const OriginalBorder original = [] {
    SmallRun run(0);
    return restBorder(run.runner->simulation().topology());
  }();
  ASSERT_EQ(original.segments.size(), 4u * 8u);  // the 9 x 9 grid's outline
  for (long steps : {1L, 12L}) {
    SmallRun run(steps);
    const Simulation& sim = run.runner->simulation();
    const topology::Topology& topo = sim.topology();
    // Independent border: edges used by exactly one triangle.
    std::map<std::pair<PointId, PointId>, int> uses;
    for (topology::TriangleId t : topo.triangles()) {
      const auto v = topo.triangleVertices(t);
      for (int i = 0; i < 3; ++i) {
        PointId a = v[std::size_t(i)], b = v[std::size_t((i + 1) % 3)];
        ++uses[{std::min(a, b), std::max(a, b)}];
      }
    }
    std::set<std::pair<PointId, PointId>> expected;
    for (const auto& [e, n] : uses)
      if (n == 1) expected.insert(e);
    const std::vector<BorderEdge> border = borderEdges(topo, original);
    std::set<std::pair<PointId, PointId>> got;
    std::size_t lips = 0;
    auto onSquare = [](const topology::Vec3& p) {
      return std::abs(p[0]) < 1e-12 || std::abs(p[0] - 1) < 1e-12 || std::abs(p[1]) < 1e-12 ||
             std::abs(p[1] - 1) < 1e-12;
    };
    for (const BorderEdge& b : border) {
      got.insert({std::min(b.a, b.b), std::max(b.a, b.b)});
      const topology::Vec3 p = topo.restPosition(b.a), q = topo.restPosition(b.b);
      const topology::Vec3 mid{(p[0] + q[0]) / 2, (p[1] + q[1]) / 2, 0.0};
      // On the outline: both ends on one side of the square (the midpoint with them).
      const bool outline = onSquare(p) && onSquare(q) && onSquare(mid);
      EXPECT_EQ(b.lip, !outline) << "edge " << b.a << "-" << b.b;
      lips += b.lip;
    }
    EXPECT_EQ(got, expected);
    if (steps == 1)
      EXPECT_EQ(lips, 0u);
    else
      EXPECT_GE(lips, 8u);
    std::ostringstream out;
    writeBordersVtp(out, sim, original);
    const std::string xml = out.str();
    expectBalanced(xml);
    EXPECT_EQ(attribute(xml, "NumberOfLines"), long(border.size()));
    EXPECT_EQ(dataArray(xml, "lip").size(), border.size());
  }
}

TEST(Output, SurfaceMarksFixedAndGraspedPoints) {
  SmallRun run(14);  // the grasp "pin" started at t = 0.12
  const Simulation& sim = run.runner->simulation();
  std::ostringstream out;
  writeSurfaceVtp(out, sim);
  const auto held = dataArray(out.str(), "constraint");
  const std::vector<PointId> live = sim.topology().points();
  ASSERT_EQ(held.size(), live.size());
  ASSERT_EQ(sim.numGrasps(), 1u);
  std::size_t fixed = 0, grasped = 0;
  for (std::size_t k = 0; k < live.size(); ++k) {
    const int expected = sim.fixed().contains(live[k])             ? 1
                         : sim.grasp(0).points().contains(live[k]) ? 2
                                                                   : 0;
    EXPECT_EQ(std::stoi(held[k]), expected);
    fixed += expected == 1;
    grasped += expected == 2;
  }
  EXPECT_EQ(fixed, sim.fixed().size());
  EXPECT_EQ(grasped, sim.grasp(0).points().size());
  EXPECT_GT(grasped, 0u);
}

TEST(Output, SpringNetworkVtpHasOneLinePerSpring) {
  SmallRun run(12);
  const Simulation& sim = run.runner->simulation();
  const auto* bending = run.runner->bendingField();
  ASSERT_NE(bending, nullptr);
  std::ostringstream out;
  writeNetworkVtp(out, sim, *bending);
  const std::string xml = out.str();
  expectBalanced(xml);
  EXPECT_EQ(attribute(xml, "NumberOfPoints"), long(sim.topology().numPoints()));
  EXPECT_EQ(attribute(xml, "NumberOfLines"), long(bending->numActiveSprings()));
  EXPECT_EQ(dataArray(xml, "connectivity").size(), 2 * bending->numActiveSprings());
  EXPECT_EQ(dataArray(xml, "offsets").size(), bending->numActiveSprings());
}

TEST(Output, PvdListsFramesWithTimes) {
  std::ostringstream out;
  writePvd(out, {{0.0, "a_000000.vtp"}, {0.25, "a_000001.vtp"}});
  const std::string xml = out.str();
  expectBalanced(xml);
  EXPECT_THAT(xml, HasSubstr("type=\"Collection\""));
  EXPECT_THAT(
      xml, HasSubstr("<DataSet timestep=\"0.25\" group=\"\" part=\"0\" file=\"a_000001.vtp\"/>"));
  const std::regex dataset("<DataSet ");
  EXPECT_EQ(
      std::distance(std::sregex_iterator(xml.begin(), xml.end(), dataset), std::sregex_iterator()),
      2);
}

TEST(Output, WriterProducesFramesCollectionsAndCsv) {
  const std::filesystem::path dir = freshDir("writer");
  SmallRun run(0);
  SceneRunner& runner = *run.runner;
  {
    OutputWriter writer(dir, run.scene.output, run.scene.forceFieldLabels(),
                        run.scene.graspNames());
    writer.record(runner.simulation(), {0, 0.0, {}}, false);
    while (!runner.finished()) {
      const StepStats stats = runner.advance();
      writer.record(runner.simulation(), {runner.currentStep(), runner.time(), stats},
                    runner.finished());
    }
    // The CSV is complete only when the run is: until then it has a temporary name.
    EXPECT_FALSE(std::filesystem::exists(dir / "steps.csv"));
    writer.finish();
    EXPECT_EQ(writer.framesWritten(), 7u);  // steps 0, 5, ..., 30
  }
  for (int i = 0; i < 7; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "%06d", i);
    EXPECT_TRUE(std::filesystem::exists(dir / ("surface_" + std::string(name) + ".vtp")));
    EXPECT_TRUE(std::filesystem::exists(dir / ("springs_" + std::string(name) + ".vtp")));
    // Every other field that draws has its own series.
    EXPECT_TRUE(
        std::filesystem::exists(dir / ("network_StretchSprings_" + std::string(name) + ".vtp")));
    EXPECT_TRUE(std::filesystem::exists(dir / ("frame_" + std::string(name) + ".obj")));
  }
  // No temporary file is left behind (nor the folder's lock).
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    EXPECT_NE(entry.path().filename().string().front(), '.') << entry.path();
  }
  const std::string pvd = readText(dir / "surface.pvd");
  expectBalanced(pvd);
  EXPECT_THAT(pvd, HasSubstr("timestep=\"0.3\""));
  EXPECT_THAT(pvd, HasSubstr("file=\"surface_000006.vtp\""));
  expectBalanced(readText(dir / "springs.pvd"));
  expectBalanced(readText(dir / "network_StretchSprings.pvd"));
  // The last surface frame: the counts of the final mesh.
  const std::string last = readText(dir / "surface_000006.vtp");
  EXPECT_EQ(attribute(last, "NumberOfPoints"), long(runner.simulation().topology().numPoints()));

  std::ifstream csv(dir / "steps.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_EQ(header,
            "time,kinetic_energy,potential_StretchSprings,potential_FastTriangularBendingSprings,"
            "gravity_energy,solver_iterations,solver_residual,solver_flags,newton_iterations,"
            "active_springs,points,edges,triangles,pin_fx,pin_fy,pin_fz");
  const std::size_t columns = std::count(header.begin(), header.end(), ',') + 1;
  std::string line;
  std::vector<std::string> rows;
  while (std::getline(csv, line)) rows.push_back(line);
  ASSERT_EQ(rows.size(), 31u);  // steps 0 .. 30
  for (const std::string& r : rows) {
    EXPECT_EQ(std::size_t(std::count(r.begin(), r.end(), ',')) + 1, columns) << r;
  }
  EXPECT_EQ(rows.front().substr(0, 4), "0,0,");
  EXPECT_EQ(rows.back().substr(0, 4), "0.3,");
  // The grasp pulls between 0.12 and 0.25: a non-zero reaction in between, zeros outside.
  EXPECT_EQ(rows[5].substr(rows[5].size() - 6), ",0,0,0");
  EXPECT_NE(rows[20].substr(rows[20].size() - 6), ",0,0,0");
  std::filesystem::remove_all(dir);
}

TEST(Output, AnEarlierRunsFilesGoAndAUsersStay) {
  const std::filesystem::path dir = freshDir("reuse");
  for (const char* name :
       {"surface_000099.vtp", "springs_000099.vtp", "network_X_000003.vtp", "obstacles_000001.vtp",
        "frame_000004.obj", "steps.csv", "surface.pvd", "springs.partial.pvd",
        ".surface_000100.vtp.tmp", ".steps.csv.tmp", "notes.txt", "final.obj", "surface.vtp"})
    std::ofstream(dir / name) << "old\n";
  SmallRun run(0);
  {
    OutputWriter writer(dir, run.scene.output, run.scene.forceFieldLabels(),
                        run.scene.graspNames());
    EXPECT_EQ(writer.replacedFiles(), 10u);
    writer.record(run.runner->simulation(), {0, 0.0, {}}, true);
    writer.finish();
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "surface_000099.vtp"));
  EXPECT_FALSE(std::filesystem::exists(dir / "frame_000004.obj"));
  EXPECT_TRUE(std::filesystem::exists(dir / "notes.txt"));
  EXPECT_TRUE(std::filesystem::exists(dir / "final.obj"));
  EXPECT_TRUE(std::filesystem::exists(dir / "surface.vtp"));
  EXPECT_EQ(readText(dir / "steps.csv").find("old"), std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST(Output, OneRunAtATimeInAFolder) {
  const std::filesystem::path dir = freshDir("lock");
  SmallRun run(0);
  OutputWriter first(dir, run.scene.output, run.scene.forceFieldLabels(), run.scene.graspNames());
  try {
    OutputWriter second(dir, run.scene.output, run.scene.forceFieldLabels(),
                        run.scene.graspNames());
    FAIL() << "a second writer took the folder";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("another run is writing into the output folder"));
  }
  EXPECT_TRUE(std::filesystem::exists(dir / ".steps.csv.tmp"));  // the first run's, untouched
  first.finish();
  {
    OutputWriter third(dir, run.scene.output, run.scene.forceFieldLabels(), run.scene.graspNames());
    third.finish();
  }
  std::filesystem::remove_all(dir);
}

TEST(Output, PartialCollectionsLagByAnEighthAtMost) {
  const std::filesystem::path dir = freshDir("partial");
  SmallRun run(0);
  OutputSettings every{};
  every.every = 1;
  every.springs = false;
  OutputWriter writer(dir, every, run.scene.forceFieldLabels(), run.scene.graspNames());
  SceneRunner& runner = *run.runner;
  writer.record(runner.simulation(), {0, 0.0, {}}, false);
  long rewrites = 0;
  std::string last;
  while (!runner.finished()) {
    const StepStats stats = runner.advance();
    writer.record(runner.simulation(), {runner.currentStep(), runner.time(), stats}, false);
    const std::string partial = readText(dir / "surface.partial.pvd");
    if (partial != last) ++rewrites;
    last = partial;
    std::size_t listed = 0;
    for (std::size_t at = partial.find("<DataSet"); at != std::string::npos;
         at = partial.find("<DataSet", at + 1))
      ++listed;
    const std::size_t frames = writer.framesWritten();
    EXPECT_GE(8 * listed, 7 * frames) << "after " << frames << " frames";
  }
  EXPECT_LT(rewrites, long(writer.framesWritten()));
  writer.finish();
  EXPECT_FALSE(std::filesystem::exists(dir / "surface.partial.pvd"));
  std::filesystem::remove_all(dir);
}

// The final collections are written under staging names and renamed only once all are written: a
// collection that cannot be written (a full disk; here a folder in the way of its temporary file)
// leaves no final collection beside the partial ones, and the run is not taken for complete.
TEST(Output, AFinalCollectionThatCannotBeWrittenLeavesNoneFinal) {
  const std::filesystem::path dir = freshDir("staged");
  SmallRun run(0);
  SceneRunner& runner = *run.runner;
  OutputWriter writer(dir, run.scene.output, run.scene.forceFieldLabels(), run.scene.graspNames());
  writer.record(runner.simulation(), {0, 0.0, {}}, false);
  while (!runner.finished()) {
    const StepStats stats = runner.advance();
    writer.record(runner.simulation(), {runner.currentStep(), runner.time(), stats},
                  runner.finished());
  }
  std::filesystem::create_directories(dir / ".springs.pvd.next.tmp");  // (surface's comes first)
  EXPECT_THROW(writer.finish(), Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "surface.pvd"));
  EXPECT_FALSE(std::filesystem::exists(dir / "surface.pvd.next"));
  EXPECT_FALSE(std::filesystem::exists(dir / "steps.csv"));
  EXPECT_TRUE(std::filesystem::exists(dir / "surface.partial.pvd"));
  std::filesystem::remove_all(dir);
}

TEST(Output, NoInfinityReachesTheCsv) {
  const std::filesystem::path dir = freshDir("finite");
  SmallRun run(2);
  OutputWriter writer(dir, run.scene.output, run.scene.forceFieldLabels(), run.scene.graspNames());
  StepStats stats;
  stats.residual = std::numeric_limits<double>::infinity();
  try {
    writer.record(run.runner->simulation(), {2, 0.02, stats}, false);
    FAIL() << "an infinite residual was written";
  } catch (const SolverError& e) {
    EXPECT_THAT(e.what(),
                HasSubstr("step 2 (t = 0.02): solver_residual is inf, not a finite number"));
  }
  stats.residual = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(writer.record(run.runner->simulation(), {2, 0.02, stats}, false), SolverError);
  // Nothing of the refused rows was written: the run stops without renaming the CSV.
  EXPECT_FALSE(std::filesystem::exists(dir / "steps.csv"));
  std::filesystem::remove_all(dir);
}

TEST(Output, AtomicWriteLeavesNothingOnFailure) {
  const std::filesystem::path dir = freshDir("atomic");
  EXPECT_THROW(writeFileAtomically(dir / "a.txt",
                                   [](std::ostream& o) {
                                     o << "half";
                                     throw Error("interrupted");
                                   }),
               Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "a.txt"));
  writeFileAtomically(dir / "a.txt", [](std::ostream& o) { o << "whole\n"; });
  EXPECT_EQ(readText(dir / "a.txt"), "whole\n");
  EXPECT_THROW(
      writeFileAtomically(dir / "no_such_folder" / "b.txt", [](std::ostream& o) { o << "x"; }),
      Error);
  std::filesystem::remove_all(dir);
}

TEST(Output, DumpFinal) {
  const std::filesystem::path dir = freshDir("dump");
  SmallRun run;
  const Simulation& sim = run.runner->simulation();
  dumpFinal(dir, sim, run.runner->bendingField());
  const topology::MeshData rest = topology::readMesh(dir / "final_rest.obj");
  const topology::MeshData current = topology::readMesh(dir / "final.obj");
  EXPECT_EQ(rest.points.size(), sim.topology().numPoints());
  EXPECT_EQ(current.points.size(), rest.points.size());
  EXPECT_EQ(rest.triangles, current.triangles);
  const std::vector<PointId> live = sim.topology().points();
  for (std::size_t i = 0; i < live.size(); ++i) {
    EXPECT_EQ(rest.points[i], sim.topology().restPosition(live[i]));  // 17 digits: exact
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(current.points[i][k], sim.state().x()[3 * live[i].idx() + k]);
  }
  const nlohmann::json j = nlohmann::json::parse(readText(dir / "final_forces.json"));
  EXPECT_EQ(j.at("forces").size(), live.size());
  EXPECT_EQ(j.at("active_springs").get<std::size_t>(),
            run.runner->bendingField()->numActiveSprings());
  EXPECT_EQ(j.at("area_weights"), "signed");
  EXPECT_EQ(j.at("bending_stiffness").get<double>(), 0.01);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cutsim::core
