// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/active_scanning/contour_scan.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "active_scanning/scan_cycle.hpp"
#include "metron/machine/active_scanning/axis_servo.hpp"
#include "metron/machine/active_scanning/scanning_probe.hpp"
#include "metron/machine/rng.hpp"

namespace metron::machine {
namespace {

enum class Phase { Approach, Scan, Retract, Done };  // Approach: the approach and the settling

bool unit_like(const Vec3& v) { return v.allFinite() && v.norm() > 1e-9; }

/// The signed distance g of p from the section (a plane, or the cylinder of `radius_mm` about an
/// axis) and its gradient.
struct SectionValue {
  double g = 0;
  Vec3 grad = Vec3::UnitZ();
};
SectionValue section_at(const ContourSection& s, double radius_mm, const Vec3& p) {
  const Vec3 a = s.direction.normalized();
  if (s.kind == ContourSection::Kind::Plane) return {(p - s.point_mm).dot(a), a};
  const Vec3 d = p - s.point_mm;
  const Vec3 radial = d - d.dot(a) * a;
  const double rho = radial.norm();
  return {rho - radius_mm, rho > 1e-12 ? Vec3(radial / rho) : Vec3(Vec3::Zero())};
}

/// The end's signed function at p: negative inside the sphere or the cylinder, and on the
/// plane's back side.
double end_value(const ContourEnd& e, const Vec3& p) {
  switch (e.kind) {
    case ContourEnd::Kind::Sphere: return (p - e.point_mm).norm() - e.diameter_mm / 2;
    case ContourEnd::Kind::Plane: return (p - e.point_mm).dot(e.direction.normalized());
    case ContourEnd::Kind::Cylinder: {
      const Vec3 a = e.direction.normalized();
      const Vec3 d = p - e.point_mm;
      return (d - d.dot(a) * a).norm() - e.diameter_mm / 2;
    }
  }
  return 1;
}

/// Watches the ball centre for the end condition. A sphere ends the scan when the centre enters
/// it, once it has been outside (a closed contour starts inside its end sphere); a plane or a
/// cylinder when the centre has crossed it `crossings` times. A side counts only beyond a dead
/// band, so the probe's noise on the boundary is not a crossing.
class EndWatch {
 public:
  explicit EndWatch(const ContourEnd& end) : m_end(end) {}
  bool reached(const Vec3& centre_mm) {
    const double v = end_value(m_end, centre_mm);
    const int side = v > k_band_mm ? 1 : v < -k_band_mm ? -1 : 0;
    if (m_end.kind == ContourEnd::Kind::Sphere) {
      if (side > 0) m_armed = true;
      return m_armed && v < 0;
    }
    if (side == 0) return false;
    if (m_side != 0 && side != m_side) ++m_crossed;
    m_side = side;
    return m_crossed >= std::max(1, m_end.crossings);
  }

 private:
  static constexpr double k_band_mm = 0.001;
  ContourEnd m_end;
  bool m_armed = false;
  int m_side = 0;
  int m_crossed = 0;
};

/// The first axis whose travel p is outside, or -1.
int outside_travel(const MachineConfig& machine, const Vec3& p) {
  for (int i = 0; i < 3; ++i) {
    const AxisTravel& t = machine.travel[static_cast<std::size_t>(i)];
    if (p[i] < t.min_mm || p[i] > t.max_mm) return i;
  }
  return -1;
}

}  // namespace

std::string validate_contour_scan(const ContourScan& c) {
  if (!c.start_mm.allFinite()) return "contour scan needs a finite start";
  if (!unit_like(c.start_normal)) return "contour scan needs a non-zero start normal";
  if (!unit_like(c.direction)) return "contour scan needs a non-zero direction";
  if (!c.section.point_mm.allFinite() || !unit_like(c.section.direction))
    return "contour scan needs a section with a non-zero direction";
  if (!c.end.point_mm.allFinite() || (c.end.kind != ContourEnd::Kind::Sphere && !unit_like(c.end.direction)))
    return "contour scan needs an end with a non-zero direction";
  if (c.end.kind != ContourEnd::Kind::Plane && !(c.end.diameter_mm > 0))
    return "contour scan's end sphere or cylinder needs a positive diameter";
  if (c.end.kind != ContourEnd::Kind::Sphere && c.end.crossings < 1)
    return "contour scan's end needs at least one crossing";
  if (c.section.kind == ContourSection::Kind::Cylinder) {
    if (section_at(c.section, 0, c.start_mm).g < 1e-6)
      return "contour scan's start lies on the section cylinder's axis";
  }
  const Vec3 grad = section_at(c.section, section_at(c.section, 0, c.start_mm).g, c.start_mm).grad;
  if (grad.cross(c.start_normal.normalized()).norm() < 1e-6)
    return "contour scan's section is parallel to the surface at the start";
  if (c.speed_mm_s && !(*c.speed_mm_s > 0)) return "scan speed must be positive";
  if (c.reference_deflection_mm && !(*c.reference_deflection_mm > 0))
    return "scan reference deflection must be positive";
  if (!(c.sample_spacing_mm >= 0) || !(c.approach_mm >= 0) || !(c.retract_mm >= 0) || !(c.max_length_mm > 0))
    return "scan sample spacing, approach and retract must be >= 0, its length limit > 0";
  return {};
}

Vec3 contour_approach_point(const ContourScan& c) { return c.start_mm + c.approach_mm * c.start_normal.normalized(); }

ScanOutcome run_contour_scan(const ContourScan& command, const ScanSetup& setup, const Vec3& start_mm,
                             double start_time_s, const std::function<void(const ScanCycle&)>& on_cycle) {
  ScanOutcome out;
  const double dt = setup.machine.dt_s;
  const ScanControlSpec& ctl = setup.machine.scanning.control;
  const double e0 = command.reference_deflection_mm.value_or(setup.machine.scanning.probe.reference_deflection_mm);
  const double range = setup.machine.scanning.probe.measuring_range_mm;
  const auto stop = [&](FaultKind kind, std::string message, const Vec3& p, double t) {
    out.fault = Fault{kind, std::move(message), p, t};
    out.end_position_mm = p;
    out.end_time_s = t;
  };
  if (const std::string bad = validate_contour_scan(command); !bad.empty()) {
    stop(FaultKind::BadCommand, bad, start_mm, start_time_s);
    return out;
  }
  if (!(e0 < range)) {
    stop(FaultKind::BadCommand,
         fmt::format("reference deflection {:.3f} mm is not below the probe's measuring range {:.3f} mm", e0, range),
         start_mm, start_time_s);
    return out;
  }
  const Vec3 n_start = command.start_normal.normalized();
  // The section cylinder passes through the start's ball centre.
  const double section_radius_mm = section_at(command.section, 0, command.start_mm).g;

  Rng rng(setup.seed);
  ScanningProbe probe(*setup.solid, setup.true_ball_radius_mm, setup.truth.probe,
                      setup.machine.scanning.probe.reference_deflection_mm, rng);
  AxisServo servo(setup.truth.servo, start_mm);
  EndWatch end(command.end);

  const double feed = std::min(command.speed_mm_s.value_or(ctl.feed_mm_s), setup.machine.max_speed_mm_s);
  const double v_max = setup.machine.max_speed_mm_s, a_max = setup.machine.max_acceleration_mm_s2;
  constexpr double speed_tau_s = 0.02;
  Phase phase = Phase::Approach;
  Vec3 v_prev = Vec3::Zero();
  Vec3 eu_last = n_start;
  Vec3 t_prev = (command.direction - command.direction.dot(n_start) * n_start).normalized();
  Vec3 head_prev = start_mm;
  double travelled = 0, next_sample_mm = 0, best_mm = 0, progress_t = 0, retract_t = 0;
  double lost_at_mm = -1, lost_at_t = 0, retract_deflection_mm = 0, kappa = 0, vf_smooth = 0;
  const double kappa_hint = command.min_radius_mm && *command.min_radius_mm > 0 ? 1 / *command.min_radius_mm : 0;
  detail::ApproachAndSettle approach(ctl, e0, range, start_mm, n_start, command.approach_mm);
  int rounds = 0;
  bool away_from_start = false;
  double sum_sq = 0, lateral_sq = 0;
  std::int64_t k = 0;
  constexpr std::int64_t max_cycles = 100'000'000;

  for (; phase != Phase::Done && k < max_cycles; ++k) {
    const double t = start_time_s + static_cast<double>(k) * dt;
    const Vec3 head = servo.position_mm();
    const detail::ProbeReading reading = detail::read_probe(probe, head, range, t, out.stats);
    if (reading.over_range) {
      stop(reading.over_range->kind, reading.over_range->message, head, t);
      break;
    }
    // Nothing bounds an unknown contour but its end: the controller's soft limits stop it at the
    // machine's travel, as they stop any motion.
    if (const int axis = outside_travel(setup.machine, head); axis >= 0) {
      const AxisTravel& tr = setup.machine.travel[static_cast<std::size_t>(axis)];
      stop(FaultKind::AxisLimit,
           fmt::format("contour scan reached the end of the {} travel [{}, {}] at {}", "xyz"[axis], tr.min_mm,
                       tr.max_mm, detail::scan_xyz(head)),
           head, t);
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
        stop(FaultKind::NoContact,
             fmt::format("no contact within {:.3f} mm of the contour scan's start {}", range,
                         detail::scan_xyz(command.start_mm)),
             head, t);
        break;
      }
      v = step.v;
      if (step.settled) {
        phase = Phase::Scan;
        progress_t = t;
        head_prev = head;
      }
    }
    if (phase == Phase::Scan) {
      const Vec3 centre = head + ep;
      const auto [g, grad] = section_at(command.section, section_radius_mm, centre);
      const Vec3 n = contact ? Vec3(ep / e) : eu_last;
      // Along the contour: across the section's normal and the felt surface normal, on the side
      // the scan has been going (at a crease the felt normal turns, and the direction with it).
      Vec3 tangent = grad.cross(n);
      tangent = tangent.norm() > 1e-9 ? Vec3(tangent.normalized()) : t_prev;
      if (tangent.dot(t_prev) < 0) tangent = -tangent;
      Vec3 eu = n - n.dot(grad) * grad;
      eu = eu.norm() > 1e-9 ? Vec3(eu.normalized()) : n;
      travelled += std::max(0.0, (head - head_prev).dot(tangent));
      // Curvature felt: the tangent's turn per mm of travel, held and let go over about a
      // millimetre, so the feed is already low when the next cycles round the same bend.
      const double ds = (head - head_prev).norm();
      if (ds > 1e-6) {
        const double turn = std::acos(std::clamp(tangent.dot(t_prev), -1.0, 1.0));
        kappa = std::max(turn / ds, kappa * std::exp(-ds));
      }
      const double bend = std::max(kappa, kappa_hint);
      const double limit = bend > 1e-9 ? std::min(feed, std::sqrt(ctl.max_centripetal_mm_s2 / bend)) : feed;
      vf_smooth += (limit - vf_smooth) * dt / speed_tau_s;
      // The nominal scan's law with the section in place of the path: the foot is the ball's
      // nearest point of the section (its Vc1 holds the ball in the section).
      const Vec3 foot = head - g * grad;
      rec.terms = scan_law_terms(ScanLaw::Vc1, ctl, e0, e, eu, foot, head, tangent, vf_smooth);
      const ScanTerms& tm = rec.terms;
      v = tm.gf * tm.vf + tm.ge * tm.ve + tm.gc * tm.vc;
      t_prev = tangent;
      head_prev = head;

      rec.scanning = true;
      rec.path_s_mm = travelled;
      rec.path_distance_mm = std::abs(g);
      rec.foot_mm = foot;
      rec.tangent = tangent;
      rec.lateral_error_mm = g;
      rec.speed_limit_mm_s = limit;
      rec.tangential_speed_mm_s = servo.velocity_mm_s().dot(tangent);
      ScanStats& st = out.stats;
      ++st.scan_cycles;
      sum_sq += (e - e0) * (e - e0);
      st.peak_deflection_error_mm = std::max(st.peak_deflection_error_mm, std::abs(e - e0));
      st.max_path_distance_mm = std::max(st.max_path_distance_mm, std::abs(g));
      st.max_lateral_error_mm = st.max_path_distance_mm;
      lateral_sq += g * g;
      st.max_speed_ratio = std::max(st.max_speed_ratio, rec.tangential_speed_mm_s / std::max(limit, 1e-9));
      st.reached_mm = travelled;
      if (!contact) ++st.free_cycles;

      if (contact && travelled >= next_sample_mm) {
        out.samples.push_back({t, centre, ep, travelled});
        next_sample_mm = command.sample_spacing_mm > 0 ? travelled + command.sample_spacing_mm : travelled;
      }
      if (travelled > best_mm + 0.01) best_mm = travelled, progress_t = t;
      if (contact) {
        lost_at_mm = -1;
      } else if (lost_at_mm < 0) {
        lost_at_mm = travelled, lost_at_t = t;
      } else if (travelled - lost_at_mm > ctl.lost_contact_mm || t - lost_at_t > ctl.stall_time_s) {
        stop(FaultKind::NoContact,
             fmt::format("contour scan lost contact with the surface after {:.3f} mm of travel", lost_at_mm), head, t);
        break;
      }
      if (t - progress_t > ctl.stall_time_s) {
        stop(FaultKind::Stalled,
             fmt::format("contour scan stalled after {:.3f} mm of travel: no progress for {:.2f} s", best_mm,
                         ctl.stall_time_s),
             head, t);
        break;
      }
      if (travelled > command.max_length_mm) {
        stop(FaultKind::Stalled,
             fmt::format("contour scan did not meet its end within {:.1f} mm of travel", command.max_length_mm), head,
             t);
        break;
      }
      // A closed contour that comes back round past its start again and again without meeting
      // its end never will: stopped after as many rounds as the end's crossings could need.
      if (const double from_start = (centre - command.start_mm).norm(); from_start > 2.0) {
        away_from_start = true;
      } else if (away_from_start && from_start < 0.5) {
        away_from_start = false;
        if (++rounds > std::max(2, command.end.crossings)) {
          stop(FaultKind::Stalled,
               fmt::format("contour scan went round a closed contour {} times without meeting its end", rounds - 1),
               head, t);
          break;
        }
      }
      if (contact && end.reached(centre)) {
        // The end's own point: the last sample is where the scan ended.
        if (out.samples.empty() || out.samples.back().time_s != t) out.samples.push_back({t, centre, ep, travelled});
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
  out.stats.path_length_mm = travelled;
  out.stats.rms_deflection_error_mm =
      out.stats.scan_cycles > 0 ? std::sqrt(sum_sq / static_cast<double>(out.stats.scan_cycles)) : 0;
  out.stats.rms_lateral_error_mm =
      out.stats.scan_cycles > 0 ? std::sqrt(lateral_sq / static_cast<double>(out.stats.scan_cycles)) : 0;
  if (!out.fault) {
    out.end_position_mm = servo.position_mm();
    out.end_time_s = start_time_s + static_cast<double>(k) * dt;
  }
  out.log.push_back(
      fmt::format("unknown contour: {:.3f} mm travelled, {} samples; |Ep| - E0: rms {:.4f} mm, peak {:.4f} mm; "
                  "ball centre off the section: rms {:.4f} mm, peak {:.4f} mm",
                  travelled, out.samples.size(), out.stats.rms_deflection_error_mm, out.stats.peak_deflection_error_mm,
                  out.stats.rms_lateral_error_mm, out.stats.max_lateral_error_mm));
  return out;
}

}  // namespace metron::machine
