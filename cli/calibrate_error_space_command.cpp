// SPDX-License-Identifier: GPL-3.0-or-later
// `metron calibrate error-space`: the sequential two-point calibration of a CMM's error space
// (SEEDS.md 4, docs/error-space.md) on the simulated rig of a world: the two-sensor head and a
// commercially flat plate, plane by plane, the planes tied by a laser run. The method sees only the
// rig's readings; `--truth` prints the world's hidden errors beside them, for checking.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "metron/machine/error_space/calibration.hpp"
#include "metron/machine/world.hpp"
#include "metron/stdlib/error_space/error_space_file.hpp"
#include "metron/stdlib/error_space/report_svg.hpp"
#include "virtual_cmm_backend.hpp"

namespace metron::cli {
namespace {

struct ErrorSpaceArgs {
  std::optional<std::string> world;
  double step_mm = 50;
  std::vector<int> size{11, 11, 3};
  std::vector<double> origin_mm{100, 100, 0};
  std::string components = "z";
  double sensor_noise_um = 0.1;
  bool reversal = false;
  bool angle_instrument = false;
  double angle_noise_urad = 0.25;
  std::vector<double> sensor_offset_mm{0, 0, -120};
  int runs = 1;
  int laser_cycles = 2;
  std::optional<std::uint64_t> seed;
  std::optional<std::string> out;
  bool append = false;
  std::optional<std::string> report;
  bool truth = false;
};

struct Comparison {
  double rms_mm = 0, max_mm = 0, floor_rms_mm = 0;
};

// Recovered against the hidden truth in the method's reference, beside the method's noise floor.
Comparison compare(const error_space::ErrorSpace& got, const error_space::ErrorSpace& truth, int c) {
  Comparison out;
  const auto& g = got.values_mm[c];
  const auto& t = truth.values_mm[c];
  const auto& sd = got.sd_mm[c];
  for (std::size_t i = 0; i < g.size() && i < t.size(); ++i) {
    const double d = g[i] - t[i];
    out.rms_mm += d * d;
    out.max_mm = std::max(out.max_mm, std::abs(d));
    if (i < sd.size()) out.floor_rms_mm += sd[i] * sd[i];
  }
  const double n = std::max<double>(1, static_cast<double>(g.size()));
  out.rms_mm = std::sqrt(out.rms_mm / n);
  out.floor_rms_mm = std::sqrt(out.floor_rms_mm / n);
  return out;
}

double rms(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return v.empty() ? 0 : std::sqrt(s / static_cast<double>(v.size()));
}

int calibrate_error_space(const ErrorSpaceArgs& args) {
  auto loaded = machine::load_world_or_default(args.world);
  if (!loaded) {
    std::cerr << "error: " << loaded.error().message << "\n";
    return 2;
  }
  machine::World world = std::move(*loaded);
  if (args.size.size() != 3 || args.origin_mm.size() != 3 || !(args.step_mm > 0)) {
    std::cerr << "error: --size takes nx,ny,nz and --origin x,y,z; --step-mm must be positive\n";
    return 2;
  }
  runtime::ErrorSpaceRequest request;
  for (int a = 0; a < 3; ++a) {
    if (args.size[a] < 1 || args.size[a] > 1000) {
      std::cerr << "error: --size: each count must be 1 to 1000\n";
      return 2;
    }
    request.size[a] = args.size[a];
    request.origin_mm[a] = args.origin_mm[a];
  }
  if (args.sensor_offset_mm.size() != 3 || args.runs < 1 || args.runs > 100 || args.laser_cycles < 1 ||
      args.laser_cycles > 100) {
    std::cerr << "error: --sensor-offset takes x,y,z; --runs and --laser-cycles 1 to 100\n";
    return 2;
  }
  request.step_mm = args.step_mm;
  for (int c = 0; c < 3; ++c) request.components[c] = args.components.find("xyz"[c]) != std::string::npos;
  request.sensor_noise_um = args.sensor_noise_um;
  request.reversal = args.reversal;
  request.angle_instrument = args.angle_instrument;
  request.angle_noise_urad = args.angle_noise_urad;
  for (int a = 0; a < 3; ++a) request.sensor_offset_mm[a] = args.sensor_offset_mm[a];
  request.runs = args.runs;
  request.laser_cycles = args.laser_cycles;
  const machine::SpaceCalibrationPlan plan = error_space_plan(request, args.seed.value_or(world.seed));

  machine::SpaceCalibration run;
  try {
    run = machine::calibrate_space(world.truth.errors, plan);
  } catch (const std::invalid_argument& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  }
  const char* names = "xyz";
  std::cout << fmt::format(
      "error space {} x {} x {} points, step {} mm, components {}; {} planes, {} to re-measure (S7); "
      "machine at {:.2f} C\n",
      args.size[0], args.size[1], args.size[2], args.step_mm, args.components, run.planes.size(),
      run.planes_to_remeasure, run.space.temperature_c);
  std::optional<error_space::ErrorSpace> truth;
  if (args.truth) truth = machine::truth_in_reference(world.truth.errors, plan);
  for (int c = 0; c < 3; ++c) {
    if (!run.space.has(static_cast<error_space::Component>(c))) continue;
    std::cout << fmt::format("  e_{}: RMS {:.3f} um over the grid, noise floor RMS {:.3f} um", names[c],
                             1e3 * rms(run.space.values_mm[c]), 1e3 * rms(run.space.sd_mm[c]));
    if (truth) {
      const Comparison k = compare(run.space, *truth, c);
      std::cout << fmt::format("; against the hidden truth: RMS {:.3f} um, max {:.3f} um ({:.2f} x the floor)",
                               1e3 * k.rms_mm, 1e3 * k.max_mm, k.floor_rms_mm > 0 ? k.rms_mm / k.floor_rms_mm : 0.0);
    }
    std::cout << "\n";
  }
  if (args.out) {
    error_space::ErrorSpaceFile file;
    if (args.append && std::filesystem::exists(*args.out)) {
      // Another temperature for the same machine: the spaces must share the grid and components.
      auto earlier = error_space::read_error_space_file(*args.out);
      if (!earlier) {
        std::cerr << "error: " << *args.out << ": " << earlier.error().pointer << ": " << earlier.error().message
                  << "\n";
        return 2;
      }
      file = std::move(*earlier);
      if (file.sensor_offset_mm !=
          std::array<double, 3>{args.sensor_offset_mm[0], args.sensor_offset_mm[1], args.sensor_offset_mm[2]}) {
        std::cerr << "error: " << *args.out << " was calibrated with another --sensor-offset\n";
        return 2;
      }
      for (const auto& s : file.spaces)
        if (std::abs(s.temperature_c - run.space.temperature_c) < 0.005) {
          std::cerr << fmt::format("error: {} already holds a space at {:.2f} C\n", *args.out, s.temperature_c);
          return 2;
        }
    }
    file.spaces.push_back(run.space);
    std::sort(file.spaces.begin(), file.spaces.end(),
              [](const auto& a, const auto& b) { return a.temperature_c < b.temperature_c; });
    file.sensor_offset_mm = {args.sensor_offset_mm[0], args.sensor_offset_mm[1], args.sensor_offset_mm[2]};
    file.description = fmt::format("metron calibrate error-space, sequential two-point method (SEEDS.md 4), world {}",
                                   args.world.value_or("<default>"));
    // The spaces must agree (grid, components): the file's own reader checks what it will be read with.
    try {
      if (auto back = error_space::from_json(error_space::to_json(file)); !back) {
        std::cerr << "error: " << *args.out << ": " << back.error().pointer << ": " << back.error().message << "\n";
        return 2;
      }
    } catch (const std::invalid_argument& e) {
      std::cerr << "error: " << *args.out << ": " << e.what() << "\n";
      return 2;
    }
    if (auto w = error_space::write_error_space_file(*args.out, file); !w) {
      std::cerr << "error: " << w.error() << "\n";
      return 2;
    }
    std::cout << "written: " << *args.out << "\n";
  }
  if (args.report) {
    error_space::ReportInput in;
    in.title = "Error-space calibration, sequential two-point method (SEEDS.md 4)";
    in.notes.push_back(
        fmt::format("world {}; grid {} x {} x {}, step {} mm; sensor noise {} um; S7 planes to re-measure: {}",
                    args.world.value_or("<default>"), args.size[0], args.size[1], args.size[2], args.step_mm,
                    args.sensor_noise_um, run.planes_to_remeasure));
    for (int c = 0; c < 3; ++c) {
      const auto comp = static_cast<error_space::Component>(c);
      if (!run.space.has(comp)) continue;
      const double z0 = run.space.grid.axes_mm[2].front();
      in.maps.push_back(
          error_space::slice_map(run.space, comp, 0, fmt::format("recovered e_{} at z = {} mm", names[c], z0)));
      if (truth) {
        error_space::ErrorSpace diff = run.space;
        for (std::size_t i = 0; i < diff.values_mm[c].size(); ++i) diff.values_mm[c][i] -= truth->values_mm[c][i];
        in.maps.push_back(error_space::slice_map(
            diff, comp, 0, fmt::format("recovered - hidden truth, e_{} at z = {} mm", names[c], z0)));
      }
      const error_space::InterpolationSpec spec;
      if (auto m =
              error_space::validation_map(run.space, comp, 0, spec, fmt::format("validation residual, e_{}", names[c])))
        in.maps.push_back(*m);
    }
    std::ofstream out(*args.report);
    out << error_space::report_svg(in);
    if (!out) {
      std::cerr << "error: cannot write " << *args.report << "\n";
      return 2;
    }
    std::cout << "written: " << *args.report << "\n";
  }
  return 0;
}

}  // namespace

void add_calibrate_error_space_command(CLI::App& calibrate, std::vector<Command>& commands) {
  auto args = std::make_shared<ErrorSpaceArgs>();
  auto* cmd = calibrate.add_subcommand(
      "error-space",
      "error-space calibration of a CMM by the sequential two-point method (SEEDS.md 4, docs/error-space.md)");
  cmd->add_option("--world", args->world,
                  "world (JSON) whose machine.errors the rig measures; default: the embedded one");
  cmd->add_option("--step-mm", args->step_mm, "grid step, which is the head's sensor spacing d")->default_val(50);
  cmd->add_option("--size", args->size, "grid points along x, y, z")
      ->delimiter(',')
      ->expected(3)
      ->default_str("11,11,3");
  cmd->add_option("--origin", args->origin_mm, "ram position of the first grid point, mm")
      ->delimiter(',')
      ->expected(3)
      ->default_str("100,100,0");
  cmd->add_option("--components", args->components,
                  "error components to measure (plates facing x, y, z): e.g. z or xyz")
      ->default_val("z")
      ->check(CLI::IsMember({"x", "y", "z", "xy", "xz", "yz", "xyz"}));
  cmd->add_option("--sensor-noise-um", args->sensor_noise_um, "white noise of each displacement reading")
      ->default_val(0.1);
  cmd->add_flag("--reversal", args->reversal,
                "measure Delta by turning the head 180 degrees (keeps each plane's slope)");
  cmd->add_flag("--angle-instrument", args->angle_instrument,
                "read the head's rotation with an autocollimator or electronic level at every position and remove "
                "it from the chain (for machines whose carriages pitch or yaw; beyond the seed)");
  cmd->add_option("--angle-noise-urad", args->angle_noise_urad, "the angle instrument's noise")
      ->default_val(0.25)
      ->check(CLI::Range(0.0, 100.0));
  cmd->add_option("--sensor-offset", args->sensor_offset_mm,
                  "sensor A's tip from the ram reference point, mm; give the stylus the map will serve "
                  "(e.g. 0,0,-50) so the Abbe levers match")
      ->delimiter(',')
      ->expected(3)
      ->default_str("0,0,-120");
  cmd->add_option("--runs", args->runs, "measure every plane this many times and average (noise floor / sqrt(runs))")
      ->default_val(1);
  cmd->add_option("--laser-cycles", args->laser_cycles, "bidirectional laser runs tying the planes (ISO 230-2)")
      ->default_val(2);
  cmd->add_option("--seed", args->seed, "noise seed (default: the world's)");
  cmd->add_option("--out", args->out, "write the error-space file (docs/error-space.md) here");
  cmd->add_flag("--append", args->append,
                "add this calibration to the spaces already in --out (the same machine at another temperature; "
                "the controller interpolates them by its thermometer)");
  cmd->add_option("--report", args->report, "write an offline SVG page of maps here");
  cmd->add_flag("--truth", args->truth, "also compare with the world's hidden errors (for checking only)");
  commands.push_back({cmd, [args] { return calibrate_error_space(*args); }});
}

}  // namespace metron::cli
