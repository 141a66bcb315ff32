// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/error_space/laser_interferometer.hpp"

namespace metron::machine {

std::vector<error_space::PositioningRecord> measure_positioning(const MachineErrorModel& errors, const LaserPlan& plan,
                                                                Rng& rng, double& time_s) {
  std::vector<error_space::PositioningRecord> out;
  const int u = plan.axis == 0 ? 1 : 0, v = plan.axis == 2 ? 1 : 2;
  auto true_deviation = [&](double target, int direction) {
    MachinePose p;
    p.axes_mm = plan.line_axes_mm;
    p.axes_mm[plan.axis] = target;
    p.probe_offset_mm = plan.reflector_offset_mm;
    p.approach[static_cast<std::size_t>(plan.axis)] = direction;
    return errors.tool_displacement(p, time_s)[plan.axis];
  };
  if (plan.targets_mm.empty()) return out;
  const double zero = true_deviation(plan.targets_mm.front(), +1);  // laser zeroed at the first target
  const int n = static_cast<int>(plan.targets_mm.size());
  for (int c = 0; c < plan.cycles; ++c)
    for (int dir : {+1, -1})
      for (int t = 0; t < n; ++t) {
        const int i = dir > 0 ? t : n - 1 - t;
        error_space::PositioningRecord r;
        r.axis = plan.axis, r.target = i, r.target_mm = plan.targets_mm[static_cast<std::size_t>(i)];
        r.cycle = c, r.direction = dir, r.time_s = time_s;
        r.line_u_mm = plan.line_axes_mm[u], r.line_v_mm = plan.line_axes_mm[v];
        r.deviation_mm = true_deviation(r.target_mm, dir) - zero + plan.noise_sd_mm * rng.normal();
        out.push_back(r);
        time_s += plan.dwell_s;
      }
  return out;
}

}  // namespace metron::machine
