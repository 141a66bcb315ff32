// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/active_scanning/speed_plan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

namespace metron::machine {

const char* to_string(SpeedLimit limit) {
  switch (limit) {
    case SpeedLimit::Feed: return "feed";
    case SpeedLimit::Segment: return "segment";
    case SpeedLimit::Machine: return "machine";
    case SpeedLimit::Centripetal: return "centripetal";
    case SpeedLimit::ProbeDynamics: return "probe dynamics";
    case SpeedLimit::Acceleration: return "acceleration";
  }
  return "unknown";
}

SpeedPlan::SpeedPlan(const geometry::PccPath& path, const SpeedPlanLimits& l, double step_mm) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  std::vector<SpeedLimit> why;
  double base = 0;
  for (std::size_t i = 0; i < path.segments.size(); ++i) {
    const geometry::PccSegment& seg = path.segments[i];
    const int n = std::max(1, static_cast<int>(std::ceil(seg.d_mm / step_mm)));
    const double seg_speed = i < path.speed_mm_s.size() && path.speed_mm_s[i] > 0 ? path.speed_mm_s[i] : inf;
    for (int k = (i == 0 ? 0 : 1); k <= n; ++k) {
      const double S = seg.d_mm * k / n;
      const double kappa = seg.curvature(S);
      // Each limit at this point, the lowest wins (ties keep the earlier, more basic one).
      const std::pair<double, SpeedLimit> candidates[] = {
          {l.feed_mm_s, SpeedLimit::Feed},
          {seg_speed, SpeedLimit::Segment},
          {l.machine_speed_mm_s, SpeedLimit::Machine},
          // SEEDS.md 1: Vf slower where curvature is higher; centripetal a = v^2 * kappa.
          {kappa > 0 ? std::sqrt(l.centripetal_mm_s2 / kappa) : inf, SpeedLimit::Centripetal},
          // The stylus (mass m, stiffness k) stays on a convex curve while its preload k*E0 can
          // give the centripetal force m*v^2*kappa: v <= sqrt(k/m) * sqrt(E0 / kappa).
          {kappa > 0 ? l.probe_natural_frequency_rad_s * std::sqrt(l.reference_deflection_mm / kappa) : inf,
           SpeedLimit::ProbeDynamics},
      };
      auto best = candidates[0];
      for (const auto& c : candidates)
        if (c.first < best.first) best = c;
      m_s.push_back(base + seg.arc_length(S));
      m_limit.push_back(best.first);
      why.push_back(best.second);
    }
    base += seg.length();
  }
  // Acceleration passes: v^2 <= v_next^2 + 2*a*ds both ways, from the creep speed at the ends.
  m_speed = m_limit;
  const std::size_t n = m_s.size();
  m_speed.front() = std::min(m_speed.front(), l.end_speed_mm_s);
  m_speed.back() = std::min(m_speed.back(), l.end_speed_mm_s);
  const double a2 = 2 * l.acceleration_mm_s2;
  for (std::size_t i = 1; i < n; ++i)
    m_speed[i] = std::min(m_speed[i], std::sqrt(m_speed[i - 1] * m_speed[i - 1] + a2 * (m_s[i] - m_s[i - 1])));
  for (std::size_t i = n - 1; i-- > 0;)
    m_speed[i] = std::min(m_speed[i], std::sqrt(m_speed[i + 1] * m_speed[i + 1] + a2 * (m_s[i + 1] - m_s[i])));
  for (std::size_t i = 0; i < n; ++i) {
    const SpeedLimit w = m_speed[i] < m_limit[i] * (1 - 1e-9) ? SpeedLimit::Acceleration : why[i];
    if (m_spans.empty() || m_spans.back().limit != w) {
      m_spans.push_back({m_s[i], m_s[i], w, m_speed[i]});
    } else {
      m_spans.back().to_mm = m_s[i];
      m_spans.back().min_speed_mm_s = std::min(m_spans.back().min_speed_mm_s, m_speed[i]);
    }
  }
}

double SpeedPlan::interpolate(const std::vector<double>& v, double s) const {
  if (s <= m_s.front()) return v.front();
  if (s >= m_s.back()) return v.back();
  const auto it = std::upper_bound(m_s.begin(), m_s.end(), s);
  const std::size_t i = static_cast<std::size_t>(it - m_s.begin());
  const double w = (s - m_s[i - 1]) / (m_s[i] - m_s[i - 1]);
  return (1 - w) * v[i - 1] + w * v[i];
}

double SpeedPlan::speed_at(double s) const { return interpolate(m_speed, s); }
double SpeedPlan::limit_at(double s) const { return interpolate(m_limit, s); }

std::vector<std::string> SpeedPlan::log() const {
  std::vector<std::string> out;
  for (const auto& s : m_spans)
    out.push_back(
        fmt::format("{:.3f}-{:.3f} mm: {}, >= {:.3f} mm/s", s.from_mm, s.to_mm, to_string(s.limit), s.min_speed_mm_s));
  return out;
}

}  // namespace metron::machine
