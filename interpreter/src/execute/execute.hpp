// SPDX-License-Identifier: GPL-3.0-or-later
// The executor's instruction handlers, one file per DMIS statement family (execute/*.cpp). Each
// family adds its rows (operation -> handler) to the table the interpreter dispatches through.
#pragma once
#include <array>
#include <functional>
#include <initializer_list>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "metron/interpreter/interpreter.hpp"

namespace metron::interpreter::detail {

/// Executes one instruction; `frame` is the current frame, its pc already past the instruction.
using ExecuteFn = ExecStatus(Interpreter& vm, const ir::Instruction& in, CallFrame& frame);
using ExecuteTable = std::array<ExecuteFn*, ir::op_count>;

inline constexpr double pi = 3.14159265358979323846;

constexpr std::size_t index(ir::Op op) { return static_cast<std::size_t>(op); }

/// Adds a family's rows to the table.
inline void add_rows(ExecuteTable& t, std::initializer_list<std::pair<ir::Op, ExecuteFn*>> rows) {
  for (const auto& [op, fn] : rows) t[index(op)] = fn;
}

/// A friend of the Interpreter: the handlers read and change its state.
struct Execute {
  /// Every family's rows (built once); an operation without a row is an internal error.
  static const ExecuteTable& table();

  // ---- shared helpers ------------------------------------------------------------------------
  /// Evaluates every Expr operand to a number, in order; the error names the expression.
  static std::optional<std::string> numbers(Interpreter& vm, const ir::Instruction& in, std::vector<double>& out);
  /// The Word operands, in order.
  static std::vector<std::string> words(const ir::Instruction& in);
  /// Degrees per program angle unit (UNITS: ANGDEC or ANGRAD).
  static double degrees(const Interpreter& vm);
  /// A position of the program in mm: CART as written, POL (radius, angle, height) in the working
  /// plane WKPLAN set (XYPLAN until one), as CMM software reads polar coordinates.
  static Vec3 position(const Interpreter& vm, ir::CoordinateForm form, double a, double b, double c);
  static runtime::FeatureRef feature_ref(const Interpreter& vm, const ir::LabelOperand& l);
  /// A setting (FEDRAT, ACLRAT, SNSET) applied now, or inside a MEAS block where it stands among
  /// the block's points, which are measured at ENDMES.
  using SettingFn = std::function<runtime::Result<void>(runtime::MeasurementRuntime&)>;
  static ExecStatus apply_setting(Interpreter& vm, const ir::Instruction& in, SettingFn apply);

  // ---- expressions (expressions.cpp) ---------------------------------------------------------
  static tl::expected<Value, std::string> obtain(Interpreter& vm, const ir::Expr& e);
  static tl::expected<Value, std::string> query(Interpreter& vm, const ir::Expr& e);
  static tl::expected<Value, std::string> binary(Interpreter& vm, const ir::Expr& e);

  // ---- families: each adds its rows ----------------------------------------------------------
  static void add_input_output(ExecuteTable& t);  // io_ops.cpp
  static void add_definitions(ExecuteTable& t);   // definition_ops.cpp
  static void add_measurement(ExecuteTable& t);   // measurement_ops.cpp
  static void add_scanning(ExecuteTable& t);      // scan_ops.cpp
  static void add_alignment(ExecuteTable& t);     // alignment_ops.cpp
  static void add_control(ExecuteTable& t);       // control_ops.cpp

  static ExecuteFn units, decimal_places, read, write, mode, text, pause, device_def, device_open, device_close;
  static ExecuteFn feature_def, tolerance_def, sensor_def, datdef, declare;
  static ExecuteFn fit_algorithm;
  static ExecuteFn work_plane;
  static ExecuteFn push;
  static ExecuteFn pop;
  static ExecuteFn go_home;
  static ExecuteFn set_home;
  static ExecuteFn on_error;
  static ExecuteFn bad_test;
  static ExecuteFn resume;
  static ExecuteFn sensor_select, probe_set, feed, accel, go_to, meas_begin, ptmeas, meas_end;
  static ExecuteFn path_def, scan_mode, scan_set, pameas;
  static std::vector<runtime::OutputItem> output_items(Interpreter& vm, const ir::Instruction& in);
  static ExecuteFn output, evaluate, datset, trans, rotate, locate, iterate, save, recall, equate, construct;
  static ExecuteFn nothing, system, end, assign, jump, jump_if_false, do_init, do_next, call_macro, return_, call_unit;
};

}  // namespace metron::interpreter::detail
