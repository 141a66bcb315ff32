// SPDX-License-Identifier: GPL-3.0-or-later
// The limits of a run (docs/limits.md): no program, however hostile, runs forever or grows
// memory without bound; each limit stops the run with an error naming the statement, and the
// results obtained so far are written.
#pragma once
#include <csignal>
#include <cstdint>
#include <optional>
#include <string>

namespace metron::interpreter {

/// Limits checked between statements by the interpreter; 0 switches one off.
struct RunLimits {
  /// IR instructions executed (a statement is one to a few): 50 million is minutes of a real
  /// inspection's worth of control flow and stops an endless JUMPTO loop in seconds.
  std::uint64_t max_steps = 50'000'000;
  /// Simulated machine time: 24 h, beyond any inspection.
  double max_simulated_s = 86'400;
  /// Wall-clock time of the run: 1 h.
  double max_wall_s = 3'600;
  /// Reported events (OUTPUT results, texts, faults) kept in memory for results.json: 200,000.
  std::uint64_t max_outputs = 200'000;
  /// The process's heap, MiB (RLIMIT_DATA, which the CLI sets for run, debug and repl with
  /// apply_memory_limit): 4 GiB, several times the largest run measured (docs/limits.md). An
  /// allocation beyond it stops the run like the other limits, with the results so far kept.
  std::uint64_t max_memory_mib = 4096;
};

/// Caps the process's data segment (heap and private writable mappings: RLIMIT_DATA) at `mib`
/// MiB; 0 leaves it. The sanitizer build leaves it too (ASan's own mappings count against the
/// limit). Empty when done (or left on purpose), otherwise why it could not be set.
std::optional<std::string> apply_memory_limit(std::uint64_t mib);

/// Asks every running interpreter to stop at its next statement (async-signal-safe: only sets a
/// flag). `signal` is the signal number for the message (0: not a signal).
void request_stop(int signal) noexcept;
/// The signal that asked to stop (0: none).
int stop_requested() noexcept;
/// Clears a stop request (tests, the debugger's next command).
void clear_stop() noexcept;
/// Installs SIGINT and SIGTERM handlers that call request_stop (metron run, debug).
void install_stop_signal_handlers();

/// The stop handlers for the lifetime of the scope, the earlier dispositions after it, and no
/// stale request on either side: the debugger runs the program inside one, so that Ctrl-C pauses
/// the program while it runs and acts as usual at the prompt.
class StopSignalScope {
 public:
  StopSignalScope();
  ~StopSignalScope();
  StopSignalScope(const StopSignalScope&) = delete;
  StopSignalScope& operator=(const StopSignalScope&) = delete;

 private:
  struct sigaction m_interrupt {};
  struct sigaction m_terminate {};
};

}  // namespace metron::interpreter
