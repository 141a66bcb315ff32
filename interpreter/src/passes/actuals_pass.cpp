// SPDX-License-Identifier: GPL-3.0-or-later
#include "passes/actuals_pass.hpp"

#include <fmt/format.h>

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

struct Uses {
  std::set<std::string> given;                // families measured, constructed or stated
  std::set<std::string> nominal;              // families with a FEAT
  std::vector<ir::LabelOperand> actual_uses;  // every FA(x) read, in program order
  bool undecidable = false;
};

void collect_expr(const ir::Expr& e, Uses& u) {
  if ((e.op == ir::ExprOp::Obtain || e.op == ir::ExprOp::Query) && e.label.prefix == "FA")
    u.actual_uses.push_back(e.label);
  for (const auto& a : e.args) collect_expr(a, u);
}

void collect(const std::vector<ir::Instruction>& code, Uses& u) {
  for (const auto& in : code) {
    if (gives_actual(in)) {
      if (named_at_run(in.name, in.name_is_param)) u.undecidable = true;
      u.given.insert(family(in.name));
    } else if (in.op == ir::Op::FeatureDef && !named_at_run(in.name, in.name_is_param)) {
      u.nominal.insert(family(in.name));
    }
    if (in.op == ir::Op::CallUnit && in.target < 0) u.undecidable = true;  // a file not found
    for (const auto& o : in.operands) {
      if (o.kind == ir::Operand::Kind::Label && o.label.prefix == "FA") u.actual_uses.push_back(o.label);
      if (o.kind == ir::Operand::Kind::Expr) collect_expr(o.expr, u);
    }
  }
}

}  // namespace

void warn_features_never_measured(const ir::Module& module, DiagnosticSink& sink) {
  Uses u;
  for (const auto& unit : module.units) collect(unit.code, u);
  for (const auto& macro : module.macros) collect(macro.code, u);
  if (u.undecidable) return;
  std::set<std::string> told;
  for (const auto& use : u.actual_uses) {
    if (use.param || use.name.rfind('@', 0) == 0) continue;
    const std::string f = family(use.name);
    if (u.given.count(f) || !u.nominal.count(f) || !told.insert(f).second) continue;
    sink.warning("sema.never-measured", use.span,
                 fmt::format("FA({}) is read here, but nothing in this program measures or constructs {} "
                             "(no MEAS, RMEAS or CONST of it, no stated actual): at run it has no actual "
                             "here",
                             use.name, use.name));
  }
}

}  // namespace metron::interpreter::passes
