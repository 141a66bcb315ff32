// SPDX-License-Identifier: GPL-3.0-or-later
// The wavefront-gauge calibration (SEEDS.md 5, docs/wavefront.md "Evidence"): recovered against
// hidden values over noise seeds (bias, spread, the pixel-noise bound), part-on-mount against
// the number of spindle angles and the gauge noise, A-Z iterations from several starting errors,
// the reversal, skipped steps; then wall-clock cost of one map, one fit, part-on-mount and the
// whole procedure. `bench_wavefront --seeds N` (default 20) sets the repetitions of the tables;
// `--whole WORLD` prints only that world's whole-procedure table (`--pixels N` with an N-pixel
// camera), `--raw-nulls` without the form stitching of the rotation nulls;
// `--no-tables` runs only the timings.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "metron/machine/wavefront/simulated_wavefront_machine.hpp"
#include "metron/runtime/wavefront/calibration.hpp"

using namespace metron;
namespace mw = machine::wavefront;
namespace rw = runtime::wavefront;

namespace {

const std::string worlds_dir = std::string(METRON_SOURCE_DIR) + "/programs/worlds/";
int g_seeds = 20;
bool g_remove_form = true;  // --raw-nulls: the B and C rotations without the form stitching
int g_pixels = 0;           // --pixels N: the camera of --whole's world (0: the world's own)

mw::WavefrontWorld world(const std::string& name) {
  auto w = mw::load_wavefront_world(worlds_dir + name);
  if (!w) throw std::runtime_error(w.error());
  return *w;
}

void strip_form(mw::WavefrontWorld& w) {
  for (auto& p : w.parts) p.astigmatism_nm = p.trefoil_nm = p.spherical_nm = 0;
}

struct Stat {
  double truth_sum = 0, sum = 0, sum2 = 0;
  int n = 0;
  void add(double recovered, double truth) {
    const double e = recovered - truth;
    truth_sum += truth, sum += e, sum2 += e * e, ++n;
  }
  [[nodiscard]] double bias() const { return sum / n; }
  [[nodiscard]] double sd() const { return n > 1 ? std::sqrt(std::max(0.0, (sum2 - sum * sum / n) / (n - 1))) : 0; }
};

void print_stat(const char* name, const Stat& s, double scale, const char* unit, double bound = 0) {
  std::printf("  %-44s %14.6g %12.4g %12.4g %8.2f %s%s\n", name, s.truth_sum / s.n * scale, s.bias() * scale,
              s.sd() * scale, s.sd() > 0 ? std::abs(s.bias()) / s.sd() : 0.0, unit,
              bound > 0 ? fmt::format("   bound {:.4g}, sd/bound {:.2f}", bound * scale, s.sd() / bound).c_str() : "");
}

void table_whole(const std::string& name, bool form) {
  auto w = world(name);
  if (!form) strip_form(w);
  if (g_pixels > 0) w.gauge.pixels = g_pixels;
  std::map<std::string, Stat> st;
  std::vector<std::string> order;
  const auto add = [&](const std::string& k, double r, double t) {
    if (!st.count(k)) order.push_back(k);
    st[k].add(r, t);
  };
  double iterations = 0;
  for (int s = 0; s < g_seeds; ++s) {
    mw::SimulatedWavefrontMachine m(w, 100 + s);
    std::map<std::string, mw::WavefrontTruth> t;
    auto rep = rw::calibrate(
        m, "all", {}, {}, [&](const std::string& tag) { t[tag] = m.truth(); }, g_remove_form);
    if (!rep) {
      std::printf("  seed %d failed: %s\n", 100 + s, rep.error().c_str());
      continue;
    }
    const auto& r = *rep;
    add("gauge to A, x [urad]", r.gauge_frame->gauge_to_a_rad.x(), t["gauge-frame"].gauge_to_a_rad.x());
    add("gauge to A, y [urad]", r.gauge_frame->gauge_to_a_rad.y(), t["gauge-frame"].gauge_to_a_rad.y());
    add("A in gauge (centroid circle), x [um]", r.gauge_frame->a_axis_in_gauge_mm.x(),
        t["gauge-frame"].focus_to_a_mm.x());
    add("focus: table at focus, Z [steps]", r.focus->focus_table_z_steps, t["focus:cat"].focus_table_z_steps);
    add("focus to A axis, x [um]", r.focus->focus_to_a_mm.x(), t["focus:pom"].focus_to_a_mm.x());
    add("focus to A axis, y [um]", r.focus->focus_to_a_mm.y(), t["focus:pom"].focus_to_a_mm.y());
    add("dx [relative 1e-6]", r.axis_response->step_mm.x() / t["axis-response"].step_mm.x(), 1);
    add("dy [relative 1e-6]", r.axis_response->step_mm.y() / t["axis-response"].step_mm.y(), 1);
    add("gauge clocking [urad]", r.axis_response->gauge_clocking_rad, t["axis-response"].gauge_clocking_rad);
    add("A to Z before correction, x [urad]", r.a_to_z->iterations.front().angle_rad.x(), t["a-z:1"].a_to_z_rad.x());
    add("A to Z before correction, y [urad]", r.a_to_z->iterations.front().angle_rad.y(), t["a-z:1"].a_to_z_rad.y());
    const auto last = fmt::format("a-z:{}", r.a_to_z->iterations.size());
    add("A to Z residual (truth after), x [urad]", t[last].a_to_z_rad.x(), 0);
    add("A to Z residual (truth after), y [urad]", t[last].a_to_z_rad.y(), 0);
    iterations += static_cast<double>(r.a_to_z->iterations.size()) / g_seeds;
    add("P eccentricity [um]", r.b_rotation->eccentricity_mm, t["b-rotation"].eccentricity_mm);
    add("xb [um]", r.b_rotation->xb_mm, t["b-rotation"].xb_mm);
    add("zF [um]", r.b_rotation->zf_mm, t["b-rotation"].zf_mm);
    add("dz = S dx [relative 1e-6]", r.b_rotation->dz_mm / t["b-rotation"].step_mm.z(), 1);
    add("B tilt out of perpendicular [urad]", r.b_rotation->b_axis_tilt_rad, t["b-rotation"].b_axis_tilt_rad);
    add("yc (C rotation) [um]", r.c_rotation->yc_mm, t["c-rotation"].yc_mm);
    add("zc (C rotation, with zF) [um]", *r.c_rotation->zc_mm, t["c-rotation"].zc_mm);
    add("reversal: wedge x [urad]", r.reversal->part_rad.x(), t["reversal"].part_wedge_rad.x());
    add("reversal: wedge y [urad]", r.reversal->part_rad.y(), t["reversal"].part_wedge_rad.y());
    add("reversal: table tilt x [urad]", r.reversal->table_rad.x(), t["reversal"].table_tilt_rad.x());
    add("reversal: table tilt y [urad]", r.reversal->table_rad.y(), t["reversal"].table_tilt_rad.y());
  }
  if (g_pixels > 0) std::printf("\n(camera of %d pixels)", g_pixels);
  std::printf("\n%s, %s%s, %d seeds: recovered - truth (whole procedure, mean A-Z iterations %.2f)\n", name.c_str(),
              form ? "parts with form" : "form-free parts", g_remove_form ? "" : " (raw nulls, no form stitching)",
              g_seeds, iterations);
  std::printf("  %-44s %14s %12s %12s %8s\n", "quantity", "mean truth", "bias", "sd", "|bias|/sd");
  for (const auto& k : order) {
    const double scale = k.find("urad") != std::string::npos || k.find("um") != std::string::npos ? 1e6
                         : k.find("relative") != std::string::npos                                ? 1e6
                                                                                                  : 1;
    const double unit_scale = k.find("[um]") != std::string::npos ? 1e3 : scale;
    print_stat(k.c_str(), st[k], unit_scale, "");
  }
}

// Part-on-mount at one fixed position, K angles, over seeds; the bound sigma/(s sqrt(M K)).
void table_angles_and_noise() {
  auto w = world("wavefront_sphere_machine.json");
  mw::SimulatedWavefrontMachine probe(w, 1);
  auto rep = rw::calibrate(probe, "focus");
  if (!rep) throw std::runtime_error(rep.error());
  const mw::AxisCommand at = probe.position();
  const Vec2 truth = probe.truth().focus_to_a_mm;
  const Vec2 truth_r = probe.truth().part_to_a;
  const int pixels = probe.ideal_map()->valid_count();
  std::printf("\npart-on-mount on ball_low (sphere, R 12.7 mm, sin_max 0.25, %d pixels), %d seeds per row\n", pixels,
              g_seeds);
  std::printf("  %-8s %-8s %14s %14s %14s %10s %14s %14s\n", "angles", "noise", "centre bias", "centre sd", "bound",
              "sd/bound", "radius sd", "geometric sd");
  const auto row = [&](int k, double noise) {
    mw::WavefrontWorld wn = w;
    wn.gauge.noise_nm = noise;
    std::vector<double> angles;
    for (int i = 0; i < k; ++i) angles.push_back(360.0 * i / k);
    Stat cx, cy, rx, gx;
    for (int s = 0; s < g_seeds; ++s) {
      mw::SimulatedWavefrontMachine m(wn, 5000 + s);
      m.move(at);
      auto r = rw::part_on_mount(m, rep->knowledge, {angles, false});
      if (!r) {
        std::printf("  failed: %s\n", r.error().c_str());
        return;
      }
      cx.add(r->circle.centre.x(), truth.x());
      cy.add(r->circle.centre.y(), truth.y());
      rx.add(r->circle.radius_vector.x(), truth_r.x());
      if (r->geometric) gx.add(r->geometric->centre.x(), truth.x());
    }
    const double bound = noise * 1e-6 / (wn.gauge.sphere_sin_max * std::sqrt(static_cast<double>(pixels) * k));
    const double sd = std::sqrt((cx.sd() * cx.sd() + cy.sd() * cy.sd()) / 2);
    std::printf("  %-8d %-8.1f %11.3f pm %11.3f pm %11.3f pm %10.2f %11.3f pm %11s\n", k, noise,
                std::hypot(cx.bias(), cy.bias()) * 1e9, sd * 1e9, bound * 1e9, sd / bound, rx.sd() * 1e9,
                gx.n ? fmt::format("{:.3f} pm", gx.sd() * 1e9).c_str() : "-");
  };
  for (int k : {2, 3, 4, 6, 12}) row(k, w.gauge.noise_nm);
  for (double n : {0.5, 8.0, 32.0}) row(6, n);
}

void table_az() {
  std::printf("\nA-Z alignment from several starting errors (form-free sphere machine, seed 5)\n");
  std::printf("  %-10s %-10s %16s %12s %24s\n", "B zero", "C zero", "start [urad]", "iterations",
              "residual |A-Z| [urad]");
  for (double b0 : {-0.03, 0.0, 0.01, 0.05})
    for (double c0 : {0.02, -0.04}) {
      auto w = world("wavefront_sphere_machine.json");
      strip_form(w);
      w.hidden.b_zero_rad = b0 * std::numbers::pi / 180;
      w.hidden.c_zero_rad = c0 * std::numbers::pi / 180;
      mw::SimulatedWavefrontMachine m(w, 5);
      const double start = m.truth().a_to_z_rad.norm();
      auto rep = rw::calibrate(m, "a-z");
      if (!rep) {
        std::printf("  %-10.3f %-10.3f %16.1f  failed: %s\n", b0, c0, start * 1e6, rep.error().c_str());
        continue;
      }
      std::printf("  %-10.3f %-10.3f %16.1f %12zu %24.4f\n", b0, c0, start * 1e6, rep->a_to_z->iterations.size(),
                  m.truth().a_to_z_rad.norm() * 1e6);
    }
}

void table_skipped() {
  std::printf("\nskipped steps\n");
  auto w = world("wavefront_sphere_machine.json");
  {
    mw::SimulatedWavefrontMachine m(w, 1);
    m.move(mw::AxisCommand{Vec3(0, 0, (180 - 87.7) / 1e-4), 0, 0, 0});
    auto r = rw::part_on_mount(m, rw::initial_knowledge(m), {{0, 90, 180, 270}, false});
    std::printf("  part-on-mount without the null: %s\n", r ? "succeeded (unexpected)" : r.error().c_str());
  }
  strip_form(w);
  for (bool az_first : {false, true}) {
    mw::SimulatedWavefrontMachine m(w, 1);
    std::map<std::string, mw::WavefrontTruth> t;
    auto rep = az_first ? rw::calibrate(m, "all", {}, {}, [&](const std::string& tag) { t[tag] = m.truth(); })
                        : rw::calibrate(m, "b-rotation", {}, {}, [&](const std::string& tag) { t[tag] = m.truth(); });
    if (!rep) {
      std::printf("  failed: %s\n", rep.error().c_str());
      continue;
    }
    const auto& b = *rep->b_rotation;
    const auto& tb = t["b-rotation"];
    std::printf("  B rotation %s: xb error %.3f um, zF error %.3f um, dz error %.1f ppm, B tilt error %.3f urad\n",
                az_first ? "after the A-Z alignment" : "alone (B zero not corrected)", (b.xb_mm - tb.xb_mm) * 1e3,
                (b.zf_mm - tb.zf_mm) * 1e3, (b.dz_mm / tb.step_mm.z() - 1) * 1e6,
                (b.b_axis_tilt_rad - tb.b_axis_tilt_rad) * 1e6);
  }
}

// --- wall-clock cost ---

mw::WavefrontWorld sized(int pixels) {
  auto w = world("wavefront_sphere_machine.json");
  w.gauge.pixels = pixels;
  return w;
}

void BM_GaugeMap(benchmark::State& state) {
  mw::SimulatedWavefrontMachine m(sized(static_cast<int>(state.range(0))), 1);
  auto rep = rw::calibrate(m, "focus");  // a ball near null
  for (auto _ : state) benchmark::DoNotOptimize(m.measure());
}
BENCHMARK(BM_GaugeMap)->Arg(128)->Arg(256)->Arg(512)->Arg(1024)->Unit(benchmark::kMillisecond);

void BM_MapFit(benchmark::State& state) {
  mw::SimulatedWavefrontMachine m(sized(static_cast<int>(state.range(0))), 1);
  auto rep = rw::calibrate(m, "focus");
  const auto map = m.measure();
  for (auto _ : state) benchmark::DoNotOptimize(rw::read_gauge_map(*map, m.gauge()));
}
BENCHMARK(BM_MapFit)->Arg(128)->Arg(256)->Arg(512)->Arg(1024)->Unit(benchmark::kMillisecond);

void BM_CircleFit(benchmark::State& state) {
  std::vector<Vec2> p;
  std::vector<double> a;
  for (int k = 0; k < 6; ++k) {
    a.push_back(k * std::numbers::pi / 3);
    p.emplace_back(0.01 + 0.002 * std::cos(a.back()), -0.02 + 0.002 * std::sin(a.back()));
  }
  for (auto _ : state) {
    benchmark::DoNotOptimize(metron::wavefront::fit_circle_phased(p, a));
    benchmark::DoNotOptimize(metron::wavefront::fit_circle_geometric(p));
  }
}
BENCHMARK(BM_CircleFit)->Unit(benchmark::kMicrosecond);

void BM_PartOnMount(benchmark::State& state) {
  mw::SimulatedWavefrontMachine m(sized(128), 1);
  auto rep = rw::calibrate(m, "focus");
  for (auto _ : state)
    benchmark::DoNotOptimize(rw::part_on_mount(m, rep->knowledge, {{0, 60, 120, 180, 240, 300}, false}));
}
BENCHMARK(BM_PartOnMount)->Unit(benchmark::kMillisecond);

void BM_WholeProcedure(benchmark::State& state) {
  long maps = 0;
  for (auto _ : state) {
    mw::SimulatedWavefrontMachine m(sized(static_cast<int>(state.range(0))), 1);
    auto rep = rw::calibrate(m, "all");
    maps = rep ? rep->maps : -1;
  }
  state.counters["maps"] = static_cast<double>(maps);
}
BENCHMARK(BM_WholeProcedure)->Arg(128)->Arg(256)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace

int main(int argc, char** argv) {
  bool tables = true;
  std::string only_whole;
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    if (std::strcmp(argv[i], "--no-tables") == 0)
      tables = false;
    else if (std::strcmp(argv[i], "--seeds") == 0 && i + 1 < argc)
      g_seeds = std::atoi(argv[++i]);
    else if (std::strcmp(argv[i], "--raw-nulls") == 0)
      g_remove_form = false;
    else if (std::strcmp(argv[i], "--pixels") == 0 && i + 1 < argc)
      g_pixels = std::atoi(argv[++i]);
    else if (std::strcmp(argv[i], "--whole") == 0 && i + 1 < argc)
      only_whole = argv[++i];
    else
      rest.push_back(argv[i]);
  }
  int n = static_cast<int>(rest.size());
  if (!only_whole.empty()) {  // --whole WORLD: the whole-procedure table of one shipped world, parts with form
    table_whole(only_whole, true);
    return 0;
  }
  if (tables) {
    table_whole("wavefront_sphere_machine.json", true);
    table_whole("wavefront_sphere_machine.json", false);
    table_whole("wavefront_concave.json", true);
    table_angles_and_noise();
    table_az();
    table_skipped();
    std::fflush(stdout);
  }
  benchmark::Initialize(&n, rest.data());
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
