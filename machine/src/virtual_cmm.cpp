// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/virtual_cmm.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "controller.hpp"
#include "metron/machine/aborted_response.hpp"
#include "metron/machine/active_scanning/contour_scan.hpp"

namespace metron::machine {
namespace detail {
namespace {

// The ball centre from the ram's reference point, as the tool is defined (none for a degenerate
// direction): the lever through which the machine's angular errors move the ball.
Vec3 stylus_offset(const DefineTool& tool) {
  const double n = tool.stylus_direction.norm();
  return n > 1e-12 && std::isfinite(tool.stylus_length_mm) ? Vec3(tool.stylus_direction / n * tool.stylus_length_mm)
                                                           : Vec3(Vec3::Zero());
}

}  // namespace

void Controller::define_tool(const DefineTool& body, Response& response) {
  if (body.name.empty() || !(body.ball_diameter_mm > 0)) {
    response.status = Response::Status::Fault;
    response.fault = Fault{FaultKind::BadCommand, "a tool needs a name and a positive ball diameter", position, now()};
    return;
  }
  Tool t;
  t.definition = body;
  t.info.name = body.name;
  t.info.nominal_radius_mm = body.ball_diameter_mm / 2;
  t.info.effective_radius_mm = t.info.nominal_radius_mm;
  // The probe's data sheet: its rated over-travel is published, so the controller knows it.
  t.info.rated_over_travel_mm = config.data_sheet.rated_over_travel_mm;
  tools[body.name] = t;
  if (active == body.name) sim.mount_stylus(t.info.nominal_radius_mm, stylus_offset(body));
  response.tool = t.info;
}

// An active scan (SEEDS.md 1, docs/scanning.md): position to the approach point, then the
// scanning controller.
void Controller::scan(const ScanPath& body, Response& response) {
  const auto fail = [&](Fault f) {
    response.status = Response::Status::Fault;
    response.fault = std::move(f);
  };
  const Tool* tool = active_tool();
  if (!tool) return fail({FaultKind::NoTool, "no tool selected", position, now()});
  if (const std::string bad = validate_scan(body); !bad.empty())
    return fail({FaultKind::BadCommand, bad, position, now()});
  const std::size_t capacity = config.scanning.segmented.buffer_segments;
  if (body.path.segments.size() > capacity)
    return fail({FaultKind::BadCommand,
                 fmt::format("scan path of {} segments exceeds the controller's command buffer of {} segments: "
                             "the host must send it as measurement commands (ScanBufferWrite)",
                             body.path.segments.size(), capacity),
                 position, now()});
  if (auto ok = move_to(scan_approach_point(body), positioning_feed); !ok) return fail(ok.error());
  run_scanning(tool->info, response, [&](const ScanSetup& setup, const auto& observe) {
    return run_scan(body, setup, position, now(), observe);
  });
}

// A scanning controller's run from the approach point: the probe's setup, the position reports
// and the motion kept for a stop request every cycle, then the machine where the run ended.
void Controller::run_scanning(
    const ToolInfo& tool, Response& response,
    const std::function<ScanOutcome(const ScanSetup&, const std::function<void(const ScanCycle&)>&)>& scan) {
  sim.set_time(now());
  const ScanSetup setup = sim.scan_setup(tool.nominal_radius_mm, config);
  ScanOutcome out = scan(setup, [&](const ScanCycle& c) {
    emit(c.time_s + config.dt_s, c.head_mm, c.velocity_mm_s.norm());
    motion.scan.push_back({c.time_s + config.dt_s, c.head_mm, c.velocity_mm_s});
  });
  position = out.end_position_mm;
  cycle += cycles_for(out.end_time_s - now());
  response.scan = std::move(out.samples);
  response.scan_log = std::move(out.log);
  if (out.fault) {
    response.status = Response::Status::Fault;
    response.fault = std::move(*out.fault);
  }
}

// An unknown-contour scan (docs/scanning.md, "Unknown contours"): position to the approach
// point, then the contour-following controller.
void Controller::contour_scan(const ContourScan& body, Response& response) {
  const auto fail = [&](Fault f) {
    response.status = Response::Status::Fault;
    response.fault = std::move(f);
  };
  const Tool* tool = active_tool();
  if (!tool) return fail({FaultKind::NoTool, "no tool selected", position, now()});
  if (const std::string bad = validate_contour_scan(body); !bad.empty())
    return fail({FaultKind::BadCommand, bad, position, now()});
  if (auto ok = move_to(contour_approach_point(body), positioning_feed); !ok) return fail(ok.error());
  run_scanning(tool->info, response, [&](const ScanSetup& setup, const auto& observe) {
    return run_contour_scan(body, setup, position, now(), observe);
  });
}

Response Controller::run(const Command& command) {
  Response response;
  response.tag = command.tag;
  response.start_time_s = now();
  stoppable.reset();
  motion = CommandMotion{command.tag, {}, position, cycle, 0, {}, {}, last_hit};
  const auto fail = [&](Fault f) {
    response.status = Response::Status::Fault;
    response.fault = std::move(f);
  };
  if (segmented_scan && !std::holds_alternative<ScanBufferWrite>(command.body)) {
    fail({FaultKind::BadCommand, "a segmented scan is in progress: only its next measurement command may follow",
          position, now()});
    return response;
  }
  std::visit(
      [&](const auto& body) {
        using T = std::decay_t<decltype(body)>;
        if constexpr (std::is_same_v<T, GoTo>) {
          const double feed = body.speed_mm_s.value_or(positioning_feed);
          if (!(feed > 0) || !body.target_mm.allFinite())
            return fail({FaultKind::BadCommand, "goto needs a finite target and a positive speed", position, now()});
          if (auto ok = move_to(body.target_mm, feed); !ok) fail(ok.error());
          motion.what = fmt::format("move to {}", xyz(body.target_mm));
        } else if constexpr (std::is_same_v<T, PtMeas>) {
          auto hit = measure_point(body);
          if (hit)
            response.hit = *hit;
          else
            fail(hit.error());
          motion.what = fmt::format("point measurement at {}", xyz(body.nominal_mm));
        } else if constexpr (std::is_same_v<T, DefineTool>) {
          define_tool(body, response);
        } else if constexpr (std::is_same_v<T, SelectTool>) {
          auto it = tools.find(body.name);
          if (it == tools.end()) {
            // A sensor of the probe library is defined on its first selection, as a tool changer would.
            const auto sensor = find_library_sensor(config.probe_library, body.name);
            if (!sensor)
              return fail({FaultKind::UnknownTool, fmt::format("unknown tool '{}'", body.name), position, now()});
            DefineTool definition = tool_definition(*sensor);
            definition.name = body.name;
            define_tool(definition, response);
            if (response.status != Response::Status::Done) return;
            it = tools.find(body.name);
          }
          active = body.name;
          sim.mount_stylus(it->second.info.nominal_radius_mm, stylus_offset(it->second.definition));
          response.tool = it->second.info;
        } else if constexpr (std::is_same_v<T, QualifyTool>) {
          auto info = qualify();
          if (info)
            response.tool = *info;
          else
            fail(info.error());
        } else if constexpr (std::is_same_v<T, SetFeeds>) {
          if (body.positioning_mm_s < 0 || body.measuring_mm_s < 0 || body.acceleration_mm_s2 < 0)
            return fail({FaultKind::BadCommand, "feeds and acceleration must not be negative", position, now()});
          // Clamped to the machine's limits, as a controller's override would be.
          if (body.positioning_mm_s > 0) positioning_feed = std::min(body.positioning_mm_s, config.max_speed_mm_s);
          if (body.measuring_mm_s > 0) measuring_feed = std::min(body.measuring_mm_s, config.max_speed_mm_s);
          if (body.acceleration_mm_s2 > 0) {
            acceleration = std::min(body.acceleration_mm_s2, config.max_acceleration_mm_s2);
            acceleration_cap = acceleration;
          } else if (body.default_acceleration) {
            acceleration = config.max_acceleration_mm_s2;  // as the controller starts
            acceleration_cap.reset();
          }
        } else if constexpr (std::is_same_v<T, ScanPath>) {
          scan(body, response);
          motion.what = "scan";
        } else if constexpr (std::is_same_v<T, ScanBufferWrite>) {
          write_scan_buffer(body, response);
        } else if constexpr (std::is_same_v<T, ContourScan>) {
          contour_scan(body, response);
          motion.what = "unknown-contour scan";
        }
      },
      command.body);
  response.end_time_s = now();
  // A command that moved and ended without fault can be stopped afterwards (stop_move).
  if (response.status == Response::Status::Done && !motion.what.empty() &&
      (!motion.moves.empty() || !motion.scan.empty())) {
    motion.end_s = now();
    stoppable = std::move(motion);
  }
  return response;
}

}  // namespace detail

struct VirtualCmm::Impl : detail::Controller {
  using Controller::Controller;
};

VirtualCmm::VirtualCmm(World world, std::uint64_t seed)
    : m_impl(std::make_unique<Impl>(std::move(world.machine), std::move(world.truth), seed)), m_seed(seed) {}
VirtualCmm::~VirtualCmm() = default;

void VirtualCmm::submit(Command command) { m_impl->queue.push_back(std::move(command)); }

std::vector<Response> VirtualCmm::execute() {
  std::vector<Response> out;
  bool faulted = false;
  while (!m_impl->queue.empty()) {
    Command c = std::move(m_impl->queue.front());
    m_impl->queue.pop_front();
    if (faulted) {
      out.push_back(aborted_response(c, m_impl->position, m_impl->now()));
      continue;
    }
    out.push_back(m_impl->run(c));
    ++m_impl->executed;
    faulted = out.back().status == Response::Status::Fault;
  }
  return out;
}

MachineState VirtualCmm::state() const {
  MachineState s;
  s.position_mm = m_impl->position;
  s.velocity_mm_s = Vec3::Zero();  // commands run to completion: the machine is at rest between them
  s.time_s = m_impl->now();
  s.active_tool = m_impl->active;
  if (const auto it = m_impl->tools.find(m_impl->active); it != m_impl->tools.end()) s.tool = it->second.info;
  s.last_hit = m_impl->last_hit;
  s.positioning_feed_mm_s = m_impl->positioning_feed;
  s.measuring_feed_mm_s = m_impl->measuring_feed;
  s.queued_commands = m_impl->queue.size();
  s.executed_commands = m_impl->executed;
  s.scan_buffer_segments = m_impl->config.scanning.segmented.buffer_segments;
  s.temperature_c = m_impl->sim.thermometer_c(m_impl->now());
  s.home_mm = m_impl->config.home_mm;
  return s;
}

std::vector<Command> VirtualCmm::queued() const { return {m_impl->queue.begin(), m_impl->queue.end()}; }
std::optional<Response> VirtualCmm::stop_last_motion(double after_s) { return m_impl->stop_move(after_s); }
bool VirtualCmm::set_motion_observer(std::function<void(double, const Vec3&)> observer) {
  m_impl->motion_observer = std::move(observer);
  return true;
}
// Where the part now lies is the world's truth: the answer names the set-up, not the pose.
std::optional<std::string> VirtualCmm::operator_stop() {
  const auto setup = m_impl->sim.operator_stop();
  if (!setup) return std::nullopt;
  return fmt::format("the virtual operator puts the part in its set-up {} (the world's part.setups)", *setup);
}
double VirtualCmm::simulated_time_s() const { return m_impl->now(); }
void VirtualCmm::set_trace(std::function<void(const TraceSample&)> trace) { m_impl->trace = std::move(trace); }
std::uint64_t VirtualCmm::seed() const { return m_seed; }

std::unique_ptr<Machine> make_virtual_cmm(const World& world, std::uint64_t seed) {
  return std::make_unique<VirtualCmm>(world, seed);
}

tl::expected<std::unique_ptr<VirtualCmm>, WorldError> open_virtual_cmm(const std::optional<std::string>& world_path,
                                                                       std::optional<std::uint64_t> seed) {
  auto world = load_world_or_default(world_path);
  if (!world) return tl::unexpected(world.error());
  const std::uint64_t run_seed = seed ? *seed : world->seed;
  return std::make_unique<VirtualCmm>(std::move(*world), run_seed);
}

}  // namespace metron::machine
