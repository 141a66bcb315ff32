// SPDX-License-Identifier: GPL-3.0-or-later
// Error-space calibration (SEEDS.md 4): the method's compute for a 50 x 50 x 10 grid, the cost
// of one interpolation query per method (median and p99 over batches), and the every-second-point
// validation error of trilinear, B-spline and least squares side by side (printed before the
// timings, on the hidden smooth field and on a recovered noisy one). The compensation: its gain on
// the ball array of programs/worlds/cmm_errors_ball_plate.json against the hidden truth (printed),
// and its cost per commanded and per reported position (CompensatedMachine, median and p99).
// Build with -DMETRON_BENCH=ON; run ./build/bench/bench_error_space;
// ./build/bench/bench_error_space --report FILE.svg writes the calibration report page.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <time.h>

#include "ball_array.hpp"
#include "metron/machine/compensation/compensated_machine.hpp"
#include "metron/machine/error_space/calibration.hpp"
#include "metron/machine/machine_errors/grid_field.hpp"
#include "metron/machine/machine_errors/rigid_body.hpp"
#include "metron/machine/virtual_cmm.hpp"
#include "metron/stdlib/error_space/interpolation.hpp"
#include "metron/stdlib/error_space/report_svg.hpp"

#include <cstring>
#include <fstream>

namespace {

using namespace metron;
using namespace metron::machine;
using Interp = AxisFunction::Interpolation;

MachineErrorModel bench_machine() {
  std::array<AxisErrors, 3> axes;
  const std::vector<double> at = {0, 100, 200, 300, 400, 500, 600, 700, 800, 900, 1000};
  axes[0].translation_mm[2] =
      AxisFunction::table(at, {0, 3e-3, 6e-3, 8e-3, 10e-3, 11e-3, 10e-3, 8e-3, 6.5e-3, 5e-3, 4e-3}, Interp::Cubic);
  axes[1].translation_mm[2] =
      AxisFunction::table(at, {0, -2e-3, -4.5e-3, -6e-3, -7e-3, -8e-3, -7.5e-3, -6e-3, -4e-3, -2e-3, 0}, Interp::Cubic);
  axes[2].translation_mm[2] = AxisFunction::polynomial({0, 8e-6, 2e-8});
  MachineErrorModel m;
  m.add(std::make_shared<RigidBodyTerm>(axes, Squareness{4e-6, -3e-6, 5e-6}));
  error_space::Grid sag;
  sag.axes_mm = {std::vector<double>{0, 500, 1000}, std::vector<double>{0, 500, 1000}, std::vector<double>{-600, -300}};
  m.add(std::make_shared<GridFieldTerm>(
      2, sag, std::vector<double>{0, -3e-3, 0, 0, -4e-3, 0, 0, -3.5e-3, 0, 0, -2e-3, 0, 0, -3e-3, 0, 0, -2.5e-3, 0}));
  return m;
}

SpaceCalibrationPlan bench_plan() {
  SpaceCalibrationPlan plan;
  plan.head.spacing_mm = 20;
  for (int i = 0; i < 50; ++i) plan.grid.axes_mm[0].push_back(10 + 20.0 * i);
  for (int j = 0; j < 50; ++j) plan.grid.axes_mm[1].push_back(10 + 20.0 * j);
  for (int k = 0; k < 10; ++k) plan.grid.axes_mm[2].push_back(-500 + 20.0 * k);
  return plan;
}

const MachineErrorModel& machine() {
  static const MachineErrorModel m = bench_machine();
  return m;
}

// The readings of the 10 planes, simulated once outside the timing.
const std::vector<error_space::SurfaceReadings>& readings() {
  static const std::vector<error_space::SurfaceReadings> r = [] {
    const auto plan = bench_plan();
    std::vector<error_space::SurfaceReadings> out;
    TwoPointRig rig(machine(), plan_plate(plan, 2, 0), plan.head, 1);
    for (int k = 0; k < 10; ++k) {
      const FlatPlate p = plan_plate(plan, 2, k);
      Vec3 origin(
          plan.grid.axes_mm[0][0] + plan.head.sensor_offset_mm.x() - 10,
          plan.grid.axes_mm[1][0] + plan.head.sensor_offset_mm.y() - 10,
          plan.grid.axes_mm[2][static_cast<std::size_t>(k)] + plan.head.sensor_offset_mm.z() - plan.head.standoff_mm);
      rig.place_plate(2, p.normal_sign(), origin);
      out.push_back(rig.measure_surface(
          {plan.grid.axes_mm[0][0], plan.grid.axes_mm[1][0], plan.grid.axes_mm[2][static_cast<std::size_t>(k)]}, 0, 1,
          49, 49));
    }
    return out;
  }();
  return r;
}

void BM_Calibration_50x50x10_Method(benchmark::State& state) {
  const auto& r = readings();
  error_space::SurfaceOptions opt;
  opt.sensor_sigma_mm = 1e-4;
  for (auto _ : state) {
    std::vector<double> space(50 * 50 * 10);
    for (std::size_t k = 0; k < 10; ++k) {
      const auto s = error_space::solve_surface(r[k], opt);
      for (Eigen::Index j = 0; j < 50; ++j)
        for (Eigen::Index i = 0; i < 50; ++i) space[static_cast<std::size_t>(i + 50 * j) + 2500 * k] = s.error_mm(i, j);
    }
    benchmark::DoNotOptimize(space.data());
  }
}
BENCHMARK(BM_Calibration_50x50x10_Method)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

void BM_Calibration_50x50_NoiseFloor(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(error_space::surface_noise_sd_mm(49, 49, 1e-4));
}
BENCHMARK(BM_Calibration_50x50_NoiseFloor)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

void BM_Calibration_50x50x10_EndToEnd(benchmark::State& state) {
  const auto plan = bench_plan();
  for (auto _ : state) benchmark::DoNotOptimize(calibrate_space(machine(), plan));
}
BENCHMARK(BM_Calibration_50x50x10_EndToEnd)->Unit(benchmark::kMillisecond)->Iterations(3)->MeasureProcessCPUTime();

const error_space::ErrorSpace& truth_space() {
  static const error_space::ErrorSpace s = truth_in_reference(machine(), bench_plan());
  return s;
}

double thread_cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e9 * static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec);
}

// One query costs tens of ns, under the clock's resolution: time batches of 256 queries at random
// points and report the per-query median and p99 over the batches, in thread CPU time (the
// machine is shared: wall time would measure the neighbours' load, not the query).
void query_bench(benchmark::State& state, error_space::InterpolationSpec spec) {
  const auto interp = error_space::SpaceInterpolator::build(truth_space(), spec);
  if (!interp) {
    state.SkipWithError(interp.error().c_str());
    return;
  }
  Rng rng(3);
  constexpr int batch = 256;
  std::vector<Vec3> pts(batch * 64);
  for (auto& p : pts) p = {10 + 980 * rng.uniform(), 10 + 980 * rng.uniform(), -500 + 180 * rng.uniform()};
  std::vector<double> per_query_ns;
  std::size_t at = 0;
  for (auto _ : state) {
    const double t0 = thread_cpu_ns();
    double sum = 0;
    for (int q = 0; q < batch; ++q, at = (at + 1) % pts.size())
      sum += interp->error_at(pts[at].x(), pts[at].y(), pts[at].z())[2];
    benchmark::DoNotOptimize(sum);
    per_query_ns.push_back((thread_cpu_ns() - t0) / batch);
  }
  std::sort(per_query_ns.begin(), per_query_ns.end());
  state.counters["median_ns"] = per_query_ns[per_query_ns.size() / 2];
  state.counters["p99_ns"] = per_query_ns[std::min(per_query_ns.size() - 1, per_query_ns.size() * 99 / 100)];
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * batch);
}

void BM_Query_Trilinear(benchmark::State& s) { query_bench(s, {error_space::Method::Trilinear, {}}); }
void BM_Query_BSpline(benchmark::State& s) { query_bench(s, {error_space::Method::BSpline, {}}); }
void BM_Query_LeastSquares_Linear8(benchmark::State& s) { query_bench(s, {error_space::Method::LeastSquares, {1, 1}}); }
void BM_Query_LeastSquares_Quadratic64(benchmark::State& s) {
  query_bench(s, {error_space::Method::LeastSquares, {2, 2}});
}
BENCHMARK(BM_Query_Trilinear)->MeasureProcessCPUTime();
BENCHMARK(BM_Query_BSpline)->MeasureProcessCPUTime();
BENCHMARK(BM_Query_LeastSquares_Linear8)->MeasureProcessCPUTime();
BENCHMARK(BM_Query_LeastSquares_Quadratic64)->MeasureProcessCPUTime();

// The gain (docs/error-space.md, "The gain of compensation"): length errors of the 20 balls of
// programs/worlds/cmm_errors_ball_plate.json against their design with no map, calibrated maps and
// the true errors; and the simulated time the calibration and the measurement take.
SpaceCalibrationPlan ball_array_plan(int runs, int laser_cycles) {
  SpaceCalibrationPlan plan;
  plan.head.spacing_mm = 50;
  plan.head.noise_sd_mm = 0.0001;
  plan.head.sensor_offset_mm = Vec3(0, 0, -50);
  for (int i = 0; i < 17; ++i) plan.grid.axes_mm[0].push_back(100 + 50.0 * i);
  for (int i = 0; i < 13; ++i) plan.grid.axes_mm[1].push_back(100 + 50.0 * i);
  for (int i = 0; i < 3; ++i) plan.grid.axes_mm[2].push_back(100 + 50.0 * i);
  plan.components = {true, true, true};
  plan.delta_by_reversal = true;
  plan.runs = runs;
  plan.laser_cycles = laser_cycles;
  return plan;
}

std::vector<Vec3> ball_centres() {
  std::vector<Vec3> out;
  for (double y : {150, 400, 650})
    for (double x : {150, 350, 550, 750}) out.emplace_back(x, y, 60);
  for (double y : {275, 525})
    for (double x : {250, 450, 650, 850}) out.emplace_back(x, y, 130);
  return out;
}

World ball_world() {
  auto w = load_world(std::string(METRON_SOURCE_DIR) + "/programs/worlds/cmm_errors_ball_plate.json");
  if (!w) throw std::runtime_error(w.error().message);
  return *w;
}

std::shared_ptr<const ErrorMap> calibrated_map(const World& world, const SpaceCalibrationPlan& plan,
                                               double* sim_s = nullptr) {
  const auto run = calibrate_space(world.truth.errors, plan);
  if (sim_s) *sim_s = run.end_time_s;
  error_space::ErrorSpaceFile file;
  file.spaces.push_back(run.space);
  file.sensor_offset_mm = {0, 0, -50};
  return std::make_shared<const ErrorSpaceMap>(*ErrorSpaceMap::build(file));
}

void print_gain() {
  const World world = ball_world();
  const auto truth = ball_centres();
  std::printf("compensation gain, 20 balls of cmm_errors_ball_plate.json, 190 length errors vs the hidden truth:\n");
  std::printf("%-52s %10s %10s %8s %14s\n", "map", "RMS um", "max um", "gain", "measuring s");
  double none_rms = 0;
  const auto row = [&](const char* name, std::shared_ptr<const ErrorMap> map) {
    CompensatedMachine cmm(std::make_unique<VirtualCmm>(world, 3), std::move(map));
    const auto m = test_support::measure_balls(cmm, truth, 20, 200);
    const auto e = test_support::length_errors(m.centres_mm, truth);
    if (none_rms == 0) none_rms = e.rms_mm;
    std::printf("%-52s %10.3f %10.3f %8.1f %14.1f%s\n", name, 1e3 * e.rms_mm, 1e3 * e.max_abs_mm, none_rms / e.rms_mm,
                m.simulated_time_s, m.error.empty() ? "" : (" " + m.error).c_str());
  };
  row("none", nullptr);
  double t1 = 0, t4 = 0;
  row("calibrated, 1 run per plane, 2 laser cycles", calibrated_map(world, ball_array_plan(1, 2), &t1));
  row("calibrated, 4 runs per plane, 8 laser cycles", calibrated_map(world, ball_array_plan(4, 8), &t4));
  const auto plan = ball_array_plan(1, 2);
  row("true errors on the 17 x 13 x 3 grid (trilinear)",
      std::make_shared<const ErrorSpaceMap>(
          *ErrorSpaceMap::build(test_support::truth_error_space(world.truth.errors, plan.grid, Vec3(0, 0, -50), {}))));
  row("true errors exactly", std::make_shared<const test_support::TruthErrorMap>(world.truth.errors, Vec3(0, 0, -50)));
  std::printf("simulated calibration time: %.0f s (1 run), %.0f s (4 runs)\n\n", t1, t4);
}

// The controller's cost: a commanded target (two map queries, the fixed point) and a reported
// point (one query) through CompensatedMachine with the calibrated trilinear map, in thread CPU time.
void compensation_bench(benchmark::State& state, bool command) {
  static const auto map = calibrated_map(ball_world(), ball_array_plan(1, 2));
  const CompensatedMachine cmm(std::make_unique<VirtualCmm>(default_world(), 1), map);
  Rng rng(5);
  constexpr int batch = 256;
  std::vector<Vec3> pts(batch * 64);
  for (auto& p : pts) p = {100 + 800 * rng.uniform(), 100 + 600 * rng.uniform(), 50 + 100 * rng.uniform()};
  std::vector<double> per_query_ns;
  std::size_t at = 0;
  for (auto _ : state) {
    const double t0 = thread_cpu_ns();
    Vec3 sum = Vec3::Zero();
    for (int q = 0; q < batch; ++q, at = (at + 1) % pts.size())
      sum += command ? cmm.command_for(pts[at]) : cmm.corrected(pts[at]);
    benchmark::DoNotOptimize(sum);
    per_query_ns.push_back((thread_cpu_ns() - t0) / batch);
  }
  std::sort(per_query_ns.begin(), per_query_ns.end());
  state.counters["median_ns"] = per_query_ns[per_query_ns.size() / 2];
  state.counters["p99_ns"] = per_query_ns[std::min(per_query_ns.size() - 1, per_query_ns.size() * 99 / 100)];
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * batch);
}
void BM_Compensation_CommandedTarget(benchmark::State& s) { compensation_bench(s, true); }
void BM_Compensation_ReportedPoint(benchmark::State& s) { compensation_bench(s, false); }
BENCHMARK(BM_Compensation_CommandedTarget)->MeasureProcessCPUTime();
BENCHMARK(BM_Compensation_ReportedPoint)->MeasureProcessCPUTime();

// A map calibrated at two temperatures follows the controller's thermometer: each 0.01 K step
// rebuilds it (at_temperature, then the interpolator) before the next command. The cost of one
// rebuild for the 50 x 50 x 10 e_z space, per interpolation method, in process CPU time.
void rebuild_bench(benchmark::State& state, error_space::Method method) {
  error_space::ErrorSpaceFile file;
  error_space::ErrorSpace warm = truth_space();
  warm.temperature_c = 24;
  for (double& v : warm.values_mm[2]) v *= 1.2;
  file.spaces = {truth_space(), warm};
  file.interpolation.method = method;
  const auto map = ErrorSpaceMap::build(file, 20);
  if (!map) {
    state.SkipWithError(map.error().c_str());
    return;
  }
  double t = 20;
  for (auto _ : state) {
    t = t >= 24 ? 20 : t + 0.01;
    auto at = map->at_temperature(t);
    benchmark::DoNotOptimize(at);
  }
}
void BM_Compensation_RebuildAtTemperature_Trilinear(benchmark::State& s) {
  rebuild_bench(s, error_space::Method::Trilinear);
}
void BM_Compensation_RebuildAtTemperature_BSpline(benchmark::State& s) {
  rebuild_bench(s, error_space::Method::BSpline);
}
BENCHMARK(BM_Compensation_RebuildAtTemperature_Trilinear)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
BENCHMARK(BM_Compensation_RebuildAtTemperature_BSpline)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

void print_validation() {
  const auto plan = bench_plan();
  const auto run = calibrate_space(machine(), plan);
  const error_space::InterpolationSpec specs[] = {{error_space::Method::Trilinear, {}},
                                                  {error_space::Method::BSpline, {}},
                                                  {error_space::Method::LeastSquares, {1, 1}},
                                                  {error_space::Method::LeastSquares, {2, 2}}};
  const char* names[] = {"trilinear", "bspline (cubic, not-a-knot)", "least squares linear, 8 pts",
                         "least squares quadratic, 64 pts"};
  std::printf("every-second-point validation, e_z on 50 x 50 x 10 (20 mm), fit on 25 x 25 x 5, predict the rest:\n");
  std::printf("%-34s %22s %22s\n", "method", "hidden field RMS/max um", "recovered RMS/max um");
  for (int i = 0; i < 4; ++i) {
    const auto a = error_space::validate_every_second(plan.grid, truth_space().values_mm[2], specs[i]);
    const auto b = error_space::validate_every_second(plan.grid, run.space.values_mm[2], specs[i]);
    if (!a || !b) {
      std::printf("%-34s %s\n", names[i], (a ? b.error() : a.error()).c_str());
      continue;
    }
    std::printf("%-34s %10.4f / %-10.4f %10.4f / %-10.4f\n", names[i], 1e3 * a->rms_mm, 1e3 * a->max_abs_mm,
                1e3 * b->rms_mm, 1e3 * b->max_abs_mm);
  }
  double floor2 = 0;
  for (double s : run.space.sd_mm[2]) floor2 += s * s;
  std::printf("recovered space's noise floor RMS: %.4f um\n\n",
              1e3 * std::sqrt(floor2 / static_cast<double>(run.space.sd_mm[2].size())));
}

// The calibration report of the 50 x 50 x 10 run as one offline SVG page (the template for the
// future `metron calibrate error-space --report`).
int write_report(const char* path) {
  using namespace metron::error_space;
  const auto plan = bench_plan();
  const auto run = calibrate_space(machine(), plan);
  const ErrorSpace& truth = truth_space();
  ErrorSpace diff = run.space;
  double d2 = 0, f2 = 0;
  for (std::size_t i = 0; i < diff.values_mm[2].size(); ++i) {
    diff.values_mm[2][i] -= truth.values_mm[2][i];
    d2 += diff.values_mm[2][i] * diff.values_mm[2][i], f2 += run.space.sd_mm[2][i] * run.space.sd_mm[2][i];
  }
  const double n = static_cast<double>(diff.values_mm[2].size());
  ReportInput in;
  in.title = "Error-space calibration, sequential two-point method (SEEDS.md 4)";
  in.notes.push_back(
      fmt::format("grid 50 x 50 x 10, step 20 mm; head d = 20 mm, sensor noise 0.1 um; plate form 5 um; "
                  "planes tied by an ISO 230-2 laser run along z ({} cycles)",
                  plan.laser_cycles));
  in.notes.push_back(
      fmt::format("recovered e_z vs hidden truth (method's reference): RMS {:.3f} um; noise floor RMS {:.3f} um; "
                  "S7 planes to re-measure: {}",
                  1e3 * std::sqrt(d2 / n), 1e3 * std::sqrt(f2 / n), run.planes_to_remeasure));
  in.maps.push_back(slice_map(run.space, Component::Z, 0, "recovered e_z, z = -500"));
  in.maps.push_back(slice_map(run.space, Component::Z, 9, "recovered e_z, z = -320"));
  in.maps.push_back(slice_map(diff, Component::Z, 0, "recovered - hidden truth, z = -500"));
  HeatMap plate;
  plate.title = "plate profile recovered (under A), plane 0";
  plate.x_label = "x (mm)", plate.y_label = "y (mm)";
  plate.x_mm = plan.grid.axes_mm[0], plate.y_mm = plan.grid.axes_mm[1];
  plate.values_mm = run.planes[0].surface.profile_mm;
  in.maps.push_back(plate);
  HeatMap plate_truth = plate;
  plate_truth.title = "plate profile, hidden truth (same reference)";
  plate_truth.values_mm = plate_truth_in_reference(machine(), plan, 2, 0);
  in.maps.push_back(plate_truth);
  HeatMap sd = slice_map(run.space, Component::Z, 0, "noise floor (sd), z = -500");
  for (std::size_t i = 0; i < 50; ++i)
    for (std::size_t j = 0; j < 50; ++j)
      sd.values_mm(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) =
          run.space.sd_mm[2][plan.grid.index(i, j, 0)];
  in.maps.push_back(sd);
  const std::pair<InterpolationSpec, const char*> methods[] = {
      {{Method::Trilinear, {}}, "trilinear"},
      {{Method::BSpline, {}}, "bspline"},
      {{Method::LeastSquares, {2, 2}}, "least squares (quadratic, 64)"}};
  for (const auto& [spec, name] : methods) {
    const auto v = validate_every_second(plan.grid, run.space.values_mm[2], spec);
    auto m = validation_map(run.space, Component::Z, 0, spec, fmt::format("validation residual, {}, z = -500", name));
    if (!v || !m) continue;
    in.notes.push_back(fmt::format("every-second-point validation, {}: RMS {:.3f} um, max {:.3f} um ({} points)", name,
                                   1e3 * v->rms_mm, 1e3 * v->max_abs_mm, v->points));
    in.maps.push_back(*m);
  }
  std::ofstream out(path);
  out << report_svg(in);
  std::printf("wrote %s\n", path);
  return out ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::strcmp(argv[1], "--report") == 0) return write_report(argv[2]);
  print_validation();
  print_gain();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
