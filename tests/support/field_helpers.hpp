#pragma once
// Helpers shared by the force-field tests: a topology with a field on it, rest positions as a
// state vector, vector and dense-matrix measures, rigid motions.
//
// The dense-matrix helpers are plain loops: GCC 12 reports false -Wmaybe-uninitialized warnings
// inside Eigen's vectorised dense kernels (products, reductions) under -march=native.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "cutsim/forcefields/force_field.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::test {

/// A small bumpy, jittered sheet on [0, 4]^2: springs and hinges in every direction, not all in
/// one plane.
topology::MeshData bumpyGrid(int n, std::uint64_t seed);

/// The small meshes the force-field invariants run on, by name: a flat grid, a bumpy sheet, a
/// closed and an open fan.
std::vector<std::pair<std::string, topology::MeshData>> smallMeshes();

/// A topology and a field on it (the field points to the topology: neither moves).
template <class Field>
struct FieldModel {
  std::unique_ptr<topology::Topology> topo;
  std::unique_ptr<Field> ff;
  std::vector<double> rest;  ///< 3 * pointCapacity
  std::size_t n() const { return topo->pointCapacity(); }
};

/// The rest positions as a state vector: 3 doubles per point slot, zeros in dead slots.
std::vector<double> restOf(const topology::Topology& t);

template <class Field, class Parameters>
FieldModel<Field> makeFieldModel(const topology::MeshData& mesh, const Parameters& p) {
  FieldModel<Field> m;
  m.topo = std::make_unique<topology::Topology>(mesh.points, mesh.triangles);
  m.ff = std::make_unique<Field>(*m.topo, p);
  m.rest = restOf(*m.topo);
  return m;
}

/// n doubles, uniform in [-amplitude, amplitude] (seeded).
std::vector<double> randomVector(std::size_t n, double amplitude, std::uint64_t seed);

double maxAbs(const std::vector<double>& v);

/// max |a - b| / max(|a|, |b|) (the absolute error when both are zero).
double relativeError(const std::vector<double>& a, const std::vector<double>& b);

double maxAbsCoeff(const Eigen::MatrixXd& a);

/// max |a(i, j) - a(j, i)|.
double maxAsymmetry(const Eigen::MatrixXd& a);

/// a x.
std::vector<double> times(const Eigen::MatrixXd& a, const std::vector<double>& x);

/// The eigenvalues of a symmetric matrix, ascending, by Eigen's SelfAdjointEigenSolver in long
/// double: Eigen does not vectorise long double, so this is free of the warnings above.
std::vector<double> symmetricEigenvalues(const Eigen::MatrixXd& a);

/// A random rotation (a normalised Gaussian quaternion, seeded).
Eigen::Matrix3d randomRotation(std::uint64_t seed);

/// x (3 doubles per point) -> a x + t.
std::vector<double> transformed(const std::vector<double>& x, const Eigen::Matrix3d& a,
                                const Eigen::Vector3d& t);

/// x -> R x + (1.5, -2.0, 0.7) with R = randomRotation(seed).
std::vector<double> rigidMotion(const std::vector<double>& x, std::uint64_t seed);

/// The forces f at the positions x have zero sum and zero torque about the origin (relative to
/// the largest |f_i| max(1, |x_i|)).
void expectZeroNetForceAndTorque(const std::vector<double>& x, const std::vector<double>& f);

/// After a random sequence of operations: the rest shape of the cut mesh, scaled by the fields'
/// `restScale` (the prestrain of the stretch fields; 1 for none), is force-free for `ff` (new
/// points interpolate their ancestors' rest positions), and `fresh`, built from scratch on the
/// final mesh, gives the same force and energy as the incrementally maintained `ff` (within
/// `tolerance`, relative) at x = rest + uniform noise of `amplitude` (seeded). Returns x.
std::vector<double> expectSameAsFresh(const forcefields::ForceField& ff,
                                      const forcefields::ForceField& fresh,
                                      const topology::Topology& topo, double amplitude,
                                      std::uint64_t seed, double tolerance, double restScale = 1.0);

}  // namespace cutsim::test
