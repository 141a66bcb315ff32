// SPDX-License-Identifier: GPL-3.0-or-later
#include "simulated_probe.hpp"

#include <algorithm>
#include <cmath>

#include "metron/machine/contact.hpp"
#include "metron/machine/machine_errors/machine_error_solid.hpp"
#include "metron/machine/touch_cycle/axis_dynamics.hpp"
#include "metron/machine/world_solid.hpp"

namespace metron::machine::detail {

namespace {

// What the probe touches: the world as the machine's scales see it (a perfect machine: the world).
std::unique_ptr<Solid> make_probed_solid(const WorldTruth& truth, const Vec3& stylus_offset_mm) {
  auto world = make_world_solid(truth);
  if (truth.errors.empty()) return world;
  auto seen = std::make_unique<MachineErrorSolid>(std::move(world), truth.errors);
  seen->set_probe_offset(stylus_offset_mm);
  return seen;
}

}  // namespace

SimulatedProbe::SimulatedProbe(WorldTruth truth, std::uint64_t seed)
    : m_truth(std::move(truth)), m_solid(make_probed_solid(m_truth, m_stylus_offset_mm)), m_rng(seed) {}

void SimulatedProbe::mount_stylus(double nominal_radius_mm, const Vec3& offset_mm) {
  m_ball_radius_mm = nominal_radius_mm + m_truth.probe.ball_radius_error_mm;
  m_free_radius_mm = -1;
  if (offset_mm != m_stylus_offset_mm) {
    m_stylus_offset_mm = offset_mm;
    for (auto* solid : {m_solid.get(), m_scan_solid.get()})
      if (auto* seen = dynamic_cast<MachineErrorSolid*>(solid)) seen->set_probe_offset(offset_mm);
  }
}

void SimulatedProbe::set_time(double time_s) {
  const double sampled = std::floor(time_s / kErrorTimeStep_s) * kErrorTimeStep_s;
  if (sampled == m_error_time_s) return;
  m_error_time_s = sampled;
  update_error_state();
}

// The errors changed: the solids see the new state, and the free space known so far is forgotten.
void SimulatedProbe::update_error_state() {
  if (m_truth.errors.empty()) return;
  for (auto* solid : {m_solid.get(), m_scan_solid.get()})
    if (auto* seen = dynamic_cast<MachineErrorSolid*>(solid)) seen->set_state(m_error_time_s, m_approach);
  m_free_radius_mm = -1;
}

std::optional<std::size_t> SimulatedProbe::operator_stop() {
  if (!m_truth.part || m_setups_done >= m_truth.part->setups.size()) return std::nullopt;
  m_truth.part->pose = m_truth.part->setups[m_setups_done++];
  m_solid = make_probed_solid(m_truth, m_stylus_offset_mm);
  m_scan_solid.reset();
  update_error_state();
  m_free_radius_mm = -1;
  return m_setups_done + 1;
}

std::optional<double> SimulatedProbe::sweep(const Vec3& a, const Vec3& b) {
  // An axis that moves sets its approach direction; one that stands keeps its last.
  std::array<int, 3> approach = m_approach;
  for (int i = 0; i < 3; ++i)
    if (b[i] != a[i]) approach[static_cast<std::size_t>(i)] = b[i] > a[i] ? 1 : -1;
  if (approach != m_approach) {
    m_approach = approach;
    update_error_state();
  }
  // A segment inside a ball of space known to be free cannot touch (the ball is convex); this
  // saves the distance queries of most cycles of a long move, without changing any result.
  if ((a - m_free_centre).norm() < m_free_radius_mm && (b - m_free_centre).norm() < m_free_radius_mm)
    return std::nullopt;
  const double gap = m_solid->signed_distance(a) - m_ball_radius_mm;
  if (gap > 0) {
    m_free_centre = a;
    m_free_radius_mm = 0.999 * gap / std::max(1.0, m_solid->lipschitz());
    if ((b - a).norm() < m_free_radius_mm) return std::nullopt;
  }
  return first_ball_contact(*m_solid, a, b, m_ball_radius_mm);
}

std::string SimulatedProbe::feature_at(const Vec3& p) const { return m_solid->feature_at(p); }

void SimulatedProbe::begin_probe(const MotionProfile* profile, const Vec3& a, const Vec3& u, double t0_s) {
  m_profile = profile;
  m_probe_t0_s = t0_s;
  m_probe_start = a;
  m_probe_dir = u;
  m_contact_s = inf;
  m_signal_s = inf;
}

std::optional<double> SimulatedProbe::probe_step(double t0, double t1) {
  if (m_contact_s == inf) {
    set_time(m_probe_t0_s + t0);
    const double s0 = m_profile->at(t0).position_mm, s1 = m_profile->at(t1).position_mm;
    const auto f = sweep(m_probe_start + s0 * m_probe_dir, m_probe_start + s1 * m_probe_dir);
    if (!f) return std::nullopt;
    m_contact_s = s0 + *f * (s1 - s0);
    // SEEDS.md 3: after contact the stylus bends until the sensing threshold (pre-travel, for
    // the direction in which the surface pushes: the negated true normal); the threshold's
    // scatter is the probe's repeatability. Then the interface filter and the transmission.
    const ProbeSpec& probe = m_truth.probe;
    const Vec3 n = m_solid->normal(m_probe_start + m_contact_s * m_probe_dir);
    const double noise = probe.repeatability_mm * m_rng.normal();
    const double trigger_s = m_contact_s + std::max(0.0, probe.pre_travel.at(-n) + noise);
    if (trigger_s <= m_profile->end_position_mm())
      m_signal_s = m_profile->time_at(trigger_s) + probe.filter_delay_s + probe.transmission_delay_s;
  }
  if (m_signal_s <= t1) return m_signal_s;
  return std::nullopt;
}

std::optional<double> SimulatedProbe::over_travel(double stop_s) const {
  if (m_contact_s == inf || stop_s - m_contact_s <= m_truth.probe.over_travel_mm) return std::nullopt;
  return stop_s - m_contact_s;
}

MotionLimits SimulatedProbe::motion_limits(const MachineConfig& config, const Vec3& u, double feed_mm_s,
                                           double acceleration_mm_s2, std::optional<double> cap_mm_s2) const {
  return path_limits(config, m_truth.axes, u, feed_mm_s, acceleration_mm_s2, cap_mm_s2);
}

std::optional<BrakingLimits> SimulatedProbe::motion_braking(const MachineConfig& config, const Vec3& u,
                                                            double feed_mm_s, std::optional<double> cap_mm_s2) const {
  return path_braking(config, m_truth.axes, u, feed_mm_s, cap_mm_s2);
}

ScanSetup SimulatedProbe::scan_setup(double nominal_radius_mm, const MachineConfig& config) {
  if (!m_scan_solid) {
    m_scan_solid = make_probed_solid(m_truth, m_stylus_offset_mm);
    update_error_state();
  }
  return ScanSetup{m_scan_solid.get(), nominal_radius_mm + m_truth.probe.ball_radius_error_mm, config, m_truth.scanning,
                   static_cast<std::uint64_t>(scan_phase() * 0x1.0p53)};
}

}  // namespace metron::machine::detail
