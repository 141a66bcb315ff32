// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "metron/machine/command.hpp"

namespace metron::machine {

/// What the controller can say about itself (for reports and the debugger's `machine` command).
struct MachineState {
  Vec3 position_mm = Vec3::Zero();  ///< ball centre, machine coordinates
  Vec3 velocity_mm_s = Vec3::Zero();
  double time_s = 0;             ///< simulated clock
  std::string active_tool;       ///< empty when none selected
  std::optional<ToolInfo> tool;  ///< calibration of the active tool
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
  /// Where the machine goes home to (DMIS GOHOME), machine coordinates, when the backend knows.
  std::optional<Vec3> home_mm;
  /// A dry run's machine (every touch on its nominal, moves without ramps): it has no dynamics a
  /// characterisation could measure.
  bool nominal = false;
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
  /// Stops the last executed command as a stop request `after_s` into it would have (I++ DME
  /// AbortE during a motion, docs/ipp-dme.md). A simulated machine runs every command at once, so
  /// the stop comes afterwards: a motion (GoTo, PtMeas, an active scan) that ended without fault
  /// is cut at `after_s` and braked to rest at the machine's limits; position and clock become
  /// the stop's, and the answer returned (FaultKind::Aborted) replaces the command's. nullopt:
  /// nothing to stop (the last command did not move, or it was over by then), or a backend that
  /// cannot.
  virtual std::optional<Response> stop_last_motion(double /*after_s*/) { return std::nullopt; }
  /// The program stops for its operator (DMIS PAUSE). A simulated machine's virtual operator does
  /// what its world has him do there (puts the part in its next set-up); the answer says what
  /// was done, for the run's record. nullopt: nothing (a real controller, or nothing to do).
  virtual std::optional<std::string> operator_stop() { return std::nullopt; }
  /// Called with the controller clock and the ball centre (machine coordinates) every control
  /// cycle while the machine moves, for position reports along a motion (I++ DME
  /// OnMoveReportE); nullptr removes it. false: this backend cannot report its motion.
  virtual bool set_motion_observer(std::function<void(double time_s, const Vec3& position_mm)> /*observer*/) {
    return false;
  }
};

}  // namespace metron::machine
