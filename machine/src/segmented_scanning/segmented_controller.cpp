// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/segmented_scanning/segmented_controller.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

namespace metron::machine::segmented {

SegmentedController::SegmentedController(ControllerConfig config, ScanRecorder* recorder)
    : m_config(std::move(config)), m_recorder(recorder), m_interp(m_config.limits.path) {
  // SEEDS.md 2 step 3: the low speed is claimed for 1-5 mm/s.
  if (!(m_config.low.speed_mm_s >= 1.0 && m_config.low.speed_mm_s <= 5.0))
    throw std::invalid_argument(fmt::format("low speed {} mm/s outside the seed's 1-5 mm/s", m_config.low.speed_mm_s));
  if (!(m_config.low.length_mm >= 0)) throw std::invalid_argument("low-speed region length must be >= 0");
  if (!(m_config.dt_s > 0) || m_config.buffer_segments == 0)
    throw std::invalid_argument("control cycle and buffer size must be positive");
}

double SegmentedController::planning_time_s(std::size_t segments) const {
  // SEEDS.md 2 step 4: Tp is about 1.3 times the net planning time.
  return m_config.planning_margin *
         (m_config.planning_fixed_s + m_config.planning_s_per_segment * static_cast<double>(segments));
}

double SegmentedController::retract_time_s() const {
  return rest_to_rest_time_s(m_config.retract_mm, m_config.positioning);
}

double SegmentedController::approach_time_s() const { return retract_time_s() + m_config.contact_settle_s; }

int SegmentedController::free_buffer() const {
  // Commands alternate between the buffers: Ci goes to buffer (i mod 2) + 1.
  const std::size_t b = m_next_load % 2;
  return m_buffers[b].full || m_last_loaded ? 0 : static_cast<int>(b) + 1;
}

tl::expected<void, Fault> SegmentedController::load(MeasurementCommand command) {
  const auto fault = [&](std::string msg) {
    return tl::unexpected(Fault{FaultKind::BadCommand, std::move(msg), Vec3::Zero(), m_t_s});
  };
  const int b = free_buffer();
  if (b == 0) return fault("no writable command buffer (SB(1) = SB(2) = 1)");
  if (command.index != m_next_load)
    return fault(fmt::format("measurement command {} loaded out of order (expected {})", command.index, m_next_load));
  if (command.segments.empty() || command.segments.size() > m_config.buffer_segments)
    return fault(fmt::format("measurement command {} has {} segments; a buffer holds 1 to {}", command.index,
                             command.segments.size(), m_config.buffer_segments));
  Buffer& buf = m_buffers[static_cast<std::size_t>(b - 1)];
  if (command.last) {
    m_last_loaded = true;
    m_last_index = command.index;
  }
  buf = Buffer{};
  buf.full = true;
  buf.command = std::move(command);
  if (m_recorder != nullptr) m_recorder->command_loaded(*buf.command);
  ++m_next_load;
  return {};
}

int SegmentedController::buffer_of(std::size_t index) const {
  for (std::size_t b = 0; b < 2; ++b)
    if (m_buffers[b].full && m_buffers[b].command->index == index) return static_cast<int>(b);
  return -1;
}

double SegmentedController::remaining_time_s(const SpeedPlan& plan, double s) const {
  const auto& p = plan.pieces;
  const auto it = std::upper_bound(p.begin(), p.end(), s, [](double x, const LimitPiece& q) { return x < q.end_mm; });
  if (it == p.end()) return 0;
  const std::size_t k = static_cast<std::size_t>(it - p.begin());
  const double len = it->end_mm - it->start_mm;
  const double frac = len > 0 ? std::clamp((it->end_mm - s) / len, 0.0, 1.0) : 0.0;
  return plan.time_to_end_s[k + 1] + frac * (plan.time_to_end_s[k] - plan.time_to_end_s[k + 1]);
}

double SegmentedController::gap_before_s(std::size_t index) const {
  // tei - t for C(index-1): the command the plan of C(index) must connect to.
  if (index == 0) return 0;
  const int pb = buffer_of(index - 1);
  if (pb < 0 || !m_buffers[static_cast<std::size_t>(pb)].plan_ready) return 0;
  const Buffer& prev = m_buffers[static_cast<std::size_t>(pb)];
  if (prev.attached) return remaining_time_s(*prev.plan, m_interp.state().s_mm);
  double wait = approach_time_s();
  if (m_phase == Phase::Approaching) wait = std::max(0.0, m_phase_end_s - m_t_s);
  if (m_phase == Phase::Retracting) wait = std::max(0.0, m_phase_end_s - m_t_s) + approach_time_s();
  return wait + prev.plan->duration_s();
}

void SegmentedController::start_planning(std::size_t b) {
  Buffer& buf = m_buffers[b];
  const MeasurementCommand& cmd = *buf.command;
  PlanKind kind = PlanKind::LookAhead;
  if (m_config.mode == SegmentedMode::Conventional) kind = PlanKind::Conventional;
  if (m_config.mode == SegmentedMode::Seed) {
    // SEEDS.md 2 step 4: the planner reads LF when it takes up the command: LF = 1 gives a
    // connection plan, LF = 0 an individual plan. LF judges the command that follows the one
    // executing; any other command (nothing executing before it) gets an individual plan.
    const bool lf = cmd.index > 0 && cmd.index == m_done_commands + 1 && m_lf;
    kind = lf ? PlanKind::Connection : PlanKind::Individual;
  }
  const auto w0 = std::chrono::steady_clock::now();
  buf.plan = plan_command(cmd.segments, cmd.speed_mm_s, cmd.index, m_next_start_mm, kind, m_config.limits, m_config.low,
                          cmd.last);
  const auto w1 = std::chrono::steady_clock::now();
  m_stats.planning_wall_s.push_back(std::chrono::duration<double>(w1 - w0).count());
  m_stats.plan_kinds.push_back(kind);
  m_next_start_mm = buf.plan->end_mm;
  const double net =
      m_config.planning_fixed_s + m_config.planning_s_per_segment * static_cast<double>(cmd.segments.size());
  const double factor = m_config.planning_factor ? m_config.planning_factor(cmd.index) : 1.0;
  m_planning = static_cast<int>(b);
  m_plan_ready_s = m_t_s + net * factor;
  m_plan_expected_s = m_t_s + planning_time_s(cmd.segments.size());
  ++m_next_plan;
}

void SegmentedController::attach(std::size_t b, bool from_rest) {
  Buffer& buf = m_buffers[b];
  SpeedPlan& plan = *buf.plan;
  if (from_rest && plan.kind == PlanKind::Connection) {
    // A late connection plan: the probe stopped and approached again, so the command starts from
    // rest like an individual plan; only the schedule is redone (cheap, not charged as Tp).
    plan.kind = PlanKind::Individual;
    plan.start_speed_mm_s = 0;
    schedule_plan(plan, m_config.limits.path);
  }
  if (from_rest) m_interp.reset_state({plan.start_mm, 0, 0, 0});
  m_interp.trim();
  m_interp.append(plan.pieces);
  buf.attached = true;
  ++m_next_attach;
}

void SegmentedController::finish_completed_commands() {
  // Short commands may end several in one cycle.
  for (int guard = 0; guard < 2; ++guard) {
    const std::size_t before = m_done_commands;
    finish_one_command();
    if (m_done_commands == before) break;
  }
}

void SegmentedController::finish_one_command() {
  Buffer& buf = m_buffers[static_cast<std::size_t>(m_exec_buffer)];
  if (!buf.full || !buf.attached) return;
  const PathState& x = m_interp.state();
  if (x.s_mm < buf.plan->end_mm - 1e-9) return;
  const bool last = buf.command->last;
  if (!last) {
    BoundaryEvent ev;
    ev.next_command = buf.command->index + 1;
    ev.s_mm = buf.plan->end_mm;
    ev.t_s = m_t_s;
    ev.stopped = m_interp.at_rest_at_end();
    // Speed when the boundary was passed: back from the end of the cycle by the overshoot.
    ev.speed_mm_s = ev.stopped ? 0.0 : x.v_mm_s - x.a_mm_s2 * (x.s_mm - ev.s_mm) / std::max(x.v_mm_s, 1e-9);
    m_stats.boundaries.push_back(ev);
  }
  // The command has been executed: its buffer may be overwritten (SB = 0), B moves on.
  buf = Buffer{};
  ++m_done_commands;
  if (!last) m_exec_buffer ^= 1;
}

void SegmentedController::pace() {
  // The controller knows when it expects its own plan (start + Tp), not when it will really be
  // ready: reach the buffered end no earlier than that, at no less than the low speed.
  double cap = std::numeric_limits<double>::infinity();
  const int b = buffer_of(m_next_attach);
  const bool pending = m_planning >= 0 && b == m_planning;
  if (pending) {
    const double left_s = m_plan_expected_s - m_t_s;
    const double d = m_interp.horizon_end_mm() - m_interp.state().s_mm;
    if (left_s > 0) cap = std::max(m_config.low.speed_mm_s, d / left_s);
  }
  m_interp.set_speed_override(cap);
}

bool SegmentedController::record_cycle() {
  if (m_recorder == nullptr) return false;
  const LimitPiece* p = m_interp.current_piece();
  if (p == nullptr) return false;
  const PathState& x = m_interp.state();
  ScanCycle c;
  c.t_s = m_t_s;
  c.dt_s = m_config.dt_s;
  c.command_index = p->command_index;
  c.state = x;
  c.limit_mm_s = p->limit_mm_s;
  const double u = parameter_at_arc(p->segment, x.s_mm - p->segment_start_mm, p->segment_length_mm);
  const Vec3 d1 = p->segment.derivative(u), d2 = p->segment.second_derivative(u);
  c.position_mm = p->segment.point(u);
  const double n = d1.norm();
  if (n > 0) {
    const Vec3 t = d1 / n;
    const Vec3 kappa_n = (d2 - d2.dot(t) * t) / (n * n);  // curvature vector kappa*N
    c.acceleration_mm_s2 = x.a_mm_s2 * t + x.v_mm_s * x.v_mm_s * kappa_n;
  }
  m_recorder->record(c);
  return true;
}

void SegmentedController::step() {
  if (m_phase == Phase::Done) return;
  const double dt = m_config.dt_s;
  // The planner finishes a plan, then takes up the next command in a buffer.
  if (m_planning >= 0 && m_t_s + 1e-12 >= m_plan_ready_s) {
    m_buffers[static_cast<std::size_t>(m_planning)].plan_ready = true;
    m_planning = -1;
  }
  // LF as of this cycle, before the planner may read it.
  update_connection_flag();
  if (m_planning < 0) {
    const int b = buffer_of(m_next_plan);
    const bool conventional_ready =
        m_phase == Phase::Retracted && m_done_commands == m_next_plan;  // plan only after the stop
    if (b >= 0 && (m_config.mode != SegmentedMode::Conventional || conventional_ready)) {
      start_planning(static_cast<std::size_t>(b));
      if (m_t_s + 1e-12 >= m_plan_ready_s) {
        m_buffers[static_cast<std::size_t>(b)].plan_ready = true;
        m_planning = -1;
      }
    }
  }
  m_t_s += dt;
  switch (m_phase) {
    case Phase::Retracted: {
      if (drives_probe()) m_recorder->off_path(OffPathMove::Hold, m_interp.state().s_mm, m_t_s);
      const int b = buffer_of(m_next_attach);
      if (b >= 0 && m_buffers[static_cast<std::size_t>(b)].plan_ready) {
        m_phase = Phase::Approaching;
        m_phase_end_s = m_t_s + approach_time_s();
        m_approach_buffer = b;
      }
      break;
    }
    case Phase::Approaching: {
      // A driven probe reports when it touches and has settled; else the estimate decides.
      const bool arrived =
          drives_probe()
              ? m_recorder->off_path(OffPathMove::Approach,
                                     m_buffers[static_cast<std::size_t>(m_approach_buffer)].plan->start_mm, m_t_s)
              : m_t_s + 1e-12 >= m_phase_end_s;
      if (arrived) {
        attach(static_cast<std::size_t>(m_approach_buffer), true);
        if (m_recorder != nullptr) m_recorder->contact_changed(true, m_t_s);
        if (m_next_attach == 1) m_stats.scan_start_s = m_t_s;
        m_phase = Phase::Scanning;
        m_stop_counted = false;
      }
      break;
    }
    case Phase::Scanning: {
      const int b = buffer_of(m_next_attach);
      if (b >= 0 && m_buffers[static_cast<std::size_t>(b)].plan_ready) {
        const PlanKind kind = m_buffers[static_cast<std::size_t>(b)].plan->kind;
        // Look-ahead continues from whatever state; a seed connection plan only while the probe
        // still moves (once it rests, the fallback below retracts and approaches again).
        if (kind == PlanKind::LookAhead || (kind == PlanKind::Connection && !m_interp.at_rest_at_end()))
          attach(static_cast<std::size_t>(b), false);
      }
      if (m_config.mode == SegmentedMode::LookAhead && m_config.pace_to_planner) pace();
      m_interp.step(dt);
      if (!record_cycle() && drives_probe()) m_recorder->off_path(OffPathMove::Hold, m_interp.state().s_mm, m_t_s);
      finish_completed_commands();
      if (m_interp.at_rest_at_end()) {
        if (m_last_index && m_done_commands == *m_last_index + 1) {
          m_phase = Phase::Done;
          m_stats.scan_end_s = m_t_s;
        } else if (!m_stop_counted) {
          m_stop_counted = true;
          ++m_stats.stops;
          if (!m_stats.boundaries.empty() && std::abs(m_stats.boundaries.back().s_mm - m_interp.state().s_mm) < 1e-6) {
            m_stats.boundaries.back().stopped = true;
            m_stats.boundaries.back().speed_mm_s = 0;
          }
          if (m_config.mode != SegmentedMode::LookAhead) {
            // SEEDS.md 2 step 5: stop, retract, approach again when the next plan is ready.
            m_phase = Phase::Retracting;
            m_phase_end_s = m_t_s + retract_time_s();
            ++m_stats.retracts;
            if (m_recorder != nullptr) m_recorder->contact_changed(false, m_t_s);
            if (!m_stats.boundaries.empty()) m_stats.boundaries.back().retracted = true;
            const int nb = buffer_of(m_next_attach);
            const bool connection_pending = m_config.mode == SegmentedMode::Seed && nb >= 0 &&
                                            m_stats.plan_kinds.size() > m_next_attach &&
                                            m_stats.plan_kinds[m_next_attach] == PlanKind::Connection;
            if (connection_pending) {
              ++m_stats.late_plans;
              if (!m_stats.boundaries.empty()) m_stats.boundaries.back().late_plan = true;
            }
          }
        }
      } else {
        m_stop_counted = false;
      }
      break;
    }
    case Phase::Retracting:
      if (drives_probe() ? m_recorder->off_path(OffPathMove::Retract, m_interp.state().s_mm, m_t_s)
                         : m_t_s + 1e-12 >= m_phase_end_s)
        m_phase = Phase::Retracted;
      break;
    case Phase::Done: break;
  }
  update_connection_flag();
}

void SegmentedController::update_connection_flag() {
  // SEEDS.md 2 step 4: every cycle, with the gap time tei - t of the executing command Ci, LF = 1
  // while tei - t > Tp (Tp = margin * the net planning time of Ci+1, not the net time itself: the
  // margin is what makes a connection plan ready in time). No Ci+1 (Ci is the last): LF = 0.
  const int nb = buffer_of(m_done_commands + 1);
  const std::size_t next_segments =
      nb >= 0 ? m_buffers[static_cast<std::size_t>(nb)].command->segments.size() : m_config.buffer_segments;
  m_lf = m_phase != Phase::Done && !(m_last_index && m_done_commands >= *m_last_index) &&
         gap_before_s(m_done_commands + 1) > planning_time_s(next_segments);
}

}  // namespace metron::machine::segmented
