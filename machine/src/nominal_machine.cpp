// SPDX-License-Identifier: GPL-3.0-or-later
// The dry-run backend (nominal_machine.hpp): touches at their nominals, scans along their paths.
#include "metron/machine/nominal_machine.hpp"

#include <algorithm>
#include <cmath>
#include <variant>

#include <fmt/format.h>

#include "metron/machine/aborted_response.hpp"
#include "metron/machine/probe_library.hpp"

namespace metron::machine {

NominalMachine::NominalMachine(const MachineConfig& config)
    : m_config(config),
      m_position(config.home_mm),
      m_positioning_feed(config.positioning_feed_mm_s),
      m_measuring_feed(config.measuring_feed_mm_s) {}

void NominalMachine::submit(Command command) { m_queue.push_back(std::move(command)); }

std::vector<Response> NominalMachine::execute() {
  std::vector<Response> out;
  bool faulted = false;
  while (!m_queue.empty()) {
    Command c = std::move(m_queue.front());
    m_queue.pop_front();
    if (faulted) {
      out.push_back(aborted_response(c, m_position, m_time_s));
      continue;
    }
    out.push_back(run(c));
    ++m_executed;
    faulted = out.back().status == Response::Status::Fault;
  }
  return out;
}

MachineState NominalMachine::state() const {
  MachineState s;
  s.position_mm = m_position;
  s.time_s = m_time_s;
  s.active_tool = m_active;
  if (const ToolInfo* t = active_tool()) s.tool = *t;
  s.last_hit = m_last_hit;
  s.positioning_feed_mm_s = m_positioning_feed;
  s.measuring_feed_mm_s = m_measuring_feed;
  s.queued_commands = m_queue.size();
  s.executed_commands = m_executed;
  s.scan_buffer_segments = 0;  // whole scans: no command buffers to fill
  s.home_mm = m_config.home_mm;
  s.nominal = true;
  return s;
}

std::vector<Command> NominalMachine::queued() const { return {m_queue.begin(), m_queue.end()}; }

const ToolInfo* NominalMachine::active_tool() const {
  const auto it = m_tools.find(m_active);
  return it == m_tools.end() ? nullptr : &it->second;
}

void NominalMachine::move_to(const Vec3& target_mm, double feed_mm_s) {
  m_time_s += (target_mm - m_position).norm() / feed_mm_s;
  m_position = target_mm;
}

Response NominalMachine::run(const Command& command) {
  Response response;
  response.tag = command.tag;
  response.start_time_s = m_time_s;
  const auto fail = [&](FaultKind kind, std::string message) {
    response.status = Response::Status::Fault;
    response.fault = Fault{kind, std::move(message), m_position, m_time_s};
  };
  const auto define = [&](const DefineTool& d) {
    ToolInfo info;
    info.name = d.name;
    info.nominal_radius_mm = d.ball_diameter_mm / 2;
    // Qualified as it is defined: a dry run has no reference sphere to touch.
    info.effective_radius_mm = info.nominal_radius_mm;
    info.qualified = true;
    m_tools[d.name] = info;
    return info;
  };
  std::visit(
      [&](const auto& body) {
        using T = std::decay_t<decltype(body)>;
        if constexpr (std::is_same_v<T, GoTo>) {
          const double feed = body.speed_mm_s.value_or(m_positioning_feed);
          if (!(feed > 0) || !body.target_mm.allFinite())
            return fail(FaultKind::BadCommand, "goto needs a finite target and a positive speed");
          move_to(body.target_mm, feed);
        } else if constexpr (std::is_same_v<T, PtMeas>) {
          const ToolInfo* tool = active_tool();
          if (!tool) return fail(FaultKind::NoTool, "no tool selected");
          if (!body.nominal_mm.allFinite() || !(body.normal.norm() > 0.5))
            return fail(FaultKind::BadCommand, "ptmeas needs a finite point and a unit normal");
          const Vec3 n = body.normal.normalized();
          const double r = tool->effective_radius_mm;
          // The cycle's moves: to the approach point, probing to contact, the retract.
          move_to(body.nominal_mm + (r + body.approach_mm) * n, m_positioning_feed);
          const double feed = body.speed_mm_s.value_or(m_measuring_feed);
          move_to(body.nominal_mm + r * n, feed > 0 ? feed : m_measuring_feed);
          Hit hit{m_position, n, r, m_time_s};
          move_to(m_position + body.retract_mm * n, feed > 0 ? feed : m_measuring_feed);
          response.hit = hit;
          m_last_hit = hit;
        } else if constexpr (std::is_same_v<T, DefineTool>) {
          response.tool = define(body);
        } else if constexpr (std::is_same_v<T, SelectTool>) {
          if (!m_tools.count(body.name)) {
            const auto sensor = find_library_sensor(m_config.probe_library, body.name);
            if (!sensor) return fail(FaultKind::UnknownTool, fmt::format("unknown tool '{}'", body.name));
            DefineTool d = tool_definition(*sensor);
            d.name = body.name;
            define(d);
          }
          m_active = body.name;
          response.tool = m_tools.at(body.name);
        } else if constexpr (std::is_same_v<T, QualifyTool>) {
          const ToolInfo* tool = active_tool();
          if (!tool) return fail(FaultKind::NoTool, "no tool selected");
          response.tool = *tool;
        } else if constexpr (std::is_same_v<T, SetFeeds>) {
          if (body.positioning_mm_s < 0 || body.measuring_mm_s < 0 || body.acceleration_mm_s2 < 0)
            return fail(FaultKind::BadCommand, "feeds and acceleration must not be negative");
          if (body.positioning_mm_s > 0) m_positioning_feed = std::min(body.positioning_mm_s, m_config.max_speed_mm_s);
          if (body.measuring_mm_s > 0) m_measuring_feed = std::min(body.measuring_mm_s, m_config.max_speed_mm_s);
        } else if constexpr (std::is_same_v<T, ScanPath>) {
          const ToolInfo* tool = active_tool();
          if (!tool) return fail(FaultKind::NoTool, "no tool selected");
          if (body.path.segments.empty()) return fail(FaultKind::BadCommand, "a scan needs a path");
          // The path holds ball centres at the reference deflection E0, (r - E0) off the surface
          // (geometry/scan_path.cpp): in contact the ball centre is E0 further out, and the
          // deflection reading is E0 along the surface normal.
          const double e0 = body.reference_deflection_mm.value_or(m_config.scanning.probe.reference_deflection_mm);
          const double feed = body.speed_mm_s.value_or(m_config.scanning.control.feed_mm_s);
          const double spacing = body.sample_spacing_mm > 0 ? body.sample_spacing_mm : feed * m_config.dt_s;
          const auto& normals = body.path.normals;
          const Vec3 start = body.path.segments.front().start();
          move_to(start + body.approach_mm * body.approach_normal, m_positioning_feed);
          move_to(start, m_measuring_feed);
          for (std::size_t i = 0; i < body.path.segments.size(); ++i) {
            const auto& seg = body.path.segments[i];
            const int steps = std::max(1, static_cast<int>(std::ceil(seg.length() / spacing)));
            for (int k = (i == 0 ? 0 : 1); k <= steps; ++k) {
              const double u = static_cast<double>(k) / steps;
              Vec3 n = body.approach_normal;
              if (normals.size() == body.path.segments.size() + 1) {
                const Vec3 blend = (1 - u) * normals[i] + u * normals[i + 1];
                if (blend.norm() > 1e-9) n = blend.normalized();
              }
              const Vec3 at = seg.point(u * seg.d_mm);
              m_time_s += (at - m_position).norm() / feed;
              m_position = at;
              response.scan.push_back({m_time_s, Vec3(at + e0 * n), Vec3(e0 * n), 0.0});
            }
          }
          move_to(m_position + body.retract_mm * response.scan.back().deflection_mm.normalized(), m_measuring_feed);
          response.scan_log.push_back(
              fmt::format("dry run: {} samples along the nominal path, {} mm apart", response.scan.size(), spacing));
        } else if constexpr (std::is_same_v<T, ScanBufferWrite>) {
          fail(FaultKind::BadCommand, "a dry run scans whole paths only");
        } else if constexpr (std::is_same_v<T, ContourScan>) {
          fail(FaultKind::BadCommand, "a dry run has no surface to follow: an unknown-contour scan needs a machine");
        }
      },
      command.body);
  response.end_time_s = m_time_s;
  return response;
}

}  // namespace metron::machine
