// SPDX-License-Identifier: GPL-3.0-or-later
// `metron debug PROGRAM` and `metron repl`: the terminal front end of the debugger core.
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include <editline/readline.h>
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "metron/interpreter/debugger.hpp"
#include "metron/interpreter/run_events.hpp"
#include "metron/interpreter/run_limits.hpp"
#include "metron/interpreter/session.hpp"
#include "metron/runtime/alignment_ops.hpp"
#include "metron/runtime/outputs.hpp"
#include "metron/stdlib/file_access.hpp"
#include "virtual_cmm_backend.hpp"

namespace metron::cli {
namespace {

struct DebugArgs {
  std::string program;  ///< empty for `repl`
  std::optional<std::string> world;
  std::optional<std::uint64_t> seed;
  std::optional<std::string> commands;  ///< read commands from this file instead of the terminal
  std::string out_dir = ".";
  std::vector<std::string> include_dirs;
  interpreter::RunLimits limits;
};

const std::vector<std::string> command_names = {"break", "delete",  "info",   "run",   "continue",
                                                "step",  "next",    "finish", "where", "list",
                                                "print", "machine", "set",    "help",  "quit"};
std::string upper(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}
std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  return s.substr(b, s.find_last_not_of(" \t\r\n") - b + 1);
}

// Completion candidates, refreshed before each prompt (libedit calls back without context).
std::vector<std::string> g_candidates;

char* completion_generator(const char* text, int state) {
  static std::size_t index;
  static std::string prefix;
  if (state == 0) {
    index = 0;
    prefix = upper(text);
  }
  while (index < g_candidates.size()) {
    const std::string& c = g_candidates[index++];
    if (upper(c).rfind(prefix, 0) == 0) return strdup(c.c_str());
  }
  return nullptr;
}

char** complete(const char* text, int, int) {
  rl_attempted_completion_over = 1;
  return rl_completion_matches(text, completion_generator);
}

// Where lines come from: the terminal (libedit, history, completion) or a pipe/file.
class LineSource {
 public:
  explicit LineSource(std::istream* in) : m_in(in), m_interactive(!in && ::isatty(STDIN_FILENO)) {
    if (m_interactive) {
      rl_attempted_completion_function = complete;
      using_history();
    }
  }
  std::optional<std::string> read(const std::string& prompt) {
    if (m_interactive) {
      char* line = readline(prompt.c_str());
      if (!line) return std::nullopt;
      std::string s(line);
      std::free(line);
      if (!trim(s).empty()) add_history(s.c_str());
      return s;
    }
    std::string s;
    if (!std::getline(m_in ? *m_in : std::cin, s)) return std::nullopt;
    std::cout << prompt << s << std::endl;  // a transcript that reads like the session, as it happens
    return s;
  }

 private:
  std::istream* m_in;
  bool m_interactive;
};

class Repl {
 public:
  Repl(interpreter::Session& session, std::string out_dir) : m_session(session), m_debugger(session) {
    m_session.runtime().set_output_directory(std::move(out_dir));
    m_session.runtime().on_event([](const runtime::RunEvent& e) { std::cout << interpreter::event_text(e); });
  }

  int loop(LineSource& source, bool has_program) {
    m_has_program = has_program;
    std::cout << (has_program ? "metron debugger: 'run' starts the program, 'help' lists the commands\n"
                              : "metron repl: type DMIS statements or 'help'\n");
    for (;;) {
      refresh_candidates();
      auto line = source.read("(metron) ");
      if (!line) break;
      std::string text = trim(*line);
      if (text.empty()) continue;
      if (is_command(text)) {
        if (!command(text)) break;
        continue;
      }
      // A DMIS statement; blocks (MEAS ... ENDMES, IF, DO, MACRO) and `$` continuations span lines.
      int depth = block_delta(text);
      while (depth > 0 || (!text.empty() && text.back() == '$')) {
        auto more = source.read("...> ");
        if (!more) break;
        text += "\n" + *more;
        depth += block_delta(trim(*more));
      }
      statement(text);
      if (m_terminated) break;
    }
    if (m_terminated) return 4;  // docs/limits.md: stopped by a signal
    return m_errors > 0 && !std::cin ? 1 : 0;
  }

 private:
  static std::string first_word(const std::string& text) {
    std::size_t e = 0;
    while (e < text.size() && (std::isalnum(static_cast<unsigned char>(text[e])) || text[e] == '_')) ++e;
    return text.substr(0, e);
  }
  bool is_command(const std::string& text) const {
    const std::string w = first_word(text);
    if (w.empty()) return false;
    if (text.size() > w.size() && (text[w.size()] == '(' || text[w.size()] == '/'))
      return false;  // F(x)=..., MAJOR/...
    static const std::set<std::string> aliases = {"c", "s", "n", "bt", "l", "p", "q", "exit", "b", "help"};
    std::string lw = w;
    for (auto& c : lw) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    // `print 4/2` and `set V = A/B` are commands: their expressions may divide.
    if (text.find('/') != std::string::npos && lw != "print" && lw != "p" && lw != "set") return false;
    return std::find(command_names.begin(), command_names.end(), lw) != command_names.end() || aliases.count(lw);
  }
  // +1 for a statement that opens a block, -1 for one that closes it.
  static int block_delta(const std::string& line) {
    std::string major = upper(line);
    const auto eq = major.find('=');
    const auto slash = major.find('/');
    if (eq != std::string::npos && (slash == std::string::npos || eq < slash)) major = trim(major.substr(eq + 1));
    major = first_word(major);
    if (major == "MEAS" || major == "IF" || major == "DO" || major == "MACRO") return 1;
    if (major == "ENDMES" || major == "ENDIF" || major == "ENDDO" || major == "ENDMAC") return -1;
    return 0;
  }

  void refresh_candidates() {
    g_candidates = command_names;
    const auto major_words = interpreter::Compiler::statement_words();
    g_candidates.insert(g_candidates.end(), major_words.begin(), major_words.end());
    const auto& sym = m_session.compiler().symbols();
    for (const auto& [name, info] : sym.features) {
      g_candidates.push_back("F(" + name + ")");
      g_candidates.push_back("FA(" + name + ")");
    }
    for (const auto& [name, kind] : sym.tolerances) {
      g_candidates.push_back("T(" + name + ")");
      g_candidates.push_back("TA(" + name + ")");
    }
    for (const auto& name : sym.alignments) g_candidates.push_back("D(" + name + ")");
    for (const auto& name : sym.sensors) g_candidates.push_back("S(" + name + ")");
    for (const auto& [name, info] : sym.variables) g_candidates.push_back(name);
  }

  void print_diagnostics() {
    const std::string d = m_session.take_diagnostics();
    if (d.find(": error: ") != std::string::npos) ++m_errors;
    std::cout << d;
  }

  void statement(const std::string& text) {
    // A long statement typed at the prompt (a MEAS block) stops at SIGINT with an error and the
    // session goes on; at SIGTERM the session ends.
    const auto status = [&] {
      const interpreter::StopSignalScope signals;
      const auto executed = m_session.execute_text(text + "\n");
      if (interpreter::stop_requested() == SIGTERM) m_terminated = true;
      return executed;
    }();
    print_diagnostics();
    if (status == interpreter::ExecStatus::Faulted) std::cout << "the statement stopped on a machine fault\n";
  }

  void report_stop(const interpreter::Stop& stop) {
    using interpreter::StopReason;
    print_diagnostics();
    switch (stop.reason) {
      case StopReason::Breakpoint: std::cout << fmt::format("breakpoint {}: {}\n", stop.breakpoint, stop.detail); break;
      case StopReason::Measured:
        std::cout << fmt::format("breakpoint {}: {}\n", stop.breakpoint, stop.detail);
        show_current();
        break;
      case StopReason::Step: std::cout << stop.detail << "\n"; break;
      case StopReason::Fault:
        std::cout << fmt::format("machine fault{}: {}\n",
                                 stop.breakpoint ? fmt::format(" (breakpoint {})", stop.breakpoint) : "", stop.detail);
        break;
      case StopReason::Error: std::cout << stop.detail << "\n"; break;
      case StopReason::Finished: std::cout << "the program has ended\n"; break;
      case StopReason::Interrupted:
        std::cout << fmt::format("interrupted by {} before {}\n", stop.signal == SIGTERM ? "SIGTERM" : "SIGINT",
                                 stop.detail);
        if (stop.signal != SIGTERM) std::cout << "'continue' resumes the program\n";
        break;
    }
  }
  void show_current() {
    const Span s = m_debugger.current_span();
    if (!s.valid()) return;
    const Location loc = m_session.sources().locate(s);
    std::cout << fmt::format("next: {}:{}: {}\n", loc.path, loc.line, m_session.sources().line_text(s.file, s.begin));
  }

  bool command(const std::string& text) {
    std::istringstream in(text);
    std::string word;
    in >> word;
    for (auto& c : word) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    std::string rest;
    std::getline(in, rest);
    rest = trim(rest);
    if (word == "quit" || word == "q" || word == "exit") return false;
    if (word == "help") return help();
    if (word == "break" || word == "b") return breakpoint(rest);
    if (word == "delete") {
      if (rest.empty()) {
        while (!m_debugger.breakpoints().empty()) m_debugger.remove(m_debugger.breakpoints().front().id);
        std::cout << "all breakpoints deleted\n";
      } else if (m_debugger.remove(std::atoi(rest.c_str()))) {
        std::cout << "breakpoint " << rest << " deleted\n";
      } else {
        std::cout << "error: no breakpoint " << rest << "\n";
      }
      return true;
    }
    if (word == "info") {
      if (m_debugger.breakpoints().empty()) std::cout << "no breakpoints\n";
      for (const auto& b : m_debugger.breakpoints()) {
        using K = interpreter::Breakpoint::Kind;
        const std::string what = b.kind == K::Line
                                     ? fmt::format("line {}{}", b.file.empty() ? "" : b.file + ":", b.line)
                                 : b.kind == K::Feature ? fmt::format("feature F({}) measured", b.feature)
                                                        : std::string("machine fault");
        std::cout << fmt::format("{:3}  {}  (hit {} time{})\n", b.id, what, b.hits, b.hits == 1 ? "" : "s");
      }
      return true;
    }
    if (word == "run" || word == "continue" || word == "c" || word == "step" || word == "s" || word == "next" ||
        word == "n" || word == "finish") {
      if (!m_has_program) {
        std::cout << "error: no program is loaded (use 'metron debug PROGRAM')\n";
        return true;
      }
      if (word == "run" && m_ran) {
        std::cout << "the program is already running: use 'continue'\n";
        return true;
      }
      m_ran = true;
      interpreter::Stop stop;
      {
        // While the program runs, SIGINT (Ctrl-C) pauses it and SIGTERM ends the session cleanly;
        // at the prompt both act as usual (docs/debugger.md).
        const interpreter::StopSignalScope signals;
        if (word == "run" || word == "continue" || word == "c")
          stop = m_debugger.resume();
        else if (word == "step" || word == "s")
          stop = m_debugger.step();
        else if (word == "next" || word == "n")
          stop = m_debugger.next();
        else
          stop = m_debugger.finish();
      }
      report_stop(stop);
      if (stop.reason == interpreter::StopReason::Interrupted && stop.signal == SIGTERM) {
        m_terminated = true;
        return false;
      }
      return true;
    }
    if (word == "where" || word == "bt") {
      for (const auto& f : m_debugger.where()) std::cout << f << "\n";
      if (m_debugger.where().empty()) std::cout << "(no frames)\n";
      return true;
    }
    if (word == "list" || word == "l") {
      std::cout << m_debugger.list();
      return true;
    }
    if (word == "print" || word == "p") return print(rest);
    if (word == "machine") return machine();
    if (word == "set") return set(rest);
    std::cout << "error: unknown command " << word << "\n";
    return true;
  }

  bool help() {
    std::cout
        << "commands:\n"
           "  break LINE | break FILE:LINE | break F(label) | break fault   set a breakpoint\n"
           "  delete [ID]            delete one or all breakpoints\n"
           "  info breakpoints       list breakpoints\n"
           "  run                    start the program\n"
           "  continue (c)           run to the next breakpoint\n"
           "  step (s)               one statement, into macros and called files\n"
           "  next (n)               one statement, over macros and called files\n"
           "  finish                 until the current macro or called file returns\n"
           "  where (bt)             call stack\n"
           "  list (l)               source around the current statement\n"
           "  print EXPR | F(x) | FA(x) | T(x) | TA(x) | D   values, features, tolerances, the coordinate system\n"
           "  machine                position, feeds, sensor, simulated clock, last hit, queued commands\n"
           "  set VAR = EXPR         change a variable\n"
           "  quit                   leave\n"
           "Any DMIS statement (or a whole MEAS ... ENDMES block) runs in the current context.\n";
    return true;
  }

  bool breakpoint(const std::string& rest) {
    static const std::regex feature(R"(^[Ff][Aa]?\(([^)]+)\)$)");
    static const std::regex file_line(R"(^(.*):(\d+)$)");
    std::smatch m;
    int id = 0;
    if (upper(rest) == "FAULT") {
      id = m_debugger.break_on_fault();
      std::cout << fmt::format("breakpoint {}: on machine faults\n", id);
    } else if (std::regex_match(rest, m, feature)) {
      const std::string label = upper(m[1].str());
      if (!m_session.compiler().symbols().features.count(label))
        std::cout << fmt::format("warning: F({}) is not defined yet\n", m[1].str());
      id = m_debugger.break_at_feature(label);
      std::cout << fmt::format("breakpoint {}: when F({}) is measured\n", id, label);
    } else if (std::regex_match(rest, m, file_line)) {
      const auto line = line_number(m[2].str());
      if (!line_exists(m[1].str(), line)) {
        std::cout << fmt::format("error: {} has no line {} (or is not part of the program)\n", m[1].str(), m[2].str());
        return true;
      }
      id = m_debugger.break_at_line(m[1].str(), line);
      std::cout << fmt::format("breakpoint {}: {}:{}\n", id, m[1].str(), m[2].str());
    } else if (!rest.empty() && std::all_of(rest.begin(), rest.end(),
                                            [](char c) { return std::isdigit(static_cast<unsigned char>(c)); })) {
      if (!line_exists(m_session.record().program, line_number(rest))) {
        std::cout << fmt::format("error: the program has no line {}\n", rest);
        return true;
      }
      id = m_debugger.break_at_line(m_session.record().program, line_number(rest));
      std::cout << fmt::format("breakpoint {}: line {}\n", id, rest);
    } else {
      std::cout << "error: expected break LINE, break FILE:LINE, break F(label) or break fault\n";
    }
    return true;
  }

  // A line number as typed (0 when it does not fit: no such line).
  static std::uint32_t line_number(const std::string& digits) {
    return digits.size() > 9 ? 0 : static_cast<std::uint32_t>(std::stoul(digits));
  }
  // Whether `file` (as the program names it, or its file name) is a compiled unit with `line`.
  bool line_exists(const std::string& file, std::uint32_t line) const {
    if (line == 0) return false;
    const auto& units = m_session.compiler().module().units;
    for (const auto& u : units) {
      if (u.file == 0) continue;
      const std::filesystem::path a(u.path), b(file);
      if (!(a == b || a.filename() == b.filename())) continue;
      if (line <= m_session.sources().file(u.file).line_starts.size()) return true;
    }
    return false;
  }

  bool print(const std::string& rest) {
    static const std::regex label(R"(^([A-Za-z]+)\(([^)]+)\)$)");
    std::smatch m;
    if (rest.empty()) {
      std::cout << "error: print what? (an expression, F(x), FA(x), T(x), TA(x) or D)\n";
      return true;
    }
    if ((upper(rest) == "D" && !m_session.interpreter().variable("D")) || upper(rest) == "ALIGNMENT")
      return print_alignment();
    if (std::regex_match(rest, m, label)) {
      const std::string prefix = upper(m[1].str());
      const std::string name = upper(m[2].str());
      if (prefix == "F" || prefix == "FA") return print_feature(name, prefix == "FA");
      if (prefix == "T" || prefix == "TA") return print_tolerance(name);
    }
    auto e = m_session.compiler().compile_expression(rest, runtime_names());
    if (!e) {
      print_diagnostics();
      return true;
    }
    auto v = m_session.interpreter().evaluate(*e);
    if (!v)
      std::cout << "error: " << v.error() << "\n";
    else
      std::cout << rest << " = " << v->to_display() << "\n";
    return true;
  }

  bool print_feature(const std::string& name, bool actual) {
    const auto* f = m_session.runtime().find_feature(name);
    if (!f) {
      std::cout << fmt::format("error: feature F({}) is not defined\n", name);
      return true;
    }
    const auto& align = m_session.runtime().alignment();
    runtime::FeatureReport r;
    r.label = f->label;
    r.frame = align.label;
    r.nominal = runtime::to_frame(f->nominal, align.part_to_machine);
    if (actual && f->actual) r.actual = runtime::to_frame(*f->actual, align.part_to_machine);
    r.fit = f->fit;
    r.point_count = f->points.size();
    r.source = f->source;
    std::cout << runtime::format_feature_report(r);
    if (actual && !f->actual) std::cout << "  (no actual: not measured yet)\n";
    if (actual)
      for (std::size_t i = 0; i < f->points.size(); ++i) {
        const Vec3 p = align.to_part_point(f->points[i].surface_mm());
        const Vec3 n = align.to_part_vector(f->points[i].normal);
        const double res = f->fit && i < f->fit->residuals_mm.size() ? f->fit->residuals_mm[i] : 0.0;
        std::cout << fmt::format("  pt {:2}  {:10.4f} {:10.4f} {:10.4f}   {:9.6f} {:9.6f} {:9.6f}   res {:+.4f}\n",
                                 i + 1, p.x(), p.y(), p.z(), n.x(), n.y(), n.z(), res);
      }
    return true;
  }

  bool print_tolerance(const std::string& name) {
    const auto* t = m_session.runtime().find_tolerance(name);
    if (!t) {
      std::cout << fmt::format("error: tolerance T({}) is not defined\n", name);
      return true;
    }
    std::cout << fmt::format("T({})  {}  lower {:+.4f}  upper {:+.4f}  zone {:.4f}\n", name,
                             runtime::dmis_word(t->kind), t->lower, t->upper, t->zone);
    if (const auto* r = interpreter::last_tolerance_result(m_session.record(), name)) {
      std::cout << "last result: " << runtime::format_tolerance_result(*r);
      return true;
    }
    std::cout << "  (not evaluated yet: OUTPUT it with a feature)\n";
    return true;
  }

  bool print_alignment() {
    const auto& a = m_session.runtime().alignment();
    const auto& f = a.part_to_machine;
    std::cout << fmt::format("coordinate system D({}), part to machine:\n", a.label);
    for (int r = 0; r < 3; ++r)
      std::cout << fmt::format("  {:10.6f} {:10.6f} {:10.6f}   {:12.4f}\n", f.linear()(r, 0), f.linear()(r, 1),
                               f.linear()(r, 2), f.translation()[r]);
    return true;
  }

  bool machine() {
    const auto s = m_session.machine().state();
    const Vec3 part = m_session.runtime().alignment().to_part_point(s.position_mm);
    std::cout << fmt::format("position   {:.4f} {:.4f} {:.4f} mm (machine)   {:.4f} {:.4f} {:.4f} (D({}))\n",
                             s.position_mm.x(), s.position_mm.y(), s.position_mm.z(), part.x(), part.y(), part.z(),
                             m_session.runtime().alignment().label);
    std::cout << fmt::format("velocity   {:.4f} {:.4f} {:.4f} mm/s\n", s.velocity_mm_s.x(), s.velocity_mm_s.y(),
                             s.velocity_mm_s.z());
    std::cout << fmt::format("feeds      positioning {:.3f} mm/s, measuring {:.3f} mm/s\n", s.positioning_feed_mm_s,
                             s.measuring_feed_mm_s);
    if (s.tool)
      std::cout << fmt::format("sensor     {} (nominal radius {:.4f}, effective {:.6f} mm, {})\n", s.active_tool,
                               s.tool->nominal_radius_mm, s.tool->effective_radius_mm,
                               s.tool->qualified ? "qualified" : "not qualified");
    else
      std::cout << "sensor     none selected\n";
    std::cout << fmt::format("clock      {:.4f} s simulated\n", s.time_s);
    if (s.last_hit)
      std::cout << fmt::format(
          "last hit   {:.4f} {:.4f} {:.4f} (ball centre)  approach {:.4f} {:.4f} {:.4f}  at {:.4f} s\n",
          s.last_hit->centre_mm.x(), s.last_hit->centre_mm.y(), s.last_hit->centre_mm.z(), s.last_hit->normal.x(),
          s.last_hit->normal.y(), s.last_hit->normal.z(), s.last_hit->time_s);
    else
      std::cout << "last hit   none\n";
    std::cout << fmt::format("commands   {} executed, {} queued\n", s.executed_commands, s.queued_commands);
    if (m_session.interpreter().in_measurement()) {
      // Settings and sensor selections in the block are applied between its points at ENDMES: the
      // feeds and sensor above are still those before the block.
      const auto& block = *m_session.interpreter().pending_block();
      const auto held =
          std::count_if(block.steps.begin(), block.steps.end(), [](const metron::runtime::MeasStep& step) {
            return step.kind == metron::runtime::MeasStep::Kind::Setting ||
                   step.kind == metron::runtime::MeasStep::Kind::SelectSensor;
          });
      std::cout << fmt::format(
          "measuring  F({}): {} steps collected{}, sent at ENDMES\n", block.feature, block.steps.size(),
          held == 1  ? std::string(" (1 setting or sensor selection, applied between the points)")
          : held > 1 ? fmt::format(" ({} settings or sensor selections, applied between the points)", held)
                     : std::string());
    }
    return true;
  }

  bool set(const std::string& rest) {
    const auto eq = rest.find('=');
    std::string name = upper(trim(eq == std::string::npos ? rest.substr(0, rest.find(' ')) : rest.substr(0, eq)));
    std::string expr =
        trim(eq == std::string::npos ? rest.substr(std::min(rest.size(), rest.find(' '))) : rest.substr(eq + 1));
    if (name.empty() || expr.empty()) {
      std::cout << "error: expected set VAR = EXPR\n";
      return true;
    }
    if (!m_session.interpreter().variable(name)) {
      std::cout << fmt::format("error: variable {} is not declared\n", name);
      return true;
    }
    auto e = m_session.compiler().compile_expression(expr, runtime_names());
    if (!e) {
      print_diagnostics();
      return true;
    }
    auto v = m_session.interpreter().evaluate(*e);
    if (!v) {
      std::cout << "error: " << v.error() << "\n";
      return true;
    }
    if (auto set = m_session.interpreter().set_variable(name, *v); !set) {
      std::cout << "error: " << set.error() << "\n";
      return true;
    }
    std::cout << name << " = " << m_session.interpreter().variable(name)->to_display() << "\n";
    return true;
  }

  // Macro parameters and locals of the innermost frames (the compiler does not see them).
  std::set<std::string> runtime_names() const {
    std::set<std::string> names;
    for (const auto& f : m_session.interpreter().frames())
      for (const auto& [name, value] : f.locals) names.insert(name);
    return names;
  }

  interpreter::Session& m_session;
  interpreter::Debugger m_debugger;
  bool m_has_program = false;
  bool m_ran = false;
  bool m_terminated = false;  // SIGTERM while the program ran: the session ends (exit 4)
  int m_errors = 0;
};

int debug(const DebugArgs& args) {
  auto backend = virtual_cmm_backend(args.world, args.seed);
  if (!backend) {
    std::cerr << "error: " << backend.error() << "\n";
    return 2;
  }
  auto session = interpreter::Session::create(std::move(*backend));
  std::unique_ptr<std::istringstream> file;
  if (args.commands) {
    // Read whole, with the input size cap: /dev/zero or a huge file is refused, not streamed.
    auto text = read_input_file(*args.commands);
    if (!text) {
      std::cerr << "error: " << printable(text.error(), 1000) << "\n";
      return 2;
    }
    file = std::make_unique<std::istringstream>(std::move(*text));
  }
  std::error_code ec;
  std::filesystem::create_directories(args.out_dir, ec);
  if (ec || !std::filesystem::is_directory(args.out_dir, ec)) {
    std::cerr << fmt::format("error: cannot create the output directory {}\n", args.out_dir);
    return 2;
  }
  interpreter::Session& s = *session;
  s.runtime().set_output_directory(args.out_dir);
  s.set_include_dirs(args.include_dirs);
  s.interpreter().set_limits(args.limits);
  if (auto failed = interpreter::apply_memory_limit(args.limits.max_memory_mib))
    std::cerr << "warning: " << *failed << "\n";
  if (!args.program.empty()) {
    if (auto text = read_input_file(args.program); !text) {
      std::cerr << "error: " << printable(text.error(), 1000) << "\n";
      return 2;
    }
    const bool ok = s.load(args.program);
    std::cout << s.take_diagnostics();
    if (!ok) {
      std::cerr << fmt::format("error: {} does not compile\n", args.program);
      return 1;
    }
  }
  LineSource source(file.get());
  Repl repl(s, args.out_dir);
  return repl.loop(source, !args.program.empty());
}

}  // namespace

void add_debug_commands(CLI::App& app, std::vector<Command>& commands) {
  for (const bool with_program : {true, false}) {
    auto args = std::make_shared<DebugArgs>();
    auto* cmd = with_program ? app.add_subcommand("debug", "step-debug a program in a REPL")
                             : app.add_subcommand("repl", "an interactive DMIS session on the virtual CMM");
    if (with_program) cmd->add_option("program", args->program, "the DMIS program")->required();
    cmd->add_option("--world", args->world, "world description (JSON); default: the embedded default world");
    add_seed_option(*cmd, args->seed);
    add_include_option(*cmd, args->include_dirs);
    add_limit_options(*cmd, args->limits);
    cmd->add_option("--commands", args->commands, "read the commands from this file instead of the terminal");
    cmd->add_option("--out", args->out_dir, "directory for DMIS output files")->default_val(".");
    commands.push_back({cmd, [args] { return debug(*args); }});
  }
}

}  // namespace metron::cli
