// SPDX-License-Identifier: GPL-3.0-or-later
// The independent lower bound of segmented scanning time (issue 11 item 5): time-optimal with
// speed, acceleration and centripetal limits and no jerk limit, against analytic answers, and
// below metron's jerk-limited reference on the benchmark paths.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "metron/machine/segmented_scanning/time_optimal_bound.hpp"
#include "reference_planner.hpp"
#include "sample_paths.hpp"
#include "scan_paths.hpp"

namespace {

using namespace metron;
using namespace metron::machine::segmented;

// A straight line of length L at limits v, a: trapezoid L/v + v/a when L > v^2/a, else the
// triangle 2 sqrt(L/a).
TEST(TimeOptimalBound, StraightLineIsTheTrapezoid) {
  geometry::PccPath path;
  scan_test::add_line(path, Vec3::Zero(), Vec3(100, 0, 0), 5, Vec3::UnitZ());
  const BoundLimits lim{50, 500, 500};
  EXPECT_NEAR(time_optimal_bound(path, lim).time_s, 100.0 / 50 + 50.0 / 500, 1e-6);
  geometry::PccPath short_path;
  scan_test::add_line(short_path, Vec3::Zero(), Vec3(2, 0, 0), 1, Vec3::UnitZ());
  EXPECT_NEAR(time_optimal_bound(short_path, lim).time_s, 2 * std::sqrt(2.0 / 500), 1e-4);
}

// A circle of radius R: speed sqrt(a_n R) (below v), reached and left at a: L/vc + vc/a. The
// hermite arcs of 10 degrees have a curvature within 0.1 % of 1/R.
TEST(TimeOptimalBound, CircleRunsAtTheCentripetalSpeed) {
  const double R = 8, an = 200, a = 1000;
  const geometry::PccPath path = scan_test::circle_path(Vec3::Zero(), R, true);
  const double vc = std::sqrt(an * R), L = 2 * std::numbers::pi * R;
  const TimeOptimalBound b = time_optimal_bound(path, BoundLimits{100, a, an});
  EXPECT_NEAR(b.length_mm, L, 1e-3 * L);
  EXPECT_NEAR(b.time_s, L / vc + vc / a, 2e-3 * (L / vc));
}

// No jerk-limited motion under the same limits can be faster: metron's reference (the whole
// path buffered, jerk-limited) must not beat the bound; with the jerk out of the way it comes
// within 6 % of it.
TEST(TimeOptimalBound, BelowTheJerkLimitedReferenceOnTheBenchPaths) {
  const ScanLimits limits;
  const BoundLimits lim{limits.path.speed_mm_s, limits.path.acceleration_mm_s2, limits.normal_acceleration_mm_s2};
  for (const auto& path : {test_support::freeform_contour(2000, 1.0), test_support::tight_meander(2000, 0.5)}) {
    const auto ref = test_support::reference_profile(path, limits, 0.001);
    const TimeOptimalBound b = time_optimal_bound(path, lim);
    EXPECT_NEAR(b.length_mm, ref.length_mm, 1e-3 * ref.length_mm);
    EXPECT_LE(b.time_s, ref.time_s + 0.002);
    // Where the gap comes from: the same reference with a jerk limit 1000x higher.
    ScanLimits stiff = limits;
    stiff.path.jerk_mm_s3 *= 1000;
    const auto ref_stiff = test_support::reference_profile(path, stiff, 0.001);
    // Issue 11 item 5: where jerk is not what costs the time, the reference is close to the
    // bound: the planner gives each quarter of a segment its own curvature limit (one limit per
    // segment, the sharpest point's, left the meander 17.9 % above the bound).
    EXPECT_LT(ref_stiff.time_s, 1.06 * b.time_s);
    std::printf(
        "[figures] %.1f mm: bound %.3f s, reference %.3f s (+%.1f %%), with 1000x the jerk %.3f s (+%.1f %%), "
        "sum(l/v) %.3f s\n",
        b.length_mm, b.time_s, ref.time_s, 100 * (ref.time_s / b.time_s - 1), ref_stiff.time_s,
        100 * (ref_stiff.time_s / b.time_s - 1), ref.lower_bound_s);
  }
}

}  // namespace
