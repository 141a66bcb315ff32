// SPDX-License-Identifier: GPL-3.0-or-later
// Model-discrepancy analysis of 10 000 rows (docs/discrepancy.md): the whole analysis (catalogue
// search, forward selection, cross-validation, structure searches) on
//  - an ISO 230-2 style positioning record along x with time, direction, two temperatures, a hidden
//    cyclic error and a reversal (7 catalogue candidates, 2 claimed);
//  - a drift log of one displacement with four temperatures and a hidden lagged thermal effect.
// Run ./build/bench/bench_discrepancy.
#include <cmath>
#include <random>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include "metron/machine/discrepancy/prediction.hpp"
#include "metron/stdlib/discrepancy/analysis.hpp"
#include "metron/stdlib/discrepancy/measured_data.hpp"

namespace {

namespace dc = metron::discrepancy;
using nlohmann::json;
constexpr double kPi = 3.14159265358979323846;

dc::MeasuredData positioning_10k() {
  std::mt19937_64 rng(1);
  std::normal_distribution<double> noise(0, 0.3);
  std::string csv = "t,dir,x,ta,ts,dev\n";
  for (int r = 0; r < 10000; ++r) {
    const int run = r / 100, i = r % 100;
    const int d = run % 2 ? -1 : 1;
    const double x = (d > 0 ? i : 99 - i) * 10.0;
    const double t = 2.0 * r;
    const double dev = 1.5 * std::sin(2 * kPi * x / 130) + 2.0 * d + noise(rng);
    csv += fmt::format("{},{},{},{:.4f},{:.4f},{:.4f}\n", t, d, x, 20 + 0.5 * std::sin(t / 5000),
                       20.2 + 0.3 * std::sin(t / 7000), dev);
  }
  const json desc = json::parse(R"({"kind": "positioning", "noise_mm": 0.0003, "columns": [
    {"name": "t", "role": "time", "unit": "s"}, {"name": "dir", "role": "direction", "axis": "x"},
    {"name": "x", "role": "nominal", "axis": "x", "unit": "mm"}, {"name": "ta", "role": "temperature", "unit": "C"},
    {"name": "ts", "role": "temperature", "unit": "C"}, {"name": "dev", "role": "deviation", "axis": "x", "unit": "um"}]})");
  return *dc::parse_measured_data(csv, "bench", *dc::parse_description(desc, "bench"));
}

dc::MeasuredData drift_10k() {
  std::mt19937_64 rng(2);
  std::normal_distribution<double> noise(0, 0.3);
  std::string csv = "t,t1,t2,t3,t4,dz\n";
  std::vector<double> ts, T;
  for (int r = 0; r < 10000; ++r)
    ts.push_back(15.0 * r), T.push_back(20 + 2 * std::sin(15.0 * r / 20000) + (r > 3000 ? 1.5 : 0));
  const auto lag = dc::first_order_lag(ts, T, 3000);
  for (int r = 0; r < 10000; ++r)
    csv += fmt::format("{},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f}\n", ts[static_cast<std::size_t>(r)],
                       T[static_cast<std::size_t>(r)], 20 + std::cos(ts[static_cast<std::size_t>(r)] / 9000),
                       21 + 0.2 * std::sin(ts[static_cast<std::size_t>(r)] / 3000), 19 + 0.001 * r / 10,
                       3.0 * (lag[static_cast<std::size_t>(r)] - 20) + noise(rng));
  const json desc = json::parse(R"({"kind": "drift", "noise_mm": 0.0003, "columns": [
    {"name": "t", "role": "time", "unit": "s"}, {"name": "t1", "role": "temperature", "unit": "C"},
    {"name": "t2", "role": "temperature", "unit": "C"}, {"name": "t3", "role": "temperature", "unit": "C"},
    {"name": "t4", "role": "temperature", "unit": "C"}, {"name": "dz", "role": "deviation", "axis": "z", "unit": "um"}]})");
  return *dc::parse_measured_data(csv, "bench", *dc::parse_description(desc, "bench"));
}

void run(benchmark::State& state, const dc::MeasuredData& data) {
  dc::Analysis a;
  for (auto _ : state) {
    a = dc::analyse(dc::make_problem(data, [](std::size_t, int) { return 0.0; }));
    benchmark::ClobberMemory();
  }
  std::string found;
  for (const auto& e : a.effects) found += e.what + "; ";
  state.SetLabel(fmt::format("{} rows, claimed: {}CV {:.3f} -> {:.3f} um, fit {:.3f} um", data.rows, found,
                             a.cv_rms_before_mm * 1e3, a.cv_rms_after_mm * 1e3, a.fit_rms_after_mm * 1e3));
}

void BM_DiscrepancyPositioning10k(benchmark::State& state) {
  static const auto data = positioning_10k();
  run(state, data);
}
void BM_DiscrepancyDriftLog10k(benchmark::State& state) {
  static const auto data = drift_10k();
  run(state, data);
}
BENCHMARK(BM_DiscrepancyPositioning10k)->Unit(benchmark::kMillisecond)->Iterations(2);
BENCHMARK(BM_DiscrepancyDriftLog10k)->Unit(benchmark::kMillisecond)->Iterations(2);

}  // namespace

BENCHMARK_MAIN();
