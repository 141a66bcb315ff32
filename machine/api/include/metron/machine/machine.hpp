// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "metron/machine/command.hpp"

namespace metron::machine {

/// What the controller can say about itself (for reports and the debugger's `machine` command).
struct MachineState {
  Vec3 position_mm = Vec3::Zero();    ///< ball centre, machine coordinates
  Vec3 velocity_mm_s = Vec3::Zero();
  double time_s = 0;                  ///< simulated clock
  std::string active_tool;            ///< empty when none selected
  std::optional<ToolInfo> tool;       ///< calibration of the active tool
  std::optional<Hit> last_hit;
  double positioning_feed_mm_s = 0;
  double measuring_feed_mm_s = 0;
  std::size_t queued_commands = 0;
  std::size_t executed_commands = 0;
  /// Segments one scan command buffer holds (a longer ScanPath must come as ScanBufferWrite).
  std::size_t scan_buffer_segments = 0;
  /// The machine's thermometer (its scales' temperature, C, to 0.01 K) when it has one: the
  /// controller interpolates a compensation map calibrated at several temperatures by it.
  std::optional<double> temperature_c;
};

/// A machine backend: the virtual CMM, or a real controller behind the same interface.
class Machine {
 public:
  virtual ~Machine() = default;
  /// Queues a command; nothing moves until execute().
  virtual void submit(Command command) = 0;
  /// Executes the queue in order and answers every command. After a fault, the remaining
  /// queued commands are answered with FaultKind::Aborted and the queue is empty.
  virtual std::vector<Response> execute() = 0;
  [[nodiscard]] virtual MachineState state() const = 0;
  /// Commands waiting in the queue (for the debugger).
  [[nodiscard]] virtual std::vector<Command> queued() const = 0;
};

}  // namespace metron::machine
