// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/error_space/two_point_rig.hpp"

namespace metron::machine {

TwoPointRig::TwoPointRig(const MachineErrorModel& errors, FlatPlate plate, TwoPointHead head, std::uint64_t seed,
                         double start_time_s)
    : m_errors(errors), m_plate(std::move(plate)), m_head(std::move(head)), m_rng(seed), m_time_s(start_time_s) {}

std::pair<double, double> TwoPointRig::read(const Vec3& axes, int step_axis, double travel_mm, bool turned,
                                            bool reversed) {
  const double d = m_head.spacing_mm;
  MachinePose pose;
  pose.axes_mm = axes;
  pose.approach = {1, 1, 1};
  Vec3 b_offset = m_head.sensor_offset_mm;
  b_offset[step_axis] += (reversed ? -1.0 : 1.0) * (d + m_head.spacing_error_mm);
  // Each tip moves with the machine's tool errors at its own offset (angular errors: Abbe).
  pose.probe_offset_mm = m_head.sensor_offset_mm;
  const Vec3 pa = pose.nominal_tip_mm() + m_errors.tool_displacement(pose, m_time_s);
  pose.probe_offset_mm = b_offset;
  const Vec3 pb = pose.nominal_tip_mm() + m_errors.tool_displacement(pose, m_time_s);
  const double theta = m_head.pitch_rad(travel_mm);
  auto reading = [&](const Vec3& p, double extra_gap, double zero) {
    const Vec2 uv = m_plate.plate_uv(p);
    const double gap = m_plate.height_mm(p) - m_plate.profile_mm(uv.x(), uv.y()) + extra_gap;
    double r = m_head.standoff_mm - gap;  // grows as the surface comes closer
    r += m_head.linearity_per_mm * r * r;
    return r + zero + m_head.noise_sd_mm * m_rng.normal();
  };
  const double lever = reversed ? -0.5 * theta * d : 0.5 * theta * d;
  // The angle instrument: the rotation that moved B's tip away from the plate relative to A's
  // (the tool displacements' difference along the normal, and the head's own pitch on its lever),
  // per unit of B's nominal lever.
  const int normal = m_plate.normal_axis();
  const double b_lever = reversed ? -d : d;
  const double rotated_mm =
      m_plate.normal_sign() * ((pb - pa)[normal] - (b_offset - m_head.sensor_offset_mm)[normal]) - 2 * lever;
  m_last_angle_rad = rotated_mm / b_lever;
  if (m_head.angle_instrument) m_last_angle_rad += m_head.angle_noise_sd_rad * m_rng.normal();
  const double a = reading(pa, +lever, m_head.zero_a_mm);
  const double b =
      reading(pb, -lever - m_head.delta_mm - (turned ? m_head.delta_change_turned_mm : 0.0), m_head.zero_b_mm);
  m_time_s += dwell_s;
  return {a, b};
}

error_space::LineReadings TwoPointRig::measure_line(const Vec3& start, int step_axis, int steps, bool turned,
                                                    bool reversed) {
  error_space::LineReadings out;
  for (int k = 0; k <= steps; ++k) {
    Vec3 q = start;
    q[step_axis] += k * m_head.spacing_mm;
    const auto [a, b] = read(q, step_axis, k * m_head.spacing_mm, turned, reversed);
    out.a_mm.push_back(a);
    out.b_mm.push_back(b);
    if (m_head.angle_instrument) out.angle_rad.push_back(m_last_angle_rad);
  }
  out.b_lever_mm = reversed ? -m_head.spacing_mm : m_head.spacing_mm;
  return out;
}

error_space::SurfaceReadings TwoPointRig::measure_surface(const Vec3& origin, int u_axis, int v_axis, int l, int m) {
  error_space::SurfaceReadings r;
  const double d = m_head.spacing_mm;
  for (int j = 0; j <= m; ++j) {  // S1
    Vec3 q = origin;
    q[v_axis] += j * d;
    r.x_lines.push_back(measure_line(q, u_axis, l));
  }
  r.y_line_first = measure_line(origin, v_axis, m, true);  // S4: the same sensors turned 90 degrees
  Vec3 q = origin;
  q[u_axis] += l * d;
  r.y_line_last = measure_line(q, v_axis, m, true);
  return r;
}

}  // namespace metron::machine
