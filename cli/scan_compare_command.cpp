// SPDX-License-Identifier: GPL-3.0-or-later
// `metron scan-compare`: the scanning strategies side by side on a user's world (issue 11):
// the trajectory-correction laws (SEEDS.md 1: none, Vc1, Vc1', Vc2, optionally each at its best
// Kc) with the deviation across the scan direction, and the segmented-scanning modes (SEEDS.md 2)
// against the independent time-optimal bound. The simulation runs on the world's hidden truth, like
// the benchmarks; nothing here feeds a measurement result.
#include <cmath>
#include <iostream>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include <fmt/format.h>

#include "commands.hpp"
#include "metron/machine/active_scanning/scan_controller.hpp"
#include "metron/machine/segmented_scanning/segmented_controller.hpp"
#include "metron/machine/segmented_scanning/time_optimal_bound.hpp"
#include "metron/machine/world.hpp"
#include "metron/machine/world_solid.hpp"
#include "metron/runtime/scan_segmentation.hpp"

namespace metron::cli {
namespace {

struct ScanCompareArgs {
  std::optional<std::string> world;
  std::vector<double> line;             // x0 y0 z0 x1 y1 z1: ball centres
  std::vector<double> circle;           // cx cy cz r: ball centres, in a plane z = cz
  std::vector<double> normal{0, 0, 1};  // approach normal of a line
  std::vector<double> start_offset{0, 0, 0};
  bool bore = false;
  bool kc_sweep = false;
  bool laws_only = false, segmented_only = false;
  double segment_mm = 1;
  double ball_radius_mm = 2;
  std::size_t buffer_segments = 50;
};

const char* law_name(machine::ScanLaw law) {
  switch (law) {
    case machine::ScanLaw::Vc1: return "Vc1";
    case machine::ScanLaw::Vc1Prime: return "Vc1'";
    case machine::ScanLaw::Vc2: return "Vc2";
  }
  return "?";
}

// The ball-centre path from the options, with its approach normal.
tl::expected<machine::ScanPath, std::string> make_path(const ScanCompareArgs& a) {
  machine::ScanPath c;
  const double seg = a.segment_mm > 0 ? a.segment_mm : 1;
  if (a.line.size() == 6) {
    const Vec3 p0(a.line[0], a.line[1], a.line[2]), p1(a.line[3], a.line[4], a.line[5]);
    const Vec3 n = Vec3(a.normal[0], a.normal[1], a.normal[2]);
    if ((p1 - p0).norm() < 1e-6 || n.norm() < 1e-9)
      return tl::unexpected(std::string("--line needs two distinct points and --normal a direction"));
    const Vec3 u = (p1 - p0).normalized();
    const int k = std::max(1, static_cast<int>(std::ceil((p1 - p0).norm() / seg)));
    for (int i = 0; i < k; ++i) {
      c.path.segments.push_back(
          geometry::PccSegment::hermite(p0 + (p1 - p0) * i / k, p0 + (p1 - p0) * (i + 1) / k, u, u));
      c.path.normals.push_back(n.normalized());
    }
    c.path.normals.push_back(n.normalized());
    c.approach_normal = n.normalized();
  } else if (a.circle.size() == 4 && a.circle[3] > 0) {
    const Vec3 centre(a.circle[0], a.circle[1], a.circle[2]);
    const double r = a.circle[3], sign = a.bore ? -1 : 1;
    const int k = std::max(8, static_cast<int>(std::ceil(2 * std::numbers::pi * r / seg)));
    const auto radial = [](double t) { return Vec3(std::cos(t), std::sin(t), 0); };
    const auto tangent = [](double t) { return Vec3(-std::sin(t), std::cos(t), 0); };
    for (int i = 0; i < k; ++i) {
      const double t0 = 2 * std::numbers::pi * i / k, t1 = 2 * std::numbers::pi * (i + 1) / k;
      c.path.segments.push_back(
          geometry::PccSegment::hermite(centre + r * radial(t0), centre + r * radial(t1), tangent(t0), tangent(t1)));
      c.path.normals.push_back(sign * radial(t0));
    }
    c.path.normals.push_back(sign * radial(0));
    c.approach_normal = sign * radial(0);
  } else {
    return tl::unexpected(
        std::string("give the ball-centre path: --line x0 y0 z0 x1 y1 z1 (with --normal) or --circle cx cy cz r"));
  }
  c.sample_spacing_mm = 0.1;
  return c;
}

struct LawRun {
  machine::ScanOutcome out;
  double late_lateral_mm = 0;  // mean |lateral| over the second half of the path
};

LawRun run_law(const machine::World& w, const machine::Solid& solid, machine::ScanPath cmd, machine::ScanLaw law,
               double kc, const ScanCompareArgs& a) {
  machine::MachineConfig config = w.machine;
  config.scanning.control.trajectory_gain_1_s = kc;
  cmd.law = law;
  const machine::ScanSetup setup{&solid, a.ball_radius_mm + w.truth.probe.ball_radius_error_mm, config,
                                 w.truth.scanning, w.seed};
  const Vec3 start = machine::scan_approach_point(cmd) + Vec3(a.start_offset[0], a.start_offset[1], a.start_offset[2]);
  double sum = 0, half = 0;
  int n = 0;
  std::vector<std::pair<double, double>> lat;
  LawRun r;
  r.out = machine::run_scan(cmd, setup, start, 0, [&](const machine::ScanCycle& c) {
    if (c.scanning) lat.emplace_back(c.path_s_mm, std::abs(c.lateral_error_mm));
  });
  half = r.out.stats.path_length_mm / 2;
  for (const auto& [s, l] : lat)
    if (s >= half) sum += l, ++n;
  r.late_lateral_mm = n ? sum / n : std::nan("");
  return r;
}

std::string done_text(const machine::ScanOutcome& o) {
  return o.completed ? "yes"
                     : fmt::format("no: {} at {:.1f} mm", o.fault ? machine::to_string(o.fault->kind) : "?",
                                   o.stats.reached_mm);
}

void compare_laws(const machine::World& w, const machine::ScanPath& cmd, const ScanCompareArgs& a) {
  const auto solid = machine::make_world_solid(w.truth);
  const double kc0 = w.machine.scanning.control.trajectory_gain_1_s;
  std::cout << fmt::format(
      "trajectory-correction laws (SEEDS.md 1), K {} /s, Kc {} /s; lat = (P - Pp) . q, the deviation across the scan\n"
      "direction (um): rms, peak, mean over the second half; dE = |Ep| - E0 (um); none = Kc 0\n",
      w.machine.scanning.control.deflection_gain_1_s, kc0);
  std::cout << fmt::format("{:<5} {:>9} {:>9} {:>9} | {:>9} {:>9} | {}\n", "law", "lat rms", "lat pk", "lat late",
                           "dE rms", "dE pk", "done");
  const auto row = [&](const char* name, machine::ScanLaw law, double kc) {
    const LawRun r = run_law(w, *solid, cmd, law, kc, a);
    const auto& st = r.out.stats;
    std::cout << fmt::format("{:<5} {:>9.2f} {:>9.2f} {:>9.2f} | {:>9.2f} {:>9.2f} | {}\n", name,
                             1000 * st.rms_lateral_error_mm, 1000 * st.max_lateral_error_mm, 1000 * r.late_lateral_mm,
                             1000 * st.rms_deflection_error_mm, 1000 * st.peak_deflection_error_mm, done_text(r.out));
  };
  row("none", machine::ScanLaw::Vc2, 0);
  for (auto law : {machine::ScanLaw::Vc1, machine::ScanLaw::Vc1Prime, machine::ScanLaw::Vc2})
    row(law_name(law), law, kc0);
  if (!a.kc_sweep) return;
  std::cout
      << "\nKc-only sweep (K fixed): lat rms / dE rms (um), * = not completed; best = smallest sum among completed\n";
  const std::vector<double> gains = {2.5, 5, 10, 20, 40, 80};
  std::cout << fmt::format("{:>6} | {:>16} {:>16} {:>16}\n", "Kc", "Vc1", "Vc1'", "Vc2");
  double best[3] = {1e300, 1e300, 1e300}, best_kc[3] = {0, 0, 0};
  for (double kc : gains) {
    std::cout << fmt::format("{:>6.1f} |", kc);
    int i = 0;
    for (auto law : {machine::ScanLaw::Vc1, machine::ScanLaw::Vc1Prime, machine::ScanLaw::Vc2}) {
      const LawRun r = run_law(w, *solid, cmd, law, kc, a);
      const auto& st = r.out.stats;
      const double score = st.rms_lateral_error_mm + st.rms_deflection_error_mm;
      if (r.out.completed && score < best[i]) best[i] = score, best_kc[i] = kc;
      std::cout << fmt::format(" {:>16}", fmt::format("{:.1f}/{:.1f}{}", 1000 * st.rms_lateral_error_mm,
                                                      1000 * st.rms_deflection_error_mm, r.out.completed ? " " : "*"));
      ++i;
    }
    std::cout << "\n";
  }
  std::cout << fmt::format("  best | {:>16} {:>16} {:>16}\n", fmt::format("Kc {} ({:.1f})", best_kc[0], 1000 * best[0]),
                           fmt::format("Kc {} ({:.1f})", best_kc[1], 1000 * best[1]),
                           fmt::format("Kc {} ({:.1f})", best_kc[2], 1000 * best[2]));
}

void compare_segmented(const machine::World& w, const machine::ScanPath& cmd, const ScanCompareArgs& a) {
  namespace sg = machine::segmented;
  const machine::SegmentedScanSpec& g = w.machine.scanning.segmented;
  sg::ControllerConfig base;
  base.buffer_segments = a.buffer_segments;
  base.planning_s_per_segment = g.planning_s_per_segment;
  base.planning_fixed_s = g.planning_fixed_s;
  base.planning_margin = g.planning_margin;
  base.low = {g.low_length_mm, g.low_speed_mm_s};
  base.dt_s = w.machine.dt_s;
  const double feed = std::min(w.machine.scanning.control.feed_mm_s, w.machine.max_speed_mm_s);
  base.limits.path = {feed, g.path_acceleration_mm_s2, g.path_jerk_mm_s3};
  base.limits.normal_acceleration_mm_s2 = w.machine.scanning.control.max_centripetal_mm_s2;
  const auto bound = sg::time_optimal_bound(
      cmd.path, sg::BoundLimits{feed, g.path_acceleration_mm_s2, w.machine.scanning.control.max_centripetal_mm_s2});
  std::cout << fmt::format(
      "\nsegmented scanning (SEEDS.md 2): {} segments, {:.1f} mm, P = {}, feed {} mm/s, a {} mm/s2, j {} mm/s3;\n"
      "independent time-optimal bound (speed, acceleration, centripetal; no jerk): {:.3f} s\n",
      cmd.path.segments.size(), bound.length_mm, a.buffer_segments, feed, g.path_acceleration_mm_s2, g.path_jerk_mm_s3,
      bound.time_s);
  std::cout << fmt::format("{:<12} {:>5} {:>6} {:>9} {:>8}\n", "mode", "cmds", "stops", "time s", "/bound");
  for (auto mode : {sg::SegmentedMode::Conventional, sg::SegmentedMode::Seed, sg::SegmentedMode::LookAhead}) {
    sg::ControllerConfig cfg = base;
    cfg.mode = mode;
    sg::SegmentedController ctl(cfg);
    const auto cmds = runtime::split_commands(cmd.path, cfg.buffer_segments);
    std::size_t next = 0;
    while (!ctl.finished() && ctl.time_s() < 1e5) {
      while (next < cmds.size() && ctl.free_buffer() != 0)
        if (!ctl.load(cmds[next++])) break;
      ctl.step();
    }
    const double t = ctl.stats().scan_time_s();
    const char* name = mode == sg::SegmentedMode::Conventional ? "conventional"
                       : mode == sg::SegmentedMode::Seed       ? "seed"
                                                               : "look-ahead";
    std::cout << fmt::format("{:<12} {:>5} {:>6} {:>9.3f} {:>8.3f}{}\n", name, cmds.size(), ctl.stats().stops, t,
                             t / bound.time_s, ctl.finished() ? "" : "  (did not finish)");
  }
}

int scan_compare_cmd(const ScanCompareArgs& a) {
  auto loaded = machine::load_world_or_default(a.world);
  if (!loaded) {
    std::cerr << "error: " << loaded.error().message << "\n";
    return 2;
  }
  const auto cmd = make_path(a);
  if (!cmd) {
    std::cerr << "error: " << cmd.error() << "\n";
    return 2;
  }
  std::cout << "scan comparison on " << a.world.value_or("<default>") << "\n";
  if (!a.segmented_only) compare_laws(*loaded, *cmd, a);
  if (!a.laws_only) compare_segmented(*loaded, *cmd, a);
  return 0;
}

}  // namespace

void add_scan_compare_command(CLI::App& app, std::vector<Command>& commands) {
  auto a = std::make_shared<ScanCompareArgs>();
  auto* cmd =
      app.add_subcommand("scan-compare",
                         "compare the scanning laws (SEEDS.md 1) and the segmented-scanning modes (SEEDS.md 2) on a "
                         "world: lateral and deflection errors, scan time against the time-optimal bound");
  cmd->add_option("--world", a->world, "world description (JSON); default: the embedded default world");
  cmd->add_option("--line", a->line, "a straight ball-centre path: x0 y0 z0 x1 y1 z1 (mm)")->expected(6);
  cmd->add_option("--normal", a->normal, "the line's approach normal i j k (default 0 0 1)")->expected(3);
  cmd->add_option("--circle", a->circle, "a circular ball-centre path in the plane z = cz: cx cy cz r (mm)")
      ->expected(4);
  cmd->add_flag("--bore", a->bore, "the circle is inside a bore (normals point to the centre)");
  cmd->add_option("--start-offset", a->start_offset, "start the head this far from the approach point: dx dy dz (mm)")
      ->expected(3);
  cmd->add_option("--ball-radius", a->ball_radius_mm, "stylus ball radius (mm)")->default_val(2);
  cmd->add_option("--segment-mm", a->segment_mm, "path segment length (mm)")->default_val(1);
  cmd->add_option("--buffer-segments", a->buffer_segments, "P, segments per measurement command")->default_val(50);
  cmd->add_flag("--kc-sweep", a->kc_sweep, "also sweep Kc per law (K fixed) and give each law's best");
  cmd->add_flag("--laws-only", a->laws_only, "only the law comparison");
  cmd->add_flag("--segmented-only", a->segmented_only, "only the segmented-scanning comparison");
  commands.push_back({cmd, [a] { return scan_compare_cmd(*a); }});
}

}  // namespace metron::cli
