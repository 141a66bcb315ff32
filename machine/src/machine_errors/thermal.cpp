// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/machine_errors/thermal.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace metron::machine {
namespace {

// First-order lag over s seconds of an air ramp A + B s, from T0 (exact; see thermal.hpp).
double lag_step(double t0_c, double a, double b, double s, double tau) {
  if (tau <= 0) return a + b * s;
  return a + b * (s - tau) + (t0_c - a + b * tau) * std::exp(-s / tau);
}

}  // namespace

TemperatureHistory::TemperatureHistory(std::vector<double> t, std::vector<double> air, double lag, double initial)
    : m_t(std::move(t)), m_air(std::move(air)), m_lag_s(lag) {
  if (m_t.empty() || m_t.size() != m_air.size())
    throw std::invalid_argument("temperature history: times and temperatures differ in number");
  for (std::size_t i = 1; i < m_t.size(); ++i)
    if (!(m_t[i] > m_t[i - 1])) throw std::invalid_argument("temperature history: times must increase");
  if (lag < 0) throw std::invalid_argument("temperature history: the lag must be >= 0");
  m_body_at.assign(m_t.size(), 0.0);
  m_body_at[0] = std::isnan(initial) || lag == 0 ? m_air[0] : initial;
  for (std::size_t i = 1; i < m_t.size(); ++i) {
    const double s = m_t[i] - m_t[i - 1];
    m_body_at[i] = lag_step(m_body_at[i - 1], m_air[i - 1], (m_air[i] - m_air[i - 1]) / s, s, lag);
  }
}

double TemperatureHistory::air_c(double t) const {
  if (t <= m_t.front()) return m_air.front();
  if (t >= m_t.back()) return m_air.back();
  const std::size_t hi = static_cast<std::size_t>(std::upper_bound(m_t.begin(), m_t.end(), t) - m_t.begin());
  const double w = (t - m_t[hi - 1]) / (m_t[hi] - m_t[hi - 1]);
  return (1 - w) * m_air[hi - 1] + w * m_air[hi];
}

double TemperatureHistory::body_c(double t) const {
  if (t <= m_t.front()) return m_body_at.front();
  if (t >= m_t.back()) return lag_step(m_body_at.back(), m_air.back(), 0.0, t - m_t.back(), m_lag_s);
  const std::size_t hi = static_cast<std::size_t>(std::upper_bound(m_t.begin(), m_t.end(), t) - m_t.begin());
  const std::size_t lo = hi - 1;
  const double b = (m_air[hi] - m_air[lo]) / (m_t[hi] - m_t[lo]);
  return lag_step(m_body_at[lo], m_air[lo], b, t - m_t[lo], m_lag_s);
}

Vec3 ScaleThermalTerm::displacement(const MachinePose& pose, double t) const {
  Vec3 e = Vec3::Zero();
  for (int a = 0; a < 3; ++a) {
    const Scale& s = m_scales[static_cast<std::size_t>(a)];
    if (s.alpha_per_k == 0 || !s.temperature) continue;
    e[a] = s.alpha_per_k * (s.temperature->body_c(t) - 20.0) * (pose.axes_mm[a] - s.fixed_at_mm);
  }
  return e;
}

std::optional<double> ScaleThermalTerm::machine_temperature_c(double t) const {
  double sum = 0;
  int n = 0;
  for (const Scale& s : m_scales)
    if (s.temperature) sum += s.temperature->body_c(t), ++n;
  if (n == 0) return std::nullopt;
  return sum / n;
}

Vec3 PartThermalTerm::displacement(const MachinePose& pose, double t) const {
  if (!m_temperature) return Vec3::Zero();
  return -m_alpha * (m_temperature->body_c(t) - 20.0) * (pose.nominal_tip_mm() - m_fixed);
}

}  // namespace metron::machine
