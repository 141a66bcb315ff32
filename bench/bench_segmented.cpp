// SPDX-License-Identifier: GPL-3.0-or-later
// Segmented continuous scanning (SEEDS.md 2): conventional / seed / look-ahead against the
// reference limit on long paths, the seed's fallback with a slow planner, data quality near
// command boundaries, and the planner's wall-clock cost.
// Build with -DMETRON_BENCH=ON; run ./build/bench/bench_segmented [segments (default 10000)].
// ./build/bench/bench_segmented --probe [turns (default 5)]: the same modes driving the real
// scanning probe (SEEDS.md 1 law, ProbeScanDriver) round a lobed boss in the simulated world.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <numbers>

#include "fixtures.hpp"
#include "metron/machine/rng.hpp"
#include "metron/machine/segmented_scanning/probe_scan_driver.hpp"
#include "metron/machine/segmented_scanning/segmented_controller.hpp"
#include "metron/machine/segmented_scanning/time_optimal_bound.hpp"
#include "metron/machine/world_solid.hpp"
#include "metron/runtime/scan_segmentation.hpp"
#include "metron/stdlib/fitting/fit.hpp"
#include "reference_planner.hpp"
#include "sample_paths.hpp"
#include "scan_paths.hpp"
#include "stream_commands.hpp"

namespace {

using namespace metron;
using namespace metron::machine;
using namespace metron::machine::segmented;
using namespace metron::test_support;

const char* name(SegmentedMode m) {
  switch (m) {
    case SegmentedMode::Conventional: return "conventional";
    case SegmentedMode::Seed: return "seed";
    case SegmentedMode::LookAhead: return "look-ahead";
  }
  return "?";
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");  // printed as nan: no such points
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5))];
}

struct Quality {
  double defl_near_max_um = 0, defl_near_mean_um = 0, defl_far_mean_um = 0, defl_far_max_um = 0;
  double gap_near_max_mm = 0, gap_far_max_mm = 0, gap_near_median_mm = 0, gap_far_median_mm = 0;
  bool continuous = true;
};

// Points within +-2 mm of a command boundary are "near"; the rest "far".
Quality quality(const std::vector<ScanPoint>& pts, const std::vector<BoundaryEvent>& bounds, double length) {
  Quality q;
  std::vector<double> gaps_near, gaps_far;
  double sum_near = 0, sum_far = 0;
  std::size_t n_near = 0, n_far = 0;
  std::size_t b = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const double s = pts[i].s_mm;
    while (b < bounds.size() && bounds[b].s_mm < s - 2.0) ++b;
    const bool near = b < bounds.size() && std::abs(bounds[b].s_mm - s) <= 2.0;
    const double d = pts[i].deflection_error_mm * 1000;
    if (near) {
      q.defl_near_max_um = std::max(q.defl_near_max_um, d);
      sum_near += d;
      ++n_near;
    } else {
      q.defl_far_max_um = std::max(q.defl_far_max_um, d);
      sum_far += d;
      ++n_far;
    }
    if (i > 0) {
      const double g = s - pts[i - 1].s_mm;
      if (!(g > 0) || pts[i].command_index < pts[i - 1].command_index) q.continuous = false;
      (near ? gaps_near : gaps_far).push_back(g);
    }
  }
  if (pts.empty() || pts.front().s_mm > 1e-3 || std::abs(pts.back().s_mm - length) > 1e-6) q.continuous = false;
  q.defl_near_mean_um = n_near ? sum_near / static_cast<double>(n_near) : std::nan("");
  q.defl_far_mean_um = n_far ? sum_far / static_cast<double>(n_far) : std::nan("");
  q.gap_near_max_mm = gaps_near.empty() ? 0 : *std::max_element(gaps_near.begin(), gaps_near.end());
  q.gap_far_max_mm = gaps_far.empty() ? 0 : *std::max_element(gaps_far.begin(), gaps_far.end());
  q.gap_near_median_mm = quantile(gaps_near, 0.5);
  q.gap_far_median_mm = quantile(gaps_far, 0.5);
  return q;
}

struct Outcome {
  SegmentedStats stats;
  Quality q;
  double wall_s = 0;
  std::size_t commands = 0;
  double mean_junction_mm_s = 0;
};

Outcome run(const geometry::PccPath& path, double length, const ControllerConfig& cfg) {
  Outcome o;
  StylusDeflectionRecorder rec;
  SegmentedController ctl(cfg, &rec);
  const auto cmds = runtime::split_commands(path, cfg.buffer_segments);
  o.commands = cmds.size();
  const auto w0 = std::chrono::steady_clock::now();
  const auto r = test_support::stream_commands(cmds, ctl, 1e6);
  o.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
  if (!r) {
    std::printf("run failed: %s\n", r.error().message.c_str());
    std::exit(1);
  }
  o.stats = *r;
  o.q = quality(rec.points(), o.stats.boundaries, length);
  double sum = 0;
  for (const auto& b : o.stats.boundaries) sum += b.speed_mm_s;
  o.mean_junction_mm_s = o.stats.boundaries.empty() ? 0 : sum / static_cast<double>(o.stats.boundaries.size());
  return o;
}

void header() {
  std::printf("%-8s %5s %-12s %5s %6s %5s %5s %9s %7s %7s %7s %7s | %7s %7s %7s | %8s %8s %8s | %6s\n", "path", "P",
              "mode", "cmds", "stops", "retr", "late", "time_s", "/limit", "/topp", "/bound", "v_junc", "dNear",
              "dNmax", "dFar", "gapNmed", "gapFmed", "gapNmax", "wall_s");
  std::printf("%-8s %5s %-12s %5s %6s %5s %5s %9s %7s %7s %7s %7s | %7s %7s %7s | %8s %8s %8s | %6s\n", "", "", "", "",
              "", "", "", "", "", "", "", "mm/s", "um", "um", "um", "mm", "mm", "mm", "");
}

// The independent lower bound (time-optimal, no jerk limit; time_optimal_bound.hpp) for a path.
double topp_s(const geometry::PccPath& path, const ScanLimits& l) {
  return time_optimal_bound(path,
                            BoundLimits{l.path.speed_mm_s, l.path.acceleration_mm_s2, l.normal_acceleration_mm_s2})
      .time_s;
}

void row(const char* path, std::size_t P, const char* mode, const Outcome& o, const ReferenceProfile& ref,
         double topp) {
  const double t = o.stats.scan_time_s();
  std::printf(
      "%-8s %5zu %-12s %5zu %6zu %5zu %5zu %9.2f %7.3f %7.3f %7.3f %7.2f | %7.2f %7.2f %7.2f | %8.4f %8.4f %8.4f | "
      "%6.2f%s\n",
      path, P, mode, o.commands, o.stats.stops, o.stats.retracts, o.stats.late_plans, t, t / ref.time_s, t / topp,
      t / ref.lower_bound_s, o.mean_junction_mm_s, o.q.defl_near_mean_um, o.q.defl_near_max_um, o.q.defl_far_mean_um,
      o.q.gap_near_median_mm, o.q.gap_far_median_mm, o.q.gap_near_max_mm, o.wall_s,
      o.q.continuous ? "" : "  DISCONTINUOUS");
}

// CPU time of this thread: unlike the wall clock, it does not count time the thread waited for
// a core, so it separates the planner's own cost from preemption on a loaded machine.
void planner_cost(const geometry::PccPath& path) {
  const ScanLimits limits;
  const LowSpeedRegion low;
  std::vector<double> per_command, per_command_cpu, per_segment;
  const std::size_t P = 1000;
  for (int rep = 0; rep < 20; ++rep) {
    for (std::size_t first = 0; first + P <= path.segments.size(); first += P) {
      std::span<const geometry::PccSegment> segs(path.segments.data() + first, P);
      const auto w0 = std::chrono::steady_clock::now();
      const double c0 = test_support::thread_cpu_s();
      const segmented::SpeedPlan plan = plan_command(segs, {}, 1, 0.0, PlanKind::Connection, limits, low, false);
      per_command_cpu.push_back(test_support::thread_cpu_s() - c0);
      per_command.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count());
      if (plan.pieces.empty()) std::abort();
    }
  }
  for (std::size_t i = 0; i < std::min<std::size_t>(path.segments.size(), 20000); ++i) {
    std::span<const geometry::PccSegment> seg(path.segments.data() + i % path.segments.size(), 1);
    const auto w0 = std::chrono::steady_clock::now();
    const segmented::SpeedPlan plan = plan_command(seg, {}, 1, 0.0, PlanKind::LookAhead, limits, low, false);
    per_segment.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count());
    if (plan.pieces.empty()) std::abort();
  }
  std::printf(
      "\nplanner cost (wall clock, this machine): one P=1000 command: min %.3f median %.3f p90 %.3f p99 %.3f ms"
      " (%zu plans); one segment: median %.2f us, p99 %.2f us (%zu plans)\n",
      quantile(per_command, 0.0) * 1e3, quantile(per_command, 0.5) * 1e3, quantile(per_command, 0.9) * 1e3,
      quantile(per_command, 0.99) * 1e3, per_command.size(), quantile(per_segment, 0.5) * 1e6,
      quantile(per_segment, 0.99) * 1e6, per_segment.size());
  std::printf(
      "planner cost per segment (P=1000, median wall): %.2f us; the configured net planning time "
      "(SegmentedScanSpec::planning_s_per_segment) is %.0f us per segment, %.0fx that\n",
      quantile(per_command, 0.5) * 1e6 / static_cast<double>(P), ControllerConfig{}.planning_s_per_segment * 1e6,
      ControllerConfig{}.planning_s_per_segment / (quantile(per_command, 0.5) / static_cast<double>(P)));
  std::printf("planner cost (thread CPU time): one P=1000 command: min %.3f median %.3f p90 %.3f p99 %.3f ms\n",
              quantile(per_command_cpu, 0.0) * 1e3, quantile(per_command_cpu, 0.5) * 1e3,
              quantile(per_command_cpu, 0.9) * 1e3, quantile(per_command_cpu, 0.99) * 1e3);
}

// ---- the real probe: segmented plans driving the scanning law round a lobed boss ----

using metron::scan_test::boss_scan;
using metron::scan_test::lobed_boss_world;
constexpr double k_ball_mm = metron::scan_test::boss_ball_radius_mm;

void probe_bench(double turns) {
  const World w = lobed_boss_world();
  const auto solid = make_world_solid(w.truth);
  const ScanSetup setup{solid.get(), k_ball_mm, w.machine, w.truth.scanning, 9};
  const ScanPath scan = boss_scan(turns, 0.2);
  ControllerConfig base;
  base.limits.path = {w.machine.scanning.control.feed_mm_s, 500.0, 5000.0};
  base.limits.normal_acceleration_mm_s2 = w.machine.scanning.control.max_centripetal_mm_s2;
  const ReferenceProfile ref = reference_profile(scan.path, base.limits, base.dt_s);
  const double topp = topp_s(scan.path, base.limits);
  std::printf(
      "real probe: %zu segments (%.1f mm, %.0f turns round a 50 mm boss with a hidden 5 um 3-lobe form), "
      "feed %.0f mm/s, a %.0f, j %.0f; reference %.2f s, independent time-optimal bound %.2f s\n",
      scan.path.segments.size(), ref.length_mm, turns, base.limits.path.speed_mm_s, base.limits.path.acceleration_mm_s2,
      base.limits.path.jerk_mm_s3, ref.time_s, topp);
  std::printf(
      "dNear/dFar: max ||Ep| - E0| within 2 mm of a boundary / elsewhere (scanning cycles); gapMax: largest "
      "sample spacing (spacing 0.2 mm); form: circle fit of the samples (hidden 5.0 um)\n");
  std::printf("%5s %-12s %5s %6s %6s %9s %7s %7s %7s %8s %8s %8s %8s %7s\n", "P", "mode", "stops", "retr", "late",
              "time s", "/limit", "/topp", "samples", "gapMax", "dNear um", "dFar um", "form um", "wall s");
  for (std::size_t P : {std::size_t{1000}, std::size_t{50}, std::size_t{4}}) {
    for (SegmentedMode mode : {SegmentedMode::Conventional, SegmentedMode::Seed, SegmentedMode::LookAhead}) {
      const auto w0 = std::chrono::steady_clock::now();
      ControllerConfig cfg = base;
      cfg.mode = mode;
      cfg.buffer_segments = P;
      ScanPath settings = scan;
      settings.path = {};
      ProbeScanDriver probe(settings, setup, scan_approach_point(scan), 0);
      SegmentedController ctl(cfg, &probe);
      const auto cmds = runtime::split_commands(scan.path, P);
      auto stats = test_support::stream_commands(cmds, ctl, 1e5);
      bool ok = stats.has_value() && !probe.fault() && probe.finish(ctl.path_state().s_mm);
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
      if (!ok) {
        std::printf("%5zu %-12s failed: %s\n", P, name(mode),
                    probe.fault() ? probe.fault()->message.c_str()
                    : stats       ? "did not finish"
                                  : stats.error().message.c_str());
        continue;
      }
      double gap = 0;
      const auto& smp = probe.samples();
      for (std::size_t i = 1; i < smp.size(); ++i) gap = std::max(gap, smp[i].path_s_mm - smp[i - 1].path_s_mm);
      double near = 0, far = 0;
      for (const DrivenCycle& c : probe.cycles()) {
        if (!c.scanning) continue;
        const bool close = std::any_of(stats->boundaries.begin(), stats->boundaries.end(),
                                       [&](const BoundaryEvent& b) { return std::abs(b.s_mm - c.s_mm) < 2.0; });
        double& m = close ? near : far;
        m = std::max(m, std::abs(c.deflection_error_mm));
      }
      const auto f = metron::scan_test::fit_scanned_boss(smp, k_ball_mm);
      std::printf("%5zu %-12s %5zu %6zu %6zu %9.2f %7.3f %7.3f %7zu %8.4f %8.2f %8.2f %8.2f %7.2f\n", P, name(mode),
                  stats->stops, probe.retracts(), stats->late_plans, stats->scan_time_s(),
                  stats->scan_time_s() / ref.time_s, stats->scan_time_s() / topp, smp.size(), gap, near * 1000,
                  far * 1000, f ? f->form_mm * 1000 : std::nan(""), wall);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && std::string(argv[1]) == "--probe") {
    probe_bench(argc > 2 ? std::atof(argv[2]) : 5.0);
    return 0;
  }
  const std::size_t segments = argc > 1 ? static_cast<std::size_t>(std::atol(argv[1])) : 10000;
  struct Named {
    const char* name;
    geometry::PccPath path;
  };
  const std::vector<Named> paths = {{"freeform", freeform_contour(segments, 1.0)},
                                    {"meander", tight_meander(segments, 0.5)}};
  const ControllerConfig base;
  std::printf(
      "segmented scanning bench: limits v=%.0f mm/s a=%.0f mm/s2 j=%.0f mm/s3 a_n=%.0f mm/s2, dt=%.0f ms, "
      "low region L=%.0f mm at %.0f mm/s, Tp=%.1f*%.2f us*P, retract %.0f mm, settle %.2f s\n",
      base.limits.path.speed_mm_s, base.limits.path.acceleration_mm_s2, base.limits.path.jerk_mm_s3,
      base.limits.normal_acceleration_mm_s2, base.dt_s * 1e3, base.low.length_mm, base.low.speed_mm_s,
      base.planning_margin, base.planning_s_per_segment * 1e6, base.retract_mm, base.contact_settle_s);
  std::printf(
      "/limit: scan time over the reference (metron's interpolator, whole path buffered); /topp: over the\n"
      "independent time-optimal bound (speed, acceleration, centripetal limits, no jerk); /bound: over "
      "sum(length/v_limit);\n"
      "dNear/dNmax/dFar: stylus deflection error mean/max within 2 mm of a boundary, mean elsewhere;\n"
      "gapNmed/gapFmed/gapNmax: point spacing median near/far from boundaries, max near\n\n");
  for (const auto& [pname, path] : paths) {
    const ReferenceProfile ref = reference_profile(path, base.limits, base.dt_s);
    const double topp = topp_s(path, base.limits);
    std::printf(
        "%s: %zu segments, %.1f mm; reference %.2f s (%zu cycles, +%.1f %% over the bound), independent "
        "time-optimal bound (no jerk limit) %.2f s, sum(length/v_limit) %.2f s\n",
        pname, path.segments.size(), ref.length_mm, ref.time_s, ref.cycles, 100 * (ref.time_s / topp - 1), topp,
        ref.lower_bound_s);
  }
  std::printf("\n");
  header();
  for (const auto& [pname, path] : paths) {
    const ReferenceProfile ref = reference_profile(path, base.limits, base.dt_s);
    const double topp = topp_s(path, base.limits);
    for (std::size_t P : {std::size_t{1000}, std::size_t{50}, std::size_t{4}}) {
      for (SegmentedMode mode : {SegmentedMode::Conventional, SegmentedMode::Seed, SegmentedMode::LookAhead}) {
        ControllerConfig cfg = base;
        cfg.mode = mode;
        cfg.buffer_segments = P;
        row(pname, P, name(mode), run(path, ref.length_mm, cfg), ref, topp);
      }
    }
  }
  // Tp does not fit: a planner 150x slower (Tp = 1.3 * 30 ms * P = 1.95 s for P = 50, about
  // one command's duration), and the same with actual planning times scattered between 1x and
  // 1.6x the net time (seeded), so some connection plans are late (SEEDS.md 2 step 5).
  std::printf("\nslow planner (P = 50): Tp = 1.3 * 30 ms * 50 = 1.95 s; ~: actual = net * U(1, 1.6), seed 42\n");
  header();
  for (const auto& [pname, path] : paths) {
    const ReferenceProfile ref = reference_profile(path, base.limits, base.dt_s);
    const double topp = topp_s(path, base.limits);
    for (bool jitter : {false, true}) {
      for (SegmentedMode mode : {SegmentedMode::Conventional, SegmentedMode::Seed, SegmentedMode::LookAhead}) {
        ControllerConfig cfg = base;
        cfg.mode = mode;
        cfg.buffer_segments = 50;
        cfg.planning_s_per_segment = 30e-3;
        if (jitter) {
          auto rng = std::make_shared<Rng>(42);
          auto factors = std::make_shared<std::vector<double>>();
          for (std::size_t i = 0; i < segments; ++i) factors->push_back(1.0 + 0.6 * rng->uniform());
          cfg.planning_factor = [factors](std::size_t i) { return (*factors)[i % factors->size()]; };
        }
        const std::string mname = std::string(name(mode)) + (jitter ? "~" : "");
        row(pname, 50, mname.c_str(), run(path, ref.length_mm, cfg), ref, topp);
      }
    }
  }
  planner_cost(paths.front().path);
  return 0;
}
