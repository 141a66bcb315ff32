// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "metron/interpreter/ir/expr.hpp"
#include "metron/interpreter/ir/vocabulary.hpp"
#include "metron/stdlib/source.hpp"
#include "metron/stdlib/span.hpp"

namespace metron::interpreter::ir {

/// One operand of an instruction: an expression, a minor word, or a label.
struct Operand {
  enum class Kind { Expr, Word, Label } kind = Kind::Expr;
  ir::Expr expr;
  std::string word;  ///< upper-case minor word
  LabelOperand label;
  Span span;
  int width = -1;     ///< WRITE: the field width of `e:width[:decimals]` (-1: as TEXT shows it)
  int decimals = -1;  ///< WRITE: the decimals of a number (-1: as TEXT shows it)
};

/// IR operations. Operand layouts are documented per operation in docs/ir.md; the compiler has
/// already checked them, so the interpreter decodes by position. Words that select behaviour are
/// lowered to the instruction's typed payload.
enum class Op {
  Nop,    ///< a statement with no run-time effect (DMISMN, DISPLY, PRCOMP, skipped vendor statements); `name` = major
          ///< word
  End,    ///< ENDFIL: end of the program
  Units,  ///< payload: UnitsPayload
  Mode,   ///< payload: ModePayload
  Text,   ///< words: OPER|OUTFIL|...; expr: the text
  FeatureDef,  ///< `name` = label; payload: FeaturePayload; exprs: the numbers; `count` 1: FA(l)=FEAT, a stated actual
  ToleranceDef,  ///< `name` = label; payload: kind; words: modifiers; exprs: values; labels: datums
  SensorDef,     ///< `name` = label; words: PROBE, FIXED|INDEX, CART|POL; exprs: numbers
  SensorSelect,  ///< `name` = sensor label
  ProbeSet,      ///< words: APPRCH|RETRCT|SEARCH|CLRSRF|DEPTH; expr: distance
  Feed,          ///< payload: FeedPayload; expr: value
  Accel,         ///< words: MESACL|POSACL, unit; expr: value
  GoTo,          ///< payload: FormPayload; exprs: x, y, z (inside a MEAS block: a block step)
  MeasBegin,     ///< `name` = feature; payload: FeaturePayload (type); expr: point count; `target` = index of MeasEnd
  PtMeas,        ///< payload: FormPayload; exprs: x,y,z[,i,j,k]; [label: RMEAS reference]
  MeasEnd,       ///< ENDMES: runs the collected block on the machine
  Output,        ///< labels: F/FA/T/TA in order
  Evaluate,      ///< EVAL: labels F/FA then T/TA; the tolerances are evaluated and kept, not reported
  DatDef,        ///< labels: feature, DAT(x)
  DatSet,        ///< `name` = D label; operands: MCS | (DAT label, words...)...
  Trans,         ///< `name` = D label; operands: (axis word, expr | feature label)...
  Rotate,        ///< `name` = D label; operands: axis word, expr angle | (feature label, axis word)
  Locate,        ///< `name` = D label; operands: freedom words (XDIR ... ZAXIS) and F/FA/DAT labels
  Iterate,  ///< `name` = D label; operands: F/FA/DAT labels, expr accuracy, expr count, word ABSL|INCR; `target` = the
            ///< jump label
  Save,     ///< labels: DA(x)
  Recall,   ///< labels: D(x) / DA(x)
  Equate,   ///< labels: DA(earlier set-up), DA(later set-up)
  Pause,    ///< PAUSE: the operator's stop (a virtual CMM's operator may move the part)
  Construct,      ///< `name` = feature; payload: ConstructPayload; labels: sources
  Declare,        ///< words: scope, type; `names`: variables (with `count` = array size, 0 = scalar)
  Assign,         ///< `name` = variable; exprs: [indices...,] value; `count` = number of indices
  Jump,           ///< goto `target`
  JumpIfFalse,    ///< expr: condition; goto `target` when false
  DoInit,         ///< `name` = loop variable; exprs: start, end, step; `target` = index after ENDDO
  DoNext,         ///< `name` = loop variable; `target` = first body instruction
  CallMacro,      ///< `target` = macro index in the module; operands: arguments
  Return,         ///< ENDMAC: return from the macro
  CallUnit,       ///< `target` = unit index (CALL/EXTERN,DMIS,'file')
  DeviceDef,      ///< `name` = DID label; words: STOR|TERM|...; expr: path
  DeviceOpen,     ///< labels: DID; words: FDATA|DIRECT, format, access
  DeviceClose,    ///< labels: DID
  JumpLabel,      ///< `(name)`: a JUMPTO target (no effect)
  PathDef,        ///< `name` = P label; words: LINE|ARC|HELICAL, [INNER|OUTER]; exprs: the numbers
  ScanMode,       ///< words: ON|OFF
  ScanSet,        ///< words: DIST|CHORD|ACCEL|DEFLEC, expr: value | words: LAW, VC1|VC1P|VC2
  PaMeas,         ///< labels: P(path) (inside a MEAS block: a scan step)
  System,         ///< CALL/EXTERN,SYS,'command': `name` = the command text (docs/touch-trigger.md)
  DecimalPlaces,  ///< DECPL: words ALL|LENGTH|ANGLE|...; exprs: the decimals, paired in order
  Read,           ///< READ/DID(x),v1,v2,...: labels: DID; `names`: the variables, in order
  Write,          ///< WRITE/DID(x),e1,e2,...: labels: DID; exprs: the values, written as one line
  FitAlgorithm,   ///< GEOALG/type,...: words: the type (CIRCLE, SPHERE, CYLNDR, PLANE, LINE) and the algorithm (LSTSQR,
                  ///< MAXINS, MINCIR, MINMAX)
  WorkPlane,      ///< WKPLAN/XYPLAN|YZPLAN|ZXPLAN: word, the plane of polar coordinates (CORTOL, POL positions)
  Push,           ///< PUSH/word,...: words (ALGN, SNSLCT, WKPLAN, SNSET, GEOALG, FEDRAT), each state saved on its stack
  Pop,            ///< POP/word,...: words, each state restored from its stack
  GoHome,         ///< GOHOME: no operands
  SetHome,        ///< FROM/[CART|POL,]x,y,z: payload FormPayload; exprs: the point GOHOME goes to from here on
  BadTest,        ///< BADTST/ON|OFF: word ON or OFF
  OnError,        ///< ERROR/...: words: JUMP (`target` = the handler label's index), AUTO or OFF, then the condition
  Resume,         ///< RESUME/...: word NEXTLINE, NEXTMEAS, CURMEAS, END or JUMP (`target` = the label's index)
};

/// The number of operations (Resume is the last).
inline constexpr std::size_t op_count = static_cast<std::size_t>(Op::Resume) + 1;

/// Upper-case mnemonic of an operation (for --emit-ir).
const char* to_string(Op op);

/// UNITS: the length and angle units.
struct UnitsPayload {
  LengthUnit length = LengthUnit::Mm;
  std::optional<AngleUnit> angle;              ///< unchanged when not given
  std::optional<TemperatureUnit> temperature;  ///< unchanged when not given
};
/// MODE.
struct ModePayload {
  RunMode mode = RunMode::Auto;
};
/// FEAT (and MEAS, which names only the type): the words before the numbers.
struct FeaturePayload {
  runtime::FeatureType type = runtime::FeatureType::Point;
  std::optional<runtime::Side> side;           ///< INNER|OUTER, for features of size
  std::optional<bool> bounded;                 ///< LINE: BND (true) or UNBND
  std::optional<runtime::SlotEnds> slot_ends;  ///< CPARLN: ROUND|FLAT
  std::optional<CoordinateForm> form;          ///< CART|POL (FEAT; absent for MEAS)
};
/// TOL: the tolerance kind (its modifier words stay operands, in source order).
struct TolerancePayload {
  runtime::ToleranceKind kind = runtime::ToleranceKind::Diam;
};
/// FEDRAT.
struct FeedPayload {
  FeedKind kind = FeedKind::Mesvel;
  FeedUnit unit = FeedUnit::Mmps;
};
/// GOTO and PTMEAS/RMEAS: how the coordinates are given (GOTO may leave it implicit: CART).
struct FormPayload {
  std::optional<CoordinateForm> form;
  /// RPTMEAS (RationalDMIS, in an RMEAS ...,VECBLD block): a point of the surface around the
  /// feature, probed before the block's points to find where that surface lies.
  bool reference_point = false;
};
/// CONST: the constructed type and the method.
struct ConstructPayload {
  runtime::FeatureType type = runtime::FeatureType::Point;
  ConstructionMethod method = ConstructionMethod::Bf;
};
/// The typed part of an instruction, lowered from DMIS words by the compiler.
using Payload = std::variant<std::monostate, UnitsPayload, ModePayload, FeaturePayload, TolerancePayload, FeedPayload,
                             FormPayload, ConstructPayload>;

/// The payload's words, in source order (for --emit-ir, through the vocabulary tables).
std::vector<std::string> payload_words(const Payload& payload);

/// One IR instruction; every instruction keeps the span of the statement it came from.
struct Instruction {
  Op op = Op::Nop;
  Span span;
  std::string name;
  bool name_is_param = false;  ///< `name` is a macro parameter that supplies the label's name
  Payload
      payload;  ///< the statement's words as enumerators (UNITS, MODE, FEAT, MEAS, TOL, FEDRAT, GOTO, PTMEAS, CONST)
  std::vector<Operand> operands;
  std::vector<std::string> names;  ///< Declare: variable names
  std::int64_t target = -1;
  int count = 0;
};

/// A macro: M(name)=MACRO/params ... ENDMAC, compiled into its own code.
struct Macro {
  std::string name;
  std::vector<std::string> params;  ///< upper-case parameter names
  std::vector<Instruction> code;
  Span span;
};

/// A compiled source file: the main program, a file called with CALL/EXTERN, or a REPL entry.
struct Unit {
  std::string path;
  std::uint32_t file = 0;
  std::vector<Instruction> code;
};

/// A compiled program: unit 0 is the main program; macros are global once defined.
struct Module {
  std::vector<Unit> units;
  std::vector<Macro> macros;
  /// Indexed labels (`F(HOLE[I])`): the index as the label's name holds it (`I`) -> its
  /// expression, evaluated when the label is used (DMIS 5.x indexed labels).
  std::map<std::string, Expr> label_indices;
};

/// Human-readable listing of the whole module (`metron compile --emit-ir`).
std::string to_string(const Module& module, const SourceManager& sources);

}  // namespace metron::interpreter::ir
