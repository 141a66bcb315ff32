// SPDX-License-Identifier: GPL-3.0-or-later
#include "passes/actuals_pass.hpp"

#include <fmt/format.h>

#include <algorithm>

#include <map>
#include <set>
#include <string>

namespace metron::interpreter::passes {
namespace {

// An indexed label (H[I], H[1]) is one family of features: check cannot evaluate the index.
std::string family(const std::string& name) { return name.substr(0, name.find('[')); }

bool named_at_run(const std::string& name, bool is_param) { return is_param || name.rfind('@', 0) == 0; }

bool gives_actual(const ir::Instruction& in) {
  return in.op == ir::Op::MeasBegin || in.op == ir::Op::Construct || (in.op == ir::Op::FeatureDef && in.count == 1);
}

// Where an instruction is: its unit (the main program is 0; -1 for a macro) and its index there.
struct Place {
  int unit = 0;
  std::size_t index = 0;
  Span span;
};

struct ActualUse {
  ir::LabelOperand label;
  Place place;
};

struct Uses {
  std::map<std::string, std::vector<Place>> given;    // families measured, constructed or stated, and where
  std::map<std::string, std::vector<Place>> nominal;  // families with a FEAT, and where
  std::vector<ActualUse> actual_uses;                 // every FA(x) read, in program order
  bool undecidable = false;
};

void collect_expr(const ir::Expr& e, const Place& place, Uses& u) {
  if ((e.op == ir::ExprOp::Obtain || e.op == ir::ExprOp::Query) && e.label.prefix == "FA")
    u.actual_uses.push_back({e.label, place});
  for (const auto& a : e.args) collect_expr(a, place, u);
}

void collect(const std::vector<ir::Instruction>& code, int unit, Uses& u) {
  for (std::size_t i = 0; i < code.size(); ++i) {
    const ir::Instruction& in = code[i];
    const Place place{unit, i, in.span};
    if (gives_actual(in)) {
      if (named_at_run(in.name, in.name_is_param)) u.undecidable = true;
      u.given[family(in.name)].push_back(place);
    } else if (in.op == ir::Op::FeatureDef && !named_at_run(in.name, in.name_is_param)) {
      u.nominal[family(in.name)].push_back(place);
    }
    if (in.op == ir::Op::CallUnit && in.target < 0) u.undecidable = true;  // a file not found
    for (const auto& o : in.operands) {
      if (o.kind == ir::Operand::Kind::Label && o.label.prefix == "FA") u.actual_uses.push_back({o.label, place});
      if (o.kind == ir::Operand::Kind::Expr) collect_expr(o.expr, place, u);
    }
  }
}

// Whether the main program runs each of its instructions at most once, in order: no loop, no
// jump back, no error handler or RESUME that could come back. Forward jumps (IF, JUMPTO a later
// label) only skip.
bool runs_straight_through(const std::vector<ir::Instruction>& code) {
  for (std::size_t i = 0; i < code.size(); ++i) {
    const ir::Instruction& in = code[i];
    switch (in.op) {
      case ir::Op::DoInit:
      case ir::Op::DoNext:
      case ir::Op::OnError:
      case ir::Op::Resume: return false;
      case ir::Op::Jump:
      case ir::Op::JumpIfFalse:
        if (in.target < 0 || static_cast<std::size_t>(in.target) <= i) return false;
        break;
      default: break;
    }
  }
  return true;
}

}  // namespace

void warn_features_never_measured(const ir::Module& module, const SourceManager& sources, DiagnosticSink& sink) {
  Uses u;
  for (std::size_t k = 0; k < module.units.size(); ++k) collect(module.units[k].code, static_cast<int>(k), u);
  for (const auto& macro : module.macros) collect(macro.code, -1, u);
  if (u.undecidable) return;
  const bool straight = !module.units.empty() && runs_straight_through(module.units[0].code);
  std::set<std::string> told;
  for (const auto& [use, place] : u.actual_uses) {
    if (use.param || use.name.rfind('@', 0) == 0) continue;
    const std::string f = family(use.name);
    if (!u.nominal.count(f) || told.count(f)) continue;
    const auto given = u.given.find(f);
    if (given == u.given.end()) {
      told.insert(f);
      sink.warning("sema.never-measured", use.span,
                   fmt::format("FA({}) is read here, but nothing in this program measures or constructs {} "
                               "(no MEAS, RMEAS or CONST of it, no stated actual): at run it has no actual "
                               "here",
                               use.name, use.name));
      continue;
    }
    // Read in the main program before every statement that gives it an actual, all of them
    // further down the main program, which runs straight through: nothing can have given it one.
    if (!straight || place.unit != 0) continue;
    const bool all_later = std::all_of(given->second.begin(), given->second.end(),
                                       [&](const Place& g) { return g.unit == 0 && g.index > place.index; });
    // Read before its FEAT too: the compiler told that use ("used before its definition").
    const auto& nominals = u.nominal.at(f);
    const bool undefined_yet = std::all_of(nominals.begin(), nominals.end(),
                                           [&](const Place& n) { return n.unit == 0 && n.index > place.index; });
    if (!all_later || undefined_yet) continue;
    told.insert(f);
    sink.warning("sema.read-before-measured", use.span,
                 fmt::format("FA({}) is read here, before {} is measured or constructed (first at line {}): CMM "
                             "software may keep its actual from an earlier run, metron does not; at run it has no "
                             "actual here",
                             use.name, use.name, sources.locate(given->second.front().span).line));
  }
}

}  // namespace metron::interpreter::passes
