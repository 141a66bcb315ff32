// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/segmented_scanning/time_optimal_bound.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace metron::machine::segmented {

TimeOptimalBound time_optimal_bound(const geometry::PccPath& path, const BoundLimits& limits, double step_mm) {
  TimeOptimalBound out;
  // Nodes: arc length by chords of fine parameter steps, curvature |r' x r''| / |r'|^3 at each.
  std::vector<double> s{0.0}, vmax;
  const auto limit_at = [&](const geometry::PccSegment& seg, double u) {
    const Vec3 d1 = seg.derivative(u), d2 = seg.second_derivative(u);
    const double n = d1.norm();
    const double kappa = n > 0 ? d1.cross(d2).norm() / (n * n * n) : 0.0;
    double v = limits.speed_mm_s;
    if (kappa > 0) v = std::min(v, std::sqrt(limits.normal_acceleration_mm_s2 / kappa));
    return v;
  };
  for (const auto& seg : path.segments) {
    if (!(seg.d_mm > 0)) continue;
    // Parameter steps fine enough for step_mm of arc (|r'| bounds the arc per parameter unit).
    double speed = 0;
    for (int i = 0; i <= 8; ++i) speed = std::max(speed, seg.derivative(seg.d_mm * i / 8).norm());
    const auto n = static_cast<std::size_t>(std::max(1.0, std::ceil(seg.d_mm * std::max(speed, 1e-9) / step_mm)));
    Vec3 prev = seg.point(0);
    if (vmax.empty())
      vmax.push_back(limit_at(seg, 0));
    else
      vmax.back() = std::min(vmax.back(), limit_at(seg, 0));  // the junction node: both sides' limit
    for (std::size_t i = 1; i <= n; ++i) {
      const double u = seg.d_mm * static_cast<double>(i) / static_cast<double>(n);
      const Vec3 p = seg.point(u);
      s.push_back(s.back() + (p - prev).norm());
      vmax.push_back(limit_at(seg, u));
      prev = p;
    }
  }
  const std::size_t m = s.size();
  out.nodes = m;
  out.length_mm = s.back();
  if (m < 2) return out;
  // Rest to rest; forward pass (acceleration), backward pass (braking): v^2 grows by at most 2 a ds.
  std::vector<double> v(vmax);
  v.front() = v.back() = 0;
  const double a = limits.acceleration_mm_s2;
  for (std::size_t i = 1; i < m; ++i) v[i] = std::min(v[i], std::sqrt(v[i - 1] * v[i - 1] + 2 * a * (s[i] - s[i - 1])));
  for (std::size_t i = m - 1; i-- > 0;)
    v[i] = std::min(v[i], std::sqrt(v[i + 1] * v[i + 1] + 2 * a * (s[i + 1] - s[i])));
  for (std::size_t i = 1; i < m; ++i) {
    const double ds = s[i] - s[i - 1];
    if (ds > 0) out.time_s += 2 * ds / (v[i - 1] + v[i]);
  }
  return out;
}

}  // namespace metron::machine::segmented
