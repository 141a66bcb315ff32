// SPDX-License-Identifier: GPL-3.0-or-later
// Speed-pattern planner and interpolator of segmented scanning (SEEDS.md 2): ramp algebra
// against brute-force integration, the low-speed region, and the limits of executed profiles.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "metron/machine/motion_profile.hpp"
#include "metron/machine/segmented_scanning/path_interpolator.hpp"
#include "metron/machine/segmented_scanning/speed_plan.hpp"
#include "reference_planner.hpp"
#include "sample_paths.hpp"

namespace {

using namespace metron;
using namespace metron::machine;
using namespace metron::machine::segmented;
using namespace metron::test_support;

const MotionLimits k_limits{100.0, 1000.0, 10000.0};

// Distance of the fastest jerk-limited speed change from v0 to v1 (a = 0 at both ends),
// integrated with tiny steps of bang-bang jerk: the independent check of the closed forms.
double simulated_ramp_distance(double v0, double v1, const MotionLimits& l) {
  const double sign = v1 > v0 ? 1.0 : -1.0, dv = std::abs(v1 - v0);
  const double a_peak = std::min(l.acceleration_mm_s2, std::sqrt(dv * l.jerk_mm_s3));
  const double tj = a_peak / l.jerk_mm_s3, tc = dv / a_peak - tj;
  const double h = 1e-6;
  double s = 0, v = v0, a = 0;
  for (double t = 0; t < 2 * tj + tc; t += h) {
    const double j = t < tj ? 1.0 : (t < tj + tc ? 0.0 : -1.0);
    s += v * h + a * h * h / 2;
    v += a * h;
    a += sign * j * l.jerk_mm_s3 * h;
  }
  return s;
}

TEST(SegmentedRamp, DistanceMatchesIntegration) {
  for (auto [v0, v1] : {std::pair{0.0, 3.0}, {3.0, 100.0}, {80.0, 20.0}, {0.0, 100.0}, {50.0, 51.0}}) {
    EXPECT_NEAR(ramp_distance_mm(v0, v1, k_limits), simulated_ramp_distance(v0, v1, k_limits), 2e-3)
        << v0 << " -> " << v1;
  }
}

TEST(SegmentedRamp, ReachableSpeedInvertsTheDistance) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> v(0, 150), d(1e-4, 40);
  for (int i = 0; i < 2000; ++i) {
    const double v0 = v(rng), dist = d(rng);
    const double v1 = reachable_speed_mm_s(v0, dist, k_limits);
    ASSERT_GE(v1, v0);
    EXPECT_NEAR(ramp_distance_mm(v0, v1, k_limits), dist, 1e-7 * (1 + dist)) << v0 << " " << dist;
  }
}

TEST(SegmentedRamp, BrakeDistanceMatchesIntegratedStops) {
  // From (v, a) brake with jerk -J until the speed first drops to vt or below: brute force with
  // the same strategy the formula describes (-J, hold -A, release at the last moment).
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> vd(5, 100), ad(-900, 900), vtd(0, 1);
  for (int i = 0; i < 40; ++i) {
    const double v = vd(rng), a = ad(rng), vt = vtd(rng) * v;
    const double predicted = brake_distance_mm(v, a, vt, k_limits);
    // Brute force with exact constant-jerk steps: -J (hold at -A) until releasing at +J lands
    // on vt, then +J until the acceleration is back to zero.
    const double h = 1e-6, J = k_limits.jerk_mm_s3, A = k_limits.acceleration_mm_s2;
    double s = 0, vv = v, aa = a;
    bool release = false;
    for (int n = 0; n < 10'000'000; ++n) {
      if (aa < 0 && vv - aa * aa / (2 * J) <= vt) release = true;
      if (release && (aa >= 0 || vv <= vt - 1e-3)) break;  // the speed is down to vt
      const double j = release ? J : (aa <= -A ? 0.0 : -J);
      s += vv * h + aa * h * h / 2 + j * h * h * h / 6;
      vv += aa * h + j * h * h / 2;
      aa += j * h;
    }
    EXPECT_NEAR(predicted, s, 2e-3 + 1e-4 * s) << "v=" << v << " a=" << a << " vt=" << vt;
  }
}

std::vector<geometry::PccSegment> straight(std::size_t n, double step) {
  std::vector<geometry::PccSegment> out;
  for (std::size_t i = 0; i < n; ++i) {
    out.push_back(geometry::PccSegment::hermite(Vec3(step * static_cast<double>(i), 0, 0),
                                                Vec3(step * static_cast<double>(i + 1), 0, 0), Vec3::UnitX(),
                                                Vec3::UnitX()));
  }
  return out;
}

TEST(SegmentedPlan, LowSpeedRegionReachesBackOverShortSegments) {
  // Four segments of 1 mm: L = 3 mm covers the last three and ends at the low speed.
  const auto segs = straight(4, 1.0);
  const ScanLimits limits{k_limits, 500};
  const SpeedPlan p = plan_command(segs, {}, 0, 0.0, PlanKind::Individual, limits, {3.0, 3.0}, false);
  EXPECT_NEAR(p.low_speed_from_mm, 1.0, 1e-9);
  EXPECT_EQ(p.start_speed_mm_s, 0.0);
  EXPECT_EQ(p.end_speed_mm_s, 3.0);
  for (const auto& q : p.pieces) EXPECT_EQ(q.limit_mm_s, q.start_mm >= 1.0 - 1e-9 ? 3.0 : 100.0);
  EXPECT_NEAR(p.junction_mm_s.back(), 3.0, 1e-12);
  // The low-speed region takes exactly L / v_low in the schedule.
  EXPECT_NEAR(p.time_to_end_s[1], 1.0, 1e-9);

  // One long segment: the region splits it at end - L.
  const auto one = straight(1, 10.0);
  const SpeedPlan q = plan_command(one, {}, 1, 5.0, PlanKind::Connection, limits, {3.0, 2.0}, false);
  ASSERT_EQ(q.pieces.size(), 2u);
  EXPECT_NEAR(q.pieces[0].end_mm, 12.0, 1e-9);
  EXPECT_EQ(q.start_speed_mm_s, 2.0);
  EXPECT_EQ(q.pieces[1].limit_mm_s, 2.0);

  // Shorter than L: no region, but the plan still ends at the low speed; the last command at rest.
  const auto tiny = straight(2, 1.0);
  const SpeedPlan r = plan_command(tiny, {}, 2, 0.0, PlanKind::Connection, limits, {3.0, 3.0}, false);
  EXPECT_NEAR(r.low_speed_from_mm, 2.0, 1e-9);
  EXPECT_EQ(r.pieces.back().end_cap_mm_s, 3.0);
  const SpeedPlan last = plan_command(segs, {}, 3, 0.0, PlanKind::Connection, limits, {3.0, 3.0}, true);
  EXPECT_EQ(last.end_speed_mm_s, 0.0);
  EXPECT_EQ(last.junction_mm_s.back(), 0.0);
}

TEST(SegmentedPlan, CurvatureLimitsTheSpeed) {
  // A quarter circle of radius 10 mm split into Hermite segments: v <= sqrt(a_n * R).
  std::vector<geometry::PccSegment> segs;
  const int n = 16;
  for (int i = 0; i < n; ++i) {
    const double a0 = std::numbers::pi / 2 * i / n, a1 = std::numbers::pi / 2 * (i + 1) / n;
    segs.push_back(geometry::PccSegment::hermite(
        Vec3(10 * std::cos(a0), 10 * std::sin(a0), 0), Vec3(10 * std::cos(a1), 10 * std::sin(a1), 0),
        Vec3(-std::sin(a0), std::cos(a0), 0), Vec3(-std::sin(a1), std::cos(a1), 0)));
  }
  for (const auto& s : segs) {
    const SegmentLimit l = segment_limit(s, {k_limits, 250.0});
    // A cubic Hermite arc of 5.6 degrees bends up to ~0.3 % off the circle's curvature.
    EXPECT_NEAR(l.limit_mm_s, std::sqrt(250.0 * 10.0), 0.1);
    EXPECT_NEAR(l.length_mm, 10 * std::numbers::pi / 2 / n, 1e-5);
  }
}

TEST(SegmentedReference, StraightLineIsTheAnalyticRestToRestMove) {
  // The whole-path reference over a straight line equals the closed-form time-optimal S-curve,
  // whether the line is one segment or 200: junctions cost nothing when nothing limits them.
  const ScanLimits limits{k_limits, 500};
  for (std::size_t n : {std::size_t{1}, std::size_t{200}}) {
    geometry::PccPath path;
    path.segments = straight(n, 60.0 / static_cast<double>(n));
    const ReferenceProfile ref = reference_profile(path, limits, 0.001);
    const double analytic = rest_to_rest_time_s(60.0, k_limits);
    EXPECT_NEAR(ref.time_s, analytic, 0.01) << n << " segments";
    EXPECT_GE(ref.time_s, analytic - 0.001);
  }
}

// The plan's schedule (used for tei and the connection judgement) predicts the executed time.
TEST(SegmentedPlan, ScheduleMatchesTheExecutedTime) {
  const ScanLimits limits{k_limits, 500};
  for (const geometry::PccPath& path : {freeform_contour(300, 1.0), tight_meander(300, 0.5)}) {
    const SpeedPlan plan = plan_command(path.segments, {}, 0, 0.0, PlanKind::LookAhead, limits, {}, true);
    const ReferenceProfile ref = reference_profile(path, limits, 0.001);
    EXPECT_NEAR(plan.duration_s(), ref.time_s, 0.03 * ref.time_s);
  }
}

// A speed-limit drop in the middle of a line: a chain of full S-ramps (0 -> 100, 100 -> 20 ending
// where the slow zone starts, 20 -> 100 from where it ends, 100 -> 0) with cruises between has a
// closed-form time. The optimum under pointwise limits is a little faster (it may cross the zone
// ends still braking or already accelerating, dipping a^2/2J below 20 mm/s), so the reference
// must land within 1 % below and 1.5 % above it.
TEST(SegmentedReference, LimitDropMatchesTheClosedFormChainOfRamps) {
  geometry::PccPath path;
  path.segments = straight(100, 1.0);
  for (int i = 0; i < 100; ++i) path.speed_mm_s.push_back(i >= 40 && i < 60 ? 20.0 : 100.0);
  const ReferenceProfile ref = reference_profile(path, {k_limits, 500}, 0.001);
  const double up = ramp_time_s(100, k_limits), drop = ramp_time_s(80, k_limits);
  const double d_up = 50.0 * up, d_drop = 60.0 * drop;  // mean speed times duration
  const double cruise = (40 - d_up - d_drop) / 100.0;
  const double analytic = up + cruise + drop + 20.0 / 20.0 + drop + cruise + up;
  EXPECT_NEAR(analytic, 2.1431, 1e-4);
  EXPECT_GE(ref.time_s, analytic * 0.99);
  EXPECT_LE(ref.time_s, analytic * 1.015);  // braking checks use 97 % of the jerk limit
}

// Every executed cycle respects the speed (incl. curvature), acceleration and jerk limits,
// checked against the recorded profile and, independently, the true curvature at each point.
TEST(SegmentedReference, ProfileRespectsAllLimits) {
  const geometry::PccPath path = tight_meander(400, 0.5);
  const ScanLimits limits{k_limits, 500};
  CycleLog log;
  const ReferenceProfile ref = reference_profile(path, limits, 0.001, &log);
  ASSERT_GT(log.cycles.size(), 100u);
  double prev_a = 0, prev_s = 0, max_an = 0;
  for (const ScanCycle& c : log.cycles) {
    EXPECT_LE(c.state.v_mm_s, c.limit_mm_s + 1e-9);
    EXPECT_LE(std::abs(c.state.a_mm_s2), k_limits.acceleration_mm_s2 + 1e-6);
    EXPECT_LE(std::abs(c.state.a_mm_s2 - prev_a), k_limits.jerk_mm_s3 * 0.001 + 1e-6);
    EXPECT_GE(c.state.s_mm, prev_s);
    prev_a = c.state.a_mm_s2;
    prev_s = c.state.s_mm;
    // Centripetal part: |a_vec|^2 = a_t^2 + a_n^2.
    const double a_n = std::sqrt(std::max(0.0, c.acceleration_mm_s2.squaredNorm() - c.state.a_mm_s2 * c.state.a_mm_s2));
    max_an = std::max(max_an, a_n);
  }
  // The curvature is sampled at 5 points per segment: the true peak may exceed it slightly.
  EXPECT_LE(max_an, 500.0 * 1.05);
  EXPECT_GT(max_an, 500.0 * 0.8);  // the limit is actually used on this tight path
  EXPECT_NEAR(prev_s, ref.length_mm, 1e-9);
  EXPECT_GT(ref.time_s, ref.lower_bound_s);
}

}  // namespace
