// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/active_scanning/scan_controller.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "active_scanning/scan_cycle.hpp"
#include "metron/machine/active_scanning/axis_servo.hpp"
#include "metron/machine/active_scanning/path_cursor.hpp"
#include "metron/machine/active_scanning/scanning_probe.hpp"
#include "metron/machine/rng.hpp"

namespace metron::machine {
namespace {

std::string xyz(const Vec3& p) { return fmt::format("({:.4f}, {:.4f}, {:.4f})", p.x(), p.y(), p.z()); }

enum class Phase { Approach, Scan, Retract, Done };  // Approach: the approach and the settling

}  // namespace

std::string validate_scan(const ScanPath& c) {
  if (c.path.segments.empty()) return "scan path has no segments";
  double length = 0;
  for (const auto& s : c.path.segments) {
    if (!s.k.allFinite() || !std::isfinite(s.d_mm) || s.d_mm < 0) return "scan path has a non-finite segment";
    length += s.d_mm;
  }
  if (!(length > 0)) return "scan path has zero length";
  if (!c.approach_normal.allFinite() || c.approach_normal.norm() < 1e-9) return "scan needs a non-zero approach normal";
  if (c.speed_mm_s && !(*c.speed_mm_s > 0)) return "scan speed must be positive";
  if (c.reference_deflection_mm && !(*c.reference_deflection_mm > 0))
    return "scan reference deflection must be positive";
  if (!(c.sample_spacing_mm >= 0) || !(c.approach_mm >= 0) || !(c.retract_mm >= 0))
    return "scan sample spacing, approach and retract must be >= 0";
  return {};
}

Vec3 scan_approach_point(const ScanPath& c) {
  return c.path.segments.front().start() + c.approach_mm * c.approach_normal.normalized();
}

Vec3 scan_correction_direction(const Vec3& eu, const Vec3& tangent) {
  const Vec3 q = eu.cross(tangent);
  const double qn = q.norm();
  return qn > 1e-9 ? Vec3(q / qn) : Vec3::Zero();
}

ScanTerms scan_law_terms(ScanLaw law, const ScanControlSpec& ctl, double e0_mm, double e_mm, const Vec3& eu,
                         const Vec3& foot_mm, const Vec3& head_mm, const Vec3& tangent, double vf_mm_s) {
  ScanTerms tm;
  tm.vf = vf_mm_s * tangent;
  // SEEDS.md 1: Ve = K*(|Ep| - E0)*eu (without contact |Ep| = 0: it searches toward the surface).
  tm.ve = ctl.deflection_gain_1_s * (e_mm - e0_mm) * eu;
  // SEEDS.md 1: Vc1 from the probe position Pp to the foot P of the perpendicular.
  tm.vc1 = ctl.trajectory_gain_1_s * (foot_mm - head_mm);
  switch (law) {
    case ScanLaw::Vc1: tm.vc = tm.vc1; break;
    // SEEDS.md 1: Vc1' = Vc1 - (Vc1 . eu) eu.
    case ScanLaw::Vc1Prime: tm.vc = tm.vc1 - tm.vc1.dot(eu) * eu; break;
    case ScanLaw::Vc2: {
      // SEEDS.md 1: q = (eu x Vf)/|eu x Vf|, Vc2 = (Vc1 . q) q (Vf's direction is the tangent).
      const Vec3 q = scan_correction_direction(eu, tangent);
      tm.vc = tm.vc1.dot(q) * q;
      break;
    }
  }
  // SEEDS.md 1: "Gf, Ge, Gc ... each adjusted by a function of the current deviations"
  // (docs/scanning.md, "The control law"). With dE = |Ep| - E0 and d = |P - Pp| in units of their
  // tolerances:
  // - Gf drops while either deviates, so the corrections can catch up;
  // - Ge rises from 1 toward 1.2 as the deflection falls below E0 (contact weakening: the probe
  //   is pulled back to the surface faster before it lifts off); above E0 it stays 1, because a
  //   higher gain there adds to the normal loop exactly where Vc1's term already does and makes
  //   it ring (the bench's gain sweep);
  // - Gc rises from 1 toward 1.5 with d: a large trajectory deviation is closed faster, while near
  //   the path (where noise and roughness live) it stays at Kc.
  // (Larger boosts of Ge overshoot on tight curves at speed: Scanning.SpeedLimitsAreHonouredAndLogged.)
  const double de = ctl.deflection_tolerance_mm > 0 ? (e_mm - e0_mm) / ctl.deflection_tolerance_mm : 0;
  const double dp = ctl.trajectory_tolerance_mm > 0 ? (foot_mm - head_mm).norm() / ctl.trajectory_tolerance_mm : 0;
  tm.gf = 1 / ((1 + de * de) * (1 + dp * dp));
  tm.ge = de < 0 ? 1 + 0.2 * de * de / (1 + de * de) : 1.0;
  tm.gc = 1 + 0.5 * dp * dp / (1 + dp * dp);
  return tm;
}

ScanOutcome run_scan(const ScanPath& command, const ScanSetup& setup, const Vec3& start_mm, double start_time_s,
                     const std::function<void(const ScanCycle&)>& on_cycle) {
  ScanOutcome out;
  const double dt = setup.machine.dt_s;
  const ScanControlSpec& ctl = setup.machine.scanning.control;
  const double e0 = command.reference_deflection_mm.value_or(setup.machine.scanning.probe.reference_deflection_mm);
  const double range = setup.machine.scanning.probe.measuring_range_mm;
  const Vec3 n_app = command.approach_normal.normalized();
  const auto fault_at = [&](FaultKind kind, std::string message, const Vec3& p, double t) {
    out.fault = Fault{kind, std::move(message), p, t};
  };
  if (const std::string bad = validate_scan(command); !bad.empty()) {
    fault_at(FaultKind::BadCommand, bad, start_mm, start_time_s);
    out.end_position_mm = start_mm;
    out.end_time_s = start_time_s;
    return out;
  }
  if (!(e0 < range)) {
    fault_at(
        FaultKind::BadCommand,
        fmt::format("reference deflection {:.3f} mm is not below the probe's measuring range {:.3f} mm", e0, range),
        start_mm, start_time_s);
    out.end_position_mm = start_mm;
    out.end_time_s = start_time_s;
    return out;
  }

  Rng rng(setup.seed);
  ScanningProbe probe(*setup.solid, setup.true_ball_radius_mm, setup.truth.probe,
                      setup.machine.scanning.probe.reference_deflection_mm, rng);
  AxisServo servo(setup.truth.servo, start_mm);
  PathCursor cursor(command.path);

  SpeedPlanLimits limits;
  limits.feed_mm_s = command.speed_mm_s.value_or(ctl.feed_mm_s);
  limits.machine_speed_mm_s = setup.machine.max_speed_mm_s;
  limits.acceleration_mm_s2 = 0.5 * setup.machine.max_acceleration_mm_s2;  // headroom for the corrections
  limits.centripetal_mm_s2 = ctl.max_centripetal_mm_s2;
  // wp = sqrt(k/m): N/mm over g gives (1/s^2) * 1e6. From the probe's data sheet: the controller
  // plans with the published stiffness and mass, not the true ones.
  const DataSheet& sheet = setup.machine.data_sheet;
  limits.probe_natural_frequency_rad_s = 1000 * std::sqrt(sheet.scanning_stiffness_n_mm / sheet.scanning_stylus_mass_g);
  limits.reference_deflection_mm = e0;
  limits.end_speed_mm_s = std::min(0.5, limits.feed_mm_s);
  const SpeedPlan plan(command.path, limits);
  const double length = cursor.length_mm();
  out.stats.path_length_mm = length;

  const double v_max = setup.machine.max_speed_mm_s, a_max = setup.machine.max_acceleration_mm_s2;
  Phase phase = Phase::Approach;
  Vec3 v_prev = Vec3::Zero();
  Vec3 eu_last = n_app;
  double next_sample_s = 0, best_s = -1, progress_t = 0, retract_t = 0;
  double lost_at_s = -1, lost_at_t = 0, retract_deflection_mm = 0;
  detail::ApproachAndSettle approach(ctl, e0, range, start_mm, n_app, command.approach_mm);
  constexpr double speed_tau_s = 0.02;
  double vf_smooth[2] = {0, 0};
  double sum_sq = 0, lateral_sq = 0;
  std::int64_t k = 0;
  constexpr std::int64_t max_cycles = 100'000'000;

  for (; phase != Phase::Done && k < max_cycles; ++k) {
    const double t = start_time_s + static_cast<double>(k) * dt;
    const Vec3 head = servo.position_mm();
    const detail::ProbeReading reading = detail::read_probe(probe, head, range, t, out.stats);
    if (reading.over_range) {
      out.fault = reading.over_range;
      break;
    }
    const Vec3 ep = reading.ep;
    const double e = reading.e;
    const bool contact = reading.contact;
    if (contact) eu_last = ep / e;

    ScanCycle rec;
    rec.time_s = t;
    rec.head_mm = head;
    rec.velocity_mm_s = servo.velocity_mm_s();
    rec.deflection_mm = ep;
    Vec3 v = Vec3::Zero();

    if (phase == Phase::Approach) {
      const auto step = approach.step(t, head, reading);
      if (step.no_contact) {
        fault_at(FaultKind::NoContact,
                 fmt::format("no contact within {:.3f} mm of the scan start {}", range,
                             xyz(command.path.segments.front().start())),
                 head, t);
        break;
      }
      v = step.v;
      if (step.settled) {
        phase = Phase::Scan;
        progress_t = t;
      }
    }
    if (phase == Phase::Scan) {
      cursor.project(head);
      const double s = cursor.arc_mm();
      const Vec3 foot = cursor.foot_mm();
      const Vec3 tangent = cursor.tangent();
      const Vec3 eu = contact ? Vec3(ep / e) : cursor.nominal_normal(n_app);
      // SEEDS.md 1: Vf along the path, its magnitude from curvature and the other limits. The
      // plan's speed, looked up ahead by the smoothing's lag, passes two first-order stages so
      // the drives see no step in Vf (a step would make the servo overshoot the limit).
      const double ahead = 3 * speed_tau_s * vf_smooth[1];
      const double target = std::min({plan.speed_at(s), plan.speed_at(s + ahead / 2), plan.speed_at(s + ahead)});
      vf_smooth[0] += (target - vf_smooth[0]) * dt / speed_tau_s;
      vf_smooth[1] += (std::min(vf_smooth[0], target) - vf_smooth[1]) * dt / speed_tau_s;
      rec.terms = scan_law_terms(command.law, ctl, e0, e, eu, foot, head, tangent, vf_smooth[1]);
      const ScanTerms& tm = rec.terms;
      v = tm.gf * tm.vf + tm.ge * tm.ve + tm.gc * tm.vc;

      rec.scanning = true;
      rec.path_s_mm = s;
      rec.path_distance_mm = (foot - head).norm();
      rec.foot_mm = foot;
      rec.tangent = tangent;
      rec.lateral_error_mm = (foot - head).dot(scan_correction_direction(eu, tangent));
      rec.speed_limit_mm_s = plan.limit_at(s);
      rec.tangential_speed_mm_s = servo.velocity_mm_s().dot(tangent);
      ScanStats& st = out.stats;
      ++st.scan_cycles;
      sum_sq += (e - e0) * (e - e0);
      st.peak_deflection_error_mm = std::max(st.peak_deflection_error_mm, std::abs(e - e0));
      st.max_path_distance_mm = std::max(st.max_path_distance_mm, rec.path_distance_mm);
      st.max_lateral_error_mm = std::max(st.max_lateral_error_mm, std::abs(rec.lateral_error_mm));
      lateral_sq += rec.lateral_error_mm * rec.lateral_error_mm;
      st.max_speed_ratio = std::max(st.max_speed_ratio, rec.tangential_speed_mm_s / rec.speed_limit_mm_s);
      st.reached_mm = std::max(st.reached_mm, s);
      if (!contact) ++st.free_cycles;

      if (contact && s >= next_sample_s) {
        out.samples.push_back({t, head + ep, ep, s});
        next_sample_s = command.sample_spacing_mm > 0 ? s + command.sample_spacing_mm : s;
      }
      if (s > best_s + 0.01) best_s = s, progress_t = t;
      if (contact) {
        lost_at_s = -1;
      } else if (lost_at_s < 0) {
        lost_at_s = s, lost_at_t = t;
      } else if (s - lost_at_s > ctl.lost_contact_mm || t - lost_at_t > ctl.stall_time_s) {
        fault_at(FaultKind::NoContact,
                 fmt::format("scan lost contact with the surface at {:.3f} mm along the path", lost_at_s), head, t);
        break;
      }
      if (t - progress_t > ctl.stall_time_s) {
        fault_at(FaultKind::Stalled,
                 fmt::format("scan stalled at {:.3f} of {:.3f} mm along the path: no progress for {:.2f} s", best_s,
                             length, ctl.stall_time_s),
                 head, t);
        break;
      }
      if (s >= length - 1e-3) {
        phase = Phase::Retract;
        retract_t = t;
        retract_deflection_mm = e;
        out.completed = true;
      }
    }
    if (phase == Phase::Retract && !rec.scanning) {
      const auto back = detail::retract_velocity(ctl, t - retract_t, command.retract_mm, retract_deflection_mm, eu_last,
                                                 servo.velocity_mm_s());
      if (back)
        v = *back;
      else
        phase = Phase::Done;
    }

    v = detail::within_machine_limits(v, v_prev, v_max, a_max, dt);
    v_prev = v;
    if (on_cycle) on_cycle(rec);
    servo.step(v, dt);
  }
  out.stats.cycles = k;
  out.stats.rms_deflection_error_mm =
      out.stats.scan_cycles > 0 ? std::sqrt(sum_sq / static_cast<double>(out.stats.scan_cycles)) : 0;
  out.stats.rms_lateral_error_mm =
      out.stats.scan_cycles > 0 ? std::sqrt(lateral_sq / static_cast<double>(out.stats.scan_cycles)) : 0;
  out.end_position_mm = servo.position_mm();
  out.end_time_s = start_time_s + static_cast<double>(k) * dt;
  out.log = plan.log();
  out.log.push_back(
      fmt::format("measured speed: at most {:.3f} of the limit; |Ep| - E0: rms {:.4f} mm, peak {:.4f} mm; "
                  "largest distance from the path {:.4f} mm, across it (along q) rms {:.4f} mm, peak {:.4f} mm",
                  out.stats.max_speed_ratio, out.stats.rms_deflection_error_mm, out.stats.peak_deflection_error_mm,
                  out.stats.max_path_distance_mm, out.stats.rms_lateral_error_mm, out.stats.max_lateral_error_mm));
  return out;
}

}  // namespace metron::machine
