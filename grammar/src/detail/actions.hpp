// SPDX-License-Identifier: GPL-3.0-or-later
// Binder actions: each builds one AST form from what the grammar matched.
#pragma once
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <string>

#include "detail/builder.hpp"
#include "detail/rules.hpp"

namespace metron::grammar::detail {

namespace pegtl = tao::pegtl;

template <typename Rule>
struct action : pegtl::nothing<Rule> {};

// ---- primaries ------------------------------------------------------------------------------

// number -> 12 | 12.5 | .5 | 5. | 1.E-3 | 2e5   (signs are unary operators, folded later)
template <>
struct action<rules::number> {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    const std::string_view text = in.string_view();
    Expr e;
    e.kind = ExprKind::Number;
    e.span = b.span(in.begin(), in.end());
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), e.number);
    if (ec == std::errc::result_out_of_range) {
      e.number = std::strtod(std::string(text).c_str(), nullptr);  // underflow -> 0, overflow -> inf
      if (std::isinf(e.number))
        throw SyntaxError{"parse.number-range", "number '" + std::string(text) + "' is too large", e.span};
    } else if (ec != std::errc{} || ptr != text.data() + text.size()) {
      throw SyntaxError{"parse.bad-number", "malformed number '" + std::string(text) + "'", e.span};
    }
    b.stack.push_back(std::move(e));
  }
};

// word -> 3D | 2D (a minor word that starts with a digit) | .TRUE. | .FALSE.
template <typename Rule>
struct literal_word {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    Expr e;
    e.kind = ExprKind::Word;
    e.span = b.span(in.begin(), in.end());
    e.text = upper(in.string_view());
    b.stack.push_back(std::move(e));
  }
};
template <>
struct action<rules::digit_word> : literal_word<rules::digit_word> {};
template <>
struct action<rules::bool_lit> : literal_word<rules::bool_lit> {};

// string -> 'text'   ('' inside = one quote)
template <>
struct action<rules::string_open> {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    b.string_open = in.begin();
  }
};

template <>
struct action<rules::string_lit> {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    const std::string_view raw = in.string_view().substr(1, in.size() - 2);
    Expr e;
    e.kind = ExprKind::String;
    e.span = b.span(in.begin(), in.end());
    e.text.reserve(raw.size());
    for (std::size_t i = 0; i < raw.size(); ++i) {
      e.text.push_back(raw[i]);
      if (raw[i] == '\'') ++i;  // '' -> '
    }
    b.stack.push_back(std::move(e));
  }
};

// ( expr )
template <>
struct action<rules::paren_expr> {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    Expr e;
    e.kind = ExprKind::Paren;
    e.span = b.span(in.begin(), in.end());
    e.args.push_back(b.pop());
    b.stack.push_back(std::move(e));
  }
};

// identifier: waits for '(' / '[' / nothing to decide what it is
template <typename Rule>
struct push_ident {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    b.idents.push_back({upper(in.string_view()), b.span(in.begin(), in.end())});
  }
};
template <>
struct action<rules::ident_tok> : push_ident<rules::ident_tok> {};
template <>
struct action<rules::stmt_ident> : push_ident<rules::stmt_ident> {};

// label -> PREFIX(name)   e.g. FA(PLN1), DAT(A), S(PROBE.6)
template <>
struct action<rules::label_ref_name> {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    // Blanks inside a name are dropped (DMIS names have none): F(HOLE 1) is F(HOLE1).
    std::string name = in.string();
    if (name.find_first_of(" \t") != std::string::npos) {
      if (!b.blank_in_label) b.blank_in_label = b.span(in.begin(), in.end());
      std::erase_if(name, [](char c) { return c == ' ' || c == '\t'; });
    }
    b.labels.push_back({std::move(name), {}, {}});
  }
};

// F(HOLE[I])   an indexed label: the name keeps the index's text (upper-case, no blanks)
template <>
struct action<rules::label_index_expr> {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    std::string text;
    for (char c : upper(in.string_view()))
      if (c != ' ' && c != '\t') text += c;
    b.labels.back().name += "[" + text + "]";
    b.labels.back().index.push_back(b.pop());
  }
};

// FA(x)[1,n]   a point range after a label
template <>
struct action<rules::label_point_expr> {
  template <typename In>
  static void apply(const In&, Builder& b) {
    b.labels.back().points.push_back(b.pop());
  }
};

template <>
struct action<rules::label_tail> {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    PendingIdent id = b.pop_ident();
    Builder::PendingLabel label = std::move(b.labels.back());
    b.labels.pop_back();
    Expr e;
    e.kind = ExprKind::Label;
    e.span = Span::join(id.span, b.span(in.begin(), in.end()));
    e.label =
        LabelRef{std::move(id.upper), std::move(label.name), e.span, std::move(label.index), std::move(label.points)};
    b.stack.push_back(std::move(e));
  }
};

// call -> NAME(arg, ...)   e.g. SQRT(V1), SIN(30)
template <typename Rule>
struct open_list {
  template <typename In>
  static void apply(const In& /*in*/, Builder& b) {
    b.marks.push_back(b.stack.size());
  }
};
template <>
struct action<rules::call_open> : open_list<rules::call_open> {};
template <>
struct action<rules::index_open> : open_list<rules::index_open> {};

// Builds a Call or an Index node from the pending identifier and the operands above the mark.
template <ExprKind Kind>
struct close_list {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    PendingIdent id = b.pop_ident();
    const std::size_t mark = b.marks.back();
    b.marks.pop_back();
    Expr e;
    e.kind = Kind;
    e.span = Span::join(id.span, b.span(in.begin(), in.end()));
    e.text = std::move(id.upper);
    for (std::size_t i = mark; i < b.stack.size(); ++i) e.args.push_back(std::move(b.stack[i]));
    b.stack.resize(mark);
    b.stack.push_back(std::move(e));
  }
};
template <>
struct action<rules::call_tail> : close_list<ExprKind::Call> {};
// index -> NAME[i] | NAME[i,j]
template <>
struct action<rules::index_tail> : close_list<ExprKind::Index> {};

// word -> CART | INNER | XAXIS | V1 ...
template <>
struct action<rules::word_tail> {
  template <typename In>
  static void apply(const In& /*in*/, Builder& b) {
    PendingIdent id = b.pop_ident();
    Expr e;
    e.kind = ExprKind::Word;
    e.span = id.span;
    e.text = std::move(id.upper);
    b.stack.push_back(std::move(e));
  }
};

// ---- operators ------------------------------------------------------------------------------

// Any operator token: remembered (upper case) until its right operand is complete.
template <typename Rule>
struct push_op {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    if (++b.operators > max_operators)
      throw SyntaxError{
          "parse.too-long",
          "expression too long (more than " + std::to_string(max_operators) + " operators in one statement)",
          b.point(in.begin())};
    b.ops.push_back({upper(in.string_view()), b.span(in.begin(), in.end())});
  }
};
template <>
struct action<rules::add_op> : push_op<rules::add_op> {};
template <>
struct action<rules::mul_op> : push_op<rules::mul_op> {};
template <>
struct action<rules::pow_op> : push_op<rules::pow_op> {};
template <>
struct action<rules::sign_op> : push_op<rules::sign_op> {};
template <>
struct action<rules::op_cmp> : push_op<rules::op_cmp> {};
template <>
struct action<rules::op_not> : push_op<rules::op_not> {};
template <>
struct action<rules::op_and> : push_op<rules::op_and> {};
template <>
struct action<rules::op_or> : push_op<rules::op_or> {};

// a OP b   (left-associative except **, whose right operand recurses)
template <typename Rule>
struct binary {
  template <typename In>
  static void apply(const In& /*in*/, Builder& b) {
    Expr rhs = b.pop();
    Expr lhs = b.pop();
    Expr e;
    e.kind = ExprKind::Binary;
    e.span = Span::join(lhs.span, rhs.span);
    e.text = b.pop_op().text;
    e.args.push_back(std::move(lhs));
    e.args.push_back(std::move(rhs));
    b.stack.push_back(std::move(e));
  }
};
template <>
struct action<rules::pow_tail> : binary<rules::pow_tail> {};
template <>
struct action<rules::mul_tail> : binary<rules::mul_tail> {};
template <>
struct action<rules::add_tail> : binary<rules::add_tail> {};
template <>
struct action<rules::cmp_tail> : binary<rules::cmp_tail> {};
template <>
struct action<rules::and_tail> : binary<rules::and_tail> {};
template <>
struct action<rules::or_tail> : binary<rules::or_tail> {};

// -x | +x | .NOT. x   (a sign directly before a numeric literal folds into it: -0.000)
template <typename Rule>
struct unary {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    Expr operand = b.pop();
    PendingOp op = b.pop_op();
    Expr e;
    e.span = b.span(in.begin(), in.end());
    if (operand.kind == ExprKind::Number && op.text != ".NOT." && starts_with_literal(in)) {
      e.kind = ExprKind::Number;
      e.number = op.text == "-" ? -operand.number : operand.number;
    } else {
      e.kind = ExprKind::Unary;
      e.text = std::move(op.text);
      e.args.push_back(std::move(operand));
    }
    b.stack.push_back(std::move(e));
  }
  // Whether the operand is written as a literal (`-5`), not as `-(5)` or `--5`.
  template <typename In>
  static bool starts_with_literal(const In& in) {
    std::string_view s = in.string_view().substr(1);
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
    return !s.empty() && ((s.front() >= '0' && s.front() <= '9') || s.front() == '.');
  }
};
template <>
struct action<rules::unary_tail> : unary<rules::unary_tail> {};
template <>
struct action<rules::not_tail> : unary<rules::not_tail> {};

// ---- statements -----------------------------------------------------------------------------

// MAJOR/p1,p2,...   one parameter
template <>
struct action<rules::param> {
  template <typename In>
  static void apply(const In& /*in*/, Builder& b) {
    b.stmt.params.push_back(b.pop());
  }
};

// e:width[:decimals]   a WRITE value's layout: the value on the stack is wrapped in a Format
template <>
struct action<rules::format_width> {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    Expr value = b.pop();
    Expr width;
    width.kind = ExprKind::Number;
    width.span = b.span(in.begin(), in.end());
    width.number = std::strtod(in.string().c_str(), nullptr);
    Expr f;
    f.kind = ExprKind::Format;
    f.span = Span{value.span.file, value.span.begin, width.span.end};
    f.args.push_back(std::move(value));
    f.args.push_back(std::move(width));
    b.stack.push_back(std::move(f));
  }
};
template <>
struct action<rules::format_decimals> {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    Expr decimals;
    decimals.kind = ExprKind::Number;
    decimals.span = b.span(in.begin(), in.end());
    decimals.number = std::strtod(in.string().c_str(), nullptr);
    Expr& f = b.stack.back();
    f.span.end = decimals.span.end;
    f.args.push_back(std::move(decimals));
  }
};

// MAJOR/p1,,p3   an empty parameter between two commas: a Word with empty text
template <>
struct action<rules::empty_param> {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    Expr e;
    e.kind = ExprKind::Word;
    e.span = b.point(in.begin());
    e.span.end = e.span.begin;
    b.stmt.params.push_back(std::move(e));
  }
};

// MAJOR/...   the slash that opens the parameter list
template <>
struct action<rules::slash> {
  template <typename In>
  static void apply(const In& /*in*/, Builder& b) {
    b.stmt.has_slash = true;
  }
};

// MAJOR   alone or before '/': the identifier read at the start of the statement
template <>
struct action<rules::major_plain> {
  template <typename In>
  static void apply(const In& /*in*/, Builder& b) {
    PendingIdent id = b.pop_ident();
    b.stmt.major = std::move(id.upper);
    b.stmt.major_span = id.span;
  }
};

// ... = MAJOR   the major word after a label or variable target
template <>
struct action<rules::major_after_eq> {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    b.stmt.major = upper(in.string_view());
    b.stmt.major_span = b.span(in.begin(), in.end());
  }
};

// F(l)=MAJOR/...   label target
template <>
struct action<rules::label_eq> {
  template <typename In>
  static void apply(const In& /*in*/, Builder& b) {
    b.stmt.target = b.pop().label;
  }
};

// V[i]=MAJOR/...   array element target
template <>
struct action<rules::index_eq> {
  template <typename In>
  static void apply(const In& /*in*/, Builder& b) {
    b.stmt.variable = b.pop();
  }
};

// V=MAJOR/...   variable target
template <>
struct action<rules::var_eq> {
  template <typename In>
  static void apply(const In& /*in*/, Builder& b) {
    PendingIdent id = b.pop_ident();
    Expr e;
    e.kind = ExprKind::Word;
    e.span = id.span;
    e.text = std::move(id.upper);
    b.stmt.variable = std::move(e);
  }
};

// (name)   jump label line, a JUMPTO target
template <>
struct action<rules::jump_name> {
  template <typename In>
  static void apply(const In& in, Builder& b) {
    b.stmt.jump_label = in.string();
  }
};

}  // namespace metron::grammar::detail
