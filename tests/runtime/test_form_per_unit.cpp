// SPDX-License-Identifier: GPL-3.0-or-later
// Form per unit length and area (runtime/src/form_per_unit.cpp) against profiles whose minimum
// zones are known analytically.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "runtime/src/detail/form_per_unit.hpp"

namespace metron::runtime {
namespace {

// Two stretches 2 apart along X, each a unit (1) long, the profile in Z:
//   A, x 0..1: six touches of a cosine 45 deg apart, 10 um amplitude (0, -7.07, -10, -7.07, 0,
//      7.07 um): its minimum zone 12.828 um (the Chebyshev line of the six), its least-squares
//      form 13.40 um;
//   B, x 3..4: a parabola h (x - 3)^2, h = 52.4 um, at 21 points: the Chebyshev line of x^2 on
//      [0, 1] (slope 1) leaves 1/8 either side (its extremes at 0, 1/2 and 1 are among the
//      points), so the zone, measured across the line of slope h, is h / 4 / sqrt(1 + h^2) =
//      13.082 um; its least-squares form 13.087 um.
// B's unit is the worst, though A's least-squares form is the larger: the search must not stop at
// the unit whose least-squares form is largest.
std::vector<Vec3> two_stretches(double y = 0) {
  std::vector<Vec3> points;
  for (int k = 0; k <= 5; ++k) points.emplace_back(0.2 * k, y, 0.010 * std::cos((k + 2) * std::numbers::pi / 4));
  for (int k = 0; k <= 20; ++k) points.emplace_back(3 + 0.05 * k, y, 0.0524 * (0.05 * k) * (0.05 * k));
  return points;
}

TEST(FormPerUnit, StraightnessFindsTheWorstUnitNotTheLargestLeastSquares) {
  const auto unit = straightness_per_unit_length(two_stretches(), Vec3::UnitX(), Vec3::UnitY(), 1.0);
  ASSERT_TRUE(unit.has_value());
  const double h = 0.0524;
  EXPECT_NEAR(unit->form_mm, h / 4 / std::hypot(1.0, h), 1e-7);
  EXPECT_NEAR(unit->centre.x(), 3.5, 1e-9);
  EXPECT_FALSE(unit->sampled);
  EXPECT_GE(unit->judged, 2U);  // A's unit first (larger least squares), then B's
  // A unit of 0.5: of the parabola (x - c)^2 on [c, c + 1/2] the zone is h / 16 across its
  // Chebyshev line of slope h (2c + 1/2), widest at c = 0; of the cosine three touches, at most
  // 2.93 um (a crest centred: 10 (1 - cos 45 deg)).
  const auto half = straightness_per_unit_length(two_stretches(), Vec3::UnitX(), Vec3::UnitY(), 0.5);
  ASSERT_TRUE(half.has_value());
  EXPECT_NEAR(half->form_mm, h / 16 / std::hypot(1.0, h / 2), 1e-7);
  EXPECT_GT(half->form_mm, 0.010 * (1 - std::cos(std::numbers::pi / 4)));
}

TEST(FormPerUnit, FlatnessOfRowsAlikeIsTheirProfilesStraightness) {
  std::vector<Vec3> points = two_stretches(0);
  for (const Vec3& p : two_stretches(0.5)) points.push_back(p);
  const auto unit = flatness_per_unit_area(points, Vec3::UnitZ(), Vec3::UnitX(), 1.0, 1.0);
  ASSERT_TRUE(unit.has_value());
  EXPECT_NEAR(unit->form_mm, 0.0524 / 4 / std::hypot(1.0, 0.0524), 1e-7);
  // The unit's length runs along the axis given: 1 along Y by 0.01 along X holds two touches (one
  // of each row), and no unit holds the four a plane needs.
  EXPECT_FALSE(flatness_per_unit_area(points, Vec3::UnitZ(), Vec3::UnitY(), 1.0, 0.01).has_value());
}

// The unit is placed anywhere across the plane too: two flat rows (y 0 and 0.5) and, 3 mm away,
// two rows of the parabola (y 3 and 3.5); a unit 1 along X by 0.5 along Y holds two rows, and the
// worst is the parabola's: h / 4 across its plane of slope h.
TEST(FormPerUnit, FlatnessTakesUnitsAnywhereAcrossThePlane) {
  const double h = 0.0524;
  std::vector<Vec3> points;
  for (const double y : {0.0, 0.5, 3.0, 3.5})
    for (int k = 0; k <= 10; ++k) points.emplace_back(0.1 * k, y, y > 1 ? h * (0.1 * k) * (0.1 * k) : 0.0);
  const auto unit = flatness_per_unit_area(points, Vec3::UnitZ(), Vec3::UnitX(), 1.0, 0.5);
  ASSERT_TRUE(unit.has_value());
  EXPECT_NEAR(unit->form_mm, h / 4 / std::hypot(1.0, h), 1e-7);
  EXPECT_NEAR(unit->centre.y(), 3.25, 1e-9);
}

// A scan: more points than the corners tried, which are then sampled (and said to be); the
// profile's worst unit is still found to a fraction of its form. z = a cos(2 pi x / 40), a = 2 um,
// 1601 points over x 0..160: per unit 20 (half the wavelength) the zone is a (a crest centred).
TEST(FormPerUnit, AScanIsSampledAndStillFindsTheWorstUnit) {
  std::vector<Vec3> points;
  for (int k = 0; k <= 1600; ++k)
    points.emplace_back(0.1 * k, 0, 0.002 * std::cos(2 * std::numbers::pi * 0.1 * k / 40));
  const auto unit = straightness_per_unit_length(points, Vec3::UnitX(), Vec3::UnitY(), 20.0);
  ASSERT_TRUE(unit.has_value());
  EXPECT_TRUE(unit->sampled);
  EXPECT_NEAR(unit->form_mm, 0.002, 0.002 * 0.02);
  EXPECT_LE(unit->form_mm, 0.002 + 1e-9);
}

}  // namespace
}  // namespace metron::runtime
