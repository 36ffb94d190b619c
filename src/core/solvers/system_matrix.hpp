#pragma once
// Private to cutsim::core: the implicit integrator's system matrix for CHOLMOD, assembled in place.
//
// The lower triangle of A = M (1 + h rM) - bFactor B - kFactor K is stored in compressed columns
// whose pattern is discovered once from the force fields' own blocks (which point pairs they
// couple) and kept while the topology and the list of fields do not change; each step only
// refills the values, writing every 3x3 block straight to its place. The degrees of freedom are
// numbered in a fill-reducing order of the point graph (nine times fewer entries than the scalar
// matrix CHOLMOD would otherwise order), so CHOLMOD keeps the given order: METIS nested
// dissection (about 30% fewer flops than minimum degree on cloth, but slower to compute) or AMD
// (cheap, for patterns that change every few steps, as during a progressive cut).
// Constrained points are eliminated from the values, not from the pattern: a grasp that starts
// or ends does not change the pattern, so it costs no new symbolic analysis.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "cutsim/forcefields/force_field.hpp"

namespace cutsim::core {

class SystemMatrix {
 public:
  using Fields = std::vector<forcefields::ForceField*>;
  enum class Ordering { NestedDissection, MinimumDegree };

  /// Discovers the pattern from the fields at positions x (n point slots) and orders it.
  void build(const Fields& fields, std::span<const double> x, std::size_t numSlots,
             Ordering ordering);
  bool built() const { return built_; }
  Ordering ordering() const { return ordering_; }
  std::size_t numSlots() const { return numSlots_; }

  /// Refills the values: mass (per point, already scaled) on the diagonal, minus kFactor K and
  /// bFactor B of every field. Returns false (values unusable) if a field added a block outside
  /// the pattern: build() again, then fill again.
  bool fill(const Fields& fields, std::span<const double> x, double kFactor, double bFactor,
            std::span<const double> diagonalMass);

  /// Eliminates the constrained points: their rows and columns become the identity, the
  /// right-hand side (in the original numbering) gets -A(free, constrained) dv(constrained), and
  /// the constrained entries of the result are dv. Returns the right-hand side in the matrix's
  /// numbering.
  Eigen::VectorXd eliminate(const std::vector<char>& constrained, const Eigen::VectorXd& rhs,
                            const Eigen::VectorXd& dv);

  /// The lower triangle, in the permuted numbering.
  Eigen::SparseMatrix<double>& matrix() { return A_; }
  /// Permuted -> original numbering of a vector of 3 n entries.
  Eigen::VectorXd toOriginal(const Eigen::VectorXd& permuted) const;

  /// New index of point p in the matrix's numbering.
  const std::vector<std::int32_t>& newIndex() const { return newIndex_; }
  /// Whether the last fill lumped some field's blocks onto the diagonal (contact pairs outside
  /// the pattern): the matrix then bounds the system's from above and is a preconditioner.
  bool approximate() const { return approximate_; }

 private:
  bool built_ = false;
  bool approximate_ = false;
  Ordering ordering_ = Ordering::NestedDissection;
  std::size_t numSlots_ = 0;
  std::vector<std::int32_t> newIndex_;  // point p -> its index in the matrix's numbering
  // Per block column J (new numbering): the block rows I >= J, sorted, first J itself.
  std::vector<std::int32_t> blockStart_, blockRow_;
  Eigen::SparseMatrix<double> A_;
};

}  // namespace cutsim::core
