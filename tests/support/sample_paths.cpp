// SPDX-License-Identifier: GPL-3.0-or-later
#include "sample_paths.hpp"

#include <cmath>
#include <functional>
#include <memory>
#include <numbers>
#include <vector>

namespace metron::test_support {
namespace {

// Joins points of a parametric curve, sampled at about `step_mm` of arc length, with Hermite
// segments along its tangents.
geometry::PccPath sample(const std::function<Vec3(double)>& f, const std::function<Vec3(double)>& df,
                         std::size_t segments, double step_mm) {
  geometry::PccPath path;
  path.segments.reserve(segments);
  double t = 0;
  Vec3 p0 = f(t), t0 = df(t).normalized();
  for (std::size_t i = 0; i < segments; ++i) {
    const double t1 = t + step_mm / df(t).norm();
    const Vec3 p1 = f(t1), tan1 = df(t1).normalized();
    path.segments.push_back(geometry::PccSegment::hermite(p0, p1, t0, tan1));
    t = t1;
    p0 = p1;
    t0 = tan1;
  }
  return path;
}

}  // namespace

geometry::PccPath freeform_contour(std::size_t segments, double segment_mm) {
  constexpr double pi = std::numbers::pi;
  const auto r = [](double th) { return 40.0 * (1 + 0.3 * std::sin(3 * th) + 0.12 * std::sin(7 * th + 1)); };
  const auto dr = [](double th) { return 40.0 * (0.9 * std::cos(3 * th) + 0.84 * std::cos(7 * th + 1)); };
  const double rise = 1.5 / (2 * pi);
  const auto f = [&](double th) { return Vec3(r(th) * std::cos(th), r(th) * std::sin(th), rise * th); };
  const auto df = [&](double th) {
    return Vec3(dr(th) * std::cos(th) - r(th) * std::sin(th), dr(th) * std::sin(th) + r(th) * std::cos(th), rise);
  };
  return sample(f, df, segments, segment_mm);
}

geometry::PccPath tight_meander(std::size_t segments, double segment_mm) {
  constexpr double pi = std::numbers::pi;
  // Wavelength and amplitude vary slowly along x; phase phi' = 2 pi / lambda(x).
  const auto lambda = [](double x) { return 17.0 + 13.0 * std::sin(x / 37.0); };
  const auto amp = [](double x) { return 3.5 + 2.5 * std::sin(x / 23.0 + 0.5); };
  const auto damp = [](double x) { return 2.5 / 23.0 * std::cos(x / 23.0 + 0.5); };
  // phi(x) integrated numerically on the fly would break the closed form; use the exact
  // integral of 2 pi / lambda approximated by a dense cumulative table.
  struct Phase {
    std::vector<double> phi;
    double h = 0.01;
  };
  auto table = std::make_shared<Phase>();
  const double x_max = static_cast<double>(segments) * segment_mm + 100.0;
  table->phi.resize(static_cast<std::size_t>(x_max / table->h) + 2);
  for (std::size_t i = 1; i < table->phi.size(); ++i) {
    const double xm = (static_cast<double>(i) - 0.5) * table->h;
    table->phi[i] = table->phi[i - 1] + table->h * 2 * pi / lambda(xm);
  }
  const auto phi = [table](double x) {
    const double u = x / table->h;
    const auto i = static_cast<std::size_t>(u);
    const double w = u - static_cast<double>(i);
    return table->phi[i] * (1 - w) + table->phi[i + 1] * w;
  };
  const auto f = [=](double x) { return Vec3(x, amp(x) * std::sin(phi(x)), 0.0); };
  const auto df = [=](double x) {
    return Vec3(1.0, damp(x) * std::sin(phi(x)) + amp(x) * std::cos(phi(x)) * 2 * pi / lambda(x), 0.0);
  };
  return sample(f, df, segments, segment_mm);
}

}  // namespace metron::test_support
