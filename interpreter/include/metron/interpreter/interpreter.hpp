// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "metron/interpreter/ir/instruction.hpp"
#include "metron/interpreter/run_limits.hpp"
#include "metron/runtime/measurement_runtime.hpp"
#include "metron/stdlib/diagnostic.hpp"
#include "metron/stdlib/value.hpp"

namespace metron::interpreter {

namespace detail {
struct Execute;
}

/// Where execution is: a unit's code or a macro's code, and the next instruction.
struct CallFrame {
  enum class Kind { Unit, Macro } kind = Kind::Unit;
  std::size_t index = 0;                                   ///< unit or macro index in the module
  std::size_t pc = 0;                                      ///< next instruction
  std::map<std::string, std::vector<Value>> locals;        ///< macro parameters and local variables
  std::map<std::size_t, std::pair<double, double>> loops;  ///< DoInit pc -> (end, step)
  std::map<std::size_t, int> iterations;                   ///< ITERAT pc -> fits made since it last ended
  Span call_site;                                          ///< the CALL that entered this frame
};

/// How a step or a run ended.
enum class ExecStatus {
  Running,   ///< more to do
  Finished,  ///< reached ENDFIL or the end of the main unit
  Faulted,   ///< a machine fault stopped the program (results so far are kept)
  Error,     ///< a run-time program error (reported to the sink)
};

/// The IR interpreter: variables, expressions, control flow, macros, called units; it drives the
/// measurement runtime. Steppable one instruction at a time for the debugger.
class Interpreter {
 public:
  Interpreter(const ir::Module& module, runtime::MeasurementRuntime& runtime, const SourceManager& sources,
              DiagnosticSink& sink);

  /// Starts (or restarts at) a unit: pushes its frame (the REPL runs each entry as a unit).
  void start(std::size_t unit);
  /// Executes one instruction.
  ExecStatus step();
  /// Runs until the program ends, faults or errs.
  ExecStatus run();
  /// The limits checked between statements (docs/limits.md); the defaults unless set.
  void set_limits(const RunLimits& limits) { m_limits = limits; }
  [[nodiscard]] const RunLimits& limits() const { return m_limits; }
  /// While true, a stop signal is left to the caller (the debugger pauses on it) instead of ending
  /// the run with an error; the other limits still apply.
  void leave_signals_to_caller(bool v) { m_signals_to_caller = v; }
  /// Why the run stopped at a limit or on a signal (empty: it did not).
  [[nodiscard]] const std::string& stopped_by() const { return m_stopped_by; }
  /// Drops the variables and call frames (after an allocation failed: the run is over, and its
  /// results must still be written).
  void discard_program_state();
  /// The statement of the instruction that ran last (an allocation failure names it).
  [[nodiscard]] Span executing() const { return m_executing; }

  /// The instruction that will execute next (nullptr when none).
  [[nodiscard]] const ir::Instruction* current() const;
  [[nodiscard]] const std::vector<CallFrame>& frames() const { return m_frames; }
  [[nodiscard]] bool in_measurement() const { return m_block.has_value(); }
  [[nodiscard]] const std::optional<runtime::MeasBlock>& pending_block() const { return m_block; }

  /// Scripted operator answers for `V=PROMPT/...`, used in order (`metron run --answers FILE`);
  /// when they run out a PROMPT takes its default answer ('' or 0) with a warning.
  void set_prompt_answers(std::vector<std::string> answers) {
    m_prompt_answers = std::move(answers);
    m_next_answer = 0;
  }

  /// Variables (debugger `print`/`set`); nullopt when not declared.
  [[nodiscard]] std::optional<Value> variable(const std::string& name) const;
  /// Sets a declared variable (the debugger's `set`, DO loops); the error says why it cannot hold
  /// `value` (undeclared, another type, out of its range).
  tl::expected<void, std::string> set_variable(const std::string& name, const Value& value);
  /// `value` as variable `name` stores it under its declared type: INTGR truncates toward zero and
  /// must lie in the signed 32-bit range, LONG within +-2^53 (where a double still counts every
  /// integer), REAL stays REAL; a value of another type is refused.
  [[nodiscard]] tl::expected<Value, std::string> typed_value(const std::string& name, const Value& value) const;
  [[nodiscard]] const std::map<std::string, std::vector<Value>>& globals() const { return m_globals; }
  /// Evaluates an IR expression in the current context.
  tl::expected<Value, std::string> evaluate(const ir::Expr& e);

 private:
  friend struct detail::Execute;  ///< the instruction handlers (src/execute/)
  ExecStatus fail(Span span, std::string message);
  ExecStatus from_runtime(const runtime::RuntimeError& e);
  std::string label_name(const ir::LabelOperand& l) const;
  std::string indexed(const std::string& name) const;    ///< `HOLE[I]` with I's value: `HOLE[3]`
  std::string name_of(const ir::Instruction& in) const;  ///< the instruction's label, resolved through macro parameters
  tl::expected<double, std::string> number(const ir::Expr& e);
  std::vector<Value>* find_variable(const std::string& name);
  /// The element V[i,j,...] (1-based indices) of array `name` holding `size` values, as an offset
  /// into its storage; an index outside its dimension is an error naming it.
  [[nodiscard]] tl::expected<std::size_t, std::string> element_offset(const std::string& name,
                                                                      const std::vector<double>& indices,
                                                                      std::size_t size) const;
  const std::vector<ir::Instruction>& code_of(const CallFrame& f) const;

  const ir::Module& m_module;
  runtime::MeasurementRuntime& m_runtime;
  const SourceManager& m_sources;
  DiagnosticSink& m_sink;
  std::vector<CallFrame> m_frames;
  std::map<std::string, std::vector<Value>> m_globals;
  std::map<std::string, ValueType> m_types;
  std::set<std::string> m_intgr;                           ///< variables declared INTGR (32-bit) rather than LONG
  std::map<std::string, std::vector<std::size_t>> m_dims;  ///< arrays of several dimensions: V[3,30] -> {3, 30}
  std::optional<runtime::MeasBlock> m_block;
  /// ERROR/...: which machine faults the program handles from here on, and how.
  struct ErrorHandling {
    bool automatic = false;  ///< AUTO: go on after the failing statement
    std::string condition;   ///< ALL, NOTOUCH or ILLEGALTOUCH
    std::size_t frame = 0;   ///< the frame ERROR was set in (the handler's code is there)
    CallFrame::Kind kind = CallFrame::Kind::Unit;
    std::size_t index = 0;   ///< that frame's unit or macro
    std::size_t target = 0;  ///< the handler label's instruction
  };
  std::optional<ErrorHandling> m_on_error;
  /// The fault a handler is handling: where RESUME goes on.
  struct HandledFault {
    std::size_t frame = 0;
    std::size_t failed = 0;       ///< the failing instruction
    std::size_t measurement = 0;  ///< its MEAS when it is an ENDMES, else the failing instruction
  };
  std::optional<HandledFault> m_handled;
  std::optional<machine::Fault> m_last_fault;  ///< the last machine fault a statement stopped on
  std::size_t m_handled_faults = 0;
  /// BADTST/ON: a failing measurement sets BADPT (a machine fault) or BADGT (no feature fits its
  /// points) and the run goes on after it; each MEAS clears both.
  bool m_bad_test = false;
  bool m_bad_point = false;
  std::string m_current_feature;  ///< SCFEAT(): the feature the last MEAS, RMEAS or CONST named
  bool m_bad_geometry = false;
  ExecStatus take_bad_measurement(std::size_t depth, std::size_t failed);
  ExecStatus handle_fault(std::size_t frame, std::size_t failed);
  /// ERROR/'s condition word for a fault kind (NOTOUCH, ILLEGALTOUCH), nullptr for the others
  /// (only ALL covers those): ERROR's handling and SERROR() name faults alike.
  static const char* error_condition(machine::FaultKind kind);
  Vec3 m_block_position = Vec3::Zero();
  double m_length_mm = 1.0;   ///< UNITS: mm per program length unit
  bool m_degrees = true;      ///< UNITS: ANGDEC (else ANGRAD)
  bool m_fahrenheit = false;  ///< UNITS/...,TEMPF: QTEMP answers in degrees Fahrenheit
  bool m_finished = false;
  std::vector<std::string> m_prompt_answers;  // scripted PROMPT answers
  std::size_t m_next_answer = 0;
  tl::expected<Value, std::string> prompt(const ir::Expr& e);
  /// The intrinsics that need the run (SDATE, STIME, SDATETIME, SELAPSETIME, EOF, PTDATA, EXIST,
  /// DMESYS, VMCS, VPCS, QTEMP, BADPT, BADGT);
  /// nullopt for any other function (execute/run_functions.cpp).
  std::optional<tl::expected<Value, std::string>> run_function(const ir::Expr& e);
  /// An input file opened by OPEN/DID(x),...,INPUT: its fields, read in order by READ.
  struct InputFile {
    std::vector<std::string> fields;
    std::vector<std::size_t> lines;  ///< each field's line (0-based): EOLN
    std::size_t next = 0;
  };
  std::map<std::string, InputFile> m_inputs;
  /// The run clock's start for SDATE/STIME (seconds since 1970, UTC): SOURCE_DATE_EPOCH when
  /// set (reproducible runs), else the wall clock when the run starts.
  std::int64_t m_clock_start_s = 0;
  bool m_no_thermometer_warned = false;  ///< QTEMP on a machine without one: told once
  std::mt19937_64 m_random{0};           ///< RAND: the same sequence every run (seed 0, as Fortran's srand(0))
  RunLimits m_limits;
  bool m_signals_to_caller = false;
  Span m_executing;
  std::uint64_t m_steps = 0;
  double m_wall_start_s = -1;  ///< steady-clock time of the first step
  std::string m_stopped_by;
  /// Checks the limits and a stop request before `in` executes; an error naming it when one is hit.
  std::optional<ExecStatus> check_limits(const ir::Instruction& in);
};

}  // namespace metron::interpreter
