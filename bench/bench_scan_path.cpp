// SPDX-License-Identifier: GPL-3.0-or-later
// Scan-path generation (SEEDS.md 1): PCC segments against the chord tolerance, measured
// deviation from the exact curve, speeds, and the time to cut and fit a section of a
// 125k-triangle free-form mesh. Build with -DMETRON_BENCH=ON; run ./build/bench/bench_scan_path
// (prints the tables first, then the timings).
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "metron/stdlib/geometry/contour.hpp"
#include "metron/stdlib/geometry/mesh.hpp"
#include "metron/stdlib/geometry/scan_path.hpp"

namespace {

using namespace metron;
using namespace metron::geometry;
double height(double x, double y) { return 3 * std::sin(x / 12) * std::cos(y / 17) + 0.5 * std::sin(x / 3 + y / 5); }

// z = height(x, y) over [-50, 50]^2 as a grid mesh of 2 (n - 1)^2 triangles, normals up.
Mesh free_form_mesh(int n) {
  std::vector<Vec3> v;
  std::vector<Mesh::Face> f;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double x = -50 + 100.0 * i / (n - 1), y = -50 + 100.0 * j / (n - 1);
      v.emplace_back(x, y, height(x, y));
    }
  const auto id = [n](int i, int j) { return static_cast<std::uint32_t>(i * n + j); };
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j + 1 < n; ++j) {
      f.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      f.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return *Mesh::from_triangles(std::move(v), std::move(f));
}

void print_tables() {
  std::printf("Bore R = 10 mm, r = 2, E0 = 0.3 (ball-centre radius 8.3), feed 20 mm/s, a = 200 mm/s^2\n");
  std::printf("%10s %9s %14s %14s %12s %12s\n", "tol_um", "segments", "fit_dev_um", "true_dev_um", "kappa_err_%",
              "speed_mm_s");
  for (double tol : {1e-2, 1e-3, 1e-4, 1e-5}) {
    ArcSpec bore;
    bore.radius_mm = 10;
    ScanPathOptions o;
    o.chord_tolerance_mm = tol;
    o.feed_mm_s = 20;
    auto plan = make_scan_path(arc_contour(bore, 0.01), o);
    double worst = 0, kerr = 0;
    for (const auto& s : plan->path.segments)
      for (int k = 0; k <= 200; ++k) {
        const Vec3 p = s.point(s.d_mm * k / 200);
        worst = std::max(worst, std::abs(std::hypot(p.x(), p.y()) - 8.3));
      }
    for (double kappa : plan->curvature_per_mm) kerr = std::max(kerr, std::abs(kappa * 8.3 - 1) * 100);
    std::printf("%10.2f %9zu %14.4f %14.4f %12.4f %12.3f\n", tol * 1e3, plan->path.segments.size(),
                plan->max_deviation_mm * 1e3, worst * 1e3, kerr, plan->path.speed_mm_s.front());
  }
  const Mesh mesh = free_form_mesh(251);
  std::printf("\nFree-form mesh: %zu triangles; section x = 7 (plane normal +x), r = 2, E0 = 0.3, a = 200\n",
              mesh.face_count());
  std::printf("%10s %9s %14s %12s %12s %12s %12s\n", "tol_um", "segments", "fit_dev_um", "section_ms", "fit_ms",
              "v_min_mm_s", "v_max_mm_s");
  for (double tol : {1e-2, 5e-3, 2e-3}) {
    const auto t0 = std::chrono::steady_clock::now();
    auto contour = nearest_contour(mesh_section_contours(mesh, Vec3(7, 0, 0), Vec3::UnitX(), 0.05), Vec3(7, -50, 0));
    const auto t1 = std::chrono::steady_clock::now();
    ScanPathOptions o;
    o.chord_tolerance_mm = tol;
    auto plan = make_scan_path(*contour, o);
    const auto t2 = std::chrono::steady_clock::now();
    if (!plan) {
      std::printf("%10.2f failed: %s\n", tol * 1e3, plan.error().message.c_str());
      continue;
    }
    const auto [lo, hi] = std::minmax_element(plan->path.speed_mm_s.begin(), plan->path.speed_mm_s.end());
    std::printf("%10.2f %9zu %14.4f %12.2f %12.2f %12.3f %12.3f\n", tol * 1e3, plan->path.segments.size(),
                plan->max_deviation_mm * 1e3, std::chrono::duration<double, std::milli>(t1 - t0).count(),
                std::chrono::duration<double, std::milli>(t2 - t1).count(), *lo, *hi);
  }
  std::printf("\n");
}

void circle_path_1um(benchmark::State& state) {
  ArcSpec bore;
  bore.radius_mm = 10;
  const Contour c = arc_contour(bore, 0.01);
  ScanPathOptions o;
  for (auto _ : state) benchmark::DoNotOptimize(make_scan_path(c, o));
}
BENCHMARK(circle_path_1um)->Unit(benchmark::kMicrosecond);

void free_form_section_and_fit(benchmark::State& state) {
  static const Mesh mesh = free_form_mesh(251);
  ScanPathOptions o;
  o.chord_tolerance_mm = 0.005;
  for (auto _ : state) {
    auto contour = nearest_contour(mesh_section_contours(mesh, Vec3(7, 0, 0), Vec3::UnitX(), 0.05), Vec3(7, -50, 0));
    benchmark::DoNotOptimize(make_scan_path(*contour, o));
  }
}
BENCHMARK(free_form_section_and_fit)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  print_tables();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
