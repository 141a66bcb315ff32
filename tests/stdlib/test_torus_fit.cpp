// SPDX-License-Identifier: GPL-3.0-or-later
// Oracle tests for the torus (TORUS) fit: ball centres generated from a known torus (a ring and a
// groove, tilted, exact and with seeded noise), and its failures.
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "metron/stdlib/fitting/torus_fit.hpp"

namespace metron::fitting {
namespace {

Torus torus(Vec3 centre, Vec3 axis, double major_diameter, double minor_diameter) {
  return Torus{centre, axis.normalized(), major_diameter, minor_diameter};
}

/// Ball centres of a ball of radius `r` touching `truth` at `rings` x `per_ring` points: the
/// tube angle v from -v_max to v_max (the part of the tube a probe reaches from one side), the
/// angle u round the axis evenly; each surface point moved along its normal by N(0, sigma).
/// Written from the torus's parametric form x = C + (R + r cos v)(cos u e1 + sin u e2) + r sin v a.
std::vector<Vec3> probe_torus(const Torus& truth, bool inner, double r, int rings, int per_ring, double v_max_deg,
                              double sigma_mm, unsigned seed, std::vector<double>* deviations = nullptr) {
  std::mt19937 engine(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  const Vec3 a = truth.axis;
  const Vec3 e1 = a.cross(std::abs(a.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitX()).normalized(), e2 = a.cross(e1);
  const double big_r = truth.major_diameter_mm / 2, small_r = truth.minor_diameter_mm / 2;
  std::vector<Vec3> centres;
  for (int k = 0; k < rings; ++k) {
    const double v = (rings == 1 ? 0.0 : -v_max_deg + 2 * v_max_deg * k / (rings - 1)) * std::numbers::pi / 180;
    for (int i = 0; i < per_ring; ++i) {
      const double u = 2 * std::numbers::pi * (i + 0.37 * k) / per_ring;
      const Vec3 radial = std::cos(u) * e1 + std::sin(u) * e2;
      const Vec3 normal = std::cos(v) * radial + std::sin(v) * a;  // out of the tube
      const double deviation = sigma_mm * noise(engine);
      if (deviations) deviations->push_back(deviation);
      const Vec3 surface = truth.centre + big_r * radial + (small_r + deviation) * normal;
      // A ring's material is inside the tube: the ball is outside it. A groove's is outside.
      centres.push_back(surface + (inner ? -r : r) * normal);
    }
  }
  return centres;
}

TEST(TorusFit, RecoversATiltedRingExactly) {
  const Torus truth = torus({12.5, -4, 30}, {0.1, -0.2, 1}, 60, 8);
  const auto centres = probe_torus(truth, false, 1.5, 3, 8, 60, 0, 1);
  const Torus start = torus({12, -3.5, 30.4}, {0, 0, 1}, 59.4, 8.5);
  const auto fit = fit_torus(centres, 1.5, false, start);
  ASSERT_TRUE(fit) << to_string(fit.error());
  EXPECT_NEAR((fit->torus.centre - truth.centre).norm(), 0, 1e-9);
  EXPECT_NEAR(fit->torus.axis.dot(truth.axis), 1, 1e-12);
  EXPECT_NEAR(fit->torus.major_diameter_mm, 60, 1e-9);
  EXPECT_NEAR(fit->torus.minor_diameter_mm, 8, 1e-9);
  EXPECT_LT(fit->rms_mm, 1e-9);
  EXPECT_LT(fit->form_mm, 1e-9);
}

TEST(TorusFit, RecoversAGrooveWithTheBallInsideTheTube) {
  // An INNER torus: a toroidal groove, the ball (r = 2) in its tube (minor diameter 10).
  const Torus truth = torus({0, 0, -5}, {0, 1, 0.3}, 40, 10);
  const auto centres = probe_torus(truth, true, 2, 3, 9, 50, 0, 2);
  const auto fit = fit_torus(centres, 2, true, torus({0.3, 0, -5}, {0, 1, 0.25}, 40.5, 9.6));
  ASSERT_TRUE(fit) << to_string(fit.error());
  EXPECT_NEAR((fit->torus.centre - truth.centre).norm(), 0, 1e-9);
  EXPECT_NEAR(fit->torus.major_diameter_mm, 40, 1e-9);
  EXPECT_NEAR(fit->torus.minor_diameter_mm, 10, 1e-9);
  // Fitted as a ring instead, the ball would be taken outside the tube: 4 mm smaller.
  const auto wrong_side = fit_torus(centres, 2, false, truth);
  ASSERT_TRUE(wrong_side);
  EXPECT_NEAR(wrong_side->torus.minor_diameter_mm, 10 - 4 * 2, 1e-9);
}

TEST(TorusFit, NoisyPointsGiveTheTruthWithinTheirSpreadAndTheirSignedDeviations) {
  const Torus truth = torus({5, 5, 5}, {0, 0, 1}, 80, 12);
  std::vector<double> deviations;
  const auto centres = probe_torus(truth, false, 1, 5, 24, 70, 0.002, 7, &deviations);
  const auto fit = fit_torus(centres, 1, false, truth);
  ASSERT_TRUE(fit);
  EXPECT_NEAR((fit->torus.centre - truth.centre).norm(), 0, 0.002);
  EXPECT_NEAR(fit->torus.major_diameter_mm, 80, 0.002);
  EXPECT_NEAR(fit->torus.minor_diameter_mm, 12, 0.002);
  // The residuals are the deviations put in, less what the fit absorbs (a few tenths of sigma).
  ASSERT_EQ(fit->residuals_mm.size(), deviations.size());
  double worst = 0;
  for (std::size_t i = 0; i < deviations.size(); ++i)
    worst = std::max(worst, std::abs(fit->residuals_mm[i] - deviations[i]));
  EXPECT_LT(worst, 0.0015);
  const auto [lo, hi] = std::minmax_element(deviations.begin(), deviations.end());
  EXPECT_NEAR(fit->form_mm, *hi - *lo, 0.002);
}

TEST(TorusFit, FailsClearly) {
  const Torus truth = torus({0, 0, 0}, {0, 0, 1}, 30, 6);
  auto centres = probe_torus(truth, false, 1, 1, 6, 0, 0, 1);
  EXPECT_EQ(fit_torus(centres, 1, false, truth).error(), FitFailure::TooFewPoints);
  centres = probe_torus(truth, false, 1, 2, 6, 40, 0, 1);
  centres.push_back(Vec3(0, 0, 3));  // on the axis
  EXPECT_EQ(fit_torus(centres, 1, false, truth).error(), FitFailure::Degenerate);
  centres.back() = Vec3(std::nan(""), 0, 0);
  EXPECT_EQ(fit_torus(centres, 1, false, truth).error(), FitFailure::Degenerate);
}

}  // namespace
}  // namespace metron::fitting
