// cutsim_soak: a long run of random topology operations (not part of CI; scripts/soak.sh runs it
// under the sanitizers). Sheets of random size are cut, torn, split, carved, repaired and
// compacted by the tests' random operation generator, with every observer of the core subscribed
// (the state, the mass, every force field, contact, and the event mirror); a share of the
// operations is failed at a random failure point (the undo journal must leave the digest and every
// observer unchanged). After every operation the topology and every observer are validated. Prints
// progress every ten seconds and a summary at the end; exit code 1 on the first problem, with what
// is needed to replay it.
//
//   cutsim_soak [--ops N] [--seed S] [--inject P] [--validate-every K]
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <random>
#include <string>

#include "cutsim/core/mass.hpp"
#include "cutsim/core/state.hpp"
#include "cutsim/forcefields/contact.hpp"
#include "cutsim/forcefields/dihedral_bending.hpp"
#include "cutsim/forcefields/fast_triangular_bending_springs.hpp"
#include "cutsim/forcefields/stretch_springs.hpp"
#include "cutsim/forcefields/triangular_bending_springs.hpp"
#include "cutsim/forcefields/triangular_fem.hpp"
#include "cutsim/forcefields/triangular_fem_optim.hpp"
#include "cutsim/topology/failure_injection.hpp"
#include "cutsim/topology/topology.hpp"
#include "support/fixtures.hpp"
#include "support/mirror_observer.hpp"
#include "support/random_ops.hpp"

namespace {

using namespace cutsim;

struct Options {
  std::uint64_t ops = 1000000;
  std::uint64_t seed = 1;
  double inject = 0.25;  // share of the operations failed at a random point
  std::uint64_t validateEvery = 1;
};

[[noreturn]] void usage(const std::string& problem) {
  std::cerr
      << "cutsim_soak: " << problem
      << "\nusage: cutsim_soak [--ops N] [--seed S] [--inject P (0..1)] [--validate-every K]\n";
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) usage("'" + a + "' needs a value");
    const std::string v = argv[++i];
    char* end = nullptr;
    if (a == "--ops")
      o.ops = std::strtoull(v.c_str(), &end, 10);
    else if (a == "--seed")
      o.seed = std::strtoull(v.c_str(), &end, 10);
    else if (a == "--inject")
      o.inject = std::strtod(v.c_str(), &end);
    else if (a == "--validate-every")
      o.validateEvery = std::strtoull(v.c_str(), &end, 10);
    else
      usage("unknown option '" + a + "'");
    if (end == nullptr || *end != '\0') usage("'" + v + "' is not a number (" + a + ")");
  }
  if (!(o.inject >= 0 && o.inject <= 1)) usage("--inject must be in [0, 1]");
  if (o.validateEvery == 0) usage("--validate-every must be at least 1");
  return o;
}

struct Totals {
  std::uint64_t ops = 0, applied = 0, rejected = 0, skipped = 0, injected = 0, sheets = 0;
};

void report(const Totals& t, double seconds, const char* label) {
  std::cout << label << t.ops << " operations on " << t.sheets << " sheets in " << seconds << " s ("
            << (seconds > 0 ? double(t.ops) / seconds : 0.0) << " /s): " << t.applied
            << " applied, " << t.rejected << " refused, " << t.skipped << " skipped, " << t.injected
            << " failed on purpose and rolled back" << std::endl;
}

[[noreturn]] void fail(const std::string& what, std::uint64_t sheetSeed, int side, int step,
                       const std::string& op) {
  std::cerr << "cutsim_soak: FAILED: " << what << "\n  sheet seed " << sheetSeed << ", side "
            << side << ", operation " << step << ": " << op << "\n";
  std::exit(1);
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  std::mt19937_64 rng(o.seed);
  Totals totals;
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  double lastReport = 0;
  while (totals.ops < o.ops) {
    // A fresh sheet: 5 to 12 points a side, up to 400 operations on it.
    const std::uint64_t sheetSeed = rng();
    const int side = 5 + int(rng() % 8);
    topology::Topology t(test::grid(side, test::kSheetSize, 0.25, sheetSeed));
    test::MirrorObserver mirror(t);
    auto mirrorSub = t.subscribe(mirror);
    // Every observer the core has: each validate() compares it with a rebuild.
    forcefields::FastTriangularBendingSprings springs(t, {});
    core::MechanicalState state(t);
    core::LumpedMass mass(t, 1.0);
    forcefields::StretchSprings stretch(t, {});
    forcefields::TriangularFEMParameters fem;
    fem.restScale = 0.9;
    forcefields::TriangularFEM membrane(t, fem);
    forcefields::TriangularFEMOptim optim(t, {});
    forcefields::DihedralBending dihedral(t, {});
    forcefields::TriangularBendingSprings wingSprings(t, {});
    forcefields::ContactParameters contactParameters;
    contactParameters.thickness = 0.05;
    contactParameters.stiffness = 100.0;
    forcefields::Contact contact(t, contactParameters, {});
    test::RandomTopologyOps ops(t, sheetSeed);
    ++totals.sheets;
    for (int step = 0; step < 400 && totals.ops < o.ops && t.numTriangles() > 12; ++step) {
      const std::uint64_t digest = t.digest();
      const std::size_t transactions = mirror.transactions;
      const bool inject = std::uniform_real_distribution<double>(0, 1)(rng) < o.inject;
      // Half of the failures among an operation's first points (every kind has a few), half
      // anywhere within the first 400 (cuts and repairs pass hundreds).
      if (inject) topology::injectFailureAt(1 + rng() % (rng() % 2 ? 8 : 400));
      test::RandomOp op;
      try {
        op = ops.step();
      } catch (const std::exception& e) {
        topology::injectFailureAt(0);
        fail(std::string("an operation threw outside its contract: ") + e.what(), sheetSeed, side,
             step, "(see the trace: CUTSIM_TEST_TRACE=1)");
      }
      topology::injectFailureAt(0);
      ++totals.ops;
      const bool injected = op.outcome == test::RandomOp::Outcome::Rejected &&
                            op.what.find("injected failure") != std::string::npos;
      if (injected) {
        ++totals.injected;
      } else if (op.outcome == test::RandomOp::Outcome::Applied) {
        ++totals.applied;
      } else if (op.outcome == test::RandomOp::Outcome::Rejected) {
        ++totals.rejected;
      } else {
        ++totals.skipped;
      }
      if (op.outcome == test::RandomOp::Outcome::Rejected) {
        if (t.digest() != digest)
          fail("a refused operation changed the mesh", sheetSeed, side, step, op.what);
        if (mirror.transactions != transactions)
          fail("a refused operation delivered events", sheetSeed, side, step, op.what);
        if (op.what.find("internal error") != std::string::npos)
          fail("internal error", sheetSeed, side, step, op.what);
      }
      if (totals.ops % o.validateEvery == 0) {
        const topology::ValidationReport r = t.validate();
        if (!r.ok()) fail("validation failed:\n" + r.summary(), sheetSeed, side, step, op.what);
      }
      if (elapsed() - lastReport >= 10.0) {
        lastReport = elapsed();
        report(totals, lastReport, "  ... ");
      }
    }
  }
  report(totals, elapsed(), "cutsim_soak: ");
  return 0;
}
