// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "metron/stdlib/span.hpp"

namespace metron::grammar {

struct Expr;

/// A DMIS label reference such as `FA(PLN1)`, `DAT(A)`, `D(CALN1_b)`, `S(PROBE.6)`, or an indexed
/// label `F(HOLE[I])` (DMIS 5.x): one label per value of the index.
struct LabelRef {
  std::string prefix;  ///< upper-case label prefix: F, FA, T, TA, D, DA, DAT, DID, S, SA, M, ...
  std::string
      name;   ///< the name between the parentheses as written; indexed: `HOLE[I]`, the index upper-case without blanks
  Span span;  ///< the whole reference, prefix to closing parenthesis
  std::vector<Expr> index;  ///< an indexed label's index expression (one), else empty
  /// A point range after the label, `FA(x)[first,last]` or `FA(x)[n]` (MODUS writes OUTPUT of a
  /// feature's points so): one or two expressions, else empty.
  std::vector<Expr> points;
};

enum class ExprKind {
  Number,  ///< `number`
  String,  ///< `text` (quotes removed, '' unescaped)
  Word,    ///< an identifier: a DMIS minor word (CART, INNER, XAXIS ...) or a variable; `text` upper-case
  Label,   ///< `label`
  Call,    ///< intrinsic function call: `text` = upper-case function name, `args`
  Unary,   ///< `text` = operator ("-", "+", ".NOT."), one operand in `args`
  Binary,  ///< `text` = operator ("+","-","*","/","**",".EQ.",".NE.",".LT.",".LE.",".GT.",".GE.",".AND.",".OR."), two
           ///< operands
  Paren,   ///< a parenthesised expression `( e )`, one operand in `args` (kept: JUMPTO/(L1) and IF/(c) need it)
  Index,   ///< array element `name[i]` or `name[i,j]`: `text` = upper-case variable name, indices in `args`
  Format,  ///< a WRITE value with its layout `e:width[:decimals]`: args = {e, width, [decimals]} (numbers)
};

/// An expression or a statement parameter (DMIS parameters are expressions).
struct Expr {
  ExprKind kind = ExprKind::Number;
  Span span;
  double number = 0;
  std::string text;
  LabelRef label;
  std::vector<Expr> args;
};

/// One logical DMIS statement (continuation lines joined), e.g.
/// `F(CYL1)=FEAT/CYLNDR,INNER,CART,0,0,26,0,0,-1,31,12` or `V1=ASSIGN/V2+1` or `ENDMES` or `(L1)`.
struct Statement {
  Span span;                       ///< the whole statement (physical positions)
  std::optional<LabelRef> target;  ///< label on the left of '=' (F(x)=FEAT/..., M(m)=MACRO/...)
  std::optional<Expr> variable;    ///< variable on the left of '=' (Word or Index), V1=ASSIGN/...
  std::string major;               ///< upper-case major word (FEAT, MEAS, ENDMES ...); empty for a jump label line
  Span major_span;
  bool has_slash = false;                 ///< whether '/' followed the major word
  std::vector<Expr> params;               ///< the comma-separated parameters after '/'
  std::optional<std::string> jump_label;  ///< `(name)` alone on a line: a JUMPTO target (name as written)
};

/// A parsed source file: its statements in order.
struct Program {
  std::uint32_t file = 0;  ///< SourceManager id
  std::vector<Statement> statements;
  /// The leading word of the file's first statement line, upper case, read or not (a DMISMN the
  /// parser could not read is still the program's start).
  std::string first_word;
  /// The software that wrote the file, where the file says so in a way metron reads ("WinWerth":
  /// its BEGIN/CHFILE block); empty otherwise.
  std::string writer;
  /// The labels that lines the parser could not read were defining (`DID(XLS)`, upper case, the
  /// actual's prefix read as the nominal's: FA as F), each with its line: a later use of one is
  /// told as following from that error, not as an error of its own.
  std::map<std::string, Span> unread_definitions;
};

}  // namespace metron::grammar
