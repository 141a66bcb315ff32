// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/segmented_scanning/probe_scan_driver.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "metron/machine/active_scanning/axis_servo.hpp"
#include "metron/machine/active_scanning/path_cursor.hpp"
#include "metron/machine/active_scanning/scanning_probe.hpp"
#include "metron/machine/rng.hpp"
#include "metron/machine/segmented_scanning/speed_plan.hpp"

namespace metron::machine::segmented {

ProbeScanDriver::ProbeScanDriver(const ScanPath& scan, const ScanSetup& setup, const Vec3& start_mm,
                                 double start_time_s, ProbeDriveSpec drive)
    : m_scan(scan), m_setup(setup), m_drive(drive), m_t_s(start_time_s) {
  m_e0_mm = scan.reference_deflection_mm.value_or(setup.machine.scanning.probe.reference_deflection_mm);
  m_eu_last = scan.approach_normal.normalized();
  m_rng = std::make_unique<Rng>(setup.seed);
  m_probe = std::make_unique<ScanningProbe>(*setup.solid, setup.true_ball_radius_mm, setup.truth.probe,
                                            setup.machine.scanning.probe.reference_deflection_mm, *m_rng);
  m_servo = std::make_unique<AxisServo>(setup.truth.servo, start_mm);
  const std::vector<geometry::PccSegment> segments = std::move(m_scan.path.segments);
  const std::vector<Vec3> normals = std::move(m_scan.path.normals);
  m_scan.path.segments.clear();
  m_scan.path.normals.clear();
  m_cursor = std::make_unique<PathCursor>(m_scan.path);
  extend(segments, normals);
}

ProbeScanDriver::~ProbeScanDriver() = default;

const Vec3& ProbeScanDriver::position_mm() const { return m_servo->position_mm(); }
const Vec3& ProbeScanDriver::velocity_mm_s() const { return m_servo->velocity_mm_s(); }

void ProbeScanDriver::extend(std::span<const geometry::PccSegment> segments, std::span<const Vec3> normals) {
  auto& path = m_scan.path;
  // Normals at the segment ends: a command's first normal is the previous command's last.
  const bool with_normals = normals.size() == segments.size() + 1 &&
                            path.normals.size() == path.segments.size() + (path.segments.empty() ? 0 : 1);
  if (with_normals)
    path.normals.insert(path.normals.end(), normals.begin() + (path.segments.empty() ? 0 : 1), normals.end());
  else
    path.normals.clear();
  for (const auto& g : segments) {
    path.segments.push_back(g);
    m_cumulative.push_back(m_cumulative.back() + g.length());
  }
  m_cursor->extend();
}

Vec3 ProbeScanDriver::point_at(double s_mm, Vec3* normal) const {
  const auto& path = m_scan.path;
  const auto it = std::upper_bound(m_cumulative.begin(), m_cumulative.end(), s_mm);
  std::size_t k = it == m_cumulative.begin() ? 0 : static_cast<std::size_t>(it - m_cumulative.begin()) - 1;
  k = std::min(k, path.segments.size() - 1);
  const auto& g = path.segments[k];
  const double len = m_cumulative[k + 1] - m_cumulative[k];
  const double u = parameter_at_arc(g, std::clamp(s_mm - m_cumulative[k], 0.0, len), len);
  if (normal != nullptr) {
    *normal = m_eu_last;  // no nominal normals: the last contact direction
    if (path.normals.size() == path.segments.size() + 1) {
      const double w = g.d_mm > 0 ? u / g.d_mm : 0;
      const Vec3 n = (1 - w) * path.normals[k] + w * path.normals[k + 1];
      if (n.norm() > 1e-12) *normal = n.normalized();
    }
  }
  return g.point(u);
}

void ProbeScanDriver::sense() {
  const Vec3 head = m_servo->position_mm();
  const Vec3 true_ep = m_probe->deflection(head);
  m_max_force_n = std::max(m_max_force_n, m_probe->force_n(true_ep));
  const double range = m_setup.machine.scanning.probe.measuring_range_mm;
  if (true_ep.norm() > range && !m_fault)
    m_fault = Fault{FaultKind::OverTravel,
                    fmt::format("scanning probe over-range: deflection {:.3f} mm exceeds the measuring range {:.3f} mm",
                                true_ep.norm(), range),
                    head, m_t_s};
  m_ep = m_probe->read(true_ep);
  m_e = m_ep.norm();
  m_contact = m_e > 1e-6;
  if (m_contact) m_eu_last = m_ep / m_e;
}

Vec3 ProbeScanDriver::scan_law(double plan_s_mm, double plan_v_mm_s, std::size_t command, double min_vf_mm_s,
                               double max_vf_mm_s) {
  const ScanControlSpec& ctl = m_setup.machine.scanning.control;
  const Vec3 head = m_servo->position_mm();
  m_cursor->project(head);
  m_s_mm = m_cursor->arc_mm();
  const Vec3 foot = m_cursor->foot_mm();
  const Vec3 tangent = m_cursor->tangent();
  const Vec3 eu = m_contact ? Vec3(m_ep / m_e) : m_cursor->nominal_normal(m_eu_last);
  // SEEDS.md 2 drives SEEDS.md 1: |Vf| is the segmented plan's speed, plus a position term so the
  // foot keeps up with the planned arc length (never backwards: the samples stay ordered). The
  // catch-up may not push the probe's own path speed Gf*|Vf| above `max_vf_mm_s`.
  ScanTerms tm = scan_law_terms(m_scan.law, ctl, m_e0_mm, m_e, eu, foot, head, tangent, 0.0);
  double vf = plan_v_mm_s + m_drive.position_gain_1_s * (plan_s_mm - m_s_mm);
  if (vf > plan_v_mm_s) vf = std::max(plan_v_mm_s, std::min(vf, max_vf_mm_s / tm.gf));
  vf = std::max({0.0, min_vf_mm_s, vf});
  tm.vf = vf * tangent;
  if (m_contact && m_s_mm >= m_next_sample_s) {
    m_samples.push_back({m_t_s, head + m_ep, m_ep, m_s_mm});
    m_sample_commands.push_back(command);
    m_next_sample_s = m_scan.sample_spacing_mm > 0 ? m_s_mm + m_scan.sample_spacing_mm : std::nextafter(m_s_mm, 1e300);
  }
  if (plan_s_mm - m_s_mm > ctl.lost_contact_mm && !m_fault)
    m_fault = Fault{FaultKind::Stalled,
                    fmt::format("scan stalled at {:.3f} mm along the path: the probe trails the plan by {:.3f} mm",
                                m_s_mm, plan_s_mm - m_s_mm),
                    head, m_t_s};
  if (m_contact) {
    m_lost_at_s = -1;
  } else if (m_lost_at_s < 0) {
    m_lost_at_s = m_s_mm, m_lost_at_t = m_t_s;
  } else if ((m_s_mm - m_lost_at_s > ctl.lost_contact_mm || m_t_s - m_lost_at_t > ctl.stall_time_s) && !m_fault) {
    m_fault =
        Fault{FaultKind::NoContact,
              fmt::format("scan lost contact with the surface at {:.3f} mm along the path", m_lost_at_s), head, m_t_s};
  }
  return tm.gf * tm.vf + tm.ge * tm.ve + tm.gc * tm.vc;
}

bool ProbeScanDriver::move_toward(const Vec3& target_mm, Vec3& v) {
  // A free positioning move: speed from the distance left (a braking profile) within the limits.
  const Vec3 d = target_mm - m_servo->position_mm();
  const double dist = d.norm();
  if (dist < 1e-3 && m_servo->velocity_mm_s().norm() < 1e-2) {
    v = Vec3::Zero();
    return true;
  }
  const double speed = std::min({m_drive.positioning_speed_mm_s,
                                 0.7 * std::sqrt(2 * m_drive.positioning_acceleration_mm_s2 * dist), 10.0 * dist});
  v = dist > 0 ? Vec3(d / dist * speed) : Vec3::Zero();
  return false;
}

void ProbeScanDriver::apply(Vec3 v, bool scanning, double plan_s_mm) {
  const double dt = m_setup.machine.dt_s;
  // The machine's limits on the command, as in run_scan: path speed and acceleration.
  const double v_max = m_setup.machine.max_speed_mm_s, a_max = m_setup.machine.max_acceleration_mm_s2;
  if (const double n = v.norm(); n > v_max) v *= v_max / n;
  const Vec3 dv = v - m_v_prev;
  if (const double n = dv.norm(); n > a_max * dt) v = m_v_prev + dv * (a_max * dt / n);
  m_v_prev = v;
  m_cycles.push_back({m_t_s, scanning, m_contact, m_s_mm, plan_s_mm, m_contact ? m_e - m_e0_mm : -m_e0_mm});
  m_servo->step(v, dt);
  m_t_s += dt;
}

void ProbeScanDriver::record(const ScanCycle& c) {
  sense();
  m_command = c.command_index;
  if (m_fault) return apply(Vec3::Zero(), false, c.state.s_mm);
  const Vec3 v = scan_law(c.state.s_mm, c.state.v_mm_s, c.command_index, 0.0, c.limit_mm_s);
  apply(v, true, c.state.s_mm);
}

bool ProbeScanDriver::off_path(OffPathMove move, double s_mm, double /*t_s*/) {
  sense();
  if (m_fault) {
    apply(Vec3::Zero(), false, s_mm);
    return true;  // the owner sees the fault and stops
  }
  const ScanControlSpec& ctl = m_setup.machine.scanning.control;
  Vec3 v = Vec3::Zero();
  bool done = false;
  bool scanning = false;
  switch (move) {
    case OffPathMove::Hold:
      // In contact (waiting on the path): hold E0 with Ve alone; free: stand still.
      if (m_contact) v = ctl.deflection_gain_1_s * (m_e - m_e0_mm) * m_eu_last;
      m_sub = Sub::Idle;
      break;
    case OffPathMove::Retract:
      if (m_sub != Sub::Finish && m_sub != Sub::Leave) m_sub = m_contact ? Sub::Finish : Sub::Leave;
      if (m_sub == Sub::Finish) {
        // The plan rests at the stop; the probe's foot may trail it: scan on up to the stop so no
        // stretch of the path is left without samples.
        if (m_s_mm < s_mm - 1e-3 && m_contact) {
          v = scan_law(s_mm, 0.0, m_command, m_drive.finish_creep_mm_s, ctl.feed_mm_s);
          scanning = true;
        } else {
          m_sub = Sub::Leave;
          ++m_retracts;
          m_target = m_servo->position_mm() + (m_drive.retract_mm + m_e) * m_eu_last;
        }
      }
      if (m_sub == Sub::Leave) {
        if (!scanning && m_target.isZero()) {
          m_target = m_servo->position_mm() + m_drive.retract_mm * m_eu_last;
          ++m_retracts;
        }
        if (!scanning && move_toward(m_target, v)) {
          done = true;
          m_sub = Sub::Idle;
          m_target = Vec3::Zero();
        }
      }
      break;
    case OffPathMove::Approach: {
      if (m_sub != Sub::Move && m_sub != Sub::Search && m_sub != Sub::Settle) {
        // SEEDS.md 2 step 5: approach again at the start of the next command.
        const Vec3 p = point_at(s_mm, &m_normal);
        if (m_approaches == 0 && m_scan.path.normals.empty()) m_normal = m_scan.approach_normal.normalized();
        m_target = p + m_drive.search_from_mm * m_normal;
        m_sub = Sub::Move;
        ++m_approaches;
      }
      if (m_sub == Sub::Move) {
        if (m_contact) {
          m_sub = Sub::Settle;
          m_sub_start_s = m_t_s;
          m_settled_cycles = 0;
        } else if (move_toward(m_target, v)) {
          m_sub = Sub::Search;
          m_sub_start_s = m_t_s;
        }
      }
      if (m_sub == Sub::Search) {
        if (m_contact) {
          m_sub = Sub::Settle;
          m_sub_start_s = m_t_s;
          m_settled_cycles = 0;
        } else if ((m_target - m_servo->position_mm()).norm() >
                   m_drive.search_from_mm + m_setup.machine.scanning.probe.measuring_range_mm) {
          m_fault = Fault{FaultKind::NoContact,
                          fmt::format("no contact within {:.3f} mm of the path at {:.3f} mm",
                                      m_setup.machine.scanning.probe.measuring_range_mm, s_mm),
                          m_servo->position_mm(), m_t_s};
        } else {
          v = -ctl.approach_feed_mm_s * m_normal;
        }
      }
      if (m_sub == Sub::Settle) {
        // As run_scan's settling: Ve alone until the deflection holds E0.
        const Vec3 eu = m_contact ? Vec3(m_ep / m_e) : m_normal;
        v = ctl.deflection_gain_1_s * (m_e - m_e0_mm) * eu;
        m_settled_cycles = std::abs(m_e - m_e0_mm) < 0.005 ? m_settled_cycles + 1 : 0;
        if (m_settled_cycles >= 10 || m_t_s - m_sub_start_s > 1.0) {
          done = true;
          m_sub = Sub::Idle;
          m_target = Vec3::Zero();
          m_lost_at_s = -1;
        }
      }
      break;
    }
  }
  apply(v, scanning, s_mm);
  return done;
}

bool ProbeScanDriver::finish(double end_s_mm, double max_time_s) {
  const double until = m_t_s + max_time_s;
  while (m_t_s < until) {
    if (off_path(OffPathMove::Retract, end_s_mm, m_t_s)) return !m_fault;
  }
  return false;
}

}  // namespace metron::machine::segmented
