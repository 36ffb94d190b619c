// Checkpoints of the topology: the archive format (sections with checksums, atomic writes, clear
// refusals) and Topology::save / Topology::load, which must give back the structure bit for bit,
// so that the same operations afterwards do the same things (same digests, same events).
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstring>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "cutsim/topology/archive.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/fixtures.hpp"
#include "support/mirror_observer.hpp"
#include "support/random_ops.hpp"

namespace cutsim::test {
namespace {

using topology::ArchiveReader;
using topology::ArchiveWriter;
using topology::Topology;

std::filesystem::path tempFile(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("cutsim_ckpt_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
                    ::testing::UnitTest::GetInstance()->current_test_info()->name());
  std::filesystem::create_directories(dir);
  return dir / name;
}

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void spit(const std::filesystem::path& p, const std::string& bytes) {
  std::ofstream(p, std::ios::binary) << bytes;
}

TEST(Archive, ValuesComeBackBitForBit) {
  const auto path = tempFile("values.ckpt");
  ArchiveWriter w;
  w.begin("a");
  w.u64(42);
  w.i64(-7);
  w.f64(0.1 + 0.2);
  w.f64(-0.0);
  w.boolean(true);
  w.str(std::string("with\0nul", 8));
  w.begin("b");
  w.f64s(std::vector<double>{1e-320, 1.7976931348623157e308});
  w.u32s(std::vector<std::uint32_t>{0, 4294967295u});
  w.save(path);
  ArchiveReader r(path);
  EXPECT_TRUE(r.has("a"));
  EXPECT_FALSE(r.has("c"));
  r.open("b");  // any order
  EXPECT_EQ(r.f64s(), (std::vector<double>{1e-320, 1.7976931348623157e308}));
  EXPECT_EQ(r.u32s(), (std::vector<std::uint32_t>{0, 4294967295u}));
  r.close();
  r.open("a");
  EXPECT_EQ(r.u64(), 42u);
  EXPECT_EQ(r.i64(), -7);
  EXPECT_EQ(r.f64(), 0.1 + 0.2);
  EXPECT_TRUE(std::signbit(r.f64()));
  EXPECT_TRUE(r.boolean());
  EXPECT_EQ(r.str(), std::string("with\0nul", 8));
  r.close();
  EXPECT_FALSE(std::filesystem::exists(path.parent_path() / ".values.ckpt.tmp"));
}

TEST(Archive, DamagedForeignAndMisreadArchivesAreRefusedByName) {
  const auto path = tempFile("good.ckpt");
  ArchiveWriter w;
  w.begin("state");
  w.f64s(std::vector<double>(100, 1.5));
  w.save(path);
  const std::string good = slurp(path);
  auto refused = [&](const std::string& bytes, const std::string& expected) {
    const auto p = tempFile("bad.ckpt");
    spit(p, bytes);
    try {
      ArchiveReader r(p);
      r.open("state");
      r.f64s();
      r.u64();  // one value too many
      ADD_FAILURE() << "accepted; expected: " << expected;
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.where(), p.string());
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  std::string flipped = good;
  flipped[60] = char(flipped[60] ^ 0x10);
  refused(flipped, "section 'state' fails its checksum (the file is damaged)");
  refused(good.substr(0, good.size() - 30), "the file is truncated");
  refused(good.substr(0, good.size() - 20), "the file is truncated");
  refused("{\"mesh\": {}}\n and more text to be long enough", "not a cutsim checkpoint");
  std::string version = good;
  version[8] = 9;
  refused(version, "checkpoint format 9, this cutsim reads format 1");
  refused(good + "x", "holds data after its end mark");
  refused(good, "section 'state': a value runs past the section's end");
  // A section not read to its end.
  ArchiveReader r(path);
  r.open("state");
  EXPECT_THROW(r.close(), InvalidInput);
  EXPECT_THROW(ArchiveReader{path.parent_path()}, InvalidInput);
  EXPECT_THROW(ArchiveReader{path.parent_path() / "missing.ckpt"}, InvalidInput);
}

TEST(TopologyCheckpoint, SavedAndLoadedTopologiesAreTheSameAndBehaveTheSame) {
  // After random operations (dead slots, free lists, repairs), a topology saved and loaded has the
  // same digest, and the same further operations give both the same digests and the same events.
  for (std::uint64_t seed : {5u, 17u}) {
    Topology a(grid(8, kSheetSize, 0.25, seed));
    RandomTopologyOps opsA(a, seed);
    for (int i = 0; i < 40 && a.numTriangles() > 12; ++i) opsA.step();
    const auto path = tempFile("topology.ckpt");
    ArchiveWriter w;
    a.save(w);
    w.save(path);
    ArchiveReader r(path);
    Topology b = Topology::load(r);
    ASSERT_EQ(b.digest(), a.digest());
    EXPECT_EQ(b.numPoints(), a.numPoints());
    EXPECT_EQ(b.pointCapacity(), a.pointCapacity());
    EXPECT_EQ(b.revision(), a.revision());
    EventLog logA, logB;
    auto subA = a.subscribe(logA);
    auto subB = b.subscribe(logB);
    RandomTopologyOps opsB(b, seed);
    opsB.restore(opsA.save());
    for (int i = 0; i < 40 && a.numTriangles() > 12; ++i) {
      const RandomOp x = opsA.step(), y = opsB.step();
      ASSERT_EQ(x.what, y.what);
      ASSERT_EQ(a.digest(), b.digest()) << "after " << x.what;
    }
    EXPECT_EQ(logA.log, logB.log);
    EXPECT_FALSE(logA.log.empty());
    EXPECT_TRUE(b.validate().ok());
  }
}

TEST(TopologyCheckpoint, ALoadedArchiveWhoseStructureDisagreesIsRefused) {
  // An archive whose checksums hold but whose structure is not one (written by something else):
  // the links are checked before anything walks them.
  Topology a(grid(4, 1.0));
  const auto path = tempFile("topology.ckpt");
  ArchiveWriter w;
  a.save(w);
  w.save(path);
  std::string bytes = slurp(path);
  // Rewrite one halfedge's next link inside the payload, and its checksum with it.
  const std::size_t payload = 16 + 16;  // file header, then the section's tag and length
  std::uint64_t length = 0;
  std::memcpy(&length, bytes.data() + 16 + 8, 8);
  // The halfedge array follows 11 u64 scalars and the three point arrays; find it by its size.
  const std::uint64_t nv = 16, ne = 33;
  std::size_t at = payload + 11 * 8;
  at += 8 + nv * 4;       // vertex halfedges
  at += 8 + nv * 4;       // vertex flags
  at += 8 + 3 * nv * 8;   // rest positions
  at += 8;                // the halfedge array's length
  ASSERT_LT(at + 4 * 2 * ne * 4, payload + length);
  std::uint32_t next = 0;
  std::memcpy(&next, bytes.data() + at + 2 * 4, 4);  // halfedge 0's next
  next = (next + 2) % std::uint32_t(2 * ne);
  std::memcpy(bytes.data() + at + 2 * 4, &next, 4);
  const std::uint32_t c = std::uint32_t(crc32(0L, reinterpret_cast<const Bytef*>(bytes.data() + payload),
                                              uInt(length)));
  std::memcpy(bytes.data() + payload + length, &c, 4);
  spit(path, bytes);
  ArchiveReader r(path);
  try {
    Topology::load(r);
    FAIL() << "accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("section 'topology': "), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cutsim::test
