// SPDX-License-Identifier: GPL-3.0-or-later
// Touch-trigger cycle time at equal accuracy (SEEDS.md 3, docs/touch-trigger.md): on a slow-scan
// (4 ms), a latched and a constant-time controller, side by side in one run: a conventional
// fixed default, the seed's optimal two-touch cycle, the best one-touch cycle, the blended
// one-touch cycle (beyond the seed) and the physical limit of a jerk-limited move pair. Cycle
// times are simulated (the controller clock); the table is printed, then a wall-clock
// benchmark of the characterisation runs.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "metron/machine/touch_cycle/axis_dynamics.hpp"
#include "metron/machine/touch_cycle/cycle_limit.hpp"
#include "metron/machine/virtual_cmm.hpp"
#include "metron/runtime/characterisation.hpp"

using namespace metron;

namespace {

const std::string worlds_dir = std::string(METRON_SOURCE_DIR) + "/programs/worlds/";
constexpr double clearance_mm = 2.0;        // cycle start and end: 2 mm above the nominal (SNSET/APPRCH default)
constexpr double tolerance_mm = 0.2;        // the surface lies within +-0.2 mm of its nominal
constexpr double positioning_mm_s = 200;    // positioning feed of every strategy
constexpr double backoff_default_mm = 1.0;  // the conventional fixed back-off (docs/touch-trigger.md)
constexpr int points = 40;                  // nominal offsets spread over the tolerance band

struct Row {
  std::string name;
  double time_s = 0;     // mean cycle time
  double bias_um = 0;    // mean error against constant-speed touches at the measuring feed
  double spread_um = 0;  // range of the errors
  bool measured = true;
};

struct Bench {
  machine::World world;
  runtime::MachineCharacterisation c;
  machine::VirtualCmm cmm;
  std::uint64_t tag = 1;
  double radius_mm = 2;
  const Vec3 nominal{380, 250, 40};  // the default block's top face, probed along -z
  const Vec3 n = Vec3::UnitZ();

  Bench(const machine::World& w, const runtime::MachineCharacterisation& ch) : world(w), c(ch), cmm(w, 3) {
    exec(machine::DefineTool{"T", 4.0, -Vec3::UnitZ(), 50});
    exec(machine::SelectTool{"T"});
    radius_mm = exec(machine::QualifyTool{}).tool->effective_radius_mm;
    machine::SetFeeds f;
    f.positioning_mm_s = positioning_mm_s;
    exec(f);
    // Clear of the part: up, then over the probed point.
    const Vec3 at = cmm.state().position_mm;
    exec(machine::GoTo{Vec3(at.x(), at.y(), 150), {}});
    exec(machine::GoTo{nominal + Vec3(0, 0, 110), {}});
  }
  machine::Response exec(decltype(machine::Command::body) b) {
    cmm.submit({tag++, std::move(b)});
    return cmm.execute().front();
  }
  // One cycle for a nominal `offset` from the true surface: start at rest at the clearance, end
  // at rest `clearance` above the hit. Returns {time, latched z}.
  std::pair<double, double> cycle(machine::PtMeas p, double offset) {
    p.nominal_mm = nominal + offset * n;
    p.normal = n;
    p.retract_mm = clearance_mm;
    if (p.search_mm <= 0) p.search_mm = 3;
    exec(machine::GoTo{p.nominal_mm + (radius_mm + clearance_mm) * n, {}});
    const auto r = exec(p);
    if (!r.hit) {
      fmt::print("fault: {}\n", r.fault ? r.fault->message : "?");
      return {0, 0};
    }
    return {r.end_time_s - r.start_time_s, r.hit->centre_mm.z()};
  }
  Row run(const std::string& name, const machine::PtMeas& p, double reference_z) {
    Row row{name};
    std::vector<double> err;
    for (int k = 0; k < points; ++k) {
      const double offset = tolerance_mm * (2 * (k + 0.5) / points - 1);
      const auto [t, z] = cycle(p, offset);
      row.time_s += t / points;
      err.push_back(1e3 * (z - reference_z));
    }
    double mean = 0;
    for (double e : err) mean += e / points;
    row.bias_um = mean;
    row.spread_um = *std::max_element(err.begin(), err.end()) - *std::min_element(err.begin(), err.end());
    return row;
  }
};

machine::PtMeas from_plan(const runtime::TouchPlan& plan) {
  machine::PtMeas p;
  runtime::apply_touch_plan(plan, p);
  return p;
}

void table(const std::string& world_name) {
  auto w = machine::load_world(worlds_dir + world_name);
  if (!w) {
    fmt::print("{}\n", w.error().message);
    return;
  }
  runtime::CharacterisationSettings settings;
  settings.nominal_tolerance_mm = tolerance_mm;
  runtime::MachineCharacterisation c;
  {
    machine::VirtualCmm m(*w, 1);
    auto got = runtime::characterise(m, settings);
    if (!got) {
      fmt::print("characterisation failed: {}\n", got.error());
      return;
    }
    c = *got;
  }
  Bench b(*w, c);
  const Vec3 down = -Vec3::UnitZ();
  const double fs = c.measuring_feed_mm_s, ff = c.first_feed_mm_s;

  // Reference: constant-speed touches at the measuring feed from far away, true surface.
  double reference = 0;
  {
    machine::PtMeas p;
    p.approach_mm = clearance_mm + 4 * c.acceleration_distance_mm(down, fs);
    p.speed_mm_s = fs;
    const int n = 4 * points;
    for (int k = 0; k < n; ++k) reference += b.cycle(p, 0).second / n;
  }

  // Conventional baselines a careful installer would set, from the same clearance: a plain
  // one-touch at the measuring feed, and two-touch cycles with fixed back-offs.
  std::vector<Row> rows;
  {
    machine::PtMeas p;
    p.approach_mm = clearance_mm;
    p.speed_mm_s = fs;
    rows.push_back(b.run("conventional plain one-touch (from the clearance)", p, reference));
  }
  for (double backoff : {backoff_default_mm, 0.5 * backoff_default_mm}) {
    machine::PtMeas p;
    p.approach_mm = clearance_mm;
    p.speed_mm_s = fs;
    p.two_touch = machine::PtMeas::TwoTouch{ff, backoff};
    rows.push_back(b.run(fmt::format("conventional two-touch, {:.1f} mm back-off", backoff), p, reference));
  }
  const std::size_t baselines = rows.size();
  // Every plan starts where the cycle rests: at the clearance on the approach line.
  const runtime::RestingHead rest{clearance_mm, positioning_mm_s};
  runtime::MachineCharacterisation two = c;
  two.one_touch = false;
  two.blend = false;
  rows.push_back(
      b.run("seed: optimal two-touch (D1+D2+D3)", from_plan(two.plan(b.n, fs, std::nullopt, rest)), reference));
  {
    // Beyond the seed: the first-touch feed chosen by timed trial cycles on the machine.
    machine::VirtualCmm m(*w, 1);
    runtime::CharacterisationSettings s2 = settings;
    s2.optimise_first_feed = true;
    auto tuned = runtime::characterise(m, s2);
    if (tuned && !tuned->one_touch) {
      runtime::MachineCharacterisation t2 = *tuned;
      t2.measuring_feed_mm_s = fs;
      rows.push_back(b.run(fmt::format("beyond seed: two-touch, timed first feed {:.1f}", t2.first_feed_mm_s),
                           from_plan(t2.plan(b.n, fs, std::nullopt, rest)), reference));
    }
  }
  runtime::MachineCharacterisation one = c;
  one.one_touch = true;
  one.blend = false;
  rows.push_back(b.run("seed: one-touch (D1+D3+tol, from where it rests)",
                       from_plan(one.plan(b.n, fs, std::nullopt, rest)), reference));
  runtime::MachineCharacterisation blend = c;
  blend.blend = true;
  auto bp = blend.plan(b.n, fs, clearance_mm);
  rows.push_back(b.run("beyond seed: blended one-touch", from_plan(bp), reference));

  // The physical limit from the hidden truth alone (machine/touch_cycle/cycle_limit.hpp): rest
  // to the feed by the earliest possible contact (clearance - q - tolerance), the band at the
  // feed, the trigger chain, the stop, the return. Controller-cycle rounding is not part of it.
  const auto lim = machine::touch_cycle_limit(w->machine, w->truth, down, fs, clearance_mm, tolerance_mm,
                                              positioning_mm_s, c.response.qualification_feed_mm_s);
  const double t_limit = lim.time_s;
  Row limit{"physical limit (jerk-limited, hidden truth)", t_limit, 0, 0, false};
  Row bound{"lower bound (acceleration limits only)", lim.no_jerk_time_s, 0, 0, false};

  fmt::print("\n== {}: skip {} (jitter {:.1f} ms recovered), max protected feed {:.1f} mm/s, strategy {}\n", world_name,
             c.response.scanned ? "scanned" : "latched", 1e3 * c.response.jitter_s, c.max_probe_feed_mm_s,
             c.one_touch ? "one-touch" : "two-touch");
  fmt::print(
      "   measuring feed {:.2f} mm/s (spread {:.1f} um <= {:.0f} um), first touch {:.1f} mm/s, nominal +-{:.1f} mm, "
      "clearance {:.0f} mm, positioning {:.0f} mm/s\n",
      fs, 1e3 * c.response.spread_mm(fs), 1e3 * c.threshold_mm, ff, tolerance_mm, clearance_mm, positioning_mm_s);
  fmt::print(
      "   seed standoff D1+D2+D3 = {:.4f} mm (back-off {:.4f} mm), one-touch approach {:.4f} mm, blend {:.4f} mm\n",
      two.plan(b.n, fs, std::nullopt).standoff_mm, two.plan(b.n, fs, std::nullopt).backoff_mm,
      one.plan(b.n, fs, std::nullopt).approach_mm, *bp.blend_mm);
  fmt::print("   {:<50} {:>9} {:>9} {:>12} {:>10} {:>10}\n", "cycle", "time s", "/limit", "vs best conv.", "bias um",
             "spread um");
  // The best baseline: the fastest conventional cycle that meets the threshold on every point.
  double conventional = 1e9;
  for (std::size_t i = 0; i < baselines; ++i)
    if (rows[i].spread_um <= 1e3 * c.threshold_mm && std::abs(rows[i].bias_um) <= 1e3 * c.threshold_mm)
      conventional = std::min(conventional, rows[i].time_s);
  rows.push_back(limit);
  rows.push_back(bound);
  for (const auto& r : rows) {
    if (r.measured)
      fmt::print("   {:<50} {:9.4f} {:9.3f} {:11.1f}% {:10.2f} {:10.2f}\n", r.name, r.time_s, r.time_s / t_limit,
                 100 * (1 - r.time_s / conventional), r.bias_um, r.spread_um);
    else
      fmt::print("   {:<50} {:9.4f} {:9.3f} {:11.1f}%\n", r.name, r.time_s, r.time_s / t_limit,
                 100 * (1 - r.time_s / conventional));
  }
  fmt::print("   limit: feed reached {:.4f} mm from the start (clearance - q - tolerance, q = {:.4f} mm)\n",
             lim.reach_mm, lim.q_mm);
}

void BM_Characterise(benchmark::State& state) {
  auto w = machine::load_world(worlds_dir + "touch_scanned_4ms.json");
  for (auto _ : state) {
    machine::VirtualCmm m(*w, 1);
    auto c = runtime::characterise(m, runtime::CharacterisationSettings{});
    benchmark::DoNotOptimize(c);
  }
}
BENCHMARK(BM_Characterise)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  fmt::print("touch-trigger cycle time at equal accuracy (simulated controller time; docs/touch-trigger.md)\n");
  for (const char* w : {"touch_scanned_4ms.json", "touch_latched.json", "touch_const_time.json"}) table(w);
  std::fflush(stdout);
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
