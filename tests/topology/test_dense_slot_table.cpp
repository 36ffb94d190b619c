// DenseSlotTable against a brute-force twin: long random sequences of adds, replacements, removals,
// statuses, growth, point renumberings and slot renumberings, each checked against a std::map of
// slot -> (entry, flag) or status, with the table's own consistency check after every operation.
// Besides the contents, the order of the entries is what the force passes stream, so it is
// checked too: an append goes last, a removal moves only the last entry (into the hole), and a
// renumbering lays the entries out in slot order.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <numeric>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "cutsim/topology/dense_slot_table.hpp"
#include "support/fixtures.hpp"

namespace cutsim::test {
namespace {

using topology::DenseSlotTable;
using topology::EdgeId;
using topology::Index;
using topology::kInvalidIndex;
using topology::Renumbering;
using topology::Topology;
using topology::TriangleId;

struct TestEntry {
  std::array<std::uint32_t, 3> p;  // point ids
  double w;                        // a payload
  bool operator==(const TestEntry&) const = default;
};

enum class TestStatus : std::uint8_t { A, B, Empty };

/// With a flag and an empty status that is not 0.
struct FlagTraits {
  using Status = TestStatus;
  static constexpr Status kEmpty = TestStatus::Empty;
  static constexpr bool kHasFlag = true;
  static constexpr std::string_view kNoun = "entry";
  static constexpr std::string_view kNouns = "entries";
  template <class F>
  static void forEachPoint(TestEntry& e, F&& f) {
    for (std::uint32_t& p : e.p) f(p);
  }
};

/// Without a flag, empty = 0.
enum class PlainStatus : std::uint8_t { Empty, Other };
struct PlainTraits {
  using Status = PlainStatus;
  static constexpr Status kEmpty = PlainStatus::Empty;
  static constexpr bool kHasFlag = false;
  static constexpr std::string_view kNoun = "entry";
  static constexpr std::string_view kNouns = "entries";
  template <class F>
  static void forEachPoint(TestEntry& e, F&& f) {
    for (std::uint32_t& p : e.p) f(p);
  }
};

/// What a slot holds in the twin: an entry (with its flag) or a status other than empty.
template <class Status>
struct RefSlot {
  bool hasEntry = false;
  TestEntry entry{};
  bool flag = false;
  Status status{};
};

template <class IdT, class Traits>
class Twin {
 public:
  using Table = DenseSlotTable<IdT, TestEntry, Traits>;
  using Status = typename Traits::Status;
  static constexpr std::uint32_t kPoints = 50;

  explicit Twin(std::uint64_t seed) : rng_(seed) {
    const std::size_t slots = pick(0, 40);
    table_.reset(slots, slots);
    numSlots_ = slots;
  }

  void step() {
    const std::size_t op = pick(0, 99);
    if (op < 40) {
      set();
    } else if (op < 70) {
      setStatus();
    } else if (op < 80) {
      grow();
    } else if (op < 90) {
      remapPoints();
    } else {
      renumber();
    }
  }

  void check() const {
    std::vector<std::string> problems;
    table_.checkConsistency(problems, "");
    ASSERT_TRUE(problems.empty()) << problems.front();
    ASSERT_EQ(table_.numSlots(), numSlots_);
    std::size_t entries = 0;
    for (Index s = 0; s < numSlots_ + 3; ++s) {
      const IdT id(s);
      const auto it = ref_.find(s);
      if (it == ref_.end()) {
        EXPECT_TRUE(table_.isEmpty(id)) << "slot " << s;
        EXPECT_FALSE(table_.hasEntry(id)) << "slot " << s;
        EXPECT_EQ(table_.find(id), Table::kNoEntry) << "slot " << s;
        EXPECT_EQ(table_.status(id), Traits::kEmpty) << "slot " << s;
        continue;
      }
      ASSERT_LT(s, numSlots_);
      EXPECT_FALSE(table_.isEmpty(id)) << "slot " << s;
      ASSERT_EQ(table_.hasEntry(id), it->second.hasEntry) << "slot " << s;
      if (it->second.hasEntry) {
        ++entries;
        const Index i = table_.find(id);
        ASSERT_LT(i, table_.size());
        EXPECT_EQ(table_.entry(i), it->second.entry) << "slot " << s;
        EXPECT_EQ(Index(table_.slotOf(i)), s);
        EXPECT_EQ(table_.flag(i), Traits::kHasFlag && it->second.flag) << "slot " << s;
      } else {
        EXPECT_EQ(table_.status(id), it->second.status) << "slot " << s;
      }
    }
    EXPECT_EQ(table_.size(), entries);
    EXPECT_EQ(table_.entries().size(), entries);
  }

  std::size_t size() const { return table_.size(); }

 private:
  std::size_t pick(std::size_t lo, std::size_t hi) {
    return std::uniform_int_distribution<std::size_t>(lo, hi)(rng_);
  }
  TestEntry randomEntry() {
    return {{std::uint32_t(pick(0, kPoints - 1)), std::uint32_t(pick(0, kPoints - 1)),
             std::uint32_t(pick(0, kPoints - 1))},
            double(pick(0, 1000000))};
  }
  /// The entry index of every slot with an entry.
  std::map<Index, Index> indices() const {
    std::map<Index, Index> out;
    for (const auto& [s, r] : ref_)
      if (r.hasEntry) out[s] = table_.find(IdT(s));
    return out;
  }

  void set() {
    const Index s = Index(pick(0, numSlots_ + 2));  // sometimes beyond: the table grows
    const TestEntry e = randomEntry();
    const bool flag = pick(0, 1) == 1;
    const std::map<Index, Index> before = indices();
    const std::size_t sizeBefore = table_.size();
    const Index i = table_.set(IdT(s), e, flag);
    RefSlot<Status>& r = ref_[s];
    const bool had = r.hasEntry;
    r = {true, e, flag, {}};
    numSlots_ = std::max<std::size_t>(numSlots_, s + 1);
    // Replaced in place, or appended last; no other entry moves.
    if (had) {
      EXPECT_EQ(i, before.at(s));
    } else {
      EXPECT_EQ(i, sizeBefore);
    }
    for (const auto& [slot, index] : before) EXPECT_EQ(table_.find(IdT(slot)), index);
  }

  void setStatus() {
    const Index s = Index(pick(0, numSlots_ + 2));
    const int n = Traits::kHasFlag ? 3 : 2;
    const Status st = static_cast<Status>(pick(0, n - 1));
    const std::map<Index, Index> before = indices();
    const std::size_t sizeBefore = table_.size();
    table_.setStatus(IdT(s), st);
    numSlots_ = std::max<std::size_t>(numSlots_, s + 1);
    if (st == Traits::kEmpty) {
      ref_.erase(s);
    } else {
      ref_[s] = {false, {}, false, st};
    }
    // A removal moves only the last entry, into the hole.
    const auto removed = before.find(s);
    for (const auto& [slot, index] : before) {
      if (slot == s) continue;
      const Index expected =
          removed != before.end() && index == sizeBefore - 1 ? removed->second : index;
      EXPECT_EQ(table_.find(IdT(slot)), expected) << "slot " << slot;
    }
  }

  void grow() {
    const std::size_t n = numSlots_ + pick(0, 5);
    table_.growTo(n);
    numSlots_ = std::max(numSlots_, n);
  }

  void remapPoints() {
    std::vector<Index> map(kPoints);
    std::iota(map.begin(), map.end(), Index(0));
    std::shuffle(map.begin(), map.end(), rng_);
    std::vector<std::string> problems;
    table_.remapPoints(Renumbering{map, kPoints}, problems);
    EXPECT_TRUE(problems.empty());
    for (auto& [s, r] : ref_)
      if (r.hasEntry)
        for (std::uint32_t& p : r.entry.p) p = map[p];
  }

  void renumber() {
    // Every non-empty slot gets a new index; empty ones are dropped or kept at random.
    std::vector<Index> kept;
    for (Index s = 0; s < numSlots_; ++s)
      if (ref_.count(s) || pick(0, 2) == 0) kept.push_back(s);
    const std::size_t newSize = kept.size() + pick(0, 2);  // a few fresh empty slots at the end
    std::vector<Index> targets(kept.size());
    std::iota(targets.begin(), targets.end(), Index(0));
    std::shuffle(targets.begin(), targets.end(), rng_);
    std::vector<Index> oldToNew(numSlots_, kInvalidIndex);
    for (std::size_t k = 0; k < kept.size(); ++k) oldToNew[kept[k]] = targets[k];
    std::vector<std::string> problems;
    table_.renumber(Renumbering{oldToNew, Index(newSize)}, problems);
    EXPECT_TRUE(problems.empty());
    std::map<Index, RefSlot<Status>> next;
    for (const auto& [s, r] : ref_) next[oldToNew[s]] = r;
    ref_ = std::move(next);
    numSlots_ = newSize;
    // The entries in slot order.
    for (std::size_t i = 1; i < table_.size(); ++i)
      EXPECT_LT(Index(table_.slotOf(i - 1)), Index(table_.slotOf(i)));
  }

  std::mt19937_64 rng_;
  Table table_;
  std::map<Index, RefSlot<Status>> ref_;  // slots absent: empty
  std::size_t numSlots_ = 0;
};

template <class IdT, class Traits>
void runTwin(std::uint64_t seed, int steps) {
  Twin<IdT, Traits> twin(seed);
  std::size_t largest = 0;
  for (int k = 0; k < steps; ++k) {
    twin.step();
    ASSERT_NO_FATAL_FAILURE(twin.check()) << "seed " << seed << ", step " << k;
    largest = std::max(largest, twin.size());
  }
  EXPECT_GT(largest, 5u);  // the sequence did build a table
}

TEST(DenseSlotTable, RandomSequencesWithFlagEqualTheTwin) {
  for (std::uint64_t seed = 1; seed <= 12; ++seed) runTwin<EdgeId, FlagTraits>(seed, 600);
}

TEST(DenseSlotTable, RandomSequencesWithoutFlagEqualTheTwin) {
  for (std::uint64_t seed = 101; seed <= 112; ++seed) runTwin<TriangleId, PlainTraits>(seed, 600);
}

TEST(DenseSlotTable, ReportsWhatItCannotMap) {
  DenseSlotTable<EdgeId, TestEntry, FlagTraits> table;
  table.reset(4, 4);
  table.set(EdgeId(1), {{0, 1, 2}, 1.0});
  table.set(EdgeId(2), {{1, 2, 3}, 2.0}, true);
  table.setStatus(EdgeId(3), TestStatus::B);
  // Point 3 has no new index: reported, left as it was; the others mapped.
  const std::vector<Index> points{3, 2, 1, kInvalidIndex};
  std::vector<std::string> problems;
  table.remapPoints(Renumbering{points, 3}, problems);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].find("dead point 3"), std::string::npos) << problems[0];
  EXPECT_EQ(table.entry(table.find(EdgeId(2))).p, (std::array<std::uint32_t, 3>{2, 1, 3}));
  // Edge 3 holds a status but gets no new index: reported, dropped; edge 2's entry survives
  // with its flag.
  problems.clear();
  const std::vector<Index> edges{kInvalidIndex, 1, 0, kInvalidIndex};
  table.renumber(Renumbering{edges, 2}, problems);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].find("edge 3"), std::string::npos) << problems[0];
  ASSERT_EQ(table.size(), 2u);
  EXPECT_EQ(Index(table.slotOf(0)), 0u);
  EXPECT_TRUE(table.flag(0));
  EXPECT_FALSE(table.flag(1));
  EXPECT_EQ(table.numSlots(), 2u);
}

// Every change to the entries moves revision() on (a split of the entries among threads is
// rebuilt from it: forcefields/src/parallel.hpp); reading does not.
TEST(DenseSlotTable, CountsEveryChangeToItsEntries) {
  DenseSlotTable<EdgeId, TestEntry, FlagTraits> table;
  std::uint64_t seen = table.revision();
  auto changed = [&](const char* what) {
    EXPECT_GT(table.revision(), seen) << what;
    seen = table.revision();
  };
  table.reset(4, 4);
  changed("reset");
  table.set(EdgeId(1), {{0, 1, 2}, 1.0});
  changed("set, appended");
  table.set(EdgeId(1), {{0, 1, 3}, 1.0});
  changed("set, replaced in place (other points, same count)");
  table.set(EdgeId(2), {{1, 2, 3}, 2.0}, true);
  changed("set with a flag");
  table.setStatus(EdgeId(1), TestStatus::B);
  changed("setStatus, removing an entry");
  (void)table.find(EdgeId(2));
  (void)table.entries();
  EXPECT_EQ(table.revision(), seen) << "reading";
  std::vector<std::string> problems;
  table.remapPoints(Renumbering{std::vector<Index>{1, 0, 3, 2}, 4}, problems);
  changed("points renumbered");
  table.renumber(Renumbering{std::vector<Index>{0, 1, 2, 3}, 4}, problems);
  changed("slots renumbered");
  EXPECT_TRUE(problems.empty());
}

TEST(DenseSlotTable, ValidatesAgainstTheTopology) {
  const topology::MeshData mesh = grid(4);
  Topology topo(mesh.points, mesh.triangles);
  DenseSlotTable<EdgeId, TestEntry, FlagTraits> table;
  table.reset(topo.edgeCapacity(), topo.numEdges());
  for (EdgeId e : topo.edges()) {
    const topology::EdgeVertices v = topo.edgeVertices(e);
    table.set(e, {{v[0].idx(), v[1].idx(), v[0].idx()}, 0.0});
  }
  std::vector<std::string> problems;
  table.validate(topo, problems, "T: ");
  EXPECT_TRUE(problems.empty()) << problems.front();
  // A live edge without anything, then an entry on a point beyond the mesh.
  table.setStatus(EdgeId(0), TestStatus::Empty);
  table.validate(topo, problems, "T: ");
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].find("alive but not in the table"), std::string::npos) << problems[0];
  problems.clear();
  table.set(EdgeId(0), {{0, 1, 1000}, 0.0});
  table.validate(topo, problems, "T: ");
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].find("dead point 1000"), std::string::npos) << problems[0];
  EXPECT_EQ(problems[0].rfind("T: ", 0), 0u);
  // The bytes: 4 per slot and 4 + sizeof(Entry) per entry.
  EXPECT_DOUBLE_EQ(table.bytesPerSlot(),
                   (table.size() * (sizeof(TestEntry) + 4.0) + 4.0 * table.numSlots()) /
                       double(table.numSlots()));
}

}  // namespace
}  // namespace cutsim::test
