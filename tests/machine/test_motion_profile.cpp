// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <cmath>

#include "metron/machine/motion_profile.hpp"

using namespace metron::machine;

namespace {

const MotionLimits limits{300, 1000, 10000};

// Samples the profile finely and checks speed, acceleration and jerk (by finite differences)
// against the limits, and that it never moves backward.
void expect_within_limits(const MotionProfile& p, const MotionLimits& l) {
  const double h = 1e-4;
  double last_pos = p.start().position_mm;
  for (double t = 0; t <= p.duration_s(); t += h) {
    const MotionState s = p.at(t);
    EXPECT_GE(s.position_mm, last_pos - 1e-12);
    last_pos = s.position_mm;
    EXPECT_LE(s.speed_mm_s, l.speed_mm_s * (1 + 1e-12));
    EXPECT_GE(s.speed_mm_s, -1e-9);
    EXPECT_LE(std::abs(s.acceleration_mm_s2), l.acceleration_mm_s2 * (1 + 1e-12));
    const double jerk = (p.at(t + h / 2).acceleration_mm_s2 - p.at(t - h / 2).acceleration_mm_s2) / h;
    EXPECT_LE(std::abs(jerk), l.jerk_mm_s3 * (1 + 1e-9));
  }
}

}  // namespace

TEST(MotionProfile, LongMoveTakesTheAnalyticJerkLimitedTime) {
  // Cruise reached with a constant-acceleration phase (v >= a^2/j): T = D/v + v/a + a/j.
  const double d = 1000;
  const MotionProfile p = MotionProfile::rest_to_rest(d, limits);
  const double expected = d / 300 + 300.0 / 1000 + 1000.0 / 10000;
  EXPECT_NEAR(p.duration_s(), expected, 1e-12);
  EXPECT_NEAR(rest_to_rest_time_s(d, limits), expected, 1e-12);
  EXPECT_DOUBLE_EQ(p.end_position_mm(), d);
  EXPECT_NEAR(p.at(p.duration_s() / 2).speed_mm_s, 300, 1e-9);
  // The polynomials themselves land on the target.
  EXPECT_NEAR(p.at(p.duration_s() * (1 - 1e-12)).position_mm, d, 1e-6);
  expect_within_limits(p, limits);
}

TEST(MotionProfile, ShortMoveWithoutConstantAccelerationPhase) {
  // Peak speed below a^2/j = 100 mm/s: D = 2 v^1.5 / sqrt(j), T = 4 sqrt(v/j).
  const double d = 2.0;
  const MotionProfile p = MotionProfile::rest_to_rest(d, limits);
  const double v = std::cbrt(std::pow(d / 2 * std::sqrt(10000.0), 2));
  EXPECT_NEAR(p.duration_s(), 4 * std::sqrt(v / 10000), 1e-12);
  EXPECT_NEAR(p.at(p.duration_s() / 2).speed_mm_s, v, 1e-9);
  EXPECT_LT(v * 10000, 1000.0 * 1000.0);
  expect_within_limits(p, limits);
}

TEST(MotionProfile, MediumMoveReachesTheAccelerationLimitButNotTheSpeed) {
  // a^2/j <= v < 300: v^2/a + v a/j = D.
  const double d = 30;
  const MotionProfile p = MotionProfile::rest_to_rest(d, limits);
  const double a = 1000, j = 10000;
  const double v = a / 2 * (-a / j + std::sqrt(a * a / (j * j) + 4 * d / a));
  EXPECT_GT(v, 100);
  EXPECT_LT(v, 300);
  EXPECT_NEAR(p.duration_s(), 2 * (v / a + a / j), 1e-12);
  EXPECT_NEAR(p.at(p.duration_s() / 2).speed_mm_s, v, 1e-9);
  expect_within_limits(p, limits);
}

TEST(MotionProfile, MeasuringFeedAccelerationDistance) {
  // SEEDS.md 3: the acceleration zone. At 3 mm/s the ramp is pure jerk: t = 2 sqrt(v/j),
  // distance v * t / 2.
  const MotionLimits slow{3, 1000, 10000};
  const MotionProfile p = MotionProfile::rest_to_rest(10, slow);
  const double t_ramp = 2 * std::sqrt(3.0 / 10000);
  EXPECT_NEAR(p.duration_s(), 10.0 / 3 + t_ramp, 1e-12);
  EXPECT_NEAR(p.at(t_ramp).position_mm, 3 * t_ramp / 2, 1e-12);
  EXPECT_NEAR(p.at(t_ramp).speed_mm_s, 3, 1e-12);
}

TEST(MotionProfile, TimeAtInvertsPosition) {
  const MotionProfile p = MotionProfile::rest_to_rest(100, limits);
  for (double s : {0.001, 1.0, 37.5, 99.999}) EXPECT_NEAR(p.at(p.time_at(s)).position_mm, s, 1e-9);
  EXPECT_EQ(p.time_at(-1), 0);
  EXPECT_EQ(p.time_at(200), p.duration_s());
}

TEST(MotionProfile, StopFromCruiseIsJerkLimited) {
  // From 3 mm/s: peak deceleration sqrt(j v) < a, time 2 sqrt(v/j), distance v t / 2.
  const MotionProfile s = MotionProfile::stop({5, 3, 0}, limits);
  EXPECT_NEAR(s.duration_s(), 2 * std::sqrt(3.0 / 10000), 1e-12);
  EXPECT_NEAR(s.end_position_mm() - 5, 3 * s.duration_s() / 2, 1e-12);
  EXPECT_NEAR(s.at(s.duration_s() * (1 - 1e-9)).speed_mm_s, 0, 1e-6);
  // From 300 mm/s with a constant-deceleration phase: distance v (v/a + a/j) / 2.
  const MotionProfile f = MotionProfile::stop({0, 300, 0}, limits);
  EXPECT_NEAR(f.duration_s(), 300.0 / 1000 + 1000.0 / 10000, 1e-12);
  EXPECT_NEAR(f.end_position_mm(), 300 * (0.3 + 0.1) / 2, 1e-9);
  expect_within_limits(f, limits);
}

TEST(MotionProfile, StopWhileAccelerating) {
  const MotionState from{0, 50, 800};
  const MotionProfile s = MotionProfile::stop(from, limits);
  EXPECT_NEAR(s.at(s.duration_s() * (1 - 1e-12)).speed_mm_s, 0, 1e-6);
  EXPECT_NEAR(s.at(s.duration_s() * (1 - 1e-12)).acceleration_mm_s2, 0, 1e-3);
  expect_within_limits(s, limits);
}

TEST(MotionProfile, ZeroDistance) {
  const MotionProfile p = MotionProfile::rest_to_rest(0, limits);
  EXPECT_EQ(p.duration_s(), 0);
  EXPECT_EQ(p.end_position_mm(), 0);
}
