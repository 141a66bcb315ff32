// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include "metron/interpreter/ir/instruction.hpp"
#include "metron/stdlib/diagnostic.hpp"
#include "metron/stdlib/source.hpp"

namespace metron::interpreter::passes {

/// The actuals pass: a use of FA(x) where x has a FEAT but nothing in the program, its macros or
/// its called files measures it (MEAS, RMEAS), constructs it (CONST) or states its actual
/// (FA(x)=FEAT/...) is reported once per feature as `sema.never-measured`, a warning: the run has
/// no actual there (an OUTPUT leaves it out, any other use stops the run). When a measured or
/// constructed feature is named only at run (a macro parameter, an indirect label) or a called
/// file could not be found, any feature may get an actual, and the pass says nothing.
/// A use in the main program before every statement that gives x an actual, when all of them are
/// further down the main program and it runs straight through (no loop, no jump back, no error
/// handler), is `sema.read-before-measured`, a warning naming the line of the first.
void warn_features_never_measured(const ir::Module& module, const SourceManager& sources, DiagnosticSink& sink);

}  // namespace metron::interpreter::passes
