#pragma once
// The ForceField interface: what every force field of cutsim (bending springs, stretch springs, the
// nonlinear dihedral bending model, ...) implements, and the matrix accumulators used to assemble
// stiffness and damping matrices.
//
// Names, for SOFA users:
//
//   cutsim                         SOFA (core::behavior::ForceField<DataTypes>)
//   -----------------------------  --------------------------------------------------------------
//   addForce(x, v, f)              addForce(mparams, f, x, v): f += F(x, v)
//   addDForce(x, dx, df, k, b)     addDForce(mparams, df, dx): df += (kFactor K + bFactor B) dx,
//                                  with kFactor = mparams->kFactor(), bFactor = mparams->bFactor()
//   potentialEnergy(x)             getPotentialEnergy(mparams, x) (SOFA returns a value cached by
//                                  the last addForce; cutsim always computes it from x)
//   addKToMatrix(x, m, k)          addKToMatrix(mparams, matrix) / buildStiffnessMatrix(...)
//   addBToMatrix(x, m, b)          addBToMatrix(mparams, matrix) / buildDampingMatrix(...)
//   draw(segments)                 draw(vparams): here the drawable network as point pairs, which
//                                  an output writes (no OpenGL)
//
// Vectors are flat std::span<double> with three doubles per point SLOT of the topology, so their
// size is 3 * topology.pointCapacity(); dead slots are ignored (never read, never written).
// Matrices are indexed by point slot: block (i, j) covers rows 3i..3i+2 and columns 3j..3j+2.
// K = dF/dx and B = dF/dv follow SOFA's sign convention (both negative semi-definite for springs).
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <span>
#include <string>
#include <vector>

#include "cutsim/base/fwd.hpp"
#include "cutsim/topology/types.hpp"

namespace cutsim::forcefields {

using topology::EdgeId;
using topology::Index;
using topology::PointId;
using topology::TriangleId;

/// Receives 3x3 blocks of a 3N x 3N matrix (SOFA: the matrix accessor of addKToMatrix).
/// K and B are symmetric and a field adds them whole: block (i, j) and block (j, i) = (i, j)^T
/// both (solvers may keep only one triangle, in any numbering of the points).
class MatrixAccumulator {
 public:
  virtual ~MatrixAccumulator();
  /// Adds b to block (i, j).
  virtual void addBlock(PointId i, PointId j, const Eigen::Matrix3d& b) = 0;
  /// Adds s * I3 to block (i, j). Default: addBlock(i, j, s * I3).
  virtual void addScaledIdentity(PointId i, PointId j, double s);
  /// Whether block (i, j) has a place (an assembled solver keeps a pattern; default: every block
  /// has). A field whose couplings come and go between solves (contact) asks, and adds what has
  /// no place to the diagonal blocks instead, as a bound from above (more stiffness and damping
  /// than the true matrix in every direction), telling approximated().
  virtual bool contains(PointId /*i*/, PointId /*j*/) const { return true; }
  /// Called by a field that lumped blocks onto the diagonal (see contains()).
  virtual void approximated() {}
  /// Whether only the diagonal blocks (i, i) are kept (a preconditioner's diagonal): a field
  /// may then skip computing the others. Such an accumulator must also have a place for every
  /// block (contains() true), as the default does.
  virtual bool diagonalOnly() const { return false; }
};

/// Collects the blocks as Eigen triplets (duplicates are summed by toSparse).
class TripletAccumulator : public MatrixAccumulator {
 public:
  void addBlock(PointId i, PointId j, const Eigen::Matrix3d& b) override;
  void addScaledIdentity(PointId i, PointId j, double s) override;

  /// The 3N x 3N matrix of the collected triplets (N point slots; every index must be < N).
  Eigen::SparseMatrix<double> toSparse(Index numPoints) const;
  const std::vector<Eigen::Triplet<double>>& triplets() const { return triplets_; }
  void clear() { triplets_.clear(); }
  void reserve(std::size_t n) { triplets_.reserve(n); }

 private:
  std::vector<Eigen::Triplet<double>> triplets_;
};

/// Keeps the diagonal entries of the diagonal blocks it is given (a Jacobi preconditioner's
/// diagonal): diagonal[3 i + a] += block (i, i)(a, a). Fields may skip the other blocks.
class DiagonalAccumulator final : public MatrixAccumulator {
 public:
  /// n: the number of entries (3 per point slot; every point given must be below n / 3).
  explicit DiagonalAccumulator(Eigen::Index n) : diagonal(Eigen::VectorXd::Zero(n)) {}
  void addBlock(PointId i, PointId j, const Eigen::Matrix3d& b) override;
  void addScaledIdentity(PointId i, PointId j, double s) override;
  bool diagonalOnly() const override { return true; }

  Eigen::VectorXd diagonal;
};

/// A force field over the points of a topology. See the table at the top of this file.
class ForceField {
 public:
  virtual ~ForceField();

  /// The component's name ("FastTriangularBendingSprings", ...).
  virtual std::string typeName() const = 0;

  /// f += F(x, v).
  virtual void addForce(std::span<const double> x, std::span<const double> v,
                        std::span<double> f) const = 0;

  /// df += (kFactor K(x) + bFactor B(x)) dx, with K = dF/dx and B = dF/dv.
  virtual void addDForce(std::span<const double> x, std::span<const double> dx,
                         std::span<double> df, double kFactor, double bFactor) const = 0;

  /// A linear solve's products at x follow (core::SystemOperator calls these around its life):
  /// from beginProducts(x) to the matching endProducts(x), x (the same memory) does not change,
  /// so every addDForce that passes it may skip checking whether x is still what it was. A
  /// field whose products depend on x through a cache (Contact) prepares them here. Calls may
  /// nest (one solve's operator built before another's is gone). Default: nothing.
  virtual void beginProducts(std::span<const double> /*x*/) const {}
  virtual void endProducts(std::span<const double> /*x*/) const {}

  /// The potential energy at x.
  virtual double potentialEnergy(std::span<const double> x) const = 0;
  /// Whether F(x, v) is -grad potentialEnergy(x) plus a damping B(x) v at every time (true), or
  /// not (contact: its obstacles move, its friction is not linear in v). Energy accounting
  /// (cutsim/core/energy.hpp) counts a conservative field's damping as dissipated; of a field
  /// that is not, what its potential changes by when the field itself changes at fixed x (its
  /// obstacles move) and the work of its friction (addFrictionForce).
  virtual bool conservative() const { return true; }
  /// f += the part of F(x, v) that is not -grad potentialEnergy(x): friction (a field that is
  /// not conservative()). Default: nothing.
  virtual void addFrictionForce(std::span<const double> /*x*/, std::span<const double> /*v*/,
                                std::span<double> /*f*/) const {}

  /// Adds kFactor * K(x) to m.
  virtual void addKToMatrix(std::span<const double> x, MatrixAccumulator& m,
                            double kFactor) const = 0;

  /// Adds bFactor * B(x) to m.
  virtual void addBToMatrix(std::span<const double> x, MatrixAccumulator& m,
                            double bFactor) const = 0;

  /// Appends the drawable network as point pairs (drawn at the current positions by an output).
  virtual void draw(std::vector<std::array<PointId, 2>>& /*segments*/) const {}

  /// Whether addDForce / addKToMatrix give the exact K = dF/dx at every x (true), or an
  /// approximation kept negative semi-definite for implicit solvers (a Gauss-Newton or
  /// corotational K, a clamped Jacobian): say which in the field's header.
  virtual bool stiffnessIsExact() const { return true; }
  /// Asks for the exact K (Newton's method converges quadratically only with it) or the field's
  /// default. Returns false, changing nothing, when the field has no exact K to offer.
  virtual bool setExactStiffness(bool exact) { return !exact || stiffnessIsExact(); }

  /// Why the field, as built on the rest mesh, would not do what its parameters ask (its
  /// elements dropped for values beyond what it can hold), as "KEY: message"; "" when nothing is
  /// wrong. A scene refuses such a field before it runs.
  virtual std::string problemAtRest() const { return ""; }

  /// Whether the model may replace this field by another of its type (new parameters between
  /// steps): false for a field that a step hook holds by reference (Contact).
  virtual bool replaceable() const { return true; }
  /// Called on the field that replaces `previous` (the same type, on the same topology: new
  /// parameters between steps) to carry over what the run has done to it that its parameters do
  /// not say (a dissection's released points). Default: nothing.
  virtual void continueFrom(const ForceField& /*previous*/) {}

  /// Checkpoints (cutsim run --checkpoint-every, docs/robustness.md): whether the field saves
  /// and restores everything its continuation depends on beyond the topology and its parameters,
  /// its tables in their order (the order of its sums) included. A run with a field that does
  /// not is refused checkpoints before it starts.
  virtual bool checkpointable() const { return false; }
  /// Writes that state into the open section of `out` (a field that is not checkpointable:
  /// cutsim::Error).
  virtual void saveState(ArchiveWriter& out) const;
  /// Replaces the state of a field just built on the checkpoint's topology by the saved one,
  /// refusing (ArchiveReader::fail) what does not fit that topology.
  virtual void loadState(ArchiveReader& in);
};

}  // namespace cutsim::forcefields
