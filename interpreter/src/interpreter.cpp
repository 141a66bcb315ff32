// SPDX-License-Identifier: GPL-3.0-or-later
// The interpreter's frames, variables and stepping; the instructions themselves are executed by
// the handlers in execute/, one file per DMIS statement family.
#include "metron/interpreter/interpreter.hpp"

#include <chrono>
#include <cmath>

#include <fmt/format.h>

#include "execute/execute.hpp"
#include "metron/stdlib/text_encoding.hpp"

namespace metron::interpreter {
namespace {
constexpr int SIGINT_NUMBER = 2, SIGTERM_NUMBER = 15;  // POSIX values, without <csignal> here
}  // namespace

Interpreter::Interpreter(const ir::Module& module, runtime::MeasurementRuntime& runtime, const SourceManager& sources,
                         DiagnosticSink& sink)
    : m_module(module), m_runtime(runtime), m_sources(sources), m_sink(sink) {}

void Interpreter::start(std::size_t unit) {
  CallFrame f;
  f.kind = CallFrame::Kind::Unit;
  f.index = unit;
  m_frames.push_back(std::move(f));
  m_finished = false;
}

const std::vector<ir::Instruction>& Interpreter::code_of(const CallFrame& f) const {
  return f.kind == CallFrame::Kind::Unit ? m_module.units.at(f.index).code : m_module.macros.at(f.index).code;
}

const ir::Instruction* Interpreter::current() const {
  if (m_frames.empty()) return nullptr;
  const CallFrame& f = m_frames.back();
  const auto& code = code_of(f);
  return f.pc < code.size() ? &code[f.pc] : nullptr;
}

ExecStatus Interpreter::run() {
  for (;;) {
    const ExecStatus s = step();
    if (s != ExecStatus::Running) return s;
  }
}

ExecStatus Interpreter::step() {
  if (m_finished) return ExecStatus::Finished;
  while (!m_frames.empty() && m_frames.back().pc >= code_of(m_frames.back()).size()) {
    m_frames.pop_back();  // a unit ran off its end: return to the caller
  }
  if (m_frames.empty()) {
    m_finished = true;
    return ExecStatus::Finished;
  }
  CallFrame& frame = m_frames.back();
  const ir::Instruction& in = code_of(frame)[frame.pc];
  if (auto stop = check_limits(in)) return *stop;
  m_executing = in.span;
  const std::size_t depth = m_frames.size() - 1, failed = frame.pc;
  ++frame.pc;
  detail::ExecuteFn* handler = detail::Execute::table()[detail::index(in.op)];
  if (!handler) return fail(in.span, "unknown instruction");
  const ExecStatus status = handler(*this, in, frame);
  if (status == ExecStatus::Faulted && m_bad_test && in.op == ir::Op::MeasEnd)
    return take_bad_measurement(depth, failed);
  if (status == ExecStatus::Faulted && m_on_error) return handle_fault(depth, failed);
  return status;
}

// A machine fault in a measurement under BADTST/ON: BADPT() answers .TRUE. and the run goes on
// after the measurement (the machine stays where the fault left it). The fault stays in the
// record, with a warning.
ExecStatus Interpreter::take_bad_measurement(std::size_t depth, std::size_t failed) {
  const auto& code = code_of(m_frames[depth]);
  constexpr std::size_t max_taken = 1000;  // a program that measures the same missing feature forever
  if (++m_handled_faults > max_taken) {
    m_runtime.warning(code[failed].span,
                      fmt::format("{} failed measurements were taken by BADTST/ON: the run stops here", max_taken));
    return ExecStatus::Faulted;
  }
  m_bad_point = true;
  m_block.reset();
  m_runtime.warning(
      code[failed].span,
      fmt::format("the machine fault ({}) is taken by BADTST/ON: BADPT() is .TRUE. and the run goes on after "
                  "this measurement",
                  m_last_fault ? m_last_fault->message : "unknown"));
  m_frames.resize(depth + 1);
  m_frames.back().pc = failed + 1;
  return ExecStatus::Running;
}

// A machine fault under ERROR/... (DMIS 5.x): when the condition covers it, the run goes on, at
// the handler label (kept: where RESUME goes on) or, with AUTO, after the failing statement. The
// fault stays in the record, and a warning says it was handled.
const char* Interpreter::error_condition(machine::FaultKind kind) {
  using K = machine::FaultKind;
  if (kind == K::NoContact) return "NOTOUCH";
  if (kind == K::Collision || kind == K::OverTravel) return "ILLEGALTOUCH";
  return nullptr;
}

ExecStatus Interpreter::handle_fault(std::size_t depth, std::size_t failed) {
  const ErrorHandling h = *m_on_error;
  const char* condition = error_condition(m_last_fault ? m_last_fault->kind : machine::FaultKind::BadCommand);
  const bool covered = h.condition == "ALL" || (condition && h.condition == condition);
  // The handler's frame must still be the one ERROR was set in (a macro's handler ends with it).
  const bool live = h.frame < m_frames.size() && m_frames[h.frame].kind == h.kind && m_frames[h.frame].index == h.index;
  if (!covered || !live || depth >= m_frames.size()) return ExecStatus::Faulted;
  const auto& code = code_of(m_frames[depth]);
  const Span span = code[failed].span;
  // A program whose handler takes it back to the same failing measurement forever.
  constexpr std::size_t max_handled = 1000;
  if (++m_handled_faults > max_handled) {
    m_runtime.warning(span,
                      fmt::format("{} machine faults were handled by ERROR/...: the run stops here", max_handled));
    return ExecStatus::Faulted;
  }
  std::size_t measurement = failed;
  if (code[failed].op == ir::Op::MeasEnd)
    for (std::size_t i = failed; i-- > 0;)
      if (code[i].op == ir::Op::MeasBegin && code[i].target == static_cast<std::int64_t>(failed)) {
        measurement = i;
        break;
      }
  m_block.reset();
  m_runtime.warning(span,
                    fmt::format("the machine fault ({}) is handled by ERROR/{}: the run goes on {}",
                                m_last_fault ? m_last_fault->message : "unknown", h.automatic ? "AUTO" : "(label)",
                                h.automatic ? "after this statement" : "at the handler"));
  if (h.automatic) {
    m_frames.resize(depth + 1);
    m_frames.back().pc = failed + 1;
    return ExecStatus::Running;
  }
  m_handled = HandledFault{depth, failed, measurement};
  m_frames.resize(h.frame + 1);
  m_frames.back().pc = h.target;
  return ExecStatus::Running;
}

std::optional<ExecStatus> Interpreter::check_limits(const ir::Instruction& in) {
  ++m_steps;
  const auto wall_now = [] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  };
  if (m_wall_start_s < 0) m_wall_start_s = wall_now();
  std::string why;
  if (const int signal = m_signals_to_caller ? 0 : stop_requested(); signal != 0) {
    why = signal == SIGINT_NUMBER    ? "interrupted by SIGINT"
          : signal == SIGTERM_NUMBER ? "interrupted by SIGTERM"
                                     : "interrupted";
  } else if (m_limits.max_steps && m_steps > m_limits.max_steps) {
    why = fmt::format("the run reached its limit of {} executed instructions here (--max-steps; docs/limits.md)",
                      m_limits.max_steps);
  } else if (m_limits.max_outputs && m_runtime.record_event_count() > m_limits.max_outputs) {
    why = fmt::format("the run reached its limit of {} reported outputs here (--max-outputs; docs/limits.md)",
                      m_limits.max_outputs);
  } else if (m_limits.max_simulated_s > 0 && m_runtime.machine().state().time_s > m_limits.max_simulated_s) {
    // Checked every statement: one motion statement may take seconds of simulated time.
    why = fmt::format("the run reached its limit of {:g} s of simulated time here (--max-sim-time; docs/limits.md)",
                      m_limits.max_simulated_s);
  } else if ((m_steps & 63) == 0) {
    if (m_limits.max_wall_s > 0 && wall_now() - m_wall_start_s > m_limits.max_wall_s)
      why = fmt::format("the run reached its limit of {:g} s of wall-clock time here (--max-wall-time; docs/limits.md)",
                        m_limits.max_wall_s);
  }
  if (why.empty()) return std::nullopt;
  m_stopped_by = why;
  return fail(in.span, why + "; the results obtained so far are kept");
}

ExecStatus Interpreter::fail(Span span, std::string message) {
  m_sink.error("run.error", span, std::move(message));
  return ExecStatus::Error;
}

ExecStatus Interpreter::from_runtime(const runtime::RuntimeError& e) {
  if (e.kind == runtime::RuntimeError::Kind::Fault) {
    m_last_fault = e.fault;
    return ExecStatus::Faulted;
  }
  if (e.bad_geometry && m_bad_test) {
    m_bad_geometry = true;
    m_runtime.warning(e.span, fmt::format("{}: taken by BADTST/ON: BADGT() is .TRUE. and the run goes on", e.message));
    return ExecStatus::Running;
  }
  return fail(e.span, e.message);
}

std::vector<Value>* Interpreter::find_variable(const std::string& name) {
  for (auto it = m_frames.rbegin(); it != m_frames.rend(); ++it) {
    if (auto v = it->locals.find(name); v != it->locals.end()) return &v->second;
    if (it->kind == CallFrame::Kind::Macro) break;  // macros see their locals and the globals only
  }
  auto g = m_globals.find(name);
  return g == m_globals.end() ? nullptr : &g->second;
}

std::optional<Value> Interpreter::variable(const std::string& name) const {
  auto* self = const_cast<Interpreter*>(this);
  auto* v = self->find_variable(name);
  if (!v || v->empty()) return std::nullopt;
  return v->front();
}

void Interpreter::discard_program_state() {
  std::map<std::string, std::vector<Value>>().swap(m_globals);
  std::vector<CallFrame>().swap(m_frames);
  m_finished = true;
}

tl::expected<std::size_t, std::string> Interpreter::element_offset(const std::string& name,
                                                                   const std::vector<double>& indices,
                                                                   std::size_t size) const {
  const auto dims_of = m_dims.find(name);
  const std::vector<std::size_t> dims = dims_of != m_dims.end() ? dims_of->second : std::vector<std::size_t>{size};
  if (indices.size() != dims.size())
    return tl::unexpected(fmt::format("array {} has {} dimensions, not {}", name, dims.size(), indices.size()));
  std::size_t offset = 0;
  std::string shown;
  for (std::size_t k = 0; k < dims.size(); ++k) shown += fmt::format("{}{:.0f}", k ? "," : "", std::round(indices[k]));
  std::string range;
  for (std::size_t k = 0; k < dims.size(); ++k) range += fmt::format("{}1..{}", k ? "," : "", dims[k]);
  for (std::size_t k = 0; k < dims.size(); ++k) {  // row-major: the last index runs fastest
    const double i = std::round(indices[k]);
    if (!(i >= 1 && i <= static_cast<double>(dims[k])))
      return tl::unexpected(fmt::format("index {} is outside {}[{}]", shown, name, range));
    offset = offset * dims[k] + static_cast<std::size_t>(i - 1);
  }
  if (offset >= size) return tl::unexpected(fmt::format("index {} is outside {}[{}]", shown, name, range));
  return offset;
}

tl::expected<Value, std::string> Interpreter::typed_value(const std::string& name, const Value& value) const {
  auto t = m_types.find(name);
  if (t == m_types.end()) return value;
  if (t->second == ValueType::Real && value.is_number()) return Value::real(value.number);
  if (t->second == ValueType::Integer && value.is_number()) {
    // DMIS leaves the integer ranges to the implementation: metron's INTGR is 32-bit signed (as
    // the CMM packages' C ints), LONG is what a double counts exactly (docs/language.md).
    const bool intgr = m_intgr.count(name) > 0;
    const double lo = intgr ? -2147483648.0 : -9007199254740992.0, hi = intgr ? 2147483647.0 : 9007199254740992.0;
    const double whole = std::trunc(value.number);
    if (!std::isfinite(value.number) || whole < lo || whole > hi)
      return tl::unexpected(fmt::format("{} is declared {}: {} is outside its range {:.0f} .. {:.0f}", name,
                                        intgr ? "INTGR" : "LONG", value.to_display(), lo, hi));
    return Value::integer(whole);
  }
  // The declared type holds: a CHAR value into a REAL (the debugger's set) is refused.
  if (value.type != t->second)
    return tl::unexpected(fmt::format("{} cannot hold the {} value {}: it was declared {}", name, to_string(value.type),
                                      value.to_display(), to_string(t->second)));
  return value;
}

tl::expected<void, std::string> Interpreter::set_variable(const std::string& name, const Value& value) {
  auto* v = find_variable(name);
  if (!v || v->empty()) return tl::unexpected(fmt::format("variable {} is not declared here", name));
  auto stored = typed_value(name, value);
  if (!stored) return tl::unexpected(stored.error());
  v->front() = std::move(*stored);
  return {};
}

// An indexed label's name with its index's value (`HOLE[I]` -> `HOLE[3]`); a name that holds no
// index as it is. An index that cannot be evaluated here keeps its text (the use then fails
// naming it).
std::string Interpreter::indexed(const std::string& name) const {
  if (name.size() > 1 && name.front() == '@') {
    // An indirect reference (DMIS 5.x 5.1.2.4): the CHAR variable holds the label's name, one
    // level only. A variable that holds none keeps the text (the use then fails naming it).
    auto* v = const_cast<Interpreter*>(this)->find_variable(name.substr(1));
    if (!v || v->empty() || v->front().type != ValueType::String) return name;
    std::string held = v->front().text;
    held.erase(held.find_last_not_of(' ') + 1);
    held.erase(0, std::min(held.size(), held.find_first_not_of(' ')));
    if (held.empty() || held.front() == '@') return name;
    return upper_utf8(held);
  }
  const auto open = name.find('[');
  if (open == std::string::npos || name.back() != ']') return name;
  const std::string text = name.substr(open + 1, name.size() - open - 2);
  const auto e = m_module.label_indices.find(text);
  if (e == m_module.label_indices.end()) return name;
  const auto v = const_cast<Interpreter*>(this)->evaluate(e->second);  // an index reads variables only
  if (!v || !v->is_number()) return name;
  const double i = v->number;
  return name.substr(0, open + 1) +
         (i == std::floor(i) && std::abs(i) < 1e15 ? fmt::format("{}", static_cast<long long>(i)) : v->to_display()) +
         "]";
}

std::string Interpreter::label_name(const ir::LabelOperand& l) const {
  if (!l.param || m_frames.empty()) return indexed(l.name);
  // A macro parameter standing for a label: the caller passed a label or a name.
  for (auto it = m_frames.rbegin(); it != m_frames.rend(); ++it) {
    if (auto v = it->locals.find(l.name); v != it->locals.end() && !v->second.empty()) {
      const Value& a = v->second.front();
      if (a.type == ValueType::Label || a.type == ValueType::String) return a.text;
      return a.to_display();
    }
    if (it->kind == CallFrame::Kind::Macro) break;
  }
  return l.name;
}

std::string Interpreter::name_of(const ir::Instruction& in) const {
  return in.name_is_param ? label_name({"", in.name, 0, in.span}) : indexed(in.name);
}

tl::expected<double, std::string> Interpreter::number(const ir::Expr& e) {
  auto v = evaluate(e);
  if (!v) return tl::unexpected(v.error());
  if (!v->is_number()) return tl::unexpected(fmt::format("expected a number, got {}", to_string(v->type)));
  return v->number;
}

}  // namespace metron::interpreter

namespace metron::interpreter::detail {

const ExecuteTable& Execute::table() {
  static const ExecuteTable rows = [] {
    ExecuteTable t{};
    add_input_output(t);
    add_definitions(t);
    add_measurement(t);
    add_scanning(t);
    add_alignment(t);
    add_control(t);
    return t;
  }();
  return rows;
}

std::optional<std::string> Execute::numbers(Interpreter& vm, const ir::Instruction& in, std::vector<double>& out) {
  for (const auto& o : in.operands)
    if (o.kind == ir::Operand::Kind::Expr) {
      auto v = vm.number(o.expr);
      if (!v) return v.error() + " (in " + ir::to_string(o.expr) + ")";
      out.push_back(*v);
    }
  return std::nullopt;
}

std::vector<std::string> Execute::words(const ir::Instruction& in) {
  std::vector<std::string> w;
  for (const auto& o : in.operands)
    if (o.kind == ir::Operand::Kind::Word) w.push_back(o.word);
  return w;
}

double Execute::degrees(const Interpreter& vm) { return vm.m_degrees ? 1.0 : 180.0 / pi; }

// Polar (r, angle, h) is (u, v, n) in the working plane: XYPLAN (x, y, z), YZPLAN (y, z, x),
// ZXPLAN (z, x, y); the angle from the plane's first axis toward its second, the height along its
// normal (PC-DMIS: "the height depends on the workplane currently being used").
Vec3 Execute::position(const Interpreter& vm, ir::CoordinateForm form, double a, double b, double c) {
  const Vec3 uvn = ir::position_mm(form, a, b, c, vm.m_length_mm, degrees(vm));
  if (form != ir::CoordinateForm::Pol) return uvn;
  switch (vm.m_runtime.working_plane()) {
    case runtime::WorkingPlane::XY: return uvn;
    case runtime::WorkingPlane::YZ: return Vec3(uvn.z(), uvn.x(), uvn.y());
    case runtime::WorkingPlane::ZX: return Vec3(uvn.y(), uvn.z(), uvn.x());
  }
  return uvn;
}

runtime::FeatureRef Execute::feature_ref(const Interpreter& vm, const ir::LabelOperand& l) {
  return runtime::FeatureRef{vm.label_name(l), l.prefix == "FA"};
}

}  // namespace metron::interpreter::detail
