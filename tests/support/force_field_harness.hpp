#pragma once
// A generic finite-difference harness for any ForceField: the force against the energy, dForce
// and the assembled matrix against the force, by central differences. Each check returns the
// largest error relative to the largest magnitude involved.
#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include "cutsim/forcefields/force_field.hpp"

namespace cutsim::test {

/// x with 3 doubles per slot: base + uniform noise in [-amplitude, amplitude].
std::vector<double> perturbed(std::span<const double> base, double amplitude, std::uint64_t seed);

/// The force at x (f = 0 + F(x, 0)).
std::vector<double> forceAt(const forcefields::ForceField& ff, std::span<const double> x);

/// max_i |f_i + dE/dx_i| / max(|f|, |dE/dx|), central differences with step h.
double forceVsEnergyError(const forcefields::ForceField& ff, std::span<const double> x, double h);

/// addDForce(dx) (kFactor 1, bFactor 0) against (F(x + h dx) - F(x - h dx)) / 2h.
double dForceVsForceError(const forcefields::ForceField& ff, std::span<const double> x,
                          std::span<const double> dx, double h);

/// The assembled K (kFactor 1) against columns of d(force)/dx by central differences, column by
/// column over every coordinate of the listed points.
double matrixVsForceError(const forcefields::ForceField& ff, std::span<const double> x,
                          std::size_t numPoints, double h);

/// The assembled K (kFactor 1).
Eigen::MatrixXd assembledK(const forcefields::ForceField& ff, std::span<const double> x,
                           std::size_t numPoints);

}  // namespace cutsim::test
