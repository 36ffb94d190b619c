// The undo journal of topology transactions: a failure at any point of any operation leaves the
// mesh exactly as it was (Topology::digest(), which hashes every slot as stored) and delivers no
// event, so every observer stays as it was; and what happens when an observer throws while the
// events are delivered.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "cutsim/core/state.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/topology/failure_injection.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/fixtures.hpp"
#include "support/mirror_observer.hpp"
#include "support/random_ops.hpp"

namespace cutsim::test {
namespace {

using topology::Topology;

/// Disarms the failure injection when a test ends, whatever happens.
struct Disarm {
  ~Disarm() { topology::injectFailureAt(0); }
};

/// The failures injected into one random sequence and how the operations ended.
struct InjectionTally {
  std::size_t injected = 0;    ///< operations failed at an injected point (all rolled back)
  std::size_t operations = 0;  ///< operations that then ran to their end (applied or refused)
  std::size_t maxPoints = 0;   ///< the most failure points one operation passed
  std::array<std::size_t, kNumOpKinds> perKind{};  ///< injected failures per kind of operation
};

/// Runs `steps` random operations; before each is carried out, it is tried with a failure at its
/// 1st, 2nd, ... failure point until it runs through without reaching the armed point. After
/// every injected failure the digest, the transaction count and validate() (the half-edge
/// structure, the mirror and the bending springs against their rebuilds) are checked.
InjectionTally injectEverywhere(std::uint64_t seed, int side, int steps) {
  Topology t(grid(side, kSheetSize, 0.25, seed));
  MirrorObserver mirror(t);
  auto mirrorSub = t.subscribe(mirror);
  forcefields::FastTriangularBendingSprings springs(t, {});
  core::MechanicalState state(t);
  RandomTopologyOps ops(t, seed);
  Disarm disarm;
  InjectionTally tally;
  for (int step = 0; step < steps && t.numTriangles() > 12; ++step) {
    const RandomTopologyOps::Snapshot snapshot = ops.save();
    const std::uint64_t digest = t.digest();
    const std::size_t transactions = mirror.transactions;
    const std::size_t points = state.x().size();
    for (std::uint64_t k = 1;; ++k) {
      ops.restore(snapshot);
      topology::injectFailureAt(k);
      const RandomOp op = ops.step();
      const std::uint64_t passed = topology::failurePointsPassed();
      topology::injectFailureAt(0);
      const bool injected = op.outcome == RandomOp::Outcome::Rejected &&
                            op.what.find("injected failure") != std::string::npos;
      if (!injected) {
        // Ran to its end: then the armed point was never reached (nothing may swallow it).
        EXPECT_LT(passed, k) << "step " << step << ": " << op.what;
        tally.maxPoints = std::max<std::size_t>(tally.maxPoints, passed);
        ++tally.operations;
        break;
      }
      ++tally.injected;
      ++tally.perKind[static_cast<std::size_t>(op.kind)];
      EXPECT_EQ(t.digest(), digest)
          << "step " << step << ", failure at point " << k << ": " << op.what;
      EXPECT_EQ(mirror.transactions, transactions) << "an event was delivered: " << op.what;
      EXPECT_EQ(state.x().size(), points);
      const topology::ValidationReport r = t.validate();
      EXPECT_TRUE(r.ok()) << "step " << step << ", failure at point " << k << ": " << op.what
                          << "\n"
                          << r.summary();
      if (::testing::Test::HasFailure()) return tally;
    }
    const topology::ValidationReport r = t.validate();
    EXPECT_TRUE(r.ok()) << "after step " << step << "\n" << r.summary();
    if (::testing::Test::HasFailure()) return tally;
  }
  return tally;
}

TEST(UndoJournal, AFailureAtAnyPointOfAnyOperationChangesNothing) {
  InjectionTally total;
  for (std::uint64_t seed : {3u, 11u}) {
    const InjectionTally t = injectEverywhere(seed, 7, 60);
    ASSERT_FALSE(::testing::Test::HasFailure()) << "seed " << seed;
    total.injected += t.injected;
    total.operations += t.operations;
    total.maxPoints = std::max(total.maxPoints, t.maxPoints);
    for (std::size_t k = 0; k < total.perKind.size(); ++k) total.perKind[k] += t.perKind[k];
  }
  // Every kind that changes the mesh failed somewhere (addTriangles when a carve left one to put
  // back; compaction has one failure point, before it changes anything).
  for (int k = 0; k < kNumOpKinds; ++k) {
    if (static_cast<OpKind>(k) == OpKind::AddTriangles) continue;
    EXPECT_GT(total.perKind[static_cast<std::size_t>(k)], 0u)
        << opKindName(static_cast<OpKind>(k)) << " was never failed";
  }
  EXPECT_GT(total.injected, 1000u);
  RecordProperty("injected", std::to_string(total.injected));
  std::cout << "  " << total.injected << " injected failures over " << total.operations
            << " operations (at most " << total.maxPoints << " failure points in one)\n";
}

TEST(UndoJournal, TheDigestSeesEveryKindOfChange) {
  // The oracle above is only as good as the digest: it must change with each operation.
  Topology t(grid(4, 1.0));
  std::uint64_t d = t.digest();
  auto changed = [&] {
    const std::uint64_t n = t.digest();
    const bool c = n != d;
    d = n;
    return c;
  };
  t.splitEdge(t.edges().front(), 0.5);
  EXPECT_TRUE(changed());
  t.splitTriangle(t.triangles().back(), {0.2, 0.3, 0.5});
  EXPECT_TRUE(changed());
  t.removeTriangles(std::vector<topology::TriangleId>{t.triangles().front()});
  EXPECT_TRUE(changed());
  t.compact();
  EXPECT_TRUE(changed());
  EXPECT_FALSE(changed());
  // Two topologies built alike have the same digest.
  EXPECT_EQ(Topology(grid(4, 1.0)).digest(), Topology(grid(4, 1.0)).digest());
}

/// An observer that throws on the n-th event it receives.
class ThrowingObserver : public topology::TopologyObserver {
 public:
  explicit ThrowingObserver(int at) : at_(at) {}
  std::string observerName() const override { return "thrower"; }
  void onPointsCreated(const Topology&, const topology::PointsCreated&) override { hit(); }
  void onEdgesCreated(const Topology&, const topology::EdgesCreated&) override { hit(); }
  void onTrianglesCreated(const Topology&, const topology::TrianglesCreated&) override { hit(); }
  void onTransactionEnd(const Topology&, const topology::TransactionSummary&) override { hit(); }

 private:
  void hit() {
    if (++count_ == at_) throw std::runtime_error("the observer's own failure");
  }
  int at_, count_ = 0;
};

TEST(UndoJournal, AnObserverThatThrowsDoesNotStopTheOthers) {
  // The operation is carried out (its events cannot be taken back), every other observer, before
  // and after the thrower, receives every event, and the error names the observer and the event.
  for (int at = 1; at <= 4; ++at) {
    Topology t(grid(5, 1.0));
    MirrorObserver before(t), after(t);
    forcefields::FastTriangularBendingSprings springs(t, {});
    ThrowingObserver thrower(at);
    auto s1 = t.subscribe(before);
    auto s2 = t.subscribe(thrower);
    auto s3 = t.subscribe(after);
    const std::size_t points = t.numPoints();
    try {
      t.splitEdge(t.edges()[7], 0.5);
      FAIL() << "no error";
    } catch (const ObserverError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("observer 'thrower' failed on the event '"), std::string::npos) << m;
      EXPECT_NE(m.find("'splitEdge': the observer's own failure"), std::string::npos) << m;
      EXPECT_NE(m.find("the operation was carried out"), std::string::npos) << m;
    }
    EXPECT_EQ(t.numPoints(), points + 1);
    EXPECT_EQ(before.transactions, 1u);
    EXPECT_EQ(after.transactions, 1u);
    const topology::ValidationReport r = t.validate();
    EXPECT_TRUE(r.ok()) << r.summary();
    // The next operation goes on as usual.
    EXPECT_NO_THROW(t.splitEdge(t.edges()[3], 0.5));
    EXPECT_EQ(after.transactions, 2u);
  }
}

class ModifyingObserver : public topology::TopologyObserver {
 public:
  void onTransactionEnd(const Topology& t, const topology::TransactionSummary&) override {
    const_cast<Topology&>(t).splitEdge(t.edges().front(), 0.5);
  }
  std::string observerName() const override { return "modifier"; }
};

TEST(UndoJournal, AnObserverMayNotChangeTheTopology) {
  Topology t(grid(4, 1.0));
  ModifyingObserver m;
  auto sub = t.subscribe(m);
  try {
    t.splitEdge(t.edges()[2], 0.5);
    FAIL() << "no error";
  } catch (const ObserverError& e) {
    EXPECT_NE(std::string(e.what()).find("called from an observer while events are delivered"),
              std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(t.validate().ok());
}

TEST(UndoJournal, AnObserverUnsubscribedDuringDeliveryIsNotCalledAgain) {
  // One observer's handler ends another's subscription and destroys it: the delivery skips it.
  struct Closer : topology::TopologyObserver {
    std::unique_ptr<MirrorObserver>* victim = nullptr;
    topology::Subscription* victimSub = nullptr;
    void onPointsCreated(const Topology&, const topology::PointsCreated&) override {
      victimSub->reset();
      victim->reset();
    }
  };
  Topology t(grid(4, 1.0));
  auto mirror = std::make_unique<MirrorObserver>(t);
  Closer closer;
  auto s1 = t.subscribe(closer);
  auto s2 = t.subscribe(*mirror);
  closer.victim = &mirror;
  closer.victimSub = &s2;
  EXPECT_NO_THROW(t.splitEdge(t.edges()[4], 0.5));  // (under ASan: no use after free)
  EXPECT_EQ(mirror, nullptr);
  EXPECT_EQ(t.numObservers(), 1u);
}

TEST(UndoJournal, AFailureInALargeSheetChangesNothing) {
  // The journal records around the change only; what it puts back must still be all that changed.
  Topology t(grid(200, 1.0));
  Disarm disarm;
  const std::uint64_t d = t.digest();
  topology::injectFailureAt(3);  // the split's point made, its triangles detached: then fail
  EXPECT_THROW(t.splitEdge(t.edges()[20000], 0.5), topology::InjectedFailure);
  EXPECT_EQ(t.digest(), d);
}

}  // namespace
}  // namespace cutsim::test
