// SPDX-License-Identifier: GPL-3.0-or-later
#include "passes/probing_feed_pass.hpp"

namespace metron::interpreter::passes {
namespace {

void check_code(const std::vector<ir::Instruction>& code, const runtime::MeasurementRuntime& runtime,
                DiagnosticSink& sink) {
  for (const auto& in : code) {
    if (in.op != ir::Op::Feed) continue;
    const auto& feed = std::get<ir::FeedPayload>(in.payload);
    if (feed.kind != ir::FeedKind::Mesvel) continue;
    const ir::Expr& e = in.operands.at(0).expr;
    if (e.op != ir::ExprOp::Constant || !e.value.is_number()) continue;
    const auto mm_s = ir::feed_mm_s(e.value.number, feed.unit);
    if (!mm_s) continue;  // PCENT: relative to the machine's feed at run time
    if (auto ok = runtime.check_probing_feed(*mm_s, in.span); !ok)
      sink.report(Diagnostic{Severity::Error, "run.probing-feed", in.span, ok.error().message, {}});
  }
}

}  // namespace

void check_probing_feeds(const ir::Module& module, const runtime::MeasurementRuntime& runtime, DiagnosticSink& sink) {
  for (const auto& u : module.units) check_code(u.code, runtime, sink);
  for (const auto& m : module.macros) check_code(m.code, runtime, sink);
}

}  // namespace metron::interpreter::passes
