// SPDX-License-Identifier: GPL-3.0-or-later
// Syntax error messages, one per rule that a `must<>` requires, and the PEGTL control that
// raises them (plus a nesting guard against stack exhaustion).
#pragma once
#include <algorithm>
#include <cstdio>
#include <string>
#include <type_traits>

#include "detail/builder.hpp"
#include "detail/rules.hpp"

namespace metron::grammar::detail {

template <typename Rule>
struct tag {};

inline bool is_printable(char c) { return c > ' ' && c < 0x7f; }

/// `'%'` for a printable byte, `'é'` for a whole UTF-8 character (files are decoded to UTF-8 when
/// read), `'\x00'` for anything else.
inline std::string describe_char(std::string_view rest) {
  const auto c = static_cast<unsigned char>(rest.front());
  if (is_printable(rest.front())) return std::string("'") + rest.front() + "'";
  const std::size_t length = c >= 0xF0 && c < 0xF5 ? 4 : c >= 0xE0 ? 3 : c >= 0xC2 && c < 0xE0 ? 2 : 0;
  if (length > 1 && length <= 4 && rest.size() >= length &&
      std::all_of(rest.begin() + 1, rest.begin() + static_cast<std::ptrdiff_t>(length),
                  [](char k) { return (static_cast<unsigned char>(k) & 0xC0) == 0x80; }))
    return "'" + std::string(rest.substr(0, length)) + "'";
  char buf[8];
  std::snprintf(buf, sizeof buf, "'\\x%02x'", static_cast<unsigned>(c));
  return buf;
}

inline bool at_end(const Builder& b, const char* at) { return b.offset(at) >= b.line->text.size(); }

inline SyntaxError expected(const Builder& b, const char* at, std::string code, std::string message) {
  return SyntaxError{std::move(code), std::move(message), b.point(at)};
}

inline std::string last_op(const Builder& b) { return b.ops.empty() ? std::string("operator") : b.ops.back().text; }
inline std::string last_ident(const Builder& b) { return b.idents.empty() ? std::string() : b.idents.back().upper; }

// "unexpected character 'c' after <what>", or "unknown operator '.XX.' after <what>".
inline SyntaxError unexpected(const Builder& b, const char* at, const std::string& what) {
  if (at_end(b, at)) return expected(b, at, "parse.unexpected-end", "unexpected end of the statement after " + what);
  const std::string_view rest(at, b.line->text.size() - b.offset(at));
  if (rest.size() > 2 && rest[0] == '.') {
    std::size_t i = 1;
    while (i < rest.size() && ((rest[i] >= 'A' && rest[i] <= 'Z') || (rest[i] >= 'a' && rest[i] <= 'z'))) ++i;
    if (i > 1 && i < rest.size() && rest[i] == '.') {
      const std::string op = upper(rest.substr(0, i + 1));
      return SyntaxError{"parse.unknown-operator", "unknown operator '" + op + "' after " + what,
                         b.span(at, at + i + 1)};
    }
  }
  return expected(b, at, "parse.unexpected-character",
                  "unexpected character " + describe_char(rest) + " after " + what);
}

// ---- one message per required rule ----------------------------------------------------------
// clang-format off
inline SyntaxError error_for(tag<rules::string_close>, const Builder& b, const char* at) {
  return expected(b, b.string_open ? b.string_open : at, "parse.unterminated-string", "unterminated string");
}
inline SyntaxError error_for(tag<rules::bad_number_suffix>, const Builder& b, const char* at) {
  return unexpected(b, at, "a number");
}
inline SyntaxError error_for(tag<rules::format_width>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-format", "expected a field width after ':' (WRITE/DID(x),V:10:3)");
}
inline SyntaxError error_for(tag<rules::format_decimals>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-format", "expected the number of decimals after the second ':' (WRITE/DID(x),V:10:3)");
}
inline SyntaxError error_for(tag<rules::paren_inner>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-expression", "expected an expression after '('");
}
inline SyntaxError error_for(tag<rules::paren_close>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-close", "expected ')' after the expression in parentheses");
}
inline SyntaxError error_for(tag<rules::label_ref_name>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-label-name", "expected a label name after '" + last_ident(b) + "('");
}
inline SyntaxError error_for(tag<rules::label_index_expr>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-expression", "expected the label's index after '[' (F(HOLE[I]))");
}
inline SyntaxError error_for(tag<rules::label_index_close>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-close", "expected ']' after the label's index");
}
inline SyntaxError error_for(tag<rules::label_point_expr>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-expression", "expected a point number after '[' (FA(x)[1,N])");
}
inline SyntaxError error_for(tag<rules::label_points_close>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-close", "expected ']' after the point range");
}
// A word processor's quote where a string starts (text copied from a document or a web page).
inline std::string typographic_quote_hint(const Builder& b, const char* at) {
  if (at_end(b, at)) return {};
  const std::string_view rest(at, b.line->text.size() - b.offset(at));
  for (const std::string_view q : {"\u2018", "\u2019", "\u201C", "\u201D", "\u00B4"})
    if (rest.substr(0, q.size()) == q)
      return ": " + std::string(q) + " is a typographic quote; a DMIS string is quoted with ' (an apostrophe)";
  return {};
}
inline SyntaxError error_for(tag<rules::label_close>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-close", "expected ')' after the label name");
}
inline SyntaxError error_for(tag<rules::call_next_arg>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-argument", "expected an argument after ','" + typographic_quote_hint(b, at));
}
inline SyntaxError error_for(tag<rules::call_close>, const Builder& b, const char* at) {
  if (!b.marks.empty() && b.marks.back() == b.stack.size())
    return expected(b, at, "parse.expected-argument", "expected an argument or ')' after '" + last_ident(b) + "('" +
                                    typographic_quote_hint(b, at));
  return expected(b, at, "parse.expected-close", "expected ')' after the arguments of '" + last_ident(b) + "'");
}
inline SyntaxError error_for(tag<rules::index_first>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-index", "expected an index after '" + last_ident(b) + "['");
}
inline SyntaxError error_for(tag<rules::index_next>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-index", "expected an index after ','");
}
inline SyntaxError error_for(tag<rules::index_close>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-close", "expected ']' after the index of '" + last_ident(b) + "'");
}
template <typename Operand>
  requires std::is_same_v<Operand, rules::pow_operand> || std::is_same_v<Operand, rules::unary_operand> ||
           std::is_same_v<Operand, rules::mul_operand> || std::is_same_v<Operand, rules::add_operand> ||
           std::is_same_v<Operand, rules::cmp_operand> || std::is_same_v<Operand, rules::not_operand> ||
           std::is_same_v<Operand, rules::and_operand> || std::is_same_v<Operand, rules::or_operand>
SyntaxError error_for(tag<Operand>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-expression", "expected an expression after '" + last_op(b) + "'");
}
inline SyntaxError error_for(tag<rules::first_param>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-parameter", "expected a parameter after '/'" + typographic_quote_hint(b, at));
}
inline SyntaxError error_for(tag<rules::next_param>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-parameter", "expected a parameter after ','" + typographic_quote_hint(b, at));
}
inline SyntaxError error_for(tag<rules::end_after_params>, const Builder& b, const char* at) {
  return unexpected(b, at, "parameter " + std::to_string(b.stmt.params.size()) + " of '" + b.stmt.major + "'");
}
inline SyntaxError error_for(tag<rules::end_after_major>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-slash", "expected '/' after the major word '" + b.stmt.major + "'");
}
inline SyntaxError error_for(tag<rules::label_eq>, const Builder& b, const char* at) {
  const LabelRef& l = b.stack.back().label;
  return expected(b, at, "parse.expected-equals", "expected '=' after the label '" + l.prefix + "(" + l.name + ")'");
}
inline SyntaxError error_for(tag<rules::index_eq>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-equals", "expected '=' after the array element '" + b.stack.back().text + "[...]'");
}
inline SyntaxError error_for(tag<rules::major_after_eq>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-major", "expected a major word after '='");
}
inline SyntaxError error_for(tag<rules::bad_label_prefix>, const Builder& b, const char* /*at*/) {
  return SyntaxError{"parse.unknown-label-prefix", "unknown label prefix '" + last_ident(b) + "' before '('",
                     b.idents.back().span};
}
inline SyntaxError error_for(tag<rules::statement>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-major", "expected a major word at the start of the statement");
}
inline SyntaxError error_for(tag<rules::jump_name>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-label-name", "expected a label name after '('");
}
inline SyntaxError error_for(tag<rules::jump_close>, const Builder& b, const char* at) {
  return expected(b, at, "parse.expected-close", "expected ')' after the label name");
}
inline SyntaxError error_for(tag<rules::end_after_jump>, const Builder& b, const char* at) {
  return unexpected(b, at, "the jump label '(" + b.stmt.jump_label.value_or("") + ")'");
}
// clang-format on

// Rules whose recursion the nesting guard counts.
// Operands are counted, not the operator rules, so merely trying `-x` at a primary costs nothing.
template <typename Rule>
inline constexpr bool nests = std::is_same_v<Rule, rules::or_expr> || std::is_same_v<Rule, rules::unary_operand> ||
                              std::is_same_v<Rule, rules::not_operand> || std::is_same_v<Rule, rules::pow_operand>;

template <typename Rule>
struct control : tao::pegtl::normal<Rule> {
  template <typename ParseInput>
  [[noreturn]] static void raise(const ParseInput& in, Builder& b) {
    if constexpr (requires { error_for(tag<Rule>{}, b, in.current()); })
      throw error_for(tag<Rule>{}, b, in.current());
    else  // every must<> in rules.hpp has a message; this is a grammar bug
      throw SyntaxError{"parse.internal", "syntax error", b.point(in.current())};
  }

  template <typename ParseInput>
  static void start(const ParseInput& in, Builder& b) {
    if constexpr (nests<Rule>) {
      if (++b.depth > max_nesting)
        throw SyntaxError{"parse.too-deep",
                          "expression nested too deeply (more than " + std::to_string(max_nesting) + " levels)",
                          b.point(in.current())};
    }
  }
  template <typename ParseInput>
  static void success(const ParseInput& /*in*/, Builder& b) {
    if constexpr (nests<Rule>) --b.depth;
  }
  template <typename ParseInput>
  static void failure(const ParseInput& /*in*/, Builder& b) {
    if constexpr (nests<Rule>) --b.depth;
  }
};

}  // namespace metron::grammar::detail
