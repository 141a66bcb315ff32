// SPDX-License-Identifier: GPL-3.0-or-later
// `metron characterise`: the touch-trigger machine characterisation (docs/touch-trigger.md).
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include <fmt/format.h>

#include "commands.hpp"
#include "metron/machine/touch_cycle/axis_dynamics.hpp"
#include "metron/machine/touch_cycle/cycle_limit.hpp"
#include "metron/machine/virtual_cmm.hpp"
#include "metron/machine/world.hpp"
#include "metron/runtime/characterisation.hpp"
#include "metron/runtime/cycle_comparison.hpp"

namespace metron::cli {
namespace {

struct CharacteriseArgs {
  std::optional<std::string> world;
  std::optional<std::uint64_t> seed;
  std::optional<std::string> out;
  double threshold_um = 10;
  double nominal_tolerance_mm = runtime::default_nominal_tolerance_mm;
  bool truth = false;
  bool blend = false;
  bool optimise = false;
  bool fastest = false;
  bool compare = false;
};

// The hidden truth next to what was recovered: for checking the method only (the
// characterisation itself never reads the world).
void print_truth(const machine::World& w, const runtime::MachineCharacterisation& c) {
  std::cout << "\nhidden truth (for checking only; the characterisation did not read it)\n";
  for (int i = 0; i < 3; ++i) {
    const Vec3 e = Vec3::Unit(i);
    std::cout << fmt::format("  {} axis: D1 true / recovered [mm] at", "xyz"[i]);
    for (double f : {2.0, 10.0, 50.0, 100.0}) {
      const double t = f * machine::ramp_time_s(w.machine, w.truth.axes, e, f) / 2;
      const double r = c.acceleration_distance_mm(e, f);
      std::cout << fmt::format("  {:.0f} mm/s: {:.4f}/{:.4f} ({:+.2f} %)", f, t, r, 100 * (r - t) / t);
    }
    std::cout << "\n";
  }
  const auto& s = w.machine.skip;
  const double delay = w.truth.probe.filter_delay_s + w.truth.probe.transmission_delay_s +
                       (s.kind == machine::SkipInput::Kind::Latched ? s.latency_s : 0);
  std::cout << fmt::format(
      "  skip: {} true, {} recovered; jitter {:.3f} ms true, {:.3f} ms recovered\n",
      s.kind == machine::SkipInput::Kind::Scanned ? "scanned" : "latched", c.response.scanned ? "scanned" : "latched",
      s.kind == machine::SkipInput::Kind::Scanned ? 1e3 * s.period_s : 0.0, 1e3 * c.response.jitter_s);
  std::cout << fmt::format("  constant delay {:.3f} ms true, {:.3f} ms recovered\n", 1e3 * delay,
                           1e3 * c.response.delay_s);
  std::cout << fmt::format("  pre-travel (vertical) {:.4f} mm true, {:.4f} mm estimated\n",
                           w.truth.probe.pre_travel.vertical_mm, c.pre_travel_mm);
  // Worst-case stop distance at the maximum feed along each axis, from the true parameters, for a
  // trigger anywhere on the ramp (docs/touch-trigger.md: S(F) = pre-travel + F (delay + period +
  // dt) + F (Ta + Tb)/2; braking from F takes F Tb/2, and a contact while still accelerating
  // first ramps the acceleration down, another F Ta/2 at most).
  for (int i = 0; i < 3; ++i) {
    const Vec3 e = Vec3::Unit(i);
    const double f = c.max_feed_mm_s(e);
    const double jitter = s.kind == machine::SkipInput::Kind::Scanned ? s.period_s : 0;
    const double stop = std::max(w.truth.probe.pre_travel.horizontal_mm, w.truth.probe.pre_travel.vertical_mm) +
                        w.truth.probe.repeatability_mm * 4 + f * (delay + jitter + w.machine.dt_s) +
                        f *
                            (machine::ramp_time_s(w.machine, w.truth.axes, e, f) +
                             machine::braking_time_s(w.machine, w.truth.axes, e, f)) /
                            2;
    std::cout << fmt::format(
        "  {} axis: max feed {:.1f} mm/s, true worst stop distance {:.3f} mm of {:.3f} mm over-travel\n", "xyz"[i], f,
        stop, w.truth.probe.over_travel_mm);
  }
}

int characterise_cmd(const CharacteriseArgs& args) {
  auto loaded = machine::load_world_or_default(args.world);
  if (!loaded) {
    std::cerr << "error: " << loaded.error().message << "\n";
    return 2;
  }
  machine::World world = std::move(*loaded);
  const auto machine = machine::make_virtual_cmm(world, args.seed.value_or(world.seed));
  runtime::CharacterisationSettings settings;
  settings.repeatability_threshold_mm = args.threshold_um / 1000;
  settings.nominal_tolerance_mm = args.nominal_tolerance_mm;
  settings.blend = args.blend;
  settings.optimise_first_feed = args.optimise;
  settings.fastest = args.fastest;
  auto c = runtime::characterise(*machine, settings, [](const std::string& line) { std::cerr << line << "\n"; });
  if (!c) {
    std::cerr << "error: characterisation failed: " << c.error() << "\n";
    return 3;
  }
  c->world = args.world.value_or("<default>");
  std::cout << "machine characterisation of " << c->world << "\n" << runtime::format_characterisation(*c);
  std::cout << fmt::format("simulated time: {:.1f} s\n", machine->state().time_s);
  if (args.truth) print_truth(world, *c);
  if (args.compare) {
    // Issue 11: the touch benchmark's baselines on the user's own world.
    std::cerr << "timing cycles ...\n";
    const runtime::CycleComparisonSettings cs;
    auto cmp = runtime::compare_cycles(*machine, *c, cs);
    if (!cmp) {
      std::cerr << "error: cycle comparison failed: " << cmp.error() << "\n";
      return 3;
    }
    double limit = 0;
    if (args.truth)
      limit =
          machine::touch_cycle_limit(world.machine, world.truth, -cmp->normal, c->measuring_feed_mm_s, cs.clearance_mm,
                                     c->nominal_tolerance_mm, cs.positioning_mm_s, c->response.qualification_feed_mm_s)
              .time_s;
    std::cout << fmt::format(
                     "\ntouch cycles on the reference sphere's touch point (start and end at rest {:.1f} mm above, "
                     "nominal +-{:.3f} mm, {} points, positioning {:.0f} mm/s; measuring feed {:.2f} mm/s)\n",
                     cs.clearance_mm, c->nominal_tolerance_mm, cs.points, cs.positioning_mm_s, c->measuring_feed_mm_s)
              << runtime::format_cycle_comparison(cmp->rows, c->threshold_mm, limit);
    if (args.truth)
      std::cout << fmt::format("  physical limit (hidden truth, docs/touch-trigger.md): {:.4f} s\n", limit);
  }
  if (args.out) {
    if (auto ok = runtime::save_characterisation(*c, *args.out); !ok) {
      std::cerr << "error: " << ok.error() << "\n";
      return 2;
    }
    std::cout << "written: " << *args.out << "\n";
  }
  return 0;
}

}  // namespace

void add_characterise_command(CLI::App& app, std::vector<Command>& commands) {
  auto args = std::make_shared<CharacteriseArgs>();
  auto* cmd =
      app.add_subcommand("characterise",
                         "measure the machine's acceleration and trigger response and choose the touch strategy "
                         "(SEEDS.md 3, docs/touch-trigger.md)");
  cmd->alias("characterize");
  cmd->add_option("--world", args->world, "world description (JSON); default: the embedded default world");
  cmd->add_option("--seed", args->seed, "random seed (default: the world's)");
  cmd->add_option("--out", args->out, "write the characterisation file (JSON) here");
  cmd->add_option("--threshold-um", args->threshold_um, "one-touch when the spread is below this (um)")
      ->default_val(10);
  cmd->add_option("--nominal-tolerance", args->nominal_tolerance_mm,
                  "uncertainty of nominal surface positions (mm), the standoff's tolerance term")
      ->default_val(runtime::default_nominal_tolerance_mm);
  cmd->add_flag("--blend", args->blend,
                "beyond the seed: PTMEAS blends the approach into the probing feed (one touch, no standoff stop)");
  cmd->add_flag("--optimise-first-feed", args->optimise,
                "beyond the seed: choose the two-touch first-touch feed by timed trial cycles");
  cmd->add_flag("--fastest", args->fastest,
                "beyond the seed: use the fastest cycle (one-touch, two-touch, blended) that meets the threshold, "
                "chosen by timed trial cycles");
  cmd->add_flag("--compare", args->compare,
                "also time the conventional baselines (plain one-touch, two-touch with 1 and 0.5 mm back-off) and the "
                "characterised cycles on the touch point, side by side (with --truth: against the physical limit)");
  cmd->add_flag("--truth", args->truth, "also print the world's hidden truth next to the recovered values");
  commands.push_back({cmd, [args] { return characterise_cmd(*args); }});
}

}  // namespace metron::cli
