#include "support/force_field_harness.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "support/field_helpers.hpp"

namespace cutsim::test {

std::vector<double> perturbed(std::span<const double> base, double amplitude, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> dist(-amplitude, amplitude);
  std::vector<double> x(base.begin(), base.end());
  for (double& v : x) v += dist(rng);
  return x;
}

std::vector<double> forceAt(const forcefields::ForceField& ff, std::span<const double> x) {
  std::vector<double> f(x.size(), 0.0), v(x.size(), 0.0);
  ff.addForce(x, v, f);
  return f;
}

namespace {

double relative(double err, double scale) {
  return scale > 0.0 ? err / scale : err;
}

}  // namespace

double forceVsEnergyError(const forcefields::ForceField& ff, std::span<const double> x, double h) {
  const std::vector<double> f = forceAt(ff, x);
  std::vector<double> xp(x.begin(), x.end());
  double err = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < xp.size(); ++i) {
    const double x0 = xp[i];
    xp[i] = x0 + h;
    const double ep = ff.potentialEnergy(xp);
    xp[i] = x0 - h;
    const double em = ff.potentialEnergy(xp);
    xp[i] = x0;
    const double grad = (ep - em) / (2.0 * h);
    err = std::max(err, std::fabs(f[i] + grad));
    scale = std::max({scale, std::fabs(f[i]), std::fabs(grad)});
  }
  return relative(err, scale);
}

double dForceVsForceError(const forcefields::ForceField& ff, std::span<const double> x,
                          std::span<const double> dx, double h) {
  std::vector<double> xp(x.begin(), x.end()), xm(x.begin(), x.end());
  for (std::size_t i = 0; i < xp.size(); ++i) {
    xp[i] += h * dx[i];
    xm[i] -= h * dx[i];
  }
  const std::vector<double> fp = forceAt(ff, xp), fm = forceAt(ff, xm);
  std::vector<double> df(x.size(), 0.0);
  ff.addDForce(x, dx, df, 1.0, 0.0);
  double err = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < df.size(); ++i) {
    const double fd = (fp[i] - fm[i]) / (2.0 * h);
    err = std::max(err, std::fabs(df[i] - fd));
    scale = std::max({scale, std::fabs(df[i]), std::fabs(fd)});
  }
  return relative(err, scale);
}

Eigen::MatrixXd assembledK(const forcefields::ForceField& ff, std::span<const double> x,
                           std::size_t numPoints) {
  forcefields::TripletAccumulator acc;
  ff.addKToMatrix(x, acc, 1.0);
  return Eigen::MatrixXd(acc.toSparse(static_cast<forcefields::Index>(numPoints)));
}

double matrixVsForceError(const forcefields::ForceField& ff, std::span<const double> x,
                          std::size_t numPoints, double h) {
  const Eigen::MatrixXd k = assembledK(ff, x, numPoints);
  std::vector<double> xp(x.begin(), x.end());
  double err = 0.0, scale = 0.0;
  for (std::size_t c = 0; c < 3 * numPoints; ++c) {
    const double x0 = xp[c];
    xp[c] = x0 + h;
    const std::vector<double> fp = forceAt(ff, xp);
    xp[c] = x0 - h;
    const std::vector<double> fm = forceAt(ff, xp);
    xp[c] = x0;
    for (std::size_t r = 0; r < 3 * numPoints; ++r) {
      const double fd = (fp[r] - fm[r]) / (2.0 * h);
      const double kv = k(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c));
      err = std::max(err, std::fabs(kv - fd));
      scale = std::max({scale, std::fabs(kv), std::fabs(fd)});
    }
  }
  return relative(err, scale);
}

double dForceVsMatrixError(const forcefields::ForceField& ff, std::span<const double> x,
                           std::span<const double> dx, std::size_t numPoints) {
  const Eigen::MatrixXd k = assembledK(ff, x, numPoints);
  std::vector<double> df(x.size(), 0.0);
  ff.addDForce(x, dx, df, 1.0, 0.0);
  return relativeError(df, times(k, std::vector<double>(dx.begin(), dx.end())));
}

void recordError(const std::string& key, double value) {
  std::ostringstream os;
  os << std::scientific << std::setprecision(2) << value;
  ::testing::Test::RecordProperty(key, os.str());
}

StiffnessCheck expectExactStiffness(const forcefields::ForceField& ff, std::span<const double> x,
                                    std::span<const double> dx, std::size_t numPoints, double h,
                                    double fdTolerance) {
  StiffnessCheck c;
  c.dForceVsForce = dForceVsForceError(ff, x, dx, h);
  c.matrixVsForce = matrixVsForceError(ff, x, numPoints, h);
  c.dForceVsMatrix = dForceVsMatrixError(ff, x, dx, numPoints);
  const Eigen::MatrixXd k = assembledK(ff, x, numPoints);
  const double scale = maxAbsCoeff(k);
  c.asymmetry = scale > 0.0 ? maxAsymmetry(k) / scale : 0.0;
  EXPECT_GT(scale, 0.0);
  EXPECT_LE(c.dForceVsForce, fdTolerance);
  EXPECT_LE(c.matrixVsForce, fdTolerance);
  EXPECT_LE(c.dForceVsMatrix, 1e-12);
  EXPECT_LE(c.asymmetry, 1e-13);
  return c;
}

}  // namespace cutsim::test
