// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <tl/expected.hpp>

#include "metron/machine/command.hpp"
#include "metron/machine/motion_profile.hpp"
#include "metron/machine/segmented_scanning/probe_scan_driver.hpp"
#include "metron/machine/segmented_scanning/segmented_controller.hpp"
#include "metron/machine/virtual_cmm.hpp"
#include "simulated_probe.hpp"

// The virtual CMM's controller, split by cycle: positioning (positioning.cpp), the touch cycle
// and qualification (touch_cycle/), the segmented-scan session (segmented_scanning/), command
// dispatch and active scans (virtual_cmm.cpp). It knows its own configuration (MachineConfig),
// the tools it was told about and the reference sphere's certificate; it reaches the world only
// through the simulated probe's sensors (simulated_probe.hpp).
namespace metron::machine::detail {

inline std::string xyz(const Vec3& p) { return fmt::format("({:.4f}, {:.4f}, {:.4f})", p.x(), p.y(), p.z()); }

inline tl::unexpected<Fault> fault(FaultKind kind, std::string message, const Vec3& position, double time_s) {
  return tl::unexpected(Fault{kind, std::move(message), position, time_s});
}

/// A tool the controller was told about.
struct Tool {
  ToolInfo info;          ///< its calibration state
  DefineTool definition;  ///< as defined
};

/// A segmented scan in progress (SEEDS.md 2): between its measurement commands the machine
/// answers nothing else.
struct SegmentedSession {
  std::unique_ptr<segmented::ProbeScanDriver> probe;           ///< the probe and servo under the controller
  std::unique_ptr<segmented::SegmentedController> controller;  ///< buffers, planner, interpolator
  std::size_t reported = 0;                                    ///< samples already answered
};

/// A straight move of the running command, kept so that a stop request can cut it afterwards
/// (Machine::stop_last_motion).
struct PositioningMove {
  Vec3 start_mm = Vec3::Zero();
  Vec3 direction = Vec3::UnitX();  ///< unit, start to target
  double length_mm = 0;
  MotionProfile profile;
  MotionLimits limits;
  std::optional<BrakingLimits> braking;
  std::int64_t start_cycle = 0;
  /// Into the move, the time after which it is already stopping on its own (a probing move's
  /// trigger acted on): a stop request then changes nothing.
  double cuttable_s = std::numeric_limits<double>::infinity();
  double end_s = 0;            ///< absolute time it came to rest
  Vec3 end_mm = Vec3::Zero();  ///< where it came to rest
};

/// One cycle of an active scan's head, for a stop request during the scan.
struct ScanHeadSample {
  double time_s = 0;  ///< absolute, at the end of the cycle
  Vec3 head_mm = Vec3::Zero();
  Vec3 velocity_mm_s = Vec3::Zero();
};

/// The motion of one command (GoTo, PtMeas, ScanPath) as it ran, so that a stop request
/// `after_s` into it can put the machine where it would have come to rest.
struct CommandMotion {
  std::uint64_t tag = 0;
  std::string what;  ///< "move to (x, y, z)", "point measurement", "scan"
  Vec3 start_mm = Vec3::Zero();
  std::int64_t start_cycle = 0;
  double end_s = 0;                    ///< absolute, when the command ended
  std::vector<PositioningMove> moves;  ///< its straight moves, in order
  std::vector<ScanHeadSample> scan;    ///< its scanning cycles, in order
  std::optional<Hit> hit_before;       ///< the last hit before the command, which a stop restores
};

/// The controller's state and its cycles.
struct Controller {
  SimulatedProbe sim;    ///< the world, through its sensors
  MachineConfig config;  ///< what the controller knows
  std::deque<Command> queue;
  std::map<std::string, Tool> tools;
  std::string active;
  std::int64_t cycle = 0;
  Vec3 position;
  double positioning_feed, measuring_feed, acceleration;
  std::optional<double> acceleration_cap;  ///< a programmed acceleration (caps per-axis rates)
  std::optional<Hit> last_hit;
  std::size_t executed = 0;
  std::function<void(const TraceSample&)> trace;
  std::function<void(double, const Vec3&)> motion_observer;  ///< Machine::set_motion_observer
  std::unique_ptr<SegmentedSession> segmented_scan;
  CommandMotion motion;                    ///< the running command's motion, as it runs
  std::optional<CommandMotion> stoppable;  ///< the last command, which ended without fault

  Controller(MachineConfig known, WorldTruth truth, std::uint64_t seed);

  // positioning.cpp
  [[nodiscard]] double now() const { return static_cast<double>(cycle) * config.dt_s; }
  [[nodiscard]] std::int64_t cycles_for(double t_s) const;
  [[nodiscard]] MotionLimits limits(const Vec3& u, double feed) const;
  [[nodiscard]] std::optional<BrakingLimits> braking(const Vec3& u, double feed) const;
  [[nodiscard]] MotionLimits braking_limits(const Vec3& u, double speed) const;
  [[nodiscard]] Tool* active_tool();
  void emit(double t_abs, const Vec3& p, double speed) const {
    if (trace) trace({t_abs, p, speed});
    if (motion_observer) motion_observer(t_abs, p);
  }
  tl::expected<void, Fault> check_travel(const Vec3& p, const char* what) const;
  tl::expected<void, Fault> move_to(const Vec3& target, double feed);
  std::optional<Response> stop_move(double after_s);

  // touch_cycle/touch_cycle.cpp
  struct Touch {
    Vec3 latched_mm;          ///< ball centre latched when the controller acted on the trigger
    double latch_time_s = 0;  ///< absolute
  };
  tl::expected<Touch, Fault> touch(const Vec3& start, const Vec3& u, double len, double feed, double search_mm,
                                   std::optional<double> reach_mm = std::nullopt);
  tl::expected<Hit, Fault> measure_point(const PtMeas& m);

  // touch_cycle/qualification.cpp
  tl::expected<ToolInfo, Fault> qualify();

  // segmented_scanning/segmented_session.cpp
  void write_scan_buffer(const ScanBufferWrite& body, Response& response);

  // virtual_cmm.cpp
  void define_tool(const DefineTool& body, Response& response);
  void scan(const ScanPath& body, Response& response);
  void contour_scan(const ContourScan& body, Response& response);
  void run_scanning(
      const ToolInfo& tool, Response& response,
      const std::function<ScanOutcome(const ScanSetup&, const std::function<void(const ScanCycle&)>&)>& scan);
  Response run(const Command& command);
};

}  // namespace metron::machine::detail
