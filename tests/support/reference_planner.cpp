// SPDX-License-Identifier: GPL-3.0-or-later
#include "reference_planner.hpp"

#include "metron/machine/segmented_scanning/path_interpolator.hpp"

namespace metron::test_support {

using namespace machine::segmented;

ReferenceProfile reference_profile(const geometry::PccPath& path, const ScanLimits& limits, double dt_s,
                                   ScanRecorder* recorder) {
  ReferenceProfile out;
  const SpeedPlan plan =
      plan_command(path.segments, path.speed_mm_s, 0, 0.0, PlanKind::LookAhead, limits, LowSpeedRegion{}, true);
  for (const LimitPiece& p : plan.pieces) out.lower_bound_s += (p.end_mm - p.start_mm) / p.limit_mm_s;
  out.length_mm = plan.end_mm;
  PathInterpolator interp(limits.path);
  interp.append(plan.pieces);
  // Generous cap: the lower bound plus a full stop-and-go per piece.
  const auto max_cycles = static_cast<std::size_t>((10 * out.lower_bound_s + 10) / dt_s) + 1000;
  while (!interp.at_rest_at_end() && out.cycles < max_cycles) {
    interp.step(dt_s);
    ++out.cycles;
    if (recorder != nullptr) {
      const LimitPiece* p = interp.current_piece();
      ScanCycle c;
      c.t_s = static_cast<double>(out.cycles) * dt_s;
      c.dt_s = dt_s;
      c.state = interp.state();
      c.limit_mm_s = p->limit_mm_s;
      const double u = parameter_at_arc(p->segment, c.state.s_mm - p->segment_start_mm, p->segment_length_mm);
      c.position_mm = p->segment.point(u);
      const Vec3 d1 = p->segment.derivative(u), d2 = p->segment.second_derivative(u);
      const double n = d1.norm();
      if (n > 0) {
        const Vec3 t = d1 / n;
        c.acceleration_mm_s2 = c.state.a_mm_s2 * t + c.state.v_mm_s * c.state.v_mm_s * (d2 - d2.dot(t) * t) / (n * n);
      }
      recorder->record(c);
    }
    if (out.cycles % 4096 == 0) interp.trim();
  }
  out.time_s = static_cast<double>(out.cycles) * dt_s;
  return out;
}

}  // namespace metron::test_support
