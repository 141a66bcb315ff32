// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <cstddef>
#include <functional>
#include <optional>
#include <vector>

#include <tl/expected.hpp>

#include "metron/machine/fault.hpp"
#include "metron/machine/measurement_command.hpp"
#include "metron/machine/segmented_scanning/path_interpolator.hpp"
#include "metron/machine/segmented_scanning/scan_recorder.hpp"
#include "metron/machine/segmented_scanning/speed_plan.hpp"

// The simulated motion controller of segmented continuous scanning (SEEDS.md 2): two command
// buffers, a speed-pattern planner that takes simulated time Tp, and the interpolator.
namespace metron::machine::segmented {

/// How the controller runs a path that spans several commands.
enum class SegmentedMode {
  Conventional,  ///< each command: approach, scan, stop, retract; plan the next after the stop
  Seed,          ///< SEEDS.md 2: double buffer, low-speed region, connection judgement, fallback
  LookAhead,     ///< metron: double buffer, junction speeds planned across buffered commands
};

/// Configuration of the simulated controller.
struct ControllerConfig {
  SegmentedMode mode = SegmentedMode::Seed;  ///< boundary behaviour
  ScanLimits limits;                         ///< scanning motion limits
  LowSpeedRegion low;                        ///< the seed's low-speed region
  double dt_s = 0.001;                       ///< control cycle
  std::size_t buffer_segments = 1000;        ///< P: one buffer's capacity in segments
  /// Net simulated planning time per segment. Default: the planner's measured cost on the build
  /// host (bench_segmented, P = 1000, with a piece per quarter segment since issue 11: min 1.44,
  /// median 1.47, p99 1.51 us per segment), rounded up to 2 us; a constant, so simulated results
  /// never depend on the wall clock.
  double planning_s_per_segment = 2e-6;
  double planning_fixed_s = 0.0;  ///< plus this per command
  double planning_margin = 1.3;   ///< Tp = margin * net planning time (SEEDS.md 2 step 4)
  /// Actual planning time / net planning time for command i (default 1: plans take the net
  /// time); > margin makes the plan of command i late.
  std::function<double(std::size_t)> planning_factor;
  double retract_mm = 2.0;                        ///< retract (and approach) distance off the surface
  MotionLimits positioning{50.0, 500.0, 5000.0};  ///< limits of retract and approach moves
  double contact_settle_s = 0.3;                  ///< after an approach: contact and settling at E0
  /// Look-ahead only: when the next plan is still being made, slow down so the buffered end is
  /// reached when the plan is expected (start + Tp) instead of stopping there.
  bool pace_to_planner = true;
};

/// What happened at the boundary between Ci and Ci+1.
struct BoundaryEvent {
  std::size_t next_command = 0;  ///< i+1
  double s_mm = 0;               ///< arc length of the boundary
  double t_s = 0;                ///< when the probe passed (or reached) it
  double speed_mm_s = 0;         ///< path speed there (0 when it stopped)
  bool stopped = false;          ///< the probe came to rest at the boundary
  bool retracted = false;        ///< and retracted / approached again
  bool late_plan = false;        ///< a connection plan was not ready in time (seed fallback)
};

/// Figures of one run.
struct SegmentedStats {
  std::size_t stops = 0;       ///< rests at a command boundary before the path end
  std::size_t retracts = 0;    ///< retract-approach cycles at boundaries
  std::size_t late_plans = 0;  ///< connection plans not ready in time
  double scan_start_s = 0;     ///< first motion along the path
  double scan_end_s = 0;       ///< rest at the path end
  [[nodiscard]] double scan_time_s() const { return scan_end_s - scan_start_s; }
  std::vector<PlanKind> plan_kinds;       ///< per command
  std::vector<double> planning_wall_s;    ///< wall-clock time of each plan (host CPU)
  std::vector<BoundaryEvent> boundaries;  ///< per boundary, in order
};

/// The controller: load commands into free buffers, call step() every cycle.
class SegmentedController {
 public:
  /// A controller at rest before the path start; `recorder` (may be null) gets every scanning
  /// cycle. Throws std::invalid_argument for a low speed outside 1-5 mm/s or a zero cycle/buffer.
  explicit SegmentedController(ControllerConfig config, ScanRecorder* recorder = nullptr);

  /// Buffer status SB(b) for b = 1, 2: 0 writable, 1 full.
  [[nodiscard]] int status_flag(int b) const { return m_buffers.at(static_cast<std::size_t>(b - 1)).full ? 1 : 0; }
  /// Buffer flag B: the buffer (1 or 2) holding the command being executed.
  [[nodiscard]] int buffer_flag() const { return m_exec_buffer + 1; }
  /// Connection flag LF of the current cycle (SEEDS.md 2 step 4): 1 while the executing command's
  /// gap time tei - t exceeds Tp; the planner reads it when it takes up the next command.
  [[nodiscard]] bool connection_flag() const { return m_lf; }
  /// A writable buffer (1 or 2), or 0 when both are full.
  [[nodiscard]] int free_buffer() const;
  /// Writes Ci into a free buffer; commands must come in order and fit one buffer.
  tl::expected<void, Fault> load(MeasurementCommand command);
  /// Advances one control cycle.
  void step();
  /// The path has been scanned to its end and the probe rests there.
  [[nodiscard]] bool finished() const { return m_phase == Phase::Done; }
  /// Simulated time t.
  [[nodiscard]] double time_s() const { return m_t_s; }
  /// Figures so far.
  [[nodiscard]] const SegmentedStats& stats() const { return m_stats; }
  /// The interpolator's state (arc length along the whole path, speed, acceleration).
  [[nodiscard]] const PathState& path_state() const { return m_interp.state(); }
  /// The configuration in use.
  [[nodiscard]] const ControllerConfig& config() const { return m_config; }
  /// Tp for a command of n segments (the judgement value: margin * net time).
  [[nodiscard]] double planning_time_s(std::size_t segments) const;
  /// Duration of one retract move.
  [[nodiscard]] double retract_time_s() const;
  /// Duration of one approach (move plus contact settling).
  [[nodiscard]] double approach_time_s() const;

 private:
  enum class Phase { Retracted, Approaching, Scanning, Retracting, Done };
  struct Buffer {
    bool full = false;  // SB
    std::optional<MeasurementCommand> command;
    std::optional<SpeedPlan> plan;
    bool plan_ready = false;
    bool attached = false;  // its pieces are in the interpolator
  };

  void start_planning(std::size_t b);
  void update_connection_flag();
  void attach(std::size_t b, bool from_rest);
  void finish_completed_commands();
  void finish_one_command();
  [[nodiscard]] double remaining_time_s(const SpeedPlan& plan, double s_mm) const;
  [[nodiscard]] double gap_before_s(std::size_t index) const;
  [[nodiscard]] int buffer_of(std::size_t command_index) const;
  bool record_cycle();  // false when there was nothing to record
  [[nodiscard]] bool drives_probe() const { return m_recorder != nullptr && m_recorder->drives_probe(); }
  void pace();

  ControllerConfig m_config;
  ScanRecorder* m_recorder;
  std::array<Buffer, 2> m_buffers;
  int m_exec_buffer = 0;
  std::size_t m_next_load = 0, m_next_plan = 0, m_next_attach = 0, m_done_commands = 0;
  bool m_last_loaded = false;
  std::optional<std::size_t> m_last_index;
  int m_planning = -1;           // buffer being planned
  double m_plan_ready_s = 0;     // when the plan will be ready (simulated truth)
  double m_plan_expected_s = 0;  // when the controller expects it: start + Tp
  double m_next_start_mm = 0;
  bool m_lf = false;
  Phase m_phase = Phase::Retracted;
  double m_phase_end_s = 0;  // end of the current retract / approach
  int m_approach_buffer = -1;
  bool m_stop_counted = false;
  double m_t_s = 0;
  PathInterpolator m_interp;
  SegmentedStats m_stats;
};

}  // namespace metron::machine::segmented
