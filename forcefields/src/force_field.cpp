#include "cutsim/forcefields/force_field.hpp"

#include "cutsim/base/archive.hpp"
#include "cutsim/base/errors.hpp"

namespace cutsim::forcefields {

MatrixAccumulator::~MatrixAccumulator() = default;

void MatrixAccumulator::addScaledIdentity(PointId i, PointId j, double s) {
  addBlock(i, j, s * Eigen::Matrix3d::Identity());
}

void TripletAccumulator::addBlock(PointId i, PointId j, const Eigen::Matrix3d& b) {
  const Eigen::Index r = 3 * static_cast<Eigen::Index>(i.idx());
  const Eigen::Index c = 3 * static_cast<Eigen::Index>(j.idx());
  // Every entry, zeros included, so that the sparsity pattern depends only on the topology.
  for (int a = 0; a < 3; ++a) {
    for (int k = 0; k < 3; ++k) triplets_.emplace_back(r + a, c + k, b(a, k));
  }
}

void TripletAccumulator::addScaledIdentity(PointId i, PointId j, double s) {
  const Eigen::Index r = 3 * static_cast<Eigen::Index>(i.idx());
  const Eigen::Index c = 3 * static_cast<Eigen::Index>(j.idx());
  for (int a = 0; a < 3; ++a) triplets_.emplace_back(r + a, c + a, s);
}

void DiagonalAccumulator::addBlock(PointId i, PointId j, const Eigen::Matrix3d& b) {
  if (i != j) return;
  for (int a = 0; a < 3; ++a) diagonal[3 * Eigen::Index(i.idx()) + a] += b(a, a);
}

void DiagonalAccumulator::addScaledIdentity(PointId i, PointId j, double s) {
  if (i != j) return;
  for (int a = 0; a < 3; ++a) diagonal[3 * Eigen::Index(i.idx()) + a] += s;
}

Eigen::SparseMatrix<double> TripletAccumulator::toSparse(Index numPoints) const {
  const Eigen::Index n = 3 * static_cast<Eigen::Index>(numPoints);
  Eigen::SparseMatrix<double> m(n, n);
  m.setFromTriplets(triplets_.begin(), triplets_.end());
  return m;
}

ForceField::~ForceField() = default;

void ForceField::saveState(ArchiveWriter&) const {
  throw Error("checkpoints: the " + typeName() + " force field cannot be saved");
}
void ForceField::loadState(ArchiveReader&) {
  throw Error("checkpoints: the " + typeName() + " force field cannot be restored");
}

}  // namespace cutsim::forcefields
