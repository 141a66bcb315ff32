// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "metron/interpreter/compiler.hpp"
#include "metron/interpreter/interpreter.hpp"
#include "metron/interpreter/run_limits.hpp"
#include "metron/machine/machine.hpp"
#include "metron/runtime/measurement_runtime.hpp"
#include "metron/runtime/run_record.hpp"

namespace metron::interpreter {

/// A machine backend and what the run record says about it. The composition root (cli) builds
/// it: the virtual CMM today, a real controller behind machine::Machine tomorrow.
struct Backend {
  std::unique_ptr<machine::Machine> machine;  ///< the backend
  std::string world;                          ///< for the record: world file, or "<default>"
  std::uint64_t seed = 0;                     ///< for the record: the run seed
  /// Wavefront stations for CALL/EXTERN,SYS,'CALIBRATE WAVEFRONT world' (empty: none).
  runtime::WavefrontStationFactory wavefront_stations;
  runtime::ErrorSpaceRig error_space_rig;  ///< CALIBRATE ERROR-SPACE on this machine (none: refused)
};

/// Builds a backend for a world file (none: the default world) and a seed (none: the world's);
/// the error message names the file.
using BackendFactory = std::function<tl::expected<Backend, std::string>(const std::optional<std::string>& world_path,
                                                                        std::optional<std::uint64_t> seed)>;

/// What `metron run` needs.
struct RunOptions {
  std::string program;                                     ///< path of the main program
  std::optional<std::string> world_path;                   ///< world JSON; empty = the embedded default world
  std::optional<std::uint64_t> seed;                       ///< empty = the world's seed
  std::string out_dir = ".";                               ///< results.json and DMIS output files go here
  std::function<void(const runtime::RunEvent&)> on_event;  ///< live report
  /// A machine characterisation file (docs/touch-trigger.md); PTMEAS uses its touch strategy.
  std::optional<std::string> characterisation_path;
  /// A conventional touch cycle for PTMEAS instead of the characterised one (`--touch-baseline`).
  std::optional<runtime::TouchBaseline> touch_baseline;
  /// Strict reading: a line that is not a DMIS statement is an error, not a warning.
  bool strict = false;
  /// Scripted operator answers for PROMPT, in order (`--answers FILE`, one per line).
  std::vector<std::string> prompt_answers;
  /// Folders CALL/EXTERN and CHARACTERISATION may read besides the program's own, also searched
  /// for CALL/EXTERN,DMIS files written with another machine's path (--include; docs/security.md).
  std::vector<std::string> include_dirs;
  /// Step, time and output limits (docs/limits.md).
  RunLimits limits;
};

/// Exit status of a run: 0 completed, 1 program error (compile or run time, an output that could
/// not be written), 2 bad input (program file, world, options), 3 machine fault, 4 stopped by a
/// run limit or a signal (docs/limits.md; results so far are written).
enum class RunExit { Completed = 0, ProgramError = 1, BadInput = 2, Faulted = 3, Stopped = 4 };

/// The outcome of a run.
struct RunOutcome {
  RunExit exit = RunExit::Completed;
  runtime::RunRecord record;
  std::string diagnostics;   ///< formatted diagnostics (compile and run time)
  std::string results_path;  ///< results.json written (empty if not written)
};

/// A loaded program with its machine, runtime and interpreter: what `run`, `debug` and the test
/// runner share.
class Session {
 public:
  /// A session on `backend` (built by the composition root).
  static std::unique_ptr<Session> create(Backend backend);
  /// Compiles the program as unit 0 and prepares to run it; false on compile errors, or when
  /// a characterisation is in use and a FEDRAT/MESVEL with a constant value asks for a probing
  /// feed above its maximum protected feed (refused before any motion).
  bool load(const std::string& program);
  /// Folders the program may read besides its own (--include); set before load().
  void set_include_dirs(std::vector<std::string> dirs) { m_compiler.set_include_dirs(std::move(dirs)); }
  /// Compiles REPL text as a new unit and runs it to completion in the current context.
  ExecStatus execute_text(const std::string& text);

  SourceManager& sources() { return m_sources; }
  DiagnosticSink& sink() { return m_sink; }
  Compiler& compiler() { return m_compiler; }
  Interpreter& interpreter() { return *m_interpreter; }
  runtime::MeasurementRuntime& runtime() { return *m_runtime; }
  machine::Machine& machine() { return *m_machine; }
  runtime::RunRecord& record() { return m_record; }
  /// Formats and clears the diagnostics collected so far.
  std::string take_diagnostics();

 private:
  Session() = default;
  SourceManager m_sources;
  DiagnosticSink m_sink;
  Compiler m_compiler{m_sources, m_sink};
  runtime::RunRecord m_record;
  std::unique_ptr<machine::Machine> m_machine;
  std::unique_ptr<runtime::MeasurementRuntime> m_runtime;
  std::unique_ptr<Interpreter> m_interpreter;
};

/// `metron run`: build the backend with `backend` from the options' world and seed, compile, run
/// on the machine, write results.json and DMIS outputs.
RunOutcome run_program(const RunOptions& options, const BackendFactory& backend);

}  // namespace metron::interpreter
