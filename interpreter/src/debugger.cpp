// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/interpreter/debugger.hpp"
#include "metron/interpreter/run_limits.hpp"

#include <algorithm>
#include <filesystem>

#include <fmt/format.h>

#include "metron/interpreter/run_events.hpp"

namespace metron::interpreter {

int Debugger::break_at_line(const std::string& file, std::uint32_t line) {
  Breakpoint b;
  b.kind = Breakpoint::Kind::Line;
  b.id = m_next_id++;
  b.file = file;
  b.line = line;
  m_breakpoints.push_back(b);
  return b.id;
}

int Debugger::break_at_feature(const std::string& label) {
  Breakpoint b;
  b.kind = Breakpoint::Kind::Feature;
  b.id = m_next_id++;
  b.feature = label;
  m_breakpoints.push_back(b);
  return b.id;
}

int Debugger::break_on_fault() {
  Breakpoint b;
  b.kind = Breakpoint::Kind::Fault;
  b.id = m_next_id++;
  m_breakpoints.push_back(b);
  return b.id;
}

bool Debugger::remove(int id) {
  const auto it =
      std::remove_if(m_breakpoints.begin(), m_breakpoints.end(), [&](const Breakpoint& b) { return b.id == id; });
  if (it == m_breakpoints.end()) return false;
  m_breakpoints.erase(it, m_breakpoints.end());
  return true;
}

Span Debugger::current_span() const {
  const ir::Instruction* in = m_session.interpreter().current();
  return in ? in->span : Span{};
}

std::optional<int> Debugger::line_breakpoint_at(Span span) const {
  if (!span.valid()) return std::nullopt;
  const Location loc = m_session.sources().locate(span);
  for (const auto& b : m_breakpoints) {
    if (b.kind != Breakpoint::Kind::Line || b.line != loc.line) continue;
    if (b.file.empty()) return b.id;
    const std::filesystem::path a(b.file), c(loc.path);
    if (a == c || a.filename() == c.filename() ||
        std::filesystem::weakly_canonical(a) == std::filesystem::weakly_canonical(c))
      return b.id;
  }
  return std::nullopt;
}

std::string Debugger::describe(Span span) const {
  if (!span.valid()) return "(no statement)";
  const Location loc = m_session.sources().locate(span);
  return fmt::format("{}:{}: {}", loc.path, loc.line, m_session.sources().line_text(span.file, span.begin));
}

Stop Debugger::drive(Mode mode) {
  Interpreter& vm = m_session.interpreter();
  if (m_finished) return {StopReason::Finished, 0, "the program has ended"};
  const Span start = current_span();
  const std::size_t depth = vm.frames().size();
  const bool first = !m_started;
  m_started = true;
  // The interpreter leaves signals to this loop, which pauses on them (never an error).
  struct SignalsHere {
    Interpreter& vm;
    explicit SignalsHere(Interpreter& v) : vm(v) { vm.leave_signals_to_caller(true); }
    ~SignalsHere() { vm.leave_signals_to_caller(false); }
  } signals_here(vm);
  bool moved = false;
  bool left_start = false;  // an instruction of another statement ran: coming back to the start is new
  for (;;) {
    const ir::Instruction* in = vm.current();
    // Statement boundaries: the next instruction belongs to another statement than the start, or
    // is the start statement again after others ran (the next iteration of a DO loop).
    const bool other = in && (in->span.file != start.file || in->span.begin != start.begin);
    if (moved && other) left_start = true;
    const bool new_statement = in && moved && (other || left_start);
    if (in && (new_statement || (first && !moved))) {
      if (auto id = line_breakpoint_at(in->span)) {
        for (auto& b : m_breakpoints)
          if (b.id == *id) ++b.hits;
        return {StopReason::Breakpoint, *id, describe(in->span)};
      }
    }
    if (in && new_statement) {
      const std::size_t d = vm.frames().size();
      if (mode == Mode::Step) return {StopReason::Step, 0, describe(in->span)};
      if (mode == Mode::Next && d <= depth) return {StopReason::Step, 0, describe(in->span)};
      if (mode == Mode::Finish && d < depth) return {StopReason::Step, 0, describe(in->span)};
    }
    // A signal pauses the program before its next instruction (the interpreter's own check would
    // end it with an error): the debugger's user wanted to look, not to lose the session.
    if (const int signal = stop_requested(); signal != 0 && in) {
      clear_stop();
      return {StopReason::Interrupted, 0, describe(in->span), signal};
    }
    std::optional<std::string> measuring;
    if (in && in->op == ir::Op::MeasEnd && vm.pending_block()) measuring = vm.pending_block()->feature;
    const ExecStatus s = vm.step();
    moved = true;
    switch (s) {
      case ExecStatus::Running: break;
      case ExecStatus::Finished: m_finished = true; return {StopReason::Finished, 0, "the program has ended"};
      case ExecStatus::Error: return {StopReason::Error, 0, "a run-time error stopped the program"};
      case ExecStatus::Faulted: {
        const std::string message = last_fault(m_session.record()).value_or("machine fault");
        for (auto& b : m_breakpoints)
          if (b.kind == Breakpoint::Kind::Fault) {
            ++b.hits;
            return {StopReason::Fault, b.id, message};
          }
        return {StopReason::Fault, 0, message};
      }
    }
    if (measuring)
      for (auto& b : m_breakpoints)
        if (b.kind == Breakpoint::Kind::Feature && b.feature == *measuring) {
          ++b.hits;
          return {StopReason::Measured, b.id, fmt::format("F({}) measured", *measuring)};
        }
  }
}

Stop Debugger::resume() { return drive(Mode::Continue); }
Stop Debugger::step() { return drive(Mode::Step); }
Stop Debugger::next() { return drive(Mode::Next); }
Stop Debugger::finish() { return drive(Mode::Finish); }

std::vector<std::string> Debugger::where() const {
  std::vector<std::string> out;
  const auto& frames = m_session.interpreter().frames();
  const auto& module = m_session.compiler().module();
  for (auto it = frames.rbegin(); it != frames.rend(); ++it) {
    const auto& code =
        it->kind == CallFrame::Kind::Unit ? module.units.at(it->index).code : module.macros.at(it->index).code;
    const std::string where_name = it->kind == CallFrame::Kind::Unit ? module.units.at(it->index).path
                                                                     : "M(" + module.macros.at(it->index).name + ")";
    // Outer frames have already moved past their CALL: show the call itself.
    const std::size_t pc = it == frames.rbegin() || it->pc == 0 ? it->pc : it->pc - 1;
    const Span span = pc < code.size() ? code[pc].span : (code.empty() ? Span{} : code.back().span);
    out.push_back(fmt::format("#{} {} at {}", out.size(), where_name, describe(span)));
  }
  return out;
}

std::string Debugger::list(int context_lines) const {
  const Span span = current_span();
  if (!span.valid()) return "(the program has ended)\n";
  const auto& sources = m_session.sources();
  const Location loc = sources.locate(span);
  const auto& file = sources.file(span.file);
  const std::uint32_t first = loc.line > static_cast<std::uint32_t>(context_lines) ? loc.line - context_lines : 1;
  const std::uint32_t last =
      std::min<std::uint32_t>(loc.line + context_lines, static_cast<std::uint32_t>(file.line_starts.size()));
  std::string out;
  for (std::uint32_t l = first; l <= last; ++l) {
    const std::string_view text = sources.line_text(span.file, file.line_starts[l - 1]);
    if (l == file.line_starts.size() && text.empty()) break;
    out += fmt::format("{}{:5}  {}\n", l == loc.line ? "=>" : "  ", l, text);
  }
  return out;
}

}  // namespace metron::interpreter
