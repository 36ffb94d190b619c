// Checkpoints of the topology: the archive format (sections with checksums, atomic writes, clear
// refusals) and Topology::save / Topology::load, which must give back the structure bit for bit,
// so that the same operations afterwards do the same things (same digests, same events).
#include <gtest/gtest.h>
#include <zlib.h>

#include <Eigen/Core>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include "cutsim/base/archive.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/fixtures.hpp"
#include "support/mirror_observer.hpp"
#include "support/random_ops.hpp"

namespace cutsim::test {
namespace {

using topology::Topology;

std::filesystem::path tempFile(const std::string& name) {
  const auto dir =
      std::filesystem::temp_directory_path() /
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

// Members declared once (fields): each stored as its type says, the same bytes as the calls
// written out by hand, and read back into the same values.
TEST(Archive, FieldsStoreEachMemberByItsTypeAndReadItBack) {
  const long count = -42;
  const std::size_t slots = 7;
  const bool on = true;
  const double time = 0.1 + 0.2;
  const int small = 3;
  const std::uint32_t revision = 9;
  const std::string name = "forceps";
  const std::vector<double> warm = {1.5, -0.0, 1e-300};
  const auto byHand = tempFile("by_hand.ckpt"), declared = tempFile("declared.ckpt");
  {
    ArchiveWriter w;
    w.begin("m");
    w.i64(count);
    w.u64(slots);
    w.boolean(on);
    w.f64(time);
    w.i64(small);
    w.u64(revision);
    w.str(name);
    w.f64s(warm);
    w.save(byHand);
  }
  {
    ArchiveWriter w;
    w.begin("m");
    fields(w, count, slots, on, time, small, revision, name, warm);
    w.save(declared);
  }
  EXPECT_EQ(slurp(byHand), slurp(declared));
  ArchiveReader r(declared);
  r.open("m");
  long c = 0;
  std::size_t n = 0;
  bool b = false;
  double t = 0;
  int i = 0;
  std::uint32_t v = 0;
  std::string s;
  std::vector<double> ws;
  fields(r, c, n, b, t, i, v, s, ws);
  r.close();
  EXPECT_EQ(c, count);
  EXPECT_EQ(n, slots);
  EXPECT_EQ(b, on);
  EXPECT_EQ(t, time);
  EXPECT_EQ(i, small);
  EXPECT_EQ(v, revision);
  EXPECT_EQ(s, name);
  EXPECT_EQ(ws, warm);
  EXPECT_TRUE(std::signbit(ws[1]));
}

// Tables of records (std::vector and Eigen vectors) and fixed tables (slots): the bytes a count
// and raw values written by hand give; a record's padding written as zeros whatever the memory
// held; a fixed table of another size, and a count past the section's end, refused by name.
struct Padded {
  std::uint8_t kind;  // three bytes of padding follow
  std::int32_t index;
  double value;
};
static_assert(sizeof(Padded) == 16);

TEST(Archive, TablesAndSlotsAreCountsAndBytesWithTheirPaddingZeroed) {
  std::vector<Padded> records(3);
  for (Padded& r : records) std::memset(static_cast<void*>(&r), 0xAB, sizeof r);  // dirty padding
  for (std::size_t i = 0; i < records.size(); ++i) {
    records[i].kind = std::uint8_t(i);
    records[i].index = -int(i);
    records[i].value = 0.5 * double(i);
  }
  const Eigen::VectorXd warm = Eigen::VectorXd::LinSpaced(4, -1.0, 2.0);
  std::vector<float> fixed = {1.f, 2.f, 3.f};
  const auto byHand = tempFile("by_hand.ckpt"), declared = tempFile("declared.ckpt");
  {
    ArchiveWriter w;
    w.begin("t");
    w.u64(records.size());
    for (const Padded& r : records) {
      unsigned char bytes[16] = {};
      std::memcpy(bytes, &r.kind, 1);
      std::memcpy(bytes + 4, &r.index, 4);
      std::memcpy(bytes + 8, &r.value, 8);
      w.raw(bytes, sizeof bytes);
    }
    w.f64s(std::span<const double>(warm.data(), 4));
    w.u64(fixed.size());
    w.raw(fixed.data(), fixed.size() * sizeof(float));
    w.save(byHand);
  }
  {
    ArchiveWriter w;
    w.begin("t");
    fields(w, records, warm, slots(std::span<const float>(fixed), "fixed"));
    w.save(declared);
  }
  EXPECT_EQ(slurp(byHand), slurp(declared));
  {
    ArchiveReader r(declared);
    r.open("t");
    std::vector<Padded> back;
    Eigen::VectorXd warmBack;
    std::vector<float> fixedBack(3);
    fields(r, back, warmBack, slots(std::span<float>(fixedBack), "fixed"));
    r.close();
    ASSERT_EQ(back.size(), records.size());
    for (std::size_t i = 0; i < back.size(); ++i) {
      EXPECT_EQ(back[i].kind, records[i].kind);
      EXPECT_EQ(back[i].index, records[i].index);
      EXPECT_EQ(back[i].value, records[i].value);
    }
    EXPECT_EQ(warmBack, warm);
    EXPECT_EQ(fixedBack, fixed);
  }
  {
    ArchiveReader r(declared);
    r.open("t");
    std::vector<Padded> back;
    Eigen::VectorXd warmBack;
    std::vector<float> four(4);
    try {
      fields(r, back, warmBack, slots(std::span<float>(four), "the fixed table"));
      ADD_FAILURE() << "a fixed table of another size was read";
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find("the fixed table: 3 values saved, 4 slots"),
                std::string::npos)
          << e.what();
    }
  }
  const auto shortTable = tempFile("short.ckpt");
  {
    ArchiveWriter w;
    w.begin("t");
    w.u64(3);  // three records of 24 bytes announced, 48 bytes held
    w.f64s(std::vector<double>(5, 1.0));
    w.save(shortTable);
  }
  ArchiveReader r(shortTable);
  r.open("t");
  std::vector<Eigen::Vector3d> wide;
  try {
    fields(r, wide);
    ADD_FAILURE() << "a table running past its section was read";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("a table of 3 records of 24 bytes runs past"),
              std::string::npos)
        << e.what();
  }
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
  refused(version,
          "checkpoint format 9, this cutsim reads format " + std::to_string(kArchiveFormat));
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

/// The topology section of a saved 4 x 4 grid, to be altered: offsets into its payload.
struct SavedGrid {
  std::filesystem::path path;
  std::string bytes;
  static constexpr std::size_t kPayload = 16 + 16;  // file header, the section's tag and length
  static constexpr std::uint64_t nv = 16, ne = 33;
  std::uint64_t length = 0;

  SavedGrid() : path(tempFile("topology.ckpt")) {
    Topology a(grid(4, 1.0));
    ArchiveWriter w;
    a.save(w);
    w.save(path);
    bytes = slurp(path);
    std::memcpy(&length, bytes.data() + 16 + 8, 8);
  }
  /// The n-th of the 12 scalars that open the section (sizes, revision, counters, free lists,
  /// the garbage flag, the locator's cell size).
  static std::size_t scalar(int n) { return kPayload + 8 * std::size_t(n); }
  /// Halfedge i's links (face, target, next, prev), after the scalars and the point arrays.
  static std::size_t halfedge(std::size_t i) {
    return scalar(12) + (8 + nv * 4) + (8 + nv * 4) + (8 + 3 * nv * 8) + 8 + 16 * i;
  }
  template <class T>
  void set(std::size_t at, T value) {
    std::memcpy(bytes.data() + at, &value, sizeof value);
  }
  /// Writes the altered bytes with a checksum that holds, and loads them.
  std::string load() {
    const std::uint32_t c = std::uint32_t(
        crc32(0L, reinterpret_cast<const Bytef*>(bytes.data() + kPayload), uInt(length)));
    std::memcpy(bytes.data() + kPayload + length, &c, 4);
    spit(path, bytes);
    ArchiveReader r(path);
    try {
      Topology::load(r);
    } catch (const InvalidInput& e) {
      return e.what();
    }
    return "accepted";
  }
};

TEST(TopologyCheckpoint, ALoadedArchiveWhoseStructureDisagreesIsRefused) {
  // Archives whose checksums hold but whose structure is not one (written by something else):
  // the links and the free lists are checked before anything walks them.
  {
    SavedGrid g;
    EXPECT_EQ(g.load(), "accepted");  // unaltered
  }
  {
    SavedGrid g;
    std::uint32_t next = 0;
    std::memcpy(&next, g.bytes.data() + SavedGrid::halfedge(0) + 8, 4);
    g.set(SavedGrid::halfedge(0) + 8, std::uint32_t((next + 2) % (2 * SavedGrid::ne)));
    EXPECT_NE(g.load().find("section 'topology': the half-edge links do not agree"),
              std::string::npos);
  }
  {
    SavedGrid g;
    g.set(SavedGrid::scalar(7), std::uint64_t(0));  // the points' free list starts at a live point
    EXPECT_NE(g.load().find("section 'topology': the free list of points is broken"),
              std::string::npos);
  }
  {
    SavedGrid g;
    g.set(SavedGrid::scalar(8), std::uint64_t(1) << 40);  // beyond 32 bits
    EXPECT_NE(g.load().find("the free list of edges is broken"), std::string::npos);
  }
  {
    SavedGrid g;
    g.set(SavedGrid::halfedge(5), std::uint32_t(3));  // halfedge 5 claims another triangle
    const std::string m = g.load();
    EXPECT_NE(m.find("section 'topology': "), std::string::npos) << m;
    EXPECT_EQ(m.find("accepted"), std::string::npos);
  }
}

}  // namespace
}  // namespace cutsim::test
