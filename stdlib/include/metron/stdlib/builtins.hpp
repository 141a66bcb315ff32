// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <tl/expected.hpp>

#include "metron/stdlib/value.hpp"

namespace metron {

/// A DMIS intrinsic function: name, arity and result type (for the compiler's checks).
struct Builtin {
  std::string_view name;
  int min_args = 1;
  int max_args = 1;
  ValueType result = ValueType::Real;
  bool string_args = false;  ///< takes strings (LEN, SUBSTR, CONCAT ...) rather than numbers
  bool vector_args = false;  ///< takes VECTORs (VCROSS, VDOT, VMAG, ...)
};

/// Looks up an intrinsic by upper-case name (ABS, SQRT, SIN, ..., CONCAT, STR, ...).
const Builtin* find_builtin(std::string_view name);
/// All intrinsics (for completion and docs).
const std::vector<Builtin>& builtins();

/// Evaluates an intrinsic. Trigonometric functions take and return angles in degrees when
/// `degrees` (UNITS/...,ANGDEC), else radians. Errors are lowercase messages ("SQRT of a negative number").
tl::expected<Value, std::string> call_builtin(const Builtin& fn, const std::vector<Value>& args, bool degrees);

}  // namespace metron
