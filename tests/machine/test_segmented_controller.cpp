// SPDX-License-Identifier: GPL-3.0-or-later
// The segmented-scanning controller (SEEDS.md 2): double buffering with B and SB, the connection
// judgement LF against Tp, the fallback, the conventional and look-ahead modes, and the
// continuity of the recorded point set in every mode.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "metron/machine/segmented_scanning/segmented_controller.hpp"
#include "reference_planner.hpp"
#include "sample_paths.hpp"
#include "scan_paths.hpp"

namespace {

using namespace metron;
using namespace metron::machine;
using namespace metron::machine::segmented;
using namespace metron::test_support;

using metron::scan_test::split;

struct ScanRun {
  SegmentedStats stats;
  std::vector<ScanPoint> points;
  std::vector<ScanCycle> cycles;
  std::vector<int> b_flags;                        // B at each command change
  std::vector<std::pair<std::size_t, int>> loads;  // (command, buffer written)
  std::vector<bool> lf;                            // LF per cycle
  std::vector<double> t;                           // time per cycle
  double reference_s = 0;
};

ScanRun run(const geometry::PccPath& path, ControllerConfig cfg) {
  ScanRun r;
  StylusDeflectionRecorder rec;
  CycleLog log;
  RecorderTee tee(rec, log);
  SegmentedController ctl(cfg, &tee);
  const auto cmds = split(path, cfg.buffer_segments);
  std::size_t next = 0;
  int last_b = -1;
  while (!ctl.finished() && ctl.time_s() < 600) {
    while (next < cmds.size() && ctl.free_buffer() != 0) {
      const int b = ctl.free_buffer();
      EXPECT_EQ(ctl.status_flag(b), 0);
      EXPECT_TRUE(ctl.load(cmds[next]).has_value());
      EXPECT_EQ(ctl.status_flag(b), 1);
      r.loads.emplace_back(next, b);
      ++next;
    }
    ctl.step();
    if (ctl.buffer_flag() != last_b) r.b_flags.push_back(last_b = ctl.buffer_flag());
    r.lf.push_back(ctl.connection_flag());
    r.t.push_back(ctl.time_s());
  }
  EXPECT_TRUE(ctl.finished());
  r.stats = ctl.stats();
  r.points = rec.points();
  r.cycles = std::move(log.cycles);
  return r;
}

double path_length(const geometry::PccPath& path) { return path.length(); }

// One continuous, correctly ordered point set: strictly increasing arc length from the start to
// the end, no gap longer than one cycle at the speed limit, positions on the path, commands in order.
void expect_continuous(const ScanRun& r, const geometry::PccPath& path, double v_max) {
  ASSERT_FALSE(r.points.empty());
  EXPECT_LT(r.points.front().s_mm, 1e-3);
  EXPECT_NEAR(r.points.back().s_mm, path_length(path), 1e-6);
  // Independent position check: walk the path by arc length.
  std::vector<double> cum{0.0};
  for (const auto& s : path.segments) cum.push_back(cum.back() + s.length());
  for (std::size_t i = 0; i < r.points.size(); ++i) {
    const ScanPoint& p = r.points[i];
    if (i > 0) {
      const ScanPoint& q = r.points[i - 1];
      ASSERT_GT(p.s_mm, q.s_mm) << "point " << i << " not after the previous one";
      ASSERT_LE(p.s_mm - q.s_mm, v_max * 0.001 + 1e-6) << "gap at point " << i;
      ASSERT_GE(p.command_index, q.command_index);
      ASSERT_GT(p.t_s, q.t_s);
    }
    if (i % 37 == 0) {
      const auto k = static_cast<std::size_t>(std::upper_bound(cum.begin(), cum.end(), p.s_mm) - cum.begin()) - 1;
      const auto& seg = path.segments[std::min(k, path.segments.size() - 1)];
      const double arc = p.s_mm - cum[std::min(k, path.segments.size() - 1)];
      // Bisection on the arc length, independent of the controller's Newton iteration.
      double lo = 0, hi = seg.d_mm;
      for (int it = 0; it < 60; ++it) ((seg.arc_length(0.5 * (lo + hi)) < arc) ? lo : hi) = 0.5 * (lo + hi);
      EXPECT_LT((seg.point(lo) - p.position_mm).norm(), 1e-6) << "point " << i;
    }
  }
}

ControllerConfig base(SegmentedMode mode, std::size_t P) {
  ControllerConfig c;
  c.mode = mode;
  c.buffer_segments = P;
  c.planning_s_per_segment = 2e-3;  // Tp = 1.3 * 2 ms * P
  return c;
}

const geometry::PccPath& test_path() {
  static const geometry::PccPath p = freeform_contour(240, 1.0);
  return p;
}

TEST(SegmentedController, BuffersAlternateWithFlags) {
  const ScanRun r = run(test_path(), base(SegmentedMode::Seed, 40));
  ASSERT_EQ(r.loads.size(), 6u);
  for (const auto& [cmd, b] : r.loads) EXPECT_EQ(b, static_cast<int>(cmd % 2) + 1) << "command " << cmd;
  // B toggles once per command: 1, 2, 1, 2, ...
  ASSERT_EQ(r.b_flags.size(), 6u);
  for (std::size_t i = 0; i < r.b_flags.size(); ++i) EXPECT_EQ(r.b_flags[i], static_cast<int>(i % 2) + 1);
}

TEST(SegmentedController, LoadRefusedWhenBuffersFullOrOutOfOrder) {
  SegmentedController ctl(base(SegmentedMode::Seed, 40));
  const auto cmds = split(test_path(), 40);
  EXPECT_FALSE(ctl.load(cmds[1]).has_value());
  ASSERT_TRUE(ctl.load(cmds[0]).has_value());
  ASSERT_TRUE(ctl.load(cmds[1]).has_value());
  EXPECT_EQ(ctl.free_buffer(), 0);
  const auto refused = ctl.load(cmds[2]);
  ASSERT_FALSE(refused.has_value());
  EXPECT_EQ(refused.error().kind, FaultKind::BadCommand);
  EXPECT_THROW(SegmentedController([] {
                 auto c = base(SegmentedMode::Seed, 4);
                 c.low.speed_mm_s = 8;
                 return c;
               }()),
               std::invalid_argument);
}

TEST(SegmentedController, SeedConnectsEveryBoundaryWhenTpFits) {
  const ScanRun r = run(test_path(), base(SegmentedMode::Seed, 40));
  EXPECT_EQ(r.stats.stops, 0u);
  EXPECT_EQ(r.stats.retracts, 0u);
  ASSERT_EQ(r.stats.plan_kinds.size(), 6u);
  EXPECT_EQ(r.stats.plan_kinds[0], PlanKind::Individual);
  for (std::size_t i = 1; i < 6; ++i) EXPECT_EQ(r.stats.plan_kinds[i], PlanKind::Connection);
  ASSERT_EQ(r.stats.boundaries.size(), 5u);
  // The crossing speed is interpolated back to the boundary to first order; the jerk term
  // leaves up to J*dt^2/2 = 0.005 mm/s.
  for (const auto& b : r.stats.boundaries) EXPECT_NEAR(b.speed_mm_s, 3.0, 6e-3) << "boundary " << b.next_command;
  expect_continuous(r, test_path(), 100.0);
}

TEST(SegmentedController, SeedCommandsShorterThanTheRegionStillConnectAtTheLowSpeed) {
  // 4 segments of 0.5 mm: each command (2 mm) is shorter than L = 3 mm, so no low-speed region,
  // but every plan still ends at the low speed and the probe passes each boundary at it.
  const geometry::PccPath path = tight_meander(40, 0.5);
  const ScanRun r = run(path, base(SegmentedMode::Seed, 4));
  EXPECT_EQ(r.stats.stops, 0u);
  ASSERT_EQ(r.stats.boundaries.size(), 9u);
  for (const auto& b : r.stats.boundaries) EXPECT_NEAR(b.speed_mm_s, 3.0, 6e-3) << b.next_command;
  // Faster than running everything at the low speed: the middle of each command is not capped.
  EXPECT_LT(r.stats.scan_time_s(), 0.8 * path.length() / 3.0);
  expect_continuous(r, path, 100.0);
}

TEST(SegmentedController, ConnectionFlagDropsTpBeforeTheCommandEnd) {
  // LF falls when tei - t reaches Tp; in the low-speed region the gap time is exact, so the
  // falling edge comes Tp (= 1.3 * 2 ms * 40 = 0.104 s) before the boundary.
  const ScanRun r = run(test_path(), base(SegmentedMode::Seed, 40));
  std::vector<double> falls;
  for (std::size_t i = 1; i < r.lf.size(); ++i)
    if (r.lf[i - 1] && !r.lf[i]) falls.push_back(r.t[i]);
  ASSERT_GE(falls.size(), 5u);
  for (std::size_t k = 0; k < 5; ++k) EXPECT_NEAR(r.stats.boundaries[k].t_s - falls[k], 0.104, 0.003) << k;
}

// SEEDS.md 2 step 4: the planner acts on LF, and LF compares the gap time tei - t with Tp
// (1.3 x the net planning time), not with the net time. The host loads C1 late, when C0's gap time
// lies between the net time (0.4 s) and Tp (0.52 s): LF = 0, so C1 gets an individual plan and
// the probe stops at the boundary; loaded with a gap above Tp it connects. Fails when LF is
// compared with the net time, or when the planner decides by anything but LF.
TEST(SegmentedController, PlannerReadsLFAndLFComparesTheGapWithTp) {
  ControllerConfig cfg = base(SegmentedMode::Seed, 40);
  cfg.planning_s_per_segment = 0.01;  // net 0.4 s, Tp 0.52 s for 40 segments
  const auto cmds = split(test_path(), 40);
  ASSERT_GE(cmds.size(), 3u);
  // When C0 ends: C0's plan does not depend on C1 (it always ends at the low speed).
  double te0 = 0;
  {
    SegmentedController ctl(cfg);
    ASSERT_TRUE(ctl.load(cmds[0]).has_value());
    ASSERT_TRUE(ctl.load(cmds[1]).has_value());
    while (ctl.stats().boundaries.empty() && ctl.time_s() < 60) ctl.step();
    ASSERT_FALSE(ctl.stats().boundaries.empty());
    te0 = ctl.stats().boundaries.front().t_s;
  }
  struct Outcome {
    PlanKind kind;
    bool lf_at_load;
    bool stopped;
  };
  const auto load_late = [&](double gap_s) {
    SegmentedController ctl(cfg);
    EXPECT_TRUE(ctl.load(cmds[0]).has_value());
    while (ctl.time_s() < te0 - gap_s) ctl.step();
    const bool lf = ctl.connection_flag();
    EXPECT_TRUE(ctl.load(cmds[1]).has_value());
    std::size_t next = 2;
    while (!ctl.finished() && ctl.time_s() < 120) {
      while (next < cmds.size() && ctl.free_buffer() != 0) EXPECT_TRUE(ctl.load(cmds[next++]).has_value());
      ctl.step();
    }
    EXPECT_TRUE(ctl.finished());
    const auto& st = ctl.stats();
    EXPECT_GE(st.plan_kinds.size(), 2u);
    EXPECT_GE(st.boundaries.size(), 1u);
    return Outcome{st.plan_kinds.size() > 1 ? st.plan_kinds[1] : PlanKind::LookAhead, lf,
                   !st.boundaries.empty() && st.boundaries.front().stopped};
  };
  const Outcome between = load_late(0.46);
  EXPECT_FALSE(between.lf_at_load);
  EXPECT_EQ(between.kind, PlanKind::Individual);
  EXPECT_TRUE(between.stopped);
  const Outcome above = load_late(0.60);
  EXPECT_TRUE(above.lf_at_load);
  EXPECT_EQ(above.kind, PlanKind::Connection);
  EXPECT_FALSE(above.stopped);
}

TEST(SegmentedController, SeedFallsBackOnlyAtTheLateBoundary) {
  // The plan of C3 takes 3x its net time, longer than Tp = 1.3x: LF said "connect", the plan is
  // late, the probe stops at the end of C2 only, retracts and approaches again.
  ControllerConfig cfg = base(SegmentedMode::Seed, 40);
  cfg.planning_s_per_segment = 0.02;  // net 0.8 s, Tp 1.04 s: fits the ~1.5 s commands
  cfg.planning_factor = [](std::size_t i) { return i == 3 ? 3.0 : 1.0; };
  const ScanRun r = run(test_path(), cfg);
  EXPECT_EQ(r.stats.stops, 1u);
  EXPECT_EQ(r.stats.retracts, 1u);
  EXPECT_EQ(r.stats.late_plans, 1u);
  ASSERT_EQ(r.stats.boundaries.size(), 5u);
  for (const auto& b : r.stats.boundaries) {
    EXPECT_EQ(b.stopped, b.next_command == 3) << b.next_command;
    EXPECT_EQ(b.retracted, b.next_command == 3);
    if (b.next_command != 3) {
      EXPECT_NEAR(b.speed_mm_s, 3.0, 6e-3);
    }
  }
  expect_continuous(r, test_path(), 100.0);
  // The stop lasts at least retract + plan remainder + approach.
  const ScanRun ok = run(test_path(), [] {
    auto c = base(SegmentedMode::Seed, 40);
    c.planning_s_per_segment = 0.02;
    return c;
  }());
  EXPECT_EQ(ok.stats.stops, 0u);
  EXPECT_GT(r.stats.scan_time_s(), ok.stats.scan_time_s() + 2 * rest_to_rest_time_s(2.0, cfg.positioning));
}

TEST(SegmentedController, SeedPlansIndividuallyWhenTpNeverFits) {
  // Tp longer than every command: LF = 0 whenever the planner takes a command up, so every
  // plan is individual and every boundary is a stop with retract and approach.
  ControllerConfig cfg = base(SegmentedMode::Seed, 40);
  cfg.planning_s_per_segment = 0.1;  // Tp = 5.2 s
  const ScanRun r = run(test_path(), cfg);
  for (PlanKind k : r.stats.plan_kinds) EXPECT_EQ(k, PlanKind::Individual);
  EXPECT_EQ(r.stats.stops, 5u);
  EXPECT_EQ(r.stats.late_plans, 0u);
  for (const auto& b : r.stats.boundaries) EXPECT_TRUE(b.stopped && b.retracted);
  expect_continuous(r, test_path(), 100.0);
}

TEST(SegmentedController, ConventionalStopsAndRetractsAtEveryBoundary) {
  const ScanRun r = run(test_path(), base(SegmentedMode::Conventional, 40));
  EXPECT_EQ(r.stats.stops, 5u);
  EXPECT_EQ(r.stats.retracts, 5u);
  for (PlanKind k : r.stats.plan_kinds) EXPECT_EQ(k, PlanKind::Conventional);
  expect_continuous(r, test_path(), 100.0);
}

TEST(SegmentedController, LookAheadIsNearTheLimitAndKeepsSpeedAtJunctions) {
  const ScanRun r = run(test_path(), base(SegmentedMode::LookAhead, 40));
  const ReferenceProfile ref = reference_profile(test_path(), ScanLimits{}, 0.001);
  EXPECT_EQ(r.stats.stops, 0u);
  EXPECT_LT(r.stats.scan_time_s(), 1.05 * ref.time_s);
  EXPECT_GE(r.stats.scan_time_s(), ref.time_s - 0.002);
  for (const auto& b : r.stats.boundaries) EXPECT_GT(b.speed_mm_s, 20.0) << b.next_command;
  expect_continuous(r, test_path(), 100.0);
  // The seed method is slower (1 s of low speed per command), conventional slower still.
  const ScanRun seed = run(test_path(), base(SegmentedMode::Seed, 40));
  const ScanRun conv = run(test_path(), base(SegmentedMode::Conventional, 40));
  EXPECT_GT(seed.stats.scan_time_s(), r.stats.scan_time_s() + 4.0);
  EXPECT_EQ(conv.stats.stops, 5u);
}

TEST(SegmentedController, LookAheadPacesToASlowPlannerInsteadOfStopping) {
  // Tp = 1.3 * 20 ms * 40 = 1.04 s, longer than a command takes at full speed (~0.5 s).
  ControllerConfig cfg = base(SegmentedMode::LookAhead, 40);
  cfg.planning_s_per_segment = 0.02;
  cfg.pace_to_planner = false;
  const ScanRun stopping = run(test_path(), cfg);
  EXPECT_GE(stopping.stats.stops, 3u);
  cfg.pace_to_planner = true;
  const ScanRun paced = run(test_path(), cfg);
  EXPECT_EQ(paced.stats.stops, 0u);
  EXPECT_EQ(paced.stats.retracts, 0u);
  for (const auto& b : paced.stats.boundaries) EXPECT_GE(b.speed_mm_s, 3.0 - 1e-3) << b.next_command;
  expect_continuous(paced, test_path(), 100.0);
  double prev_a = 0;
  for (const ScanCycle& c : paced.cycles) {
    ASSERT_LE(c.state.v_mm_s, c.limit_mm_s + 1e-9);
    ASSERT_LE(std::abs(c.state.a_mm_s2 - prev_a), 10.0 + 1e-6);
    prev_a = c.state.a_mm_s2;
  }
}

TEST(SegmentedController, LookAheadStopsInContactWhenThePlannerIsLate) {
  ControllerConfig cfg = base(SegmentedMode::LookAhead, 40);
  cfg.planning_factor = [](std::size_t i) { return i == 2 ? 50.0 : 1.0; };  // 4 s: C1 ends first
  const ScanRun r = run(test_path(), cfg);
  EXPECT_EQ(r.stats.stops, 1u);
  EXPECT_EQ(r.stats.retracts, 0u);
  ASSERT_EQ(r.stats.boundaries.size(), 5u);
  for (const auto& b : r.stats.boundaries) EXPECT_EQ(b.stopped, b.next_command == 2) << b.next_command;
  expect_continuous(r, test_path(), 100.0);
}

TEST(SegmentedController, ExecutedProfilesRespectTheLimitsInEveryMode) {
  for (SegmentedMode mode : {SegmentedMode::Conventional, SegmentedMode::Seed, SegmentedMode::LookAhead}) {
    const ScanRun r = run(test_path(), base(mode, 40));
    double prev_a = 0;
    bool first = true;
    for (const ScanCycle& c : r.cycles) {
      ASSERT_LE(c.state.v_mm_s, c.limit_mm_s + 1e-9);
      ASSERT_LE(std::abs(c.state.a_mm_s2), 1000.0 + 1e-6);
      if (!first) {
        ASSERT_LE(std::abs(c.state.a_mm_s2 - prev_a), 10.0 + 1e-6);
      }
      first = false;
      prev_a = c.state.a_mm_s2;
    }
  }
}

}  // namespace
