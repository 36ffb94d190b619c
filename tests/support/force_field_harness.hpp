#pragma once
// A generic finite-difference harness for any ForceField: the force against the energy, dForce
// and the assembled matrix against the force, by central differences. Each check returns the
// largest error relative to the largest magnitude involved.
#include <cstdint>
#include <random>
#include <span>
#include <string>
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

/// addDForce(dx) (kFactor 1, bFactor 0) against the assembled K (kFactor 1) times dx.
double dForceVsMatrixError(const forcefields::ForceField& ff, std::span<const double> x,
                           std::span<const double> dx, std::size_t numPoints);

/// What expectExactStiffness measured (relative errors, as the checks above; asymmetry relative
/// to the largest entry of K).
struct StiffnessCheck {
  double dForceVsForce = 0.0;   ///< dForceVsForceError
  double matrixVsForce = 0.0;   ///< matrixVsForceError
  double dForceVsMatrix = 0.0;  ///< dForceVsMatrixError
  double asymmetry = 0.0;       ///< maxAsymmetry(K) / maxAbsCoeff(K)
};

/// Records an error as a test property (in scientific notation: the XML output and the
/// console of --gtest_output show it).
void recordError(const std::string& key, double value);

/// The field's K is the exact d(force)/dx at x: addDForce along dx and the assembled K agree with
/// central differences of the force (step h) within fdTolerance (with h = 1e-6 on a mesh of
/// size 1, the differences are good to about 1e-10: 1e-8 is a safe bound), with each other
/// within 1e-12, and K is symmetric within 1e-13 of its largest entry.
StiffnessCheck expectExactStiffness(const forcefields::ForceField& ff, std::span<const double> x,
                                    std::span<const double> dx, std::size_t numPoints, double h,
                                    double fdTolerance);

}  // namespace cutsim::test
