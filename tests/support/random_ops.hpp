#pragma once
// Random topology operations for the incremental tests of the observers (the force fields): one
// seeded generator of every kind of operation the topology offers, and the loop that checks the
// topology and every observer (topology.validate(): each incremental table against a rebuild)
// after every single operation of a long random sequence.
#include <array>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <random>
#include <string>
#include <vector>

#include "cutsim/topology/topology.hpp"

namespace cutsim::test {

/// The side of the square sheet the random sequences run on (rest coordinates [0, 10]^2).
inline constexpr double kSheetSize = 10.0;

/// The kinds of operation RandomTopologyOps draws.
enum class OpKind {
  SplitEdge,      ///< at a random parameter in (0.2, 0.8), a quarter of the time at the midpoint
  Tear,           ///< an interior edge
  Incise,         ///< a walk of 1 to 4 interior edges
  Carve,          ///< removeTriangles of 1 to 3 random triangles
  CutPolyline,    ///< 1 or 2 segments in the plane z = 0, turning by any angle
  Compact,        ///< renumbering
  SplitTriangle,  ///< at random barycentric weights
  AddTriangles,   ///< puts back a triangle carved since the last compaction
  Sew,            ///< the lips around a random lip point, within a random radius, at rest
};
inline constexpr int kNumOpKinds = 9;
const char* opKindName(OpKind kind);

/// What one random operation did.
struct RandomOp {
  enum class Outcome {
    Applied,   ///< the topology carried it out
    Rejected,  ///< the topology threw TopologyError (and, by its contract, changed nothing)
    Skipped,   ///< not attempted: the mesh offered nothing to do it on
  };
  OpKind kind = OpKind::SplitEdge;
  Outcome outcome = Outcome::Applied;
  /// The call with its arguments (17 digits), enough to replay it; a rejected operation ends with
  /// " rejected: <message>", a skipped one with " skipped (<reason>)".
  std::string what;
};

/// Draws and applies random operations to a topology. Rejections (TopologyError) do not escape:
/// they are reported in the returned RandomOp. With the environment variable CUTSIM_TEST_TRACE
/// set, each operation is printed to stderr before it runs, to locate a crash.
class RandomTopologyOps {
 public:
  /// The topology's rest positions must span [0, sheetSize]^2 in x and y (test::grid's `size`):
  /// cut polylines start and stay inside it, 3% of it away from the border.
  RandomTopologyOps(topology::Topology& t, std::uint64_t seed, double sheetSize = kSheetSize);

  RandomOp step();

  /// What the next step() depends on besides the topology: draws after restore(save()) repeat.
  struct Snapshot {
    std::mt19937_64 rng;
    std::vector<topology::TriangleVertices> removed;
  };
  Snapshot save() const { return {rng_, removed_}; }
  void restore(const Snapshot& s) {
    rng_ = s.rng;
    removed_ = s.removed;
  }

 private:
  /// Writes the call into `what` and carries it out; false when skipped.
  bool apply(OpKind kind, std::ostringstream& what);
  void announce(const std::ostringstream& what) const;
  int pick(int lo, int hi);
  /// The quality repair (target 20 degrees) half of the time, none otherwise.
  topology::RepairOptions maybeRepair();
  /// A random live edge (interior only if asked), kInvalidIndex if there is none.
  topology::EdgeId randomEdge(bool interior);
  /// A short walk (1 to 4 edges) along interior edges, without repeating a vertex.
  std::vector<topology::PointId> randomPath();

  topology::Topology& t_;
  std::mt19937_64 rng_;
  double size_;
  std::vector<topology::TriangleVertices> removed_;  // cleared by compaction (ids change)
  bool trace_;
};

/// How many operations of each kind a sequence applied, saw rejected and skipped.
struct OpTally {
  std::array<int, kNumOpKinds> applied{}, rejected{}, skipped{};
  void add(const RandomOp& op);
  int totalApplied() const;
  std::string summary() const;  ///< "splitEdge 12/3/0, tear ..." (applied/rejected/skipped)
};

/// The parameters of one random sequence: the seed of the sheet and of the operations, the
/// sheet's number of vertices per side, and the number of operations.
struct SequenceCase {
  std::uint64_t seed;
  int gridSide;
  int steps;
};
/// Readable test names ("seed 1, grid 8, 150 steps") instead of the bytes of the struct.
void PrintTo(const SequenceCase& c, std::ostream* os);

/// The flat sheet a sequence runs on: test::grid(c.gridSide, kSheetSize, 0.25, c.seed), jittered
/// so that rest lengths and hinges differ and a table entry mixed up with another shows.
topology::MeshData sequenceSheet(const SequenceCase& c);

/// Applies up to `steps` random operations drawn from `seed` to `topo`, stopping early once a
/// dozen triangles or fewer are left (carving and cuts eat the sheet; on what remains most
/// operations would be rejected). After every single operation, applied or not, it asserts that
/// topo.validate() passes (the half-edge structure and every observer's validate(), i.e. each
/// incremental table equals a rebuild), that a rejected operation changed no count, and then calls
/// `check` for the test's own assertions, under a trace naming the step and the operation (a fatal
/// failure in `check` ends the sequence). At the end it expects more than a quarter of the steps
/// to have been applied, and every kind of operation but AddTriangles at least once. Call it
/// inside ASSERT_NO_FATAL_FAILURE.
void runRandomOps(topology::Topology& topo, std::uint64_t seed, int steps,
                  const std::function<void(const RandomOp&)>& check = {});

}  // namespace cutsim::test
