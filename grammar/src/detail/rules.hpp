// SPDX-License-Identifier: GPL-3.0-or-later
// The DMIS statement grammar (PEGTL 3.2.7), applied to one logical line at a time.
//
// Major and minor words are plain identifiers; their meaning is looked up in tables by later
// phases. Rules named in a `must<>` carry their own error message (detail/errors.hpp), so most
// sub-expressions get a distinct rule type per place they are required.
#pragma once
#include <tao/pegtl.hpp>

#include "metron/grammar/parser.hpp"

namespace metron::grammar::rules {

using namespace tao::pegtl;

// clang-format off

// ---- lexical --------------------------------------------------------------------------------
struct blank : one<' ', '\t', '\r', '\f', '\v'> {};
struct ws : star<blank> {};
struct ident_first : ranges<'a', 'z', 'A', 'Z'> {};
struct ident_other : ranges<'a', 'z', 'A', 'Z', '0', '9', '_'> {};
struct ident : seq<ident_first, star<ident_other>> {};
// Shop software writes labels with non-ASCII letters (UTF-8 after decoding: `PLN_Sphères`),
// `+` and `±` (`PNT+X`, `DIST±`): any byte >= 0x80 is part of a label.
struct label_high_byte : range<static_cast<char>(0x80), static_cast<char>(0xFF)> {};
struct label_char : sor<ident_other, one<'.', '-', '#', '@', '!', '~', '+'>, label_high_byte> {};
struct label_name : plus<label_char> {};

// Dotted operators; case-insensitive and delimited by their dots, so `5.EQ.X` is 5 .EQ. X.
template <char... Cs>
struct dot_word : seq<one<'.'>, istring<Cs...>, one<'.'>> {};
struct op_or : dot_word<'O', 'R'> {};
struct op_and : dot_word<'A', 'N', 'D'> {};
struct op_not : dot_word<'N', 'O', 'T'> {};
struct op_cmp : sor<dot_word<'E', 'Q'>, dot_word<'N', 'E'>, dot_word<'L', 'T'>, dot_word<'L', 'E'>,
                    dot_word<'G', 'T'>, dot_word<'G', 'E'>> {};
struct dot_op : sor<op_or, op_and, op_not, op_cmp> {};

// number -> digits [. digits] [exp] | . digits [exp]   (`5.`, `.5`, `1.E-3`, `2e5`; no sign)
struct digits : plus<digit> {};
struct exponent : seq<one<'e', 'E'>, opt<one<'+', '-'>>, digits> {};
struct fraction : seq<not_at<dot_op>, one<'.'>, star<digit>> {};
struct number_body : seq<sor<seq<digits, opt<fraction>>, seq<one<'.'>, digits>>, opt<exponent>> {};
struct number : seq<number_body, not_at<ident_other>> {};
// A minor word that starts with a digit: `3D`, `2D` (TOL/POS,3D,...).
struct digit_word : seq<digits, sor<ident_first, one<'_'>>, star<ident_other>> {};
struct bad_number_suffix {};
struct bad_number : seq<number_body, tao::pegtl::raise<bad_number_suffix>> {};

// boolean constants -> .TRUE. | .FALSE.   (a Word with the dots kept)
struct bool_lit : sor<dot_word<'T', 'R', 'U', 'E'>, dot_word<'F', 'A', 'L', 'S', 'E'>> {};

// string -> ' { '' | any byte but ' } '
struct string_open : one<'\''> {};
struct string_char : sor<two<'\''>, not_one<'\''>> {};
struct string_close : one<'\''> {};
struct string_lit : seq<string_open, star<string_char>, must<string_close>> {};

// ---- expressions ----------------------------------------------------------------------------
struct expr;
struct add_op : one<'+', '-'> {};
struct mul_op : sor<seq<one<'*'>, not_at<one<'*'>>>, one<'/'>> {};
struct pow_op : two<'*'> {};
struct sign_op : one<'+', '-'> {};

// Succeeds (consuming nothing) when the identifier just read is a DMIS label prefix.
struct if_label_prefix {
  using rule_t = if_label_prefix;
  using subs_t = empty_list;
  template <apply_mode, rewind_mode, template <typename...> class Action,
            template <typename...> class Control, typename ParseInput, typename State>
  static bool match(ParseInput& /*in*/, State& state) {
    return !state.idents.empty() && is_label_prefix(state.idents.back().upper);
  }
};

// primary -> number | 3D | .TRUE. | string | ( expr ) | label | call | index | word
struct paren_open : one<'('> {};
struct paren_inner;
struct paren_close : one<')'> {};
struct paren_expr : seq<paren_open, ws, must<paren_inner>, ws, must<paren_close>> {};

struct ident_tok : ident {};
struct label_open : one<'('> {};
// CMM software shows feature names with blanks and some exports keep them (`F(HOLE 1)`).
struct label_ref_name : list<plus<label_char>, plus<blank>> {};
struct label_close : one<')'> {};
struct label_index_open : one<'['> {};
struct label_index_expr;
struct label_index_close : one<']'> {};
struct label_index : seq<label_index_open, ws, must<label_index_expr>, ws, must<label_index_close>> {};
struct label_points_open : one<'['> {};
struct label_point_expr;
struct label_points_close : one<']'> {};
struct label_points : seq<label_points_open, ws, must<label_point_expr>, opt<ws, one<','>, ws, must<label_point_expr>>, ws,
                          must<label_points_close>> {};
struct label_tail : seq<if_label_prefix, label_open, ws, must<label_ref_name>, ws, opt<label_index>, ws, must<label_close>,
                        opt<label_points>> {};
struct call_open : one<'('> {};
struct call_arg;
struct call_next_arg;
struct call_close : one<')'> {};
struct call_args : seq<call_arg, star<ws, one<','>, ws, must<call_next_arg>>> {};
struct call_tail : seq<call_open, ws, opt<call_args>, ws, must<call_close>> {};
struct index_open : one<'['> {};
struct index_first;
struct index_next;
struct index_close : one<']'> {};
struct index_tail : seq<index_open, ws, must<index_first>, star<ws, one<','>, ws, must<index_next>>, ws, must<index_close>> {};
struct word_tail : success {};
struct ident_led : seq<ident_tok, ws, sor<label_tail, call_tail, index_tail, word_tail>> {};

struct primary : sor<number, digit_word, bool_lit, string_lit, paren_expr, ident_led, bad_number> {};

// Precedence, low to high: .OR. .AND. .NOT. comparisons + - * / unary-sign **
struct unary;
struct pow_operand;
struct pow_tail : seq<pow_op, ws, must<pow_operand>> {};
struct power : seq<primary, opt<ws, pow_tail>> {};
struct unary_operand;
struct unary_tail : seq<sign_op, ws, must<unary_operand>> {};
struct unary : sor<unary_tail, power> {};
struct pow_operand : unary {};
struct unary_operand : unary {};
struct mul_operand : unary {};
struct mul_tail : seq<mul_op, ws, must<mul_operand>> {};
struct mul_expr : seq<unary, star<ws, mul_tail>> {};
struct add_operand : mul_expr {};
struct add_tail : seq<add_op, ws, must<add_operand>> {};
struct add_expr : seq<mul_expr, star<ws, add_tail>> {};
struct cmp_operand : add_expr {};
struct cmp_tail : seq<op_cmp, ws, must<cmp_operand>> {};
struct cmp_expr : seq<add_expr, star<ws, cmp_tail>> {};
struct not_expr;
struct not_operand;
struct not_tail : seq<op_not, ws, must<not_operand>> {};
struct not_expr : sor<not_tail, cmp_expr> {};
struct not_operand : not_expr {};
struct and_operand : not_expr {};
struct and_tail : seq<op_and, ws, must<and_operand>> {};
struct and_expr : seq<not_expr, star<ws, and_tail>> {};
struct or_operand : and_expr {};
struct or_tail : seq<op_or, ws, must<or_operand>> {};
struct or_expr : seq<and_expr, star<ws, or_tail>> {};
struct expr : seq<or_expr> {};

struct paren_inner : expr {};
struct call_arg : expr {};
struct call_next_arg : expr {};
struct index_first : expr {};
struct label_index_expr : expr {};
struct label_point_expr : expr {};
struct index_next : expr {};

// ---- statements -----------------------------------------------------------------------------
// params -> / param { , param }      (a param may be empty between two commas: `A/1,,2`)
// A WRITE value may carry its layout, Fortran-like: `V:10:3` (width 10, 3 decimals), `T:20`.
struct format_width : digits {};
struct format_decimals : digits {};
struct format_suffix : seq<one<':'>, ws, must<format_width>, opt<ws, one<':'>, ws, must<format_decimals>>> {};
struct param : seq<expr, opt<ws, format_suffix>> {};
struct empty_param : at<one<','>> {};
struct first_param : sor<empty_param, param> {};
struct next_param : sor<empty_param, param> {};
struct slash : one<'/'> {};
struct end_after_params : eof {};
struct params : seq<slash, ws, must<first_param>, star<ws, one<','>, ws, must<next_param>>, ws, must<end_after_params>> {};
struct end_after_major : eof {};
struct major_tail : sor<params, must<end_after_major>> {};

// lhs -> LABEL(name) = | VAR = | VAR[i] =     then the major word
struct stmt_ident : ident {};
struct major_after_eq : ident {};
struct label_eq : one<'='> {};
struct index_eq : one<'='> {};
struct var_eq : one<'='> {};
struct bad_label_prefix {};
struct lhs_label : seq<label_tail, ws, must<label_eq>, ws, must<major_after_eq>> {};
struct lhs_index : seq<index_tail, ws, must<index_eq>, ws, must<major_after_eq>> {};
struct lhs_var : seq<var_eq, ws, must<major_after_eq>> {};
struct lhs_bad_prefix : seq<at<one<'('>>, tao::pegtl::raise<bad_label_prefix>> {};
struct major_plain : success {};
struct stmt_start : seq<stmt_ident, ws, sor<lhs_label, lhs_index, lhs_var, lhs_bad_prefix, major_plain>> {};
struct statement : seq<stmt_start, ws, major_tail> {};

// jump label line -> ( name )
struct jump_open : one<'('> {};
struct jump_name : label_name {};
struct jump_close : one<')'> {};
struct end_after_jump : eof {};
struct jump_line : seq<jump_open, ws, must<jump_name>, ws, must<jump_close>, ws, must<end_after_jump>> {};

struct line : seq<ws, sor<jump_line, must<statement>>> {};
// clang-format on

}  // namespace metron::grammar::rules
