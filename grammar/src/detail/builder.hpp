// SPDX-License-Identifier: GPL-3.0-or-later
// The parser state: actions build one Statement per logical line on value stacks.
#pragma once
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "metron/grammar/ast.hpp"
#include "metron/grammar/preprocess.hpp"
#include "metron/stdlib/span.hpp"

namespace metron::grammar::detail {

/// A syntax error: thrown by the PEGTL control on a failed `must<>`, caught per logical line.
struct SyntaxError {
  std::string code;
  std::string message;
  Span span;
};

/// An identifier waiting for what follows it to decide whether it is a word, a label, a call
/// or an array element.
struct PendingIdent {
  std::string upper;
  Span span;
};

/// An operator matched but not yet combined with its operands.
struct PendingOp {
  std::string text;
  Span span;
};

/// Nesting limit for parentheses and unary chains, so hostile input cannot overflow the stack.
inline constexpr int max_nesting = 64;
/// Limit on binary operators in one statement: a left-associative chain (1+1+...+1) nests one
/// tree level per operator, and the compiler, the evaluator and the tree's destructor recurse
/// once per level; 6,600 terms overflowed the stack (issue 15). No real statement has 1,000.
inline constexpr int max_operators = 1000;

/// Builder state for one logical line.
struct Builder {
  std::uint32_t file = 0;
  const LogicalLine* line = nullptr;
  const char* base = nullptr;  ///< first byte of line->text, for logical offsets

  std::vector<Expr> stack;           ///< finished operands
  std::vector<PendingOp> ops;        ///< operators awaiting their right operand
  std::vector<PendingIdent> idents;  ///< identifiers awaiting '(' / '[' / nothing
  std::vector<std::size_t> marks;    ///< stack size at each open call or index list
  /// The label references being read (an index may hold another): the name, its index.
  struct PendingLabel {
    std::string name;
    std::vector<Expr> index;
    std::vector<Expr> points;
  };
  std::vector<PendingLabel> labels;
  const char* string_open = nullptr;  ///< the opening quote of the string being read
  int depth = 0;
  int operators = 0;  ///< binary and sign operators read so far (max_operators)
  Statement stmt;
  std::optional<Span> blank_in_label;  ///< the first label name written with a blank (`F(HOLE 1)`)

  [[nodiscard]] std::size_t offset(const char* p) const { return static_cast<std::size_t>(p - base); }

  /// Physical span of the logical bytes [b, e).
  [[nodiscard]] Span span(const char* b, const char* e) const {
    const std::size_t lb = offset(b), le = offset(e);
    const std::uint32_t pb = line->physical[lb];
    return Span{file, pb, le > lb ? line->physical[le - 1] + 1 : pb};
  }
  /// Physical span of the byte at p (empty at the end of the line).
  [[nodiscard]] Span point(const char* p) const {
    const std::size_t lb = offset(p);
    if (lb >= line->text.size()) return Span{file, line->physical[lb], line->physical[lb]};
    return Span{file, line->physical[lb], line->physical[lb] + 1};
  }

  Expr pop() {
    Expr e = std::move(stack.back());
    stack.pop_back();
    return e;
  }
  PendingIdent pop_ident() {
    PendingIdent i = std::move(idents.back());
    idents.pop_back();
    return i;
  }
  PendingOp pop_op() {
    PendingOp o = std::move(ops.back());
    ops.pop_back();
    return o;
  }
};

/// ASCII upper case (DMIS words are ASCII; other bytes pass through).
inline std::string upper(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 'a' + 'A');
  return out;
}

}  // namespace metron::grammar::detail
