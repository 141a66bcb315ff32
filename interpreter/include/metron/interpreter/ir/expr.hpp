// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <string>
#include <vector>

#include "metron/stdlib/span.hpp"
#include "metron/stdlib/value.hpp"

namespace metron::interpreter::ir {

/// A label operand: `prefix(name)`, or a macro parameter standing for a label passed by the caller.
struct LabelOperand {
  std::string prefix;        ///< F, FA, T, TA, D, DA, DAT, DID, S, M ...
  std::string name;          ///< upper-case name (macro parameter name when `param` is set)
  std::optional<int> param;  ///< index of the enclosing macro's parameter that supplies the name
  Span span;
};

enum class ExprOp {
  Constant,  ///< `value`
  Variable,  ///< `name` (upper-case)
  Element,   ///< `name`[args...]
  Call,      ///< intrinsic `name`(args...)
  Obtain,    ///< OBTAIN/FA(x),n as a value: `label`, args[0] = parameter index
  Query,     ///< VALUE/FA(x),SIZE,n | VALUE/TA(t),ACT|DEV|AMT|INTOL|OUTOL,n: `label`, `name` = the word, args[0] = n
  Unary,     ///< `name` = "-", "+", ".NOT."; args[0]
  Binary,    ///< `name` = operator; args[0], args[1]
};

/// A typed, resolved expression; its static type is `type` (Real when unknown until run time).
struct Expr {
  ExprOp op = ExprOp::Constant;
  Span span;
  ValueType type = ValueType::Real;
  Value value;
  std::string name;
  LabelOperand label;
  std::vector<Expr> args;
};

/// Renders an expression in DMIS syntax (for --emit-ir and the debugger).
std::string to_string(const Expr& e);

}  // namespace metron::interpreter::ir
