// SPDX-License-Identifier: GPL-3.0-or-later
// Foundation benchmarks: compile speed, end-to-end run speed (simulated vs wall time), fitting.
// Build with -DMETRON_BENCH=ON; run ./build/bench/bench_foundation.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>

#include "cli/virtual_cmm_backend.hpp"
#include "metron/interpreter/compiler.hpp"
#include "metron/interpreter/session.hpp"
#include "metron/stdlib/fitting/fit.hpp"
#include "metron/stdlib/fitting/minimum_zone.hpp"
#include "runtime/src/detail/form_per_unit.hpp"

namespace {

const std::string examples = std::string(METRON_SOURCE_DIR) + "/programs/examples/";

void compile_block_program(benchmark::State& state) {
  for (auto _ : state) {
    metron::SourceManager sources;
    metron::DiagnosticSink sink;
    metron::interpreter::Compiler compiler(sources, sink);
    benchmark::DoNotOptimize(compiler.compile_file(examples + "02_block_inspection.dmi"));
  }
}
BENCHMARK(compile_block_program)->Unit(benchmark::kMicrosecond);

// A whole inspection (qualification, 12 features, ~90 probe points) on the default world.
void run_block_inspection(benchmark::State& state) {
  double simulated = 0;
  const auto out = std::filesystem::temp_directory_path() / "metron_bench";
  for (auto _ : state) {
    metron::interpreter::RunOptions o;
    o.program = examples + "02_block_inspection.dmi";
    o.out_dir = out.string();
    const auto r = metron::interpreter::run_program(o, metron::cli::virtual_cmm_backend);
    simulated += r.record.simulated_time_s;
  }
  state.counters["simulated_s_per_wall_s"] = benchmark::Counter(simulated, benchmark::Counter::kIsRate);
}
BENCHMARK(run_block_inspection)->Unit(benchmark::kMillisecond);

// A bore of radius 12.5 with 1 um noise, n points on a helix (a scan's worth at 10000).
std::vector<metron::Vec3> cylinder_points(std::int64_t n) {
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0, 0.001);
  std::vector<metron::Vec3> pts;
  for (std::int64_t i = 0; i < n; ++i) {
    const double a = 6.283185307179586 * static_cast<double>(i) / 37.0,
                 z = 30.0 * static_cast<double>(i) / static_cast<double>(n);
    pts.emplace_back(10 + 12.5 * std::cos(a) + noise(rng), -4 + 12.5 * std::sin(a) + noise(rng), z);
  }
  return pts;
}

// The baseline of the two below: the least-squares cylinder every measured cylinder gets.
void fit_cylinder(benchmark::State& state) {
  const auto pts = cylinder_points(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(metron::fitting::fit(metron::fitting::Shape::Cylinder, pts));
}
BENCHMARK(fit_cylinder)->Arg(8)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// GEOALG/CYLNDR,MINMAX (and CYLCTY): the minimum-zone cylinder, on top of the least-squares fit.
void zone_cylinder(benchmark::State& state) {
  const auto pts = cylinder_points(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(metron::fitting::minimum_zone(metron::fitting::Shape::Cylinder, pts));
}
BENCHMARK(zone_cylinder)->Arg(8)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// GEOALG/CYLNDR,MAXINS: the maximum inscribed cylinder.
void inscribed_cylinder(benchmark::State& state) {
  const auto pts = cylinder_points(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(metron::fitting::extreme_feature(metron::fitting::Shape::Cylinder, pts, true));
}
BENCHMARK(inscribed_cylinder)->Arg(8)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// A face 160 x 100 touched on a grid of n points (a scan's worth at 20000), waved 2 um along X
// (wavelength 40) and 0.5 um along Y (30), with 0.2 um noise.
std::vector<metron::Vec3> face_points(std::int64_t n) {
  std::mt19937 rng(2);
  std::normal_distribution<double> noise(0, 0.0002);
  const auto columns = static_cast<std::int64_t>(std::sqrt(static_cast<double>(n) * 1.6));
  const std::int64_t rows = std::max<std::int64_t>(1, n / columns);
  std::vector<metron::Vec3> pts;
  for (std::int64_t i = 0; i < columns; ++i)
    for (std::int64_t j = 0; j < rows; ++j) {
      const double x = 160.0 * static_cast<double>(i) / static_cast<double>(columns - 1),
                   y = 100.0 * static_cast<double>(j) / static_cast<double>(std::max<std::int64_t>(1, rows - 1));
      pts.emplace_back(
          x, y,
          0.002 * std::cos(6.283185307179586 * x / 40) + 0.0005 * std::cos(6.283185307179586 * y / 30) + noise(rng));
    }
  return pts;
}

// TOL/FLAT,t: the minimum-zone flatness of the whole face, the baseline of the per-unit search.
void zone_plane(benchmark::State& state) {
  const auto pts = face_points(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(metron::fitting::minimum_zone(metron::fitting::Shape::Plane, pts));
}
BENCHMARK(zone_plane)->Arg(60)->Arg(400)->Arg(5000)->Arg(20000)->Unit(benchmark::kMillisecond);

// TOL/FLAT,t,tu,20,20: every 20 x 20 unit anywhere (runtime/src/form_per_unit.cpp); beyond 120
// distinct coordinates along an edge the corners are sampled.
void flatness_per_unit_area(benchmark::State& state) {
  const auto pts = face_points(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(
        metron::runtime::flatness_per_unit_area(pts, metron::Vec3::UnitZ(), metron::Vec3::UnitX(), 20, 20));
}
BENCHMARK(flatness_per_unit_area)->Arg(60)->Arg(400)->Arg(5000)->Arg(20000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
