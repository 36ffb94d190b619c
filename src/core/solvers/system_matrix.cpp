#include "solvers/system_matrix.hpp"

#include <amd.h>
#include <metis.h>

#include <algorithm>
#include <stdexcept>
#include <string>

namespace cutsim::core {

namespace {

using forcefields::PointId;

/// Records which point pairs the fields couple (the lower block triangle), not the values.
struct PairCollector : forcefields::MatrixAccumulator {
  std::vector<std::uint64_t> pairs;  // (larger << 32) | smaller
  void add(PointId i, PointId j) {
    // Each pair comes as (i, j) and (j, i), and several fields and elements repeat it.
    if (i <= j) return;
    const std::uint64_t key = (std::uint64_t(i.idx()) << 32) | std::uint64_t(j.idx());
    if (!pairs.empty() && pairs.back() == key) return;
    pairs.push_back(key);
  }
  void addBlock(PointId i, PointId j, const Eigen::Matrix3d&) override { add(i, j); }
  void addScaledIdentity(PointId i, PointId j, double) override { add(i, j); }
  /// The pattern follows the mesh: couplings that come and go (contact) are lumped.
  bool contains(PointId i, PointId j) const override { return i == j; }
};

/// Writes each block straight to its place in the compressed columns (lower triangle only: the
/// fields add both (i, j) and its transpose (j, i), so the upper one is skipped).
struct Filler : forcefields::MatrixAccumulator {
  const std::int32_t* newIndex = nullptr;
  std::size_t numSlots = 0;
  const std::int32_t* blockStart = nullptr;
  const std::int32_t* blockRow = nullptr;
  const int* outer = nullptr;
  double* values = nullptr;
  bool missing = false;
  bool lumped = false;
  bool contains(PointId i, PointId j) const override {
    if (i.idx() >= numSlots || j.idx() >= numSlots) return false;
    std::int32_t I = newIndex[i.idx()], J = newIndex[j.idx()];
    if (I < J) std::swap(I, J);
    return I == J || offDiagonal(I, J) >= 0;
  }
  void approximated() override { lumped = true; }

  /// Offset of block row I in block column J's scalar columns, past the diagonal block; -1 if
  /// the pair is not in the pattern.
  std::ptrdiff_t offDiagonal(std::int32_t I, std::int32_t J) const {
    const std::int32_t* first = blockRow + blockStart[J] + 1;
    const std::int32_t* last = blockRow + blockStart[J + 1];
    const std::int32_t* it = std::lower_bound(first, last, I);
    if (it == last || *it != I) return -1;
    return 3 * (it - first);
  }

  template <class Entry>
  void add(PointId i, PointId j, Entry entry) {
    if (i.idx() >= numSlots || j.idx() >= numSlots) {
      missing = true;
      return;
    }
    const std::int32_t I = newIndex[i.idx()], J = newIndex[j.idx()];
    if (I < J) return;
    if (I == J) {
      for (int c = 0; c < 3; ++c) {
        double* col = values + outer[3 * J + c];
        for (int r = c; r < 3; ++r) col[r - c] += entry(r, c);
      }
      return;
    }
    const std::ptrdiff_t off = offDiagonal(I, J);
    if (off < 0) {
      missing = true;
      return;
    }
    for (int c = 0; c < 3; ++c) {
      double* col = values + outer[3 * J + c] + (3 - c) + off;
      for (int r = 0; r < 3; ++r) col[r] += entry(r, c);
    }
  }
  void addBlock(PointId i, PointId j, const Eigen::Matrix3d& b) override {
    add(i, j, [&](int r, int c) { return b(r, c); });
  }
  void addScaledIdentity(PointId i, PointId j, double s) override {
    add(i, j, [s](int r, int c) { return r == c ? s : 0.0; });
  }
};

/// The new index of each point in a fill-reducing order of the point graph given by its pairs
/// (a < b packed as a << 32 | b): METIS nested dissection or AMD minimum degree.
std::vector<std::int32_t> fillReducingOrder(const std::vector<std::uint64_t>& pairs,
                                            std::size_t numSlots, SystemMatrix::Ordering ordering) {
  const auto n = std::int32_t(numSlots);
  std::vector<std::int32_t> newIndex(numSlots);
  for (std::int32_t p = 0; p < n; ++p) newIndex[std::size_t(p)] = p;
  if (pairs.empty()) return newIndex;
  std::vector<idx_t> xadj(numSlots + 1, 0), adjncy(2 * pairs.size());
  for (std::uint64_t pr : pairs) {
    ++xadj[(pr >> 32) + 1];
    ++xadj[(pr & 0xFFFFFFFFu) + 1];
  }
  for (std::size_t p = 0; p < numSlots; ++p) xadj[p + 1] += xadj[p];
  std::vector<idx_t> fillPos(xadj.begin(), xadj.end() - 1);
  for (std::uint64_t pr : pairs) {
    const auto a = idx_t(pr >> 32), b = idx_t(pr & 0xFFFFFFFFu);
    adjncy[std::size_t(fillPos[std::size_t(a)]++)] = b;
    adjncy[std::size_t(fillPos[std::size_t(b)]++)] = a;
  }
  std::vector<idx_t> perm(numSlots), iperm(numSlots);
  if (ordering == SystemMatrix::Ordering::NestedDissection) {
    idx_t nv = n;
    idx_t options[METIS_NOPTIONS];
    METIS_SetDefaultOptions(options);
    options[METIS_OPTION_NUMBERING] = 0;
    const int rc =
        METIS_NodeND(&nv, xadj.data(), adjncy.data(), nullptr, options, perm.data(), iperm.data());
    if (rc != METIS_OK)
      throw std::runtime_error("METIS_NodeND failed (code " + std::to_string(rc) + ")");
  } else {
    static_assert(sizeof(idx_t) == sizeof(int), "amd_order takes int indices");
    double info[AMD_INFO];
    const int rc = amd_order(n, xadj.data(), adjncy.data(), perm.data(), nullptr, info);
    if (rc < AMD_OK) throw std::runtime_error("amd_order failed (code " + std::to_string(rc) + ")");
    for (std::int32_t k = 0; k < n; ++k) iperm[std::size_t(perm[std::size_t(k)])] = k;
  }
  for (std::size_t p = 0; p < numSlots; ++p) newIndex[p] = std::int32_t(iperm[p]);
  return newIndex;
}

}  // namespace

void SystemMatrix::build(const Fields& fields, std::span<const double> x, std::size_t numSlots,
                         Ordering ordering) {
  built_ = false;
  numSlots_ = numSlots;
  const auto n = std::int32_t(numSlots);
  PairCollector pc;
  for (auto* f : fields) {
    f->addKToMatrix(x, pc, 1.0);
    f->addBToMatrix(x, pc, 1.0);
  }
  std::sort(pc.pairs.begin(), pc.pairs.end());
  pc.pairs.erase(std::unique(pc.pairs.begin(), pc.pairs.end()), pc.pairs.end());
  for (std::uint64_t pr : pc.pairs)
    if ((pr >> 32) >= numSlots)
      throw std::logic_error("a force field couples a point beyond the state");

  newIndex_ = fillReducingOrder(pc.pairs, numSlots, ordering);
  ordering_ = ordering;

  // Block rows of each block column (new numbering), the diagonal first.
  blockStart_.assign(numSlots + 1, 0);
  for (std::int32_t J = 0; J < n; ++J) blockStart_[std::size_t(J) + 1] = 1;
  std::vector<std::pair<std::int32_t, std::int32_t>> lower;  // (I, J), I > J
  lower.reserve(pc.pairs.size());
  for (std::uint64_t pr : pc.pairs) {
    std::int32_t I = newIndex_[pr >> 32], J = newIndex_[pr & 0xFFFFFFFFu];
    if (I < J) std::swap(I, J);
    lower.emplace_back(I, J);
    ++blockStart_[std::size_t(J) + 1];
  }
  for (std::size_t J = 0; J < numSlots; ++J) blockStart_[J + 1] += blockStart_[J];
  blockRow_.assign(std::size_t(blockStart_.back()), 0);
  std::vector<std::int32_t> next(blockStart_.begin(), blockStart_.end() - 1);
  for (std::int32_t J = 0; J < n; ++J) blockRow_[std::size_t(next[std::size_t(J)]++)] = J;
  for (auto [I, J] : lower) blockRow_[std::size_t(next[std::size_t(J)]++)] = I;
  for (std::size_t J = 0; J < numSlots; ++J)
    std::sort(blockRow_.begin() + blockStart_[J] + 1, blockRow_.begin() + blockStart_[J + 1]);

  // Scalar compressed columns: column 3J + c holds rows 3J + c .. 3J + 2, then 3I .. 3I + 2 for
  // each block row I > J.
  const Eigen::Index N = Eigen::Index(3 * numSlots);
  std::vector<int> outer(std::size_t(N) + 1, 0);
  for (std::size_t J = 0; J < numSlots; ++J) {
    const int offBlocks = blockStart_[J + 1] - blockStart_[J] - 1;
    for (int c = 0; c < 3; ++c) outer[3 * J + std::size_t(c) + 1] = (3 - c) + 3 * offBlocks;
  }
  for (std::size_t k = 0; k < std::size_t(N); ++k) outer[k + 1] += outer[k];
  A_ = Eigen::SparseMatrix<double>(N, N);
  A_.resizeNonZeros(outer.back());
  std::copy(outer.begin(), outer.end(), A_.outerIndexPtr());
  int* inner = A_.innerIndexPtr();
  for (std::size_t J = 0; J < numSlots; ++J)
    for (int c = 0; c < 3; ++c) {
      int pos = outer[3 * J + std::size_t(c)];
      for (int r = c; r < 3; ++r) inner[pos++] = int(3 * J) + r;
      for (std::int32_t k = blockStart_[J] + 1; k < blockStart_[J + 1]; ++k)
        for (int r = 0; r < 3; ++r) inner[pos++] = 3 * blockRow_[std::size_t(k)] + r;
    }
  std::fill(A_.valuePtr(), A_.valuePtr() + A_.nonZeros(), 0.0);
  built_ = true;
}

bool SystemMatrix::fill(const Fields& fields, std::span<const double> x, double kFactor,
                        double bFactor, std::span<const double> diagonalMass) {
  double* values = A_.valuePtr();
  const int* outer = A_.outerIndexPtr();
  std::fill(values, values + A_.nonZeros(), 0.0);
  Filler filler;
  filler.newIndex = newIndex_.data();
  filler.numSlots = numSlots_;
  filler.blockStart = blockStart_.data();
  filler.blockRow = blockRow_.data();
  filler.outer = outer;
  filler.values = values;
  for (auto* f : fields) {
    f->addKToMatrix(x, filler, -kFactor);
    f->addBToMatrix(x, filler, -bFactor);
    if (filler.missing) return false;
  }
  approximate_ = filler.lumped;
  for (std::size_t p = 0; p < numSlots_; ++p) {
    const std::size_t J = std::size_t(newIndex_[p]);
    for (int c = 0; c < 3; ++c) values[outer[3 * J + std::size_t(c)]] += diagonalMass[p];
  }
  return true;
}

Eigen::VectorXd SystemMatrix::eliminate(const std::vector<char>& constrained,
                                        const Eigen::VectorXd& rhs, const Eigen::VectorXd& dv) {
  const Eigen::Index N = A_.rows();
  Eigen::VectorXd b(N), d(N);
  std::vector<char> fixedNew(numSlots_);
  for (std::size_t p = 0; p < numSlots_; ++p) {
    const Eigen::Index J = newIndex_[p];
    b.segment<3>(3 * J) = rhs.segment<3>(Eigen::Index(3 * p));
    d.segment<3>(3 * J) = dv.segment<3>(Eigen::Index(3 * p));
    fixedNew[std::size_t(J)] = constrained[p];
  }
  double* values = A_.valuePtr();
  const int* outer = A_.outerIndexPtr();
  const int* inner = A_.innerIndexPtr();
  for (Eigen::Index col = 0; col < N; ++col) {
    const bool cc = fixedNew[std::size_t(col / 3)];
    for (int e = outer[col]; e < outer[col + 1]; ++e) {
      const int row = inner[e];
      const bool rc = fixedNew[std::size_t(row / 3)];
      if (row == col) {
        if (cc) {
          values[e] = 1.0;
          b[col] = d[col];
        }
        continue;
      }
      if (!rc && !cc) continue;
      if (!rc)
        b[row] -= values[e] * d[col];
      else if (!cc)
        b[col] -= values[e] * d[row];
      values[e] = 0.0;
    }
  }
  return b;
}

Eigen::VectorXd SystemMatrix::toOriginal(const Eigen::VectorXd& permuted) const {
  Eigen::VectorXd out(permuted.size());
  for (std::size_t p = 0; p < numSlots_; ++p)
    out.segment<3>(Eigen::Index(3 * p)) = permuted.segment<3>(3 * Eigen::Index(newIndex_[p]));
  return out;
}

}  // namespace cutsim::core
