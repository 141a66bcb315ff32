// SPDX-License-Identifier: GPL-3.0-or-later
// `metron calibrate wavefront`: the geometry calibration of a machine with an embedded wavefront
// gauge (SEEDS.md 5, docs/wavefront.md).
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <string>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "metron/machine/wavefront/simulated_wavefront_machine.hpp"
#include "metron/runtime/wavefront/calibration.hpp"

namespace metron::cli {
namespace {

namespace mw = machine::wavefront;
namespace rw = runtime::wavefront;

}  // namespace
std::string wavefront_html(const nlohmann::json& r, const machine::wavefront::GaugeMap* map);  // wavefront_html.cpp
namespace {

struct CalibrateArgs {
  std::string world;
  std::string step = "all";
  std::optional<std::uint64_t> seed;
  std::optional<std::string> out;
  std::optional<std::string> html;
  bool truth = false;
};

std::string pair(const Vec2& v, double scale, int digits) {
  return fmt::format("({:.{}f}, {:.{}f})", v.x() * scale, digits, v.y() * scale, digits);
}

// Recovered beside hidden values; the truth was read by the observer at the state each recovered
// value refers to (the procedure itself never reads it).
void print_truth(const rw::CalibrationReport& r, const std::map<std::string, mw::WavefrontTruth>& t) {
  std::cout
      << "\nrecovered | hidden truth (read by the command at the moment of each measurement, never by the procedure)\n";
  const auto row = [](const std::string& name, const std::string& rec, const std::string& tru) {
    std::cout << fmt::format("  {:<42} {:>34} | {}\n", name, rec, tru);
  };
  if (r.gauge_frame && t.count("gauge-frame")) {
    const auto& a = t.at("gauge-frame");
    row("gauge to A axis [urad]", pair(r.gauge_frame->gauge_to_a_rad, 1e6, 3), pair(a.gauge_to_a_rad, 1e6, 3));
    row("A axis in gauge coordinates (centroids) [mm]", pair(r.gauge_frame->a_axis_in_gauge_mm, 1, 5),
        pair(a.focus_to_a_mm, 1, 5));
    row("flat's centre from A (centroid radius) [mm]",
        fmt::format("{:.5f}", r.gauge_frame->before.centroid_circle
                                  ? r.gauge_frame->before.centroid_circle->radius_vector.norm()
                                  : 0.0),
        fmt::format("{:.5f}", a.flat_centre_mm.norm()));
    if (t.count("gauge-frame:after"))
      row("gauge to A after the correction [urad]", pair(r.gauge_frame->residual_rad, 1e6, 3),
          pair(t.at("gauge-frame:after").gauge_to_a_rad, 1e6, 3));
  }
  if (r.focus && t.count("focus:cat")) {
    row("table at the focus, Z [steps]", fmt::format("{:.2f}", r.focus->focus_table_z_steps),
        fmt::format("{:.2f}", t.at("focus:cat").focus_table_z_steps));
    if (t.count("focus:pom"))
      row("A axis from the focus [um]", pair(r.focus->focus_to_a_mm, 1e3, 4),
          pair(t.at("focus:pom").focus_to_a_mm, 1e3, 4));
    if (t.count("focus:after"))
      row("A axis from the focus after X/Y [um]", pair(r.focus->residual_mm, 1e3, 4),
          pair(t.at("focus:after").focus_to_a_mm, 1e3, 4));
  }
  if (r.axis_response && t.count("axis-response")) {
    const auto& a = t.at("axis-response");
    row("dx, dy [nm/step]",
        fmt::format("({:.4f}, {:.4f})", r.axis_response->step_mm.x() * 1e6, r.axis_response->step_mm.y() * 1e6),
        fmt::format("({:.4f}, {:.4f})", a.step_mm.x() * 1e6, a.step_mm.y() * 1e6));
    row("gauge clocking [deg]", fmt::format("{:.5f}", r.axis_response->gauge_clocking_rad * 180 / std::numbers::pi),
        fmt::format("{:.5f}", a.gauge_clocking_rad * 180 / std::numbers::pi));
  }
  if (r.a_to_z) {
    for (std::size_t i = 0; i < r.a_to_z->iterations.size(); ++i) {
      const std::string tag = fmt::format("a-z:{}", i + 1);
      if (!t.count(tag)) continue;
      row(fmt::format("A to Z, iteration {} [urad]", i + 1), pair(r.a_to_z->iterations[i].angle_rad, 1e6, 3),
          pair(t.at(tag).a_to_z_rad, 1e6, 3));
    }
  }
  if (r.b_rotation && t.count("b-rotation")) {
    const auto& a = t.at("b-rotation");
    const auto& b = *r.b_rotation;
    row("P, part eccentricity [um]", fmt::format("{:.4f}", b.eccentricity_mm * 1e3),
        fmt::format("{:.4f}", a.eccentricity_mm * 1e3));
    row("xb, A from B along X [um]", fmt::format("{:.4f}", b.xb_mm * 1e3), fmt::format("{:.4f}", a.xb_mm * 1e3));
    row("zF, B to the centre of curvature [mm]", fmt::format("{:.6f}", b.zf_mm), fmt::format("{:.6f}", a.zf_mm));
    row("dz [nm/step]", fmt::format("{:.4f}", b.dz_mm * 1e6), fmt::format("{:.4f}", a.step_mm.z() * 1e6));
    row("B tilt out of perpendicular to X-Z [urad]", fmt::format("{:.3f}", b.b_axis_tilt_rad * 1e6),
        fmt::format("{:.3f}", a.b_axis_tilt_rad * 1e6));
  }
  if (r.c_rotation && t.count("c-rotation")) {
    const auto& a = t.at("c-rotation");
    row("yc, A from C along Y [um]", fmt::format("{:.4f}", r.c_rotation->yc_mm * 1e3),
        fmt::format("{:.4f}", a.yc_mm * 1e3));
    if (r.c_rotation->zc_mm)
      row("zc, B to C along Z [mm]", fmt::format("{:.6f}", *r.c_rotation->zc_mm), fmt::format("{:.6f}", a.zc_mm));
  }
  if (r.reversal && t.count("reversal")) {
    const auto& a = t.at("reversal");
    row("reversal: part wedge [urad]", pair(r.reversal->part_rad, 1e6, 3), pair(a.part_wedge_rad, 1e6, 3));
    row("reversal: table tilt [urad]", pair(r.reversal->table_rad, 1e6, 3), pair(a.table_tilt_rad, 1e6, 3));
  }
  if (r.part_on_mount && t.count("part-on-mount")) {
    const auto& a = t.at("part-on-mount");
    const double s = r.part_on_mount->sphere ? 1e3 : 1e6;
    const char* u = r.part_on_mount->sphere ? "um" : "urad";
    row(fmt::format("gauge to spindle (centre) [{}]", u), pair(r.part_on_mount->circle.centre, s, 4),
        pair(r.part_on_mount->sphere ? a.focus_to_a_mm : a.gauge_to_a_rad, s, 4));
    row(fmt::format("spindle to part (radius vector) [{}]", u), pair(r.part_on_mount->circle.radius_vector, s, 4),
        pair(a.part_to_a, s, 4));
  }
}

int calibrate_wavefront(const CalibrateArgs& args) {
  auto world = mw::load_wavefront_world(args.world);
  if (!world) {
    std::cerr << "error: " << world.error() << "\n";
    return 2;
  }
  mw::SimulatedWavefrontMachine machine(*world, args.seed.value_or(world->seed));
  std::map<std::string, mw::WavefrontTruth> truths;
  auto report = rw::calibrate(
      machine, args.step, [](const std::string& line) { std::cerr << line << "\n"; }, {},
      [&](const std::string& tag) { truths[tag] = machine.truth(); });
  if (!report) {
    std::cerr << "error: calibration failed: " << report.error() << "\n";
    return 3;
  }
  nlohmann::json j = rw::to_json(*report);
  j["world"] = args.world;
  j["step"] = args.step;
  j["seed"] = args.seed.value_or(world->seed);
  std::cout << fmt::format("wavefront calibration of {} (step {}, {} gauge maps)\n", args.world, args.step,
                           report->maps);
  std::cout << j.dump(2) << "\n";
  if (args.truth) print_truth(*report, truths);
  if (args.out) {
    std::ofstream out(*args.out);
    if (!out) {
      std::cerr << "error: cannot write " << *args.out << "\n";
      return 2;
    }
    out << j.dump(2) << "\n";
    std::cout << "written: " << *args.out << "\n";
  }
  if (args.html) {
    // One more map at the end position for the picture, with the element that suits the part.
    for (const auto& p : machine.parts())
      if (p.name == machine.mounted_part())
        machine.fit_element(p.kind == mw::PartKind::Flat ? mw::Element::Flat : mw::Element::Sphere);
    auto map = machine.measure();
    std::ofstream out(*args.html);
    if (!out) {
      std::cerr << "error: cannot write " << *args.html << "\n";
      return 2;
    }
    out << wavefront_html(j, map ? &*map : nullptr);
    std::cout << "written: " << *args.html << "\n";
  }
  return 0;
}

}  // namespace

void add_calibrate_command(CLI::App& app, std::vector<Command>& commands) {
  auto* cmd = app.add_subcommand("calibrate", "calibrate a machine from its own sensors");
  cmd->require_subcommand(1);
  auto args = std::make_shared<CalibrateArgs>();
  auto* wf = cmd->add_subcommand("wavefront",
                                 "geometry calibration of a multi-axis machine with an embedded wavefront gauge "
                                 "(SEEDS.md 5, docs/wavefront.md)");
  wf->add_option("--world", args->world, "world of kind \"wavefront\" (JSON)")->required();
  wf->add_option("--step", args->step,
                 "part-on-mount, gauge-frame, focus, axis-response, a-z, b-rotation, c-rotation, reversal or all")
      ->default_val("all");
  wf->add_option("--seed", args->seed, "noise seed (default: the world's)");
  wf->add_option("--out", args->out, "write the results (JSON) here");
  wf->add_option("--html", args->html, "write pictures (self-contained HTML with SVG) here");
  wf->add_flag("--truth", args->truth, "also print the hidden truth beside the recovered values");
  commands.push_back({wf, [args] { return calibrate_wavefront(*args); }});
  add_calibrate_error_space_command(*cmd, commands);
}

}  // namespace metron::cli
