// SPDX-License-Identifier: GPL-3.0-or-later
// Oracle tests for metron::error_space (SEEDS.md 4): the two-point line and surface on synthetic
// readings made from known motion errors and plate profiles, the derived noise floors against Monte
// Carlo, interpolation against functions each method must reproduce exactly, merging, temperature
// interpolation and the strict error-space file.
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "metron/stdlib/error_space/error_space_file.hpp"
#include "metron/stdlib/error_space/interpolation.hpp"
#include "metron/stdlib/error_space/merge.hpp"
#include "metron/stdlib/error_space/report_svg.hpp"
#include "metron/stdlib/error_space/two_point.hpp"

namespace metron::error_space {
namespace {

constexpr double pi = std::numbers::pi;

/// Readings of a line from a motion error e_k and a profile f at the plate points 0..n+1, with the
/// sign convention of two_point.hpp: a_k = f_k - e_k + cA, b_k = f_{k+1} - e_k + cB.
LineReadings make_line(const std::vector<double>& e, const std::vector<double>& f, double ca, double cb,
                       std::mt19937_64* rng = nullptr, double sigma = 0) {
  std::normal_distribution<double> noise(0, sigma);
  LineReadings r;
  for (std::size_t k = 0; k < e.size(); ++k) {
    r.a_mm.push_back(f[k] - e[k] + ca + (rng ? noise(*rng) : 0));
    r.b_mm.push_back(f[k + 1] - e[k] + cb + (rng ? noise(*rng) : 0));
  }
  return r;
}

std::vector<double> relative_to_end_line(std::vector<double> v) {
  const double n = static_cast<double>(v.size() - 1), v0 = v.front(), vn = v.back();
  for (std::size_t k = 0; k < v.size(); ++k) v[k] -= v0 + (vn - v0) * static_cast<double>(k) / n;
  return v;
}

TEST(TwoPointLine, RecoversMotionAndProfileRelativeToTheEndLine) {
  const int n = 20;
  std::vector<double> e(n + 1), f(n + 2);
  for (int k = 0; k <= n; ++k) e[k] = 0.004 * std::sin(0.3 * k) + 2e-5 * k * k + 0.001;
  for (int k = 0; k <= n + 1; ++k) f[k] = 0.003 * std::cos(0.5 * k) + 1e-4 * k;
  const double ca = 0.010, cb = 0.0137;  // Delta = 3.7 um
  const LineResult r = solve_line(make_line(e, f, ca, cb));
  const auto truth = relative_to_end_line(e);
  for (int k = 0; k <= n; ++k) EXPECT_NEAR(r.motion_mm[k], truth[k], 1e-12) << k;
  // f relative to the same line: f_k - f_0 - (e's end line slope) k
  const double s = (e[n] - e[0]) / n;
  for (int k = 0; k <= n; ++k) EXPECT_NEAR(r.profile_mm[k], f[k] - f[0] - s * k, 1e-12) << k;
  EXPECT_NEAR(r.delta_mm, (cb - ca) + s, 1e-12);
  // With the true Delta known, the raw motion e_k - e_0 comes back.
  const LineResult known = solve_line(make_line(e, f, ca, cb), cb - ca);
  for (int k = 0; k <= n; ++k) EXPECT_NEAR(known.motion_mm[k], e[k] - e[0], 1e-12);
}

TEST(TwoPointLine, TheSeedsLiteralStartValuesLeaveAKink) {
  // e_1 = 0 taken literally drops the first increment: after the end correction the curve is off
  // by (1 - k/n)(e_1 - e_0 + Delta) for k >= 1 (docs/error-space.md).
  const int n = 10;
  std::vector<double> e(n + 1, 0.0), f(n + 2, 0.0);
  for (int k = 0; k <= n; ++k) e[k] = 0.002 * std::sin(0.7 * k);
  const double delta = 0.002;
  const LineReadings rd = make_line(e, f, 0, delta);
  auto c = chain_literal_start(rd);
  const double cn = c[n];
  for (int k = 0; k <= n; ++k) c[k] -= cn * k / n;
  const auto truth = relative_to_end_line(e);
  const double kink = e[1] - e[0] + delta;
  for (int k = 1; k < n; ++k) EXPECT_NEAR(c[k] - truth[k], -(1.0 - double(k) / n) * kink, 1e-12) << k;
}

TEST(TwoPointLine, DeltaByReversalIsFreeOfTheSlope) {
  // Plate points -1..n+1; the forward head reads (k, k+1), the reversed one (k, k-1).
  const int n = 15;
  std::vector<double> e(n + 1), f(n + 3);
  for (int k = 0; k <= n; ++k) e[k] = 0.003 * std::sin(0.4 * k) + 2e-4 * k;  // a real slope
  for (int k = 0; k <= n + 2; ++k) f[k] = 0.002 * std::cos(0.3 * k);         // f[k + 1] is point k
  const double ca = 0.004, cb = 0.0063;
  LineReadings fwd, rev;
  for (int k = 0; k <= n; ++k) {
    fwd.a_mm.push_back(f[k + 1] - e[k] + ca), fwd.b_mm.push_back(f[k + 2] - e[k] + cb);
    rev.a_mm.push_back(f[k + 1] - e[k] + ca), rev.b_mm.push_back(f[k] - e[k] + cb);
  }
  const double delta = delta_by_reversal(fwd, rev);
  EXPECT_NEAR(delta, cb - ca, 1e-15);
  const LineResult r = solve_line(fwd, delta);
  for (int k = 0; k <= n; ++k) EXPECT_NEAR(r.motion_mm[k], e[k] - e[0], 1e-14);  // slope kept
}

TEST(TwoPointLine, NoiseIsARandomWalkAndABrownianBridge) {
  const int n = 16, trials = 20000;
  const double sigma = 1e-4;
  std::mt19937_64 rng(7);
  std::vector<double> zero(n + 1, 0.0), zf(n + 2, 0.0), var_raw(n + 1, 0.0), var_bridge(n + 1, 0.0);
  for (int t = 0; t < trials; ++t) {
    const LineReadings r = make_line(zero, zf, 0, 0, &rng, sigma);
    const auto raw = chain(r);
    const auto bridge = solve_line(r).motion_mm;
    for (int k = 0; k <= n; ++k)
      var_raw[k] += raw[k] * raw[k] / trials, var_bridge[k] += bridge[k] * bridge[k] / trials;
  }
  double mean_var = 0;
  for (int k = 1; k < n; ++k) {
    EXPECT_NEAR(std::sqrt(var_raw[k]), line_noise_sd_mm(n, k, sigma, false),
                0.03 * line_noise_sd_mm(n, k, sigma, false));
    EXPECT_NEAR(std::sqrt(var_bridge[k]), line_noise_sd_mm(n, k, sigma), 0.03 * line_noise_sd_mm(n, k, sigma));
  }
  for (int k = 0; k <= n; ++k) mean_var += var_bridge[k] / (n + 1);
  EXPECT_NEAR(std::sqrt(mean_var), line_noise_rms_mm(n, sigma), 0.02 * line_noise_rms_mm(n, sigma));
}

struct SyntheticSurface {
  Eigen::MatrixXd e, f;  // e: (l+1)x(m+1); f on plate points (l+2)x(m+2)
  double ca = 0.02, cb = 0.0234;
};

SyntheticSurface make_surface(int l, int m) {
  SyntheticSurface s;
  s.e.resize(l + 1, m + 1);
  s.f.resize(l + 2, m + 2);
  for (int i = 0; i <= l; ++i)
    for (int j = 0; j <= m; ++j)
      s.e(i, j) = 0.005 * std::sin(0.21 * i + 0.1) * std::cos(0.17 * j) + 3e-5 * i * j + 2e-4 * j + 0.0031;
  for (int i = 0; i <= l + 1; ++i)
    for (int j = 0; j <= m + 1; ++j) s.f(i, j) = 0.004 * std::cos(0.13 * i) * std::sin(0.19 * j + 0.4) + 5e-5 * i;
  return s;
}

SurfaceReadings read_surface(const SyntheticSurface& s, std::mt19937_64* rng = nullptr, double sigma = 0) {
  const int l = static_cast<int>(s.e.rows()) - 1, m = static_cast<int>(s.e.cols()) - 1;
  SurfaceReadings r;
  for (int j = 0; j <= m; ++j) {
    std::vector<double> e(l + 1), f(l + 2);
    for (int i = 0; i <= l; ++i) e[i] = s.e(i, j);
    for (int i = 0; i <= l + 1; ++i) f[i] = s.f(i, j);
    r.x_lines.push_back(make_line(e, f, s.ca, s.cb, rng, sigma));
  }
  for (int side = 0; side < 2; ++side) {
    const int i = side ? l : 0;
    std::vector<double> e(m + 1), f(m + 2);
    for (int j = 0; j <= m; ++j) e[j] = s.e(i, j);
    for (int j = 0; j <= m + 1; ++j) f[j] = s.f(i, j);
    (side ? r.y_line_last : r.y_line_first) = make_line(e, f, s.ca, s.cb, rng, sigma);
  }
  return r;
}

TEST(TwoPointSurface, StepsS1ToS7RecoverTheSurfaceAndTheProfile) {
  const SyntheticSurface s = make_surface(14, 9);
  const SurfaceResult r = solve_surface(read_surface(s));
  const Eigen::MatrixXd truth = surface_reference(s.e);
  EXPECT_LT((r.error_mm - truth).cwiseAbs().maxCoeff(), 1e-12);
  const double slope = (s.e(14, 0) - s.e(0, 0)) / 14;
  for (int i = 0; i <= 14; ++i)
    for (int j = 0; j <= 9; ++j) EXPECT_NEAR(r.profile_mm(i, j), s.f(i, j) - s.f(0, 0) - slope * (i + j), 1e-12);
  EXPECT_FALSE(r.remeasure);
  for (double d : r.s7_disagreement_mm) EXPECT_NEAR(d, 0, 1e-12);
  // With the true Delta known the plane keeps its slope: e - e(0,0).
  SurfaceOptions known;
  known.known_delta_mm = s.cb - s.ca;
  const SurfaceResult k = solve_surface(read_surface(s), known);
  EXPECT_LT((k.error_mm - (s.e.array() - s.e(0, 0)).matrix()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_FALSE(k.remeasure);
}

TEST(TwoPointSurface, S7AsksToRemeasureALineWithAGlitch) {
  const SyntheticSurface s = make_surface(20, 12);
  std::mt19937_64 rng(11);
  const double sigma = 5e-5;
  SurfaceReadings rd = read_surface(s, &rng, sigma);
  SurfaceOptions opt;
  opt.sensor_sigma_mm = sigma;
  EXPECT_FALSE(solve_surface(rd, opt).remeasure);
  // A 5 um jump of sensor B half-way along line 7 (a knock during the run).
  for (std::size_t k = 10; k < rd.x_lines[7].b_mm.size(); ++k) rd.x_lines[7].b_mm[k] += 0.005;
  const SurfaceResult r = solve_surface(rd, opt);
  ASSERT_TRUE(r.remeasure);
  EXPECT_EQ(r.remeasure_lines, std::vector<int>{7});
  // S6 on inconsistent data: every X curve's ends lie on the two Y boundary curves (S4, S5).
  const LineResult y0 = solve_line(rd.y_line_first, r.delta_mm), yl = solve_line(rd.y_line_last, r.delta_mm);
  for (int j = 0; j <= 12; ++j) {
    EXPECT_NEAR(r.error_mm(0, j), y0.motion_mm[j], 1e-12) << j;
    EXPECT_NEAR(r.error_mm(20, j), yl.motion_mm[j], 1e-12) << j;
  }
}

TEST(TwoPointSurface, PropagatedNoiseFloorMatchesMonteCarlo) {
  const int l = 10, m = 7, trials = 3000;
  const double sigma = 1e-4;
  const Eigen::MatrixXd sd = surface_noise_sd_mm(l, m, sigma);
  SyntheticSurface zero;
  zero.e = Eigen::MatrixXd::Zero(l + 1, m + 1);
  zero.f = Eigen::MatrixXd::Zero(l + 2, m + 2);
  zero.ca = zero.cb = 0;
  std::mt19937_64 rng(5);
  Eigen::MatrixXd var = Eigen::MatrixXd::Zero(l + 1, m + 1);
  for (int t = 0; t < trials; ++t)
    var += solve_surface(read_surface(zero, &rng, sigma)).error_mm.array().square().matrix() / trials;
  for (int i = 0; i <= l; ++i)
    for (int j = 0; j <= m; ++j)
      if (sd(i, j) > 0) {
        EXPECT_NEAR(std::sqrt(var(i, j)) / sd(i, j), 1.0, 0.06) << i << "," << j;
      }
  // The X line at y_0 is a plain bridge (line_noise_sd_mm), the first check of the propagation.
  for (int i = 0; i <= l; ++i) EXPECT_NEAR(sd(i, 0), line_noise_sd_mm(l, i, sigma), 1e-15);
}

Grid uniform_grid(int nx, int ny, int nz, double h = 10) {
  Grid g;
  for (int i = 0; i < nx; ++i) g.axes_mm[0].push_back(i * h);
  for (int j = 0; j < ny; ++j) g.axes_mm[1].push_back(j * h * 1.5);
  for (int k = 0; k < nz; ++k) g.axes_mm[2].push_back(k * h * 0.7 - 20);
  return g;
}

template <class F>
std::vector<double> sample(const Grid& g, F fn) {
  std::vector<double> v(g.size());
  for (std::size_t k = 0; k < g.axes_mm[2].size(); ++k)
    for (std::size_t j = 0; j < g.axes_mm[1].size(); ++j)
      for (std::size_t i = 0; i < g.axes_mm[0].size(); ++i)
        v[g.index(i, j, k)] = fn(g.axes_mm[0][i], g.axes_mm[1][j], g.axes_mm[2][k]);
  return v;
}

TEST(Interpolation, TrilinearReproducesMultilinearFunctions) {
  Grid g = uniform_grid(5, 4, 3);
  g.axes_mm[0][2] = 17;  // non-uniform axis
  auto fn = [](double x, double y, double z) {
    return 0.001 + 2e-5 * x - 3e-5 * y + 1e-5 * z + 4e-7 * x * y - 2e-7 * y * z + 1e-8 * x * y * z;
  };
  auto f = make_field(g, sample(g, fn), {Method::Trilinear, {}});
  ASSERT_TRUE(f);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> ux(0, 40), uy(0, 45), uz(-20, -6);
  for (int t = 0; t < 200; ++t) {
    const double x = ux(rng), y = uy(rng), z = uz(rng);
    EXPECT_NEAR((*f)->value(x, y, z), fn(x, y, z), 1e-14);
  }
}

TEST(Interpolation, BSplineReproducesTensorCubicsAndIsC2) {
  const Grid g = uniform_grid(7, 6, 5);
  auto fn = [](double x, double y, double z) {
    return 1e-6 * (x * x * x - 20 * x * x) * (1 + 0.01 * y - 1e-4 * y * y + 1e-6 * y * y * y) *
           (2 + 0.1 * z + 1e-3 * z * z * z);
  };
  auto f = make_field(g, sample(g, fn), {Method::BSpline, {}});
  ASSERT_TRUE(f);
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> ux(0, 60), uy(0, 75), uz(-20, 8);
  for (int t = 0; t < 200; ++t) {
    const double x = ux(rng), y = uy(rng), z = uz(rng);
    EXPECT_NEAR((*f)->value(x, y, z), fn(x, y, z), 1e-9 * (1 + std::abs(fn(x, y, z))));
  }
  // C2 on arbitrary data: second differences from both sides of a knot agree.
  std::vector<double> rnd(g.size());
  for (auto& v : rnd) v = std::uniform_real_distribution<double>(-1, 1)(rng);
  auto r = make_field(g, rnd, {Method::BSpline, {}});
  ASSERT_TRUE(r);
  const double h = 1e-3, x = 30, y = 22, z = -5;  // x = 30 is a knot
  const double left = ((*r)->value(x, y, z) - 2 * (*r)->value(x - h, y, z) + (*r)->value(x - 2 * h, y, z)) / (h * h);
  const double right = ((*r)->value(x + 2 * h, y, z) - 2 * (*r)->value(x + h, y, z) + (*r)->value(x, y, z)) / (h * h);
  EXPECT_NEAR(left, right, 0.01 * (std::abs(left) + 1e-3));
  EXPECT_FALSE(make_field(uniform_grid(3, 5, 5), std::vector<double>(75, 0.0), {Method::BSpline, {}}));
}

TEST(Interpolation, LeastSquaresGivesTheSeedsEstimateAndSigma) {
  // One cell = the whole 2x2x2 grid: the seed's 8-point linear model, checked against a direct solve.
  Grid g;
  g.axes_mm = {std::vector<double>{0, 10}, std::vector<double>{0, 20}, std::vector<double>{0, 5}};
  const std::vector<double> v = {0.001, 0.004, -0.002, 0.003, 0.0015, 0.002, 0.0005, 0.006};
  InterpolationSpec spec{Method::LeastSquares, {1, 1}};
  auto f = make_field(g, v, spec);
  ASSERT_TRUE(f);
  Eigen::MatrixXd A(8, 4);
  Eigen::VectorXd y(8);
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) {
        const int r = i + 2 * j + 4 * k;
        A.row(r) << g.axes_mm[0][i], g.axes_mm[1][j], g.axes_mm[2][k], 1;
        y[r] = v[g.index(i, j, k)];
      }
  const Eigen::Matrix4d inv = (A.transpose() * A).inverse();
  const Eigen::Vector4d xh = inv * A.transpose() * y;
  const double s2 = (y - A * xh).squaredNorm() / (8 - 4);
  const Eigen::Vector4d p(3, 7, 4, 1);
  const Estimate e = (*f)->estimate(3, 7, 4);
  EXPECT_NEAR(e.value_mm, p.dot(xh), 1e-14);
  EXPECT_NEAR(e.sd_mm, std::sqrt(p.dot(s2 * inv * p)), 1e-12);
}

TEST(Interpolation, ValidationOnEverySecondPoint) {
  const Grid g = uniform_grid(17, 13, 1);
  auto lin = [](double x, double y, double) { return 1e-4 * x - 2e-4 * y + 0.003; };
  for (Method m : {Method::Trilinear, Method::BSpline, Method::LeastSquares}) {
    auto v = validate_every_second(g, sample(g, lin), {m, {}});
    ASSERT_TRUE(v) << v.error();
    EXPECT_LT(v->rms_mm, 1e-12) << to_string(m);
    EXPECT_EQ(v->points, 17u * 13u - 9u * 7u);
  }
  auto smooth = [](double x, double y, double) { return 0.01 * std::sin(x / 25) * std::cos(y / 30); };
  auto tri = validate_every_second(g, sample(g, smooth), {Method::Trilinear, {}});
  auto bsp = validate_every_second(g, sample(g, smooth), {Method::BSpline, {}});
  ASSERT_TRUE(tri && bsp);
  EXPECT_LT(bsp->rms_mm, 0.2 * tri->rms_mm);
}

TEST(Merge, TheSeedsRuleOffsetsAveragesAndZeroes) {
  const Series s1 = {1.0, 2.0, 3.0, std::nullopt, std::nullopt};
  const Series s2 = {std::nullopt, 12.5, 13.5, 14.0, 15.0};  // offset by 10.5 from s1 over {1,2}
  const Series m = merge_redundant(s1, s2);
  EXPECT_DOUBLE_EQ(*m[0], 1.0);
  EXPECT_DOUBLE_EQ(*m[1], 2.0);
  EXPECT_DOUBLE_EQ(*m[2], 3.0);
  EXPECT_DOUBLE_EQ(*m[3], 3.5);
  EXPECT_DOUBLE_EQ(*m[4], 4.5);
  const Series z = merge_redundant(s1, s2, ZeroCorrection::Ends);
  EXPECT_DOUBLE_EQ(*z[0], 0.0);
  EXPECT_DOUBLE_EQ(*z[4], 0.0);
  EXPECT_DOUBLE_EQ(*z[2], 3.0 - (1.0 + 3.5 * 2 / 4));
}

TEST(Temperature, SpacesAreInterpolatedByTheMonitoredTemperature) {
  ErrorSpace a, b;
  a.grid = b.grid = uniform_grid(2, 2, 1);
  a.temperature_c = 20, b.temperature_c = 24;
  a.values_mm[2] = {0, 1, 2, 3};
  b.values_mm[2] = {4, 5, 6, 7};
  const ErrorSpace m = at_temperature({b, a}, 21);
  EXPECT_DOUBLE_EQ(m.values_mm[2][1], 2.0);
  EXPECT_DOUBLE_EQ(at_temperature({a, b}, 30).values_mm[2][0], 4.0);
}

TEST(ErrorSpaceFile, RoundTripsAndRejectsBadInputByPointer) {
  ErrorSpaceFile file;
  ErrorSpace s;
  s.grid = uniform_grid(4, 4, 2);
  s.values_mm[2] = sample(s.grid, [](double x, double y, double z) { return 1e-5 * x + 1e-6 * y * z; });
  s.sd_mm[2] = std::vector<double>(s.grid.size(), 1e-4);
  file.spaces = {s};
  file.interpolation = {Method::LeastSquares, {1, 2}};
  const auto j = to_json(file);
  auto back = from_json(j);
  ASSERT_TRUE(back) << back.error().pointer << ": " << back.error().message;
  EXPECT_EQ(back->spaces[0].values_mm[2], s.values_mm[2]);
  EXPECT_EQ(back->interpolation.least_squares.neighbourhood, 2);
  EXPECT_TRUE(back->spaces[0].values_mm[0].empty());

  auto bad = j;
  bad["temperatures"][0]["components"]["z"]["valuez_mm"] = 1;
  EXPECT_EQ(from_json(bad).error().pointer, "/temperatures/0/components/z/valuez_mm");
  bad = j;
  bad["temperatures"][0]["components"]["z"]["values_mm"].erase(0);
  EXPECT_EQ(from_json(bad).error().pointer, "/temperatures/0/components/z/values_mm");
  bad = j;
  bad["grid"]["y_mm"][2] = 0.0;
  EXPECT_EQ(from_json(bad).error().pointer, "/grid/y_mm/2");
  bad = j;
  bad["interpolation"]["method"] = "cubic";
  EXPECT_EQ(from_json(bad).error().pointer, "/interpolation/method");
  bad = j;
  bad["version"] = 2;
  EXPECT_EQ(from_json(bad).error().pointer, "/version");
  bad = j;
  bad["interpolation"] = {{"method", "bspline"}};
  bad["grid"]["z_mm"] = {0.0, 1.0};
  bad["temperatures"][0]["components"]["z"]["values_mm"] = std::vector<double>(32, 0.0);
  bad["temperatures"][0]["components"]["z"].erase("sd_mm");
  EXPECT_EQ(from_json(bad).error().pointer, "/interpolation");
}

}  // namespace
}  // namespace metron::error_space

namespace metron::error_space {
namespace {

TEST(ReportSvg, SelfContainedPageWithTheMaps) {
  ErrorSpace s;
  s.grid = uniform_grid(9, 7, 3);
  s.values_mm[2] = sample(s.grid, [](double x, double y, double z) { return 1e-5 * std::sin(x / 20) * y + 1e-6 * z; });
  ReportInput in;
  in.title = "t <&>";
  in.maps.push_back(slice_map(s, Component::Z, 1, "slice"));
  auto v = validation_map(s, Component::Z, 0, {Method::Trilinear, {}}, "residual");
  ASSERT_TRUE(v);
  // Fitted points (even i and j on the even slice) carry no residual; the rest inside the subgrid do.
  EXPECT_TRUE(std::isnan(v->values_mm(2, 4)));
  EXPECT_FALSE(std::isnan(v->values_mm(1, 4)));
  in.maps.push_back(*v);
  const std::string svg = report_svg(in);
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_NE(svg.find("t &lt;&amp;&gt;"), std::string::npos);
  // Offline: the only URL is the SVG namespace.
  std::size_t urls = 0;
  for (std::size_t p = svg.find("http"); p != std::string::npos; p = svg.find("http", p + 1)) ++urls;
  EXPECT_EQ(urls, 1u);
}

}  // namespace
}  // namespace metron::error_space
