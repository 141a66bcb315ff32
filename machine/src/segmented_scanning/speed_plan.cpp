// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/segmented_scanning/speed_plan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "metron/stdlib/jerk_limited_ramp.hpp"

namespace metron::machine::segmented {
namespace {
constexpr double k_inf = std::numeric_limits<double>::infinity();

// The speed limit at curvature `kappa`: centripetal acceleration v^2 kappa <= a_n, the path speed
// limit and the path's own (0: none).
double limit_for_curvature(double kappa, const ScanLimits& limits, double path_speed_mm_s) {
  double v = limits.path.speed_mm_s;
  if (kappa > 0) v = std::min(v, std::sqrt(limits.normal_acceleration_mm_s2 / kappa));
  if (path_speed_mm_s > 0) v = std::min(v, path_speed_mm_s);
  return v;
}
}  // namespace

double ramp_time_s(double dv, const MotionLimits& l) {
  return jerk_limited_ramp_time_s(dv, l.acceleration_mm_s2, l.jerk_mm_s3);
}

double ramp_distance_mm(double v0, double v1, const MotionLimits& l) {
  return 0.5 * (v0 + v1) * ramp_time_s(std::abs(v1 - v0), l);
}

double reachable_speed_mm_s(double v0, double d, const MotionLimits& l) {
  if (d <= 0) return v0;
  const double a = l.acceleration_mm_s2, j = l.jerk_mm_s3;
  // Jerk-only ramp: (2 v0 + x) sqrt(x/J) = d; with y = sqrt(x): y^3 + 2 v0 y - d sqrt(J) = 0,
  // a depressed cubic with one real root (Cardano), polished by one Newton step.
  const double p = 2 * v0, q = d * std::sqrt(j);
  const double r = std::sqrt(q * q / 4 + p * p * p / 27);
  double y = std::cbrt(q / 2 + r) + std::cbrt(q / 2 - r);
  y -= (y * y * y + p * y - q) / (3 * y * y + p);
  double x = y * y;
  if (x * j >= a * a) {
    // With a constant-acceleration phase: (2 v0 + x)(x/A + A/J) = 2 d, a quadratic in x.
    const double qa = 1 / a, qb = 2 * v0 / a + a / j, qc = 2 * v0 * a / j - 2 * d;
    x = (-qb + std::sqrt(std::max(0.0, qb * qb - 4 * qa * qc))) / (2 * qa);
  }
  return v0 + std::max(0.0, x);
}

double ongoing_speed_mm_s(double v0, double d, const MotionLimits& l) {
  if (d <= 0) return v0;
  const double A = l.acceleration_mm_s2, J = l.jerk_mm_s3;
  const double t1 = A / J, d1 = v0 * t1 + J * t1 * t1 * t1 / 6;
  if (d >= d1) {
    // Jerk phase up to A, then constant acceleration: v^2 = v1^2 + 2 A (d - d1).
    const double v1 = v0 + A * A / (2 * J);
    return std::sqrt(v1 * v1 + 2 * A * (d - d1));
  }
  // Within the jerk phase: v0 t + J t^3 / 6 = d (Newton from the jerk-only guess, monotone).
  double t = std::min(t1, std::cbrt(6 * d / J));
  for (int it = 0; it < 6; ++it) t -= (v0 * t + J * t * t * t / 6 - d) / (v0 + J * t * t / 2);
  return v0 + J * t * t / 2;
}

void junction_passes(std::span<const LimitPiece> pieces, double start_speed, double end_speed, const MotionLimits& l,
                     std::vector<double>& w, std::vector<double>* middle, bool ongoing) {
  const auto reach = [&](double v0, double d) {
    return ongoing ? ongoing_speed_mm_s(v0, d, l) : reachable_speed_mm_s(v0, d, l);
  };
  const std::size_t n = pieces.size();
  w.assign(n + 1, 0.0);
  if (middle != nullptr) middle->assign(n, 0.0);
  if (n == 0) return;
  std::vector<double> cap(n + 1), at(n + 1);
  cap[0] = std::min(start_speed, pieces[0].limit_mm_s);
  for (std::size_t k = 1; k < n; ++k)
    cap[k] = std::min({pieces[k - 1].limit_mm_s, pieces[k].limit_mm_s, pieces[k - 1].end_cap_mm_s});
  cap[n] = std::min({end_speed, pieces[n - 1].limit_mm_s, pieces[n - 1].end_cap_mm_s});
  for (std::size_t k = 0; k < n; ++k) at[k] = pieces[k].start_mm;
  at[n] = pieces[n - 1].end_mm;
  // Backward pass: a junction is no faster than the jerk-limited ramp down to the binding
  // constraint ahead. The ramp is measured over the whole distance to that constraint (not
  // restarted at every junction), so dense short segments do not cost speed: the binding
  // ("active") constraint is carried along and replaced when a lower one comes up.
  std::vector<std::size_t> back_active(n + 1), fwd_active(n + 1);
  std::size_t active = n;
  w[n] = cap[n];
  back_active[n] = n;
  for (std::size_t k = n; k-- > 0;) {
    const double r = reach(cap[active], at[active] - at[k]);
    if (cap[k] <= r) {
      active = k;
      w[k] = cap[k];
    } else {
      w[k] = r;
    }
    back_active[k] = active;
  }
  // Forward pass: no faster than the ramp up from the binding constraint behind.
  active = 0;
  fwd_active[0] = 0;
  for (std::size_t k = 1; k <= n; ++k) {
    const double r = reach(w[active], at[k] - at[active]);
    if (w[k] <= r) {
      active = k;
    } else {
      w[k] = r;
    }
    fwd_active[k] = active;
  }
  if (middle == nullptr) return;
  for (std::size_t k = 0; k < n; ++k) {
    const double mid = 0.5 * (at[k] + at[k + 1]);
    const std::size_t b = back_active[k + 1], f = fwd_active[k];
    (*middle)[k] = std::min({pieces[k].limit_mm_s, reach(cap[b], at[b] - mid), reach(w[f], mid - at[f])});
  }
}

void schedule_plan(SpeedPlan& plan, const MotionLimits& l) {
  // Two envelopes bracket what the interpolator does: ramps that end at zero acceleration at
  // every measured point (too slow: it passes junctions while still accelerating) and ramps that
  // never have to end (too fast: the change from accelerating to braking costs time). The
  // schedule takes the mean of the two times; the plan's junction speeds are the first.
  std::vector<double> mid_slow, w_fast, mid_fast;
  junction_passes(plan.pieces, plan.start_speed_mm_s, plan.end_speed_mm_s, l, plan.junction_mm_s, &mid_slow);
  junction_passes(plan.pieces, plan.start_speed_mm_s, plan.end_speed_mm_s, l, w_fast, &mid_fast, true);
  const auto piece_time = [](double len, double v0, double vm, double v1) {
    // Each half of the piece at its mean speed (exact for a symmetric ramp, close otherwise).
    return 0.5 * len / std::max(0.5 * (v0 + vm), 1e-9) + 0.5 * len / std::max(0.5 * (vm + v1), 1e-9);
  };
  const std::size_t n = plan.pieces.size();
  plan.time_to_end_s.assign(n + 1, 0.0);
  for (std::size_t k = n; k-- > 0;) {
    const double len = plan.pieces[k].end_mm - plan.pieces[k].start_mm;
    const double slow = piece_time(len, plan.junction_mm_s[k], mid_slow[k], plan.junction_mm_s[k + 1]);
    const double fast = piece_time(len, w_fast[k], mid_fast[k], w_fast[k + 1]);
    plan.time_to_end_s[k] = plan.time_to_end_s[k + 1] + 0.5 * (slow + fast);
  }
}

double parameter_at_arc(const geometry::PccSegment& seg, double arc, double length) {
  if (length <= 0 || seg.d_mm <= 0) return 0;
  double u = std::clamp(arc / length, 0.0, 1.0) * seg.d_mm;
  for (int it = 0; it < 3; ++it) {
    const double speed = seg.derivative(u).norm();
    if (speed <= 0) break;
    u = std::clamp(u - (seg.arc_length(u) - arc) / speed, 0.0, seg.d_mm);
  }
  return u;
}

SegmentLimit segment_limit(const geometry::PccSegment& seg, const ScanLimits& limits, double path_speed_mm_s) {
  SegmentLimit out;
  out.length_mm = seg.length();
  double kappa = 0;
  for (int i = 0; i <= 4; ++i) kappa = std::max(kappa, seg.curvature(seg.d_mm * i / 4.0));
  out.limit_mm_s = limit_for_curvature(kappa, limits, path_speed_mm_s);
  return out;
}

namespace {

// The curvature limit at the samples of one parameter range (the planner's resolution).
double curvature_limit(const geometry::PccSegment& seg, double u0, double u1, const ScanLimits& limits,
                       double path_speed_mm_s) {
  double kappa = 0;
  for (double u : {u0, 0.5 * (u0 + u1), u1}) kappa = std::max(kappa, seg.curvature(u));
  return limit_for_curvature(kappa, limits, path_speed_mm_s);
}

// Issue 11 item 5: one limit for a whole segment holds all of it at the speed its sharpest point
// allows. A segment is split at quarters of its parameter into pieces with limits of their own;
// neighbouring quarters whose limits agree within 0.1 % stay one piece (a straight segment is one).
void append_segment_pieces(std::vector<LimitPiece>& pieces, const geometry::PccSegment& seg, double start_mm,
                           double path_speed_mm_s, const ScanLimits& limits, std::size_t command_index) {
  constexpr int parts = 4;
  const double length = seg.length();
  const std::size_t first = pieces.size();
  double at = start_mm;
  for (int k = 0; k < parts; ++k) {
    const double u0 = seg.d_mm * k / parts, u1 = seg.d_mm * (k + 1) / parts;
    const double v = curvature_limit(seg, u0, u1, limits, path_speed_mm_s);
    const double end = k + 1 == parts ? start_mm + length : start_mm + seg.arc_length(u1);
    if (pieces.size() > first && std::abs(pieces.back().limit_mm_s - v) <= 1e-3 * v) {
      pieces.back().end_mm = end;
      pieces.back().limit_mm_s = std::min(pieces.back().limit_mm_s, v);
    } else {
      pieces.push_back({at, end, v, k_inf, seg, start_mm, length, command_index});
    }
    at = end;
  }
}

}  // namespace

SpeedPlan plan_command(std::span<const geometry::PccSegment> segments, std::span<const double> path_speed,
                       std::size_t command_index, double start_mm, PlanKind kind, const ScanLimits& limits,
                       const LowSpeedRegion& low, bool last_command) {
  if (!(low.speed_mm_s > 0) || !(low.length_mm >= 0))
    throw std::invalid_argument("low-speed region needs a positive speed and a length >= 0");
  SpeedPlan plan;
  plan.kind = kind;
  plan.command_index = command_index;
  plan.start_mm = start_mm;
  plan.pieces.reserve(segments.size() + 1);
  double s = start_mm;
  for (std::size_t i = 0; i < segments.size(); ++i) {
    append_segment_pieces(plan.pieces, segments[i], s, i < path_speed.size() ? path_speed[i] : 0.0, limits,
                          command_index);
    s = plan.pieces.back().end_mm;
  }
  plan.end_mm = s;
  plan.low_speed_from_mm = s;
  const bool seed = kind == PlanKind::Individual || kind == PlanKind::Connection;
  plan.start_speed_mm_s = kind == PlanKind::Connection ? low.speed_mm_s : 0.0;
  if (seed) {
    // SEEDS.md 2 step 3: the last L of the command at the low speed, reaching back over earlier
    // segments when the last one is shorter than L; none when the whole command is shorter.
    if (s - start_mm >= low.length_mm && low.length_mm > 0) {
      const double from = s - low.length_mm;
      plan.low_speed_from_mm = from;
      // In place from the back: the region covers only the last few pieces.
      std::size_t k = plan.pieces.size();
      while (k > 0 && plan.pieces[k - 1].start_mm >= from) {
        --k;
        plan.pieces[k].limit_mm_s = std::min(plan.pieces[k].limit_mm_s, low.speed_mm_s);
      }
      if (k > 0 && plan.pieces[k - 1].end_mm > from) {
        LimitPiece tail = plan.pieces[k - 1];
        plan.pieces[k - 1].end_mm = from;
        tail.start_mm = from;
        tail.limit_mm_s = std::min(tail.limit_mm_s, low.speed_mm_s);
        plan.pieces.insert(plan.pieces.begin() + static_cast<std::ptrdiff_t>(k), tail);
      }
    }
    plan.end_speed_mm_s = last_command ? 0.0 : low.speed_mm_s;
  } else {
    plan.end_speed_mm_s = 0.0;  // conventional: rest; look-ahead: stop within what is buffered
  }
  if (!plan.pieces.empty()) {
    // The command end is a junction at no more than the planned end speed (seed: the low speed,
    // also when the command is shorter than L; conventional: rest; look-ahead: free).
    if (kind != PlanKind::LookAhead) plan.pieces.back().end_cap_mm_s = plan.end_speed_mm_s;
  }
  schedule_plan(plan, limits.path);
  return plan;
}

}  // namespace metron::machine::segmented
