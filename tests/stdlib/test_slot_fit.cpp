// SPDX-License-Identifier: GPL-3.0-or-later
// Oracle tests for the closed-slot (CPARLN) fit: ball centres generated from a known outline
// (ROUND and FLAT ends, inner and outer, exact and with seeded noise), and its failures.
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "metron/stdlib/fitting/slot_fit.hpp"

namespace metron::fitting {
namespace {

/// Ball centres of a ball of radius `r` touching the outline `truth` at `per_side` points on
/// each side and `per_end` on each end, each moved along the surface normal by N(0, sigma).
std::vector<Eigen::Vector2d> probe_outline(const SlotOutline& truth, bool inner, double r, int per_side, int per_end,
                                           double sigma_mm, unsigned seed, bool with_ends = true) {
  std::mt19937 engine(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  const Eigen::Vector2d a(std::cos(truth.angle_rad), std::sin(truth.angle_rad)), b(-a.y(), a.x());
  const double half_w = 0.5 * truth.width_mm, half_l = 0.5 * truth.length_mm;
  const double straight = truth.round_ends ? half_l - half_w : half_l;
  std::vector<Eigen::Vector2d> centres;
  // `x`, `y` in the slot's frame on the outline, `nx`, `ny` its normal out of the slot's region.
  const auto add = [&](double x, double y, double nx, double ny) {
    const Eigen::Vector2d normal = nx * a + ny * b;
    const Eigen::Vector2d surface = truth.centre + x * a + y * b + sigma_mm * noise(engine) * normal;
    centres.push_back(surface + (inner ? -r : r) * normal);
  };
  for (int side : {1, -1})
    for (int i = 0; i < per_side; ++i) add((-0.8 + 1.6 * i / (per_side - 1)) * straight, side * half_w, 0, side);
  if (!with_ends) return centres;
  for (int end : {1, -1})
    for (int i = 0; i < per_end; ++i) {
      const double t = per_end == 1 ? 0.0 : -0.8 + 1.6 * i / (per_end - 1);  // across the end, -1..1
      if (truth.round_ends) {
        const double phi = t * std::numbers::pi / 2;
        add(end * (straight + half_w * std::cos(phi)), half_w * std::sin(phi), end * std::cos(phi), std::sin(phi));
      } else {
        add(end * half_l, 0.5 * t * half_w, end, 0);  // clear of the corners: a ball there touches the side too
      }
    }
  return centres;
}

SlotOutline outline(double cx, double cy, double angle_deg, double length_mm, double width_mm, bool round) {
  SlotOutline s;
  s.centre = {cx, cy};
  s.angle_rad = angle_deg * std::numbers::pi / 180;
  s.length_mm = length_mm;
  s.width_mm = width_mm;
  s.round_ends = round;
  return s;
}

// Exact ball centres: the fit lands on the outline they were made from (from a nominal 0.2 mm
// and 2 deg off), for both kinds of ends, a slot and a tab.
TEST(SlotFit, RecoversAnExactOutline) {
  for (bool round : {true, false})
    for (bool inner : {true, false}) {
      const SlotOutline truth = outline(1.3, -0.7, 12, 40.03, 12.02, round);
      const SlotOutline nominal = outline(1.1, -0.6, 10, 40, 12, round);
      const auto fit = fit_slot(probe_outline(truth, inner, 1.5, 4, 3, 0, 1), 1.5, inner, nominal);
      ASSERT_TRUE(fit) << "round " << round << " inner " << inner << ": " << to_string(fit.error());
      EXPECT_NEAR(fit->outline.centre.x(), 1.3, 1e-9);
      EXPECT_NEAR(fit->outline.centre.y(), -0.7, 1e-9);
      EXPECT_NEAR(fit->outline.angle_rad, truth.angle_rad, 1e-10);
      EXPECT_NEAR(fit->outline.length_mm, 40.03, 1e-9);
      EXPECT_NEAR(fit->outline.width_mm, 12.02, 1e-9);
      EXPECT_NEAR(fit->form_mm, 0, 1e-9);
    }
}

// Seeded noise of 1 um along the normal on 30 points: centre, length and width within 2 um,
// the axis within 0.01 deg (a few sigma over 30 points); the form is the spread of the noise.
TEST(SlotFit, RecoversAStadiumThroughNoise) {
  const SlotOutline truth = outline(-4.2, 7.5, -33, 25.0, 8.0, true);
  const SlotOutline nominal = outline(-4.0, 7.4, -30, 25.1, 7.9, true);
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const auto fit = fit_slot(probe_outline(truth, true, 1.0, 8, 7, 0.001, seed), 1.0, true, nominal);
    ASSERT_TRUE(fit) << "seed " << seed << ": " << to_string(fit.error());
    EXPECT_NEAR(fit->outline.centre.x(), -4.2, 0.002) << "seed " << seed;
    EXPECT_NEAR(fit->outline.centre.y(), 7.5, 0.002) << "seed " << seed;
    EXPECT_NEAR(fit->outline.angle_rad * 180 / std::numbers::pi, -33, 0.01) << "seed " << seed;
    EXPECT_NEAR(fit->outline.length_mm, 25.0, 0.002) << "seed " << seed;
    EXPECT_NEAR(fit->outline.width_mm, 8.0, 0.002) << "seed " << seed;
    EXPECT_GT(fit->form_mm, 0.001);
    EXPECT_LT(fit->form_mm, 0.008);
  }
}

// The signed distance: 0 on the outline, - inside, + outside, exact off the corners.
TEST(SlotFit, SignedDistance) {
  const SlotOutline stadium = outline(0, 0, 0, 20, 6, true);
  EXPECT_NEAR(signed_distance(stadium, {0, 3}), 0, 1e-12);
  EXPECT_NEAR(signed_distance(stadium, {10, 0}), 0, 1e-12);
  EXPECT_NEAR(signed_distance(stadium, {0, 0}), -3, 1e-12);
  EXPECT_NEAR(signed_distance(stadium, {10, 4}), 2, 1e-12);  // 5 from the end centre (7, 0)
  const SlotOutline box = outline(0, 0, 90, 20, 6, false);   // long axis along y
  EXPECT_NEAR(signed_distance(box, {0, 10}), 0, 1e-12);
  EXPECT_NEAR(signed_distance(box, {1, 9}), -1, 1e-12);
  EXPECT_NEAR(signed_distance(box, {7, 13}), 5, 1e-12);  // 3 and 4 beyond the corner (-3, 10)
  EXPECT_EQ(nearest_part(box, {0, 9.5}), SlotPart::PlusEnd);
  EXPECT_EQ(nearest_part(box, {-2.9, 0}), SlotPart::PlusSide);  // +y of the slot's frame is -x here
}

// Too few points, or none on an end: a failure, not a guess.
TEST(SlotFit, NeedsPointsOnBothSidesAndBothEnds) {
  const SlotOutline truth = outline(0, 0, 0, 30, 10, true);
  const auto sides_only = fit_slot(probe_outline(truth, true, 1, 4, 0, 0, 1, false), 1, true, truth);
  ASSERT_FALSE(sides_only);
  EXPECT_EQ(sides_only.error(), FitFailure::TooFewPoints);
  auto four = probe_outline(truth, true, 1, 2, 1, 0, 1);
  four.resize(4);
  EXPECT_FALSE(fit_slot(four, 1, true, truth));
}

}  // namespace
}  // namespace metron::fitting
