// A membrane under tension, stepped: the lowest out-of-plane frequency of a square membrane held
// at its border (the closed form of the wave equation), and the period-two chatter that a
// stiffness without the tension's geometric stiffness gives at a time step beyond h omega = 2
// (docs/forcefields.md, TriangularFEM's "tangent").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "cutsim/core/scene.hpp"
#include "cutsim/core/simulation.hpp"
#include "cutsim/core/state.hpp"
#include "support/scene_text.hpp"

namespace cutsim::core {
namespace {

// The membrane: 1 m x 1 m, 0.1 kg, E = 1000 Pa, nu = 0.3, 1 cm thick, its rest shape scaled by
// 0.98 and its border held at the mesh: an isotropic tension T = h E (1 - s) / (1 - nu) per unit
// length (docs/forcefields.md, "Prestrain").
constexpr double kSide = 1.0, kMass = 0.1, kYoung = 1000.0, kNu = 0.3, kThickness = 0.01,
                 kRestScale = 0.98;
constexpr int kN = 17;

std::string membraneScene(const std::string& tangent, double dt, double rayleighMass,
                          const std::string& integrator = "implicit-euler") {
  const auto num = [](double v) { return std::to_string(v); };
  return R"({
    "mesh": {"grid": {"nx": )" +
         std::to_string(kN) + R"(, "ny": )" + std::to_string(kN) +
         R"(, "size": [1, 1], "plane": "xy"}},
    "mass": {"total": )" +
         num(kMass) + R"(},
    "gravity": [0, 0, 0],
    "forceFields": [{"type": "TriangularFEM", "youngModulus": )" +
         num(kYoung) + R"(, "poissonRatio": )" + num(kNu) + R"(, "thickness": )" + num(kThickness) +
         R"(, "restScale": )" + num(kRestScale) + R"(, "tangent": ")" + tangent + R"("}],
    "constraints": [
      {"type": "fixed", "box": [[-1, -1, -1], [0.001, 2, 1]]},
      {"type": "fixed", "box": [[0.999, -1, -1], [2, 2, 1]]},
      {"type": "fixed", "box": [[-1, -1, -1], [2, 0.001, 1]]},
      {"type": "fixed", "box": [[-1, 0.999, -1], [2, 2, 1]]}
    ],
    "integrator": {"type": ")" +
         integrator + R"(", "rayleighMass": )" + num(rayleighMass) + R"(},
    "linearSolver": {"type": "cholmod"},
    "timeStep": )" +
         num(dt) + R"(, "duration": 100})";
}

/// The runner, started, with the membrane bent into its lowest mode, z = a sin(pi x) sin(pi y).
struct Membrane {
  explicit Membrane(const std::string& tangent, double dt, double rayleighMass = 0.0,
                    const std::string& integrator = "implicit-euler", double amplitude = 1e-3)
      : scene(parseScene(membraneScene(tangent, dt, rayleighMass, integrator), "inline.json",
                         test::kSceneDir)),
        runner(scene) {
    runner.start();
    std::span<double> x = runner.simulation().state().x();
    for (std::size_t i = 0; i + 2 < x.size(); i += 3) {
      x[i + 2] = amplitude * std::sin(std::numbers::pi * x[i] / kSide) *
                 std::sin(std::numbers::pi * x[i + 1] / kSide);
    }
  }
  std::vector<double> positions() {
    const std::span<const double> x = runner.simulation().state().x();
    return {x.begin(), x.end()};
  }
  Scene scene;
  SceneRunner runner;
};

TEST(MembraneTension, LowestOutOfPlaneFrequencyMatchesTheClosedForm) {
  // f = c sqrt(2) / (2 L), c = sqrt(T / rho), rho the mass per area.
  const double tension = kThickness * kYoung * (1.0 - kRestScale) / (1.0 - kNu);
  const double c = std::sqrt(tension / (kMass / (kSide * kSide)));
  const double expected = c * std::sqrt(2.0) / (2.0 * kSide);
  const double dt = 0.002;  // h omega = 0.015: implicit Euler's phase error is (h omega)^2 / 3
  Membrane m("projected", dt);
  const std::size_t centre = 3 * ((kN / 2) * kN + kN / 2) + 2;  // z of the middle point
  ASSERT_NEAR(m.positions()[centre], 1e-3, 1e-9);
  std::vector<double> crossings;  // times where z changes sign, linearly interpolated
  double previous = m.positions()[centre];
  while (crossings.size() < 5) {
    m.runner.advance();
    const double z = m.positions()[centre];
    const double t = m.runner.simulation().time();
    if ((previous > 0.0) != (z > 0.0)) crossings.push_back(t - dt * z / (z - previous));
    previous = z;
    ASSERT_LT(t, 5.0) << "no oscillation";
  }
  const double period = 2.0 * (crossings.back() - crossings.front()) / (crossings.size() - 1);
  const double f = 1.0 / period;
  EXPECT_NEAR(f / expected, 1.0, 0.02) << "f = " << f << " Hz, closed form " << expected << " Hz";
  ::testing::Test::RecordProperty("frequency_ratio", std::to_string(f / expected));
}

/// The chatter measure: over the points and the steps from `from` on, the median of the one-step
/// displacement over half the two-step displacement (1 for smooth motion; large when the points
/// jump back and forth every step).
double chatter(const std::vector<std::vector<double>>& xs, std::size_t from) {
  std::vector<double> ratios;
  for (std::size_t n = std::max<std::size_t>(from, 1); n + 1 < xs.size(); ++n) {
    for (std::size_t i = 0; i + 2 < xs[n].size(); i += 3) {
      double one = 0.0, two = 0.0;
      for (int k = 0; k < 3; ++k) {
        one += std::pow(xs[n + 1][i + k] - xs[n][i + k], 2);
        two += std::pow(xs[n + 1][i + k] - xs[n - 1][i + k], 2);
      }
      if (one > 0.0) ratios.push_back(std::sqrt(one) / (0.5 * std::sqrt(two)));
    }
  }
  if (ratios.empty()) return 0.0;
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
  return ratios[ratios.size() / 2];
}

TEST(MembraneTension, StepsBeyondTheExplicitLimitStayStillWithTheProjectedStiffness) {
  // h omega_max: the shortest out-of-plane wave (two edges long) of this mesh has
  // omega_max^2 ~ 6 T / (rho l^2); h = 0.05 puts h omega_max at about 3.3, past the explicit
  // limit of 2, where a stiffness without the tension's geometric part flips the out-of-plane
  // motion every step. Implicit Euler and BDF2 alike.
  const double dt = 0.05;
  const double l = kSide / (kN - 1);
  const double tension = kThickness * kYoung * (1.0 - kRestScale) / (1.0 - kNu);
  const double omegaMax = std::sqrt(6.0 * tension / (kMass / (kSide * kSide) * l * l));
  ASSERT_GT(dt * omegaMax, 2.5);
  for (const char* integrator : {"implicit-euler", "bdf2"}) {
    double measured[2] = {0.0, 0.0};
    int i = 0;
    for (const char* tangent : {"projected", "corotational"}) {
      SCOPED_TRACE(std::string(integrator) + ", " + tangent);
      Membrane m(tangent, dt, 0.5, integrator);
      std::vector<std::vector<double>> xs = {m.positions()};
      for (int step = 0; step < 20; ++step) {
        m.runner.advance();
        xs.push_back(m.positions());
      }
      measured[i++] = chatter(xs, 2);
    }
    EXPECT_LE(measured[0], 2.0) << integrator << ", projected: chatter " << measured[0];
    // The check sees the chatter it guards against (BDF2's own damping keeps the corotational
    // run's measure near 1.9 over these 20 steps: recorded, not asserted).
    if (std::string(integrator) == "implicit-euler")
      EXPECT_GT(measured[1], 2.0) << integrator << ", corotational: chatter " << measured[1];
    ::testing::Test::RecordProperty(std::string("chatter_projected_") + integrator,
                                    std::to_string(measured[0]));
    ::testing::Test::RecordProperty(std::string("chatter_corotational_") + integrator,
                                    std::to_string(measured[1]));
  }
}

}  // namespace
}  // namespace cutsim::core
