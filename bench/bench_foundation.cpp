// SPDX-License-Identifier: GPL-3.0-or-later
// Foundation benchmarks: compile speed, end-to-end run speed (simulated vs wall time), fitting.
// Build with -DMETRON_BENCH=ON; run ./build/bench/bench_foundation.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <random>

#include "cli/virtual_cmm_backend.hpp"
#include "metron/interpreter/compiler.hpp"
#include "metron/interpreter/session.hpp"
#include "metron/stdlib/fitting/fit.hpp"
#include "metron/stdlib/fitting/minimum_zone.hpp"

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

}  // namespace

BENCHMARK_MAIN();
