// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "metron/interpreter/session.hpp"

namespace metron::interpreter {

/// A place to stop: a source line, the measurement of a feature, or any machine fault.
struct Breakpoint {
  enum class Kind { Line, Feature, Fault } kind = Kind::Line;
  int id = 0;
  std::string file;        ///< Line: file path as loaded, or empty for any file
  std::uint32_t line = 0;  ///< Line
  std::string feature;     ///< Feature: upper-case label (stop after its MEAS block ran)
  std::uint32_t hits = 0;
};

/// Why execution stopped.
enum class StopReason {
  Breakpoint,   ///< a line breakpoint, before the statement runs
  Measured,     ///< a feature breakpoint, after the feature was measured
  Step,         ///< a step, next or finish completed
  Fault,        ///< a machine fault (with `break fault`, or ending the run)
  Error,        ///< a run-time program error
  Finished,     ///< the program ended
  Interrupted,  ///< SIGINT or SIGTERM while the program ran (Stop::signal); it can resume
};

/// The outcome of a run/continue/step command.
struct Stop {
  StopReason reason = StopReason::Finished;
  int breakpoint = 0;  ///< the breakpoint id that stopped it, when one did
  std::string detail;  ///< e.g. the feature measured, the fault message
  int signal = 0;      ///< Interrupted: the signal number
};

/// The debugger core: breakpoints and stepping over the IR interpreter; the REPL (cli) drives it.
class Debugger {
 public:
  explicit Debugger(Session& session) : m_session(session) {}

  int break_at_line(const std::string& file, std::uint32_t line);
  int break_at_feature(const std::string& label);
  int break_on_fault();
  bool remove(int id);
  [[nodiscard]] const std::vector<Breakpoint>& breakpoints() const { return m_breakpoints; }

  /// Runs until a breakpoint, a fault (with `break fault`), an error or the end.
  Stop resume();
  /// One statement, into macros and called files.
  Stop step();
  /// One statement, over macro calls and called files.
  Stop next();
  /// Until the current macro or called file returns.
  Stop finish();

  /// The statement about to run (invalid span when the program has ended).
  [[nodiscard]] Span current_span() const;
  /// Call stack, innermost first: "file:line: statement" lines.
  [[nodiscard]] std::vector<std::string> where() const;
  /// Source around the current statement, with a marker on it.
  [[nodiscard]] std::string list(int context_lines = 5) const;
  [[nodiscard]] bool finished() const { return m_finished; }

 private:
  enum class Mode { Continue, Step, Next, Finish };
  Stop drive(Mode mode);
  std::optional<int> line_breakpoint_at(Span span) const;
  std::string describe(Span span) const;

  Session& m_session;
  std::vector<Breakpoint> m_breakpoints;
  int m_next_id = 1;
  bool m_finished = false;
  bool m_started = false;
};

}  // namespace metron::interpreter
