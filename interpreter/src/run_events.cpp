// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/interpreter/run_events.hpp"

#include "metron/runtime/outputs.hpp"

namespace metron::interpreter {

std::string event_text(const runtime::RunEvent& event) {
  if (const auto* f = std::get_if<runtime::FeatureReport>(&event)) return runtime::format_feature_report(*f);
  if (const auto* t = std::get_if<runtime::ToleranceResult>(&event)) return runtime::format_tolerance_result(*t);
  if (const auto* x = std::get_if<runtime::TextReport>(&event)) return x->text + "\n";
  if (const auto* fault = std::get_if<runtime::FaultReport>(&event)) return runtime::format_fault(*fault);
  return {};
}

std::optional<std::string> last_fault(const runtime::RunRecord& record) {
  for (auto it = record.events.rbegin(); it != record.events.rend(); ++it)
    if (const auto* f = std::get_if<runtime::FaultReport>(&*it)) return f->kind + ": " + f->message;
  return std::nullopt;
}

const runtime::ToleranceResult* last_tolerance_result(const runtime::RunRecord& record, const std::string& label) {
  for (auto it = record.events.rbegin(); it != record.events.rend(); ++it)
    if (const auto* r = std::get_if<runtime::ToleranceResult>(&*it); r && r->label == label) return r;
  return nullptr;
}

}  // namespace metron::interpreter
