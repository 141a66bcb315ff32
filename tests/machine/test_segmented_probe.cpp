// SPDX-License-Identifier: GPL-3.0-or-later
// Segmented continuous scanning (SEEDS.md 2) driving the real scanning control (SEEDS.md 1):
// the segmented plan's path speed becomes Vf of the scanning law, the scanning probe touches the
// simulated part, and stops, retracts and approaches really leave and re-find the surface.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "metron/machine/segmented_scanning/probe_scan_driver.hpp"
#include "metron/machine/segmented_scanning/segmented_controller.hpp"
#include "metron/machine/virtual_cmm.hpp"
#include "metron/machine/world_solid.hpp"
#include "metron/stdlib/fitting/fit.hpp"
#include "scan_paths.hpp"

namespace {

using namespace metron;
using namespace metron::machine;
using namespace metron::machine::segmented;

using namespace metron::scan_test;
constexpr double ball_r = boss_ball_radius_mm, lobe_mm = boss_lobe_mm, boss_d = boss_diameter_mm;
const Vec3 centre = boss_centre_mm;

struct ProbeRun {
  SegmentedStats stats;
  std::vector<ScanSample> samples;
  std::vector<std::size_t> sample_commands;
  std::vector<DrivenCycle> cycles;
  std::vector<double> boundaries_mm;
  std::size_t retracts = 0, approaches = 0;
  std::optional<Fault> fault;
  double end_time_s = 0, length_mm = 0;
};

ProbeRun run(const World& w, const ScanPath& scan, ControllerConfig cfg) {
  const auto solid = make_world_solid(w.truth);
  const ScanSetup setup{solid.get(), ball_r, w.machine, w.truth.scanning, 9};
  ScanPath settings = scan;
  settings.path = {};
  ProbeScanDriver probe(settings, setup, scan_approach_point(scan), 0);
  SegmentedController ctl(cfg, &probe);
  const auto cmds = split(scan.path, cfg.buffer_segments);
  ProbeRun r;
  std::size_t next = 0;
  while (!ctl.finished() && ctl.time_s() < 600 && !probe.fault()) {
    while (next < cmds.size() && ctl.free_buffer() != 0) {
      EXPECT_TRUE(ctl.load(cmds[next]).has_value());
      ++next;
    }
    ctl.step();
  }
  if (!probe.fault()) {
    EXPECT_TRUE(ctl.finished());
    EXPECT_TRUE(probe.finish(ctl.path_state().s_mm));
  }
  r.stats = ctl.stats();
  r.samples = probe.samples();
  r.sample_commands = probe.sample_commands();
  r.cycles = probe.cycles();
  for (const auto& b : r.stats.boundaries) r.boundaries_mm.push_back(b.s_mm);
  r.retracts = probe.retracts();
  r.approaches = probe.approaches();
  r.fault = probe.fault();
  r.end_time_s = probe.time_s();
  r.length_mm = scan.path.length();
  return r;
}

ControllerConfig config(SegmentedMode mode, std::size_t P, const World& w) {
  ControllerConfig cfg;
  cfg.mode = mode;
  cfg.buffer_segments = P;
  cfg.limits.path = {w.machine.scanning.control.feed_mm_s, 500.0, 5000.0};
  cfg.limits.normal_acceleration_mm_s2 = w.machine.scanning.control.max_centripetal_mm_s2;
  return cfg;
}

// The continuity checks every mode must pass: one ordered point set, no gap, no duplicate.
void expect_continuous(const ProbeRun& r, double spacing_mm) {
  ASSERT_FALSE(r.fault) << r.fault->message;
  ASSERT_GT(r.samples.size(), 10u);
  ASSERT_EQ(r.sample_commands.size(), r.samples.size());
  double worst_gap = 0;
  for (std::size_t i = 1; i < r.samples.size(); ++i) {
    const double ds = r.samples[i].path_s_mm - r.samples[i - 1].path_s_mm;
    EXPECT_GE(ds, spacing_mm - 1e-9) << "sample " << i;  // ordered, never twice the same place
    worst_gap = std::max(worst_gap, ds);
    EXPECT_GE(r.sample_commands[i], r.sample_commands[i - 1]);
    EXPECT_GT(r.samples[i].time_s, r.samples[i - 1].time_s);
  }
  // A sample every spacing of path, plus at most one cycle of travel: none lost at a junction.
  EXPECT_LT(worst_gap, spacing_mm + 0.05);
  EXPECT_LT(r.samples.front().path_s_mm, spacing_mm);
  EXPECT_GT(r.samples.back().path_s_mm, r.length_mm - spacing_mm - 0.05);
}

// Largest | |Ep| - E0 | over scanning cycles within `window_mm` of a boundary, and elsewhere.
std::pair<double, double> junction_deflection(const ProbeRun& r, double window_mm) {
  double near = 0, away = 0;
  for (const DrivenCycle& c : r.cycles) {
    if (!c.scanning) continue;
    const bool close = std::any_of(r.boundaries_mm.begin(), r.boundaries_mm.end(),
                                   [&](double b) { return std::abs(c.s_mm - b) < window_mm; });
    (close ? near : away) = std::max(close ? near : away, std::abs(c.deflection_error_mm));
  }
  return {near, away};
}

void expect_lobed_form(const ProbeRun& r) {
  const auto f = metron::scan_test::fit_scanned_boss(r.samples, ball_r);
  ASSERT_TRUE(f);
  EXPECT_NEAR(f->form_mm, 2 * lobe_mm, 0.001);
  EXPECT_NEAR(f->diameter_mm, boss_d, 0.001);
  EXPECT_NEAR((f->position - centre).head<2>().norm(), 0, 0.001);
}

const char* name(SegmentedMode m) {
  return m == SegmentedMode::Conventional ? "conventional" : m == SegmentedMode::Seed ? "seed" : "look-ahead";
}

}  // namespace

// Three turns around the lobed boss (2,500 segments of 0.2 mm) through buffers of 100 segments.
TEST(SegmentedProbe, LongScanAroundALobedBossInEveryMode) {
  const World w = lobed_boss_world();
  const ScanPath scan = boss_scan(3, 0.2);
  ASSERT_GT(scan.path.segments.size(), 2500u);
  for (const SegmentedMode mode : {SegmentedMode::Conventional, SegmentedMode::Seed, SegmentedMode::LookAhead}) {
    SCOPED_TRACE(name(mode));
    const ControllerConfig cfg = config(mode, 100, w);
    const ProbeRun r = run(w, scan, cfg);
    expect_continuous(r, scan.sample_spacing_mm);
    const std::size_t commands = (scan.path.segments.size() + 99) / 100;
    ASSERT_EQ(r.boundaries_mm.size(), commands - 1);
    if (mode == SegmentedMode::Conventional) {
      // Every boundary: stop, leave the surface, find it again.
      EXPECT_EQ(r.stats.stops, commands - 1);
      EXPECT_EQ(r.retracts, commands);  // plus the one at the path end
      EXPECT_EQ(r.approaches, commands);
    } else {
      // Tp (1.3 * 100 * 1 us by default) fits in every command (about 1 s): no stop at all.
      EXPECT_EQ(r.stats.stops, 0u);
      EXPECT_EQ(r.retracts, 1u);
      EXPECT_EQ(r.approaches, 1u);
    }
    expect_lobed_form(r);
    const auto [near, away] = junction_deflection(r, 2.0);
    // The deflection stays well inside the gain tolerance at the junctions too.
    EXPECT_LT(near, 0.05);
    EXPECT_LT(away, 0.05);
    std::printf(
        "[figures] %s: %zu samples, scan %.2f s, stops %zu, approaches %zu, |Ep|-E0 near junctions %.4f mm, "
        "elsewhere %.4f mm\n",
        name(mode), r.samples.size(), r.stats.scan_time_s(), r.stats.stops, r.approaches, near, away);
  }
}

// A plan that is not ready in time: the seed method stops only at that boundary, retracts,
// approaches again and goes on; the point set stays one continuous, ordered set.
TEST(SegmentedProbe, LatePlanFallsBackAtThatBoundaryOnly) {
  const World w = lobed_boss_world();
  const ScanPath scan = boss_scan(3, 0.2);
  ControllerConfig cfg = config(SegmentedMode::Seed, 100, w);
  cfg.planning_s_per_segment = 2e-4;  // a slow controller CPU: Tp = 1.3 * 100 * 0.2 ms
  cfg.planning_factor = [](std::size_t i) { return i == 10 ? 200.0 : 1.0; };  // 4 s for C10
  const ProbeRun r = run(w, scan, cfg);
  expect_continuous(r, scan.sample_spacing_mm);
  EXPECT_EQ(r.stats.stops, 1u);
  EXPECT_EQ(r.stats.late_plans, 1u);
  ASSERT_EQ(r.stats.boundaries.size(), r.boundaries_mm.size());
  for (const BoundaryEvent& b : r.stats.boundaries) {
    EXPECT_EQ(b.stopped, b.next_command == 10) << b.next_command;
    EXPECT_EQ(b.retracted, b.next_command == 10) << b.next_command;
  }
  EXPECT_EQ(r.retracts, 2u);
  EXPECT_EQ(r.approaches, 2u);
  // The probe really left the surface there: cycles without contact around boundary 10.
  ASSERT_GE(r.stats.boundaries.size(), 10u);
  const double b10 = r.stats.boundaries[9].s_mm;
  std::size_t free_cycles = 0;
  for (const DrivenCycle& c : r.cycles)
    if (!c.contact && std::abs(c.plan_s_mm - b10) < 1e-6) ++free_cycles;
  EXPECT_GT(free_cycles, 100u);
  expect_lobed_form(r);
  std::printf("[figures] seed, late plan of C10: %zu samples, scan %.2f s, stops %zu, free cycles at the stop %zu\n",
              r.samples.size(), r.stats.scan_time_s(), r.stats.stops, free_cycles);
}
