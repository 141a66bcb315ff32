// SPDX-License-Identifier: GPL-3.0-or-later
// Oracle tests for the exact point-to-ellipse distance and the ellipse (ELLIPS) fit: distances
// against a densely sampled ellipse, ball centres generated from known ellipses (a hole and a
// boss, exact and with seeded noise), and the fit's failures.
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "metron/stdlib/fitting/ellipse_fit.hpp"
#include "metron/stdlib/geometry/ellipse.hpp"

namespace metron::fitting {
namespace {

constexpr double pi = std::numbers::pi;

/// The distance to x^2/a^2 + y^2/b^2 = 1 by brute force: a million samples, then a local
/// golden-section refinement of the best one (independent of Eberly's root).
double sampled_distance(double a, double b, const Eigen::Vector2d& p) {
  auto at = [&](double t) { return (Eigen::Vector2d(a * std::cos(t), b * std::sin(t)) - p).norm(); };
  double best_t = 0, best = at(0);
  const int n = 1'000'000;
  for (int i = 1; i < n; ++i) {
    const double t = 2 * pi * i / n;
    if (const double d = at(t); d < best) best = d, best_t = t;
  }
  double lo = best_t - 2 * pi / n, hi = best_t + 2 * pi / n;
  for (int i = 0; i < 200; ++i) {
    const double m1 = lo + (hi - lo) / 3, m2 = hi - (hi - lo) / 3;
    (at(m1) < at(m2) ? hi : lo) = at(m1) < at(m2) ? m2 : m1;
  }
  return at(0.5 * (lo + hi));
}

TEST(EllipseDistance, IsTheDistanceToTheNearestPointOfTheCurve) {
  const double a = 30, b = 12;
  // Outside, inside, on both axes (inside the evolute's cusp and beyond it), at the centre,
  // on the curve, in every quadrant.
  const std::vector<Eigen::Vector2d> points = {{40, 20},
                                               {-35, 3},
                                               {5, -4},
                                               {-20, -9},
                                               {10, 0},
                                               {28, 0},
                                               {45, 0},
                                               {0, 5},
                                               {0, -30},
                                               {0, 0},
                                               {30 * std::cos(1.0), 12 * std::sin(1.0)}};
  for (const auto& p : points) {
    const geometry::EllipseFoot f = geometry::ellipse_foot(a, b, p);
    const bool inside = (p.x() / a) * (p.x() / a) + (p.y() / b) * (p.y() / b) < 1;
    EXPECT_NEAR(std::abs(f.signed_distance), sampled_distance(a, b, p), 1e-9) << p.transpose();
    if (std::abs(f.signed_distance) > 1e-9) {
      EXPECT_EQ(f.signed_distance < 0, inside) << p.transpose();
    }
    // The foot lies on the curve and the normal is the curve's there.
    EXPECT_NEAR((f.foot.x() / a) * (f.foot.x() / a) + (f.foot.y() / b) * (f.foot.y() / b), 1.0, 1e-12);
    EXPECT_NEAR(f.normal.norm(), 1.0, 1e-12);
  }
  // The minor axis first (b > a) is the same curve turned: the distance does not care.
  EXPECT_NEAR(geometry::ellipse_foot(12, 30, {20, 40}).signed_distance,
              geometry::ellipse_foot(30, 12, {40, -20}).signed_distance, 1e-12);
  // A circle: |p| - r.
  EXPECT_NEAR(geometry::ellipse_foot(10, 10, {3, 4}).signed_distance, -5.0, 1e-12);
  EXPECT_NEAR(geometry::ellipse_foot(10, 10, {30, 40}).signed_distance, 40.0, 1e-12);
}

/// Ball centres of a ball of radius r touching `truth` at n points (parameter t evenly from
/// `phase`), each surface point moved along its normal by N(0, sigma). From the parametric form
/// X(t) = c + R(angle) (a cos t, b sin t), normal along R(angle) (b cos t, a sin t).
std::vector<Eigen::Vector2d> probe_ellipse(const EllipseOutline& truth, bool inner, double r, int n, double phase,
                                           double sigma_mm, unsigned seed) {
  std::mt19937 engine(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  const double a = truth.major_diameter_mm / 2, b = truth.minor_diameter_mm / 2;
  const Eigen::Vector2d u(std::cos(truth.angle_rad), std::sin(truth.angle_rad)), v(-u.y(), u.x());
  std::vector<Eigen::Vector2d> centres;
  for (int i = 0; i < n; ++i) {
    const double t = phase + 2 * pi * i / n;
    const Eigen::Vector2d normal = (b * std::cos(t) * u + a * std::sin(t) * v).normalized();
    const Eigen::Vector2d surface = truth.centre + a * std::cos(t) * u + b * std::sin(t) * v;
    centres.push_back(surface + (sigma_mm * noise(engine) + (inner ? -r : r)) * normal);
  }
  return centres;
}

EllipseOutline ellipse(double x, double y, double angle_deg, double major, double minor) {
  return {Eigen::Vector2d(x, y), angle_deg * pi / 180, major, minor};
}

TEST(EllipseFit, RecoversAHoleAndABossFromTheirNominals) {
  for (const bool inner : {true, false}) {
    const EllipseOutline truth = ellipse(0.031, -0.024, 31.5, 40.05, 24.97);
    const EllipseOutline nominal = ellipse(0, 0, 30, 40, 25);
    const auto fit = fit_ellipse(probe_ellipse(truth, inner, 1.5, 12, 0.1, 0, 7), 1.5, inner, nominal);
    ASSERT_TRUE(fit) << to_string(fit.error());
    EXPECT_NEAR(fit->outline.centre.x(), 0.031, 1e-9);
    EXPECT_NEAR(fit->outline.centre.y(), -0.024, 1e-9);
    EXPECT_NEAR(fit->outline.angle_rad, 31.5 * pi / 180, 1e-9);
    EXPECT_NEAR(fit->outline.major_diameter_mm, 40.05, 1e-9);
    EXPECT_NEAR(fit->outline.minor_diameter_mm, 24.97, 1e-9);
    EXPECT_LT(fit->rms_mm, 1e-9);
  }
}

TEST(EllipseFit, SeededNoiseLeavesTheEstimateWithinItsStatistics) {
  // 36 points with sigma 2 um: the centre is known to about sigma * sqrt(2/n) ~ 0.5 um; allow 4 um.
  const EllipseOutline truth = ellipse(5, 7, -12, 60, 30);
  const auto fit =
      fit_ellipse(probe_ellipse(truth, true, 2, 36, 0, 0.002, 11), 2, true, ellipse(5.02, 6.98, -11, 60.1, 29.9));
  ASSERT_TRUE(fit);
  EXPECT_NEAR(fit->outline.centre.x(), 5, 0.004);
  EXPECT_NEAR(fit->outline.centre.y(), 7, 0.004);
  EXPECT_NEAR(fit->outline.major_diameter_mm, 60, 0.004);
  EXPECT_NEAR(fit->outline.minor_diameter_mm, 30, 0.004);
  EXPECT_NEAR(fit->rms_mm, 0.002, 0.001);
  EXPECT_EQ(fit->residuals_mm.size(), 36u);
}

TEST(EllipseFit, AxesFoundTheOtherWayRoundAreSwapped) {
  // Started with the diameters swapped: the fit's major axis is the truth's, at its angle.
  const EllipseOutline truth = ellipse(0, 0, 10, 50, 30);
  const auto fit = fit_ellipse(probe_ellipse(truth, true, 1, 16, 0.2, 0, 3), 1, true, ellipse(0, 0, 100, 32, 48));
  ASSERT_TRUE(fit) << to_string(fit.error());
  EXPECT_NEAR(fit->outline.major_diameter_mm, 50, 1e-9);
  EXPECT_NEAR(fit->outline.minor_diameter_mm, 30, 1e-9);
  EXPECT_NEAR(std::remainder(fit->outline.angle_rad - 10 * pi / 180, pi), 0, 1e-9);
}

TEST(EllipseFit, FailsOnTooFewPointsAndBadCoordinates) {
  const EllipseOutline nominal = ellipse(0, 0, 0, 40, 20);
  auto four = probe_ellipse(nominal, true, 1, 4, 0, 0, 1);
  EXPECT_EQ(fit_ellipse(four, 1, true, nominal).error(), FitFailure::TooFewPoints);
  auto bad = probe_ellipse(nominal, true, 1, 8, 0, 0, 1);
  bad[3].x() = std::nan("");
  EXPECT_EQ(fit_ellipse(bad, 1, true, nominal).error(), FitFailure::Degenerate);
}

}  // namespace
}  // namespace metron::fitting
