// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/interpreter/session.hpp"

#include <filesystem>
#include <fstream>
#include <new>

#include <fmt/format.h>

#include "metron/runtime/outputs.hpp"
#include "metron/stdlib/file_access.hpp"
#include "passes/probing_feed_pass.hpp"

namespace metron::interpreter {

std::unique_ptr<Session> Session::create(Backend backend) {
  std::unique_ptr<Session> s(new Session());
  s->m_record.world = std::move(backend.world);
  s->m_record.seed = backend.seed;
  s->m_machine = std::move(backend.machine);
  s->m_runtime = std::make_unique<runtime::MeasurementRuntime>(*s->m_machine, s->m_sources, s->m_record);
  s->m_runtime->set_wavefront_stations(std::move(backend.wavefront_stations));
  s->m_runtime->set_error_space_rig(std::move(backend.error_space_rig));
  s->m_interpreter = std::make_unique<Interpreter>(s->m_compiler.module(), *s->m_runtime, s->m_sources, s->m_sink);
  return s;
}

bool Session::load(const std::string& program) {
  m_record.program = program;
  auto unit = m_compiler.compile_file(program);
  // The runtime's files (CHARACTERISE, CHARACTERISATION, output files) follow the same policy:
  // read where the compiler may, write inside the output directory (docs/security.md).
  m_runtime->set_file_policy(FileAccessPolicy(
      [&] {
        std::vector<std::string> dirs;
        for (const auto& d : m_compiler.file_policy().read_dirs()) dirs.push_back(d.string());
        return dirs;
      }(),
      m_runtime->output_directory()));
  if (!unit) return false;
  if (m_sink.has_errors()) return false;
  if (m_runtime->characterisation()) {
    // Refuse before any motion: every constant probing feed of the program and its macros.
    passes::check_probing_feeds(m_compiler.module(), *m_runtime, m_sink);
    if (m_sink.has_errors()) return false;
  }
  m_interpreter->start(*unit);
  return true;
}

ExecStatus Session::execute_text(const std::string& text) {
  const std::size_t before = m_sink.error_count();
  const std::size_t unit =
      m_compiler.compile_text(fmt::format("<repl:{}>", m_compiler.module().units.size()), text, UnitKind::ReplEntry);
  if (m_sink.error_count() > before) return ExecStatus::Error;
  m_interpreter->start(unit);
  const std::size_t depth = m_interpreter->frames().size();
  for (;;) {
    if (m_interpreter->frames().size() < depth) return ExecStatus::Finished;
    const ExecStatus s = m_interpreter->step();
    if (s != ExecStatus::Running) return s;
  }
}

std::string Session::take_diagnostics() {
  std::string out;
  for (const auto& d : m_sink.items()) out += format_diagnostic(d, m_sources);
  m_sink.clear();
  return out;
}

namespace {
/// results.json of a run that did not start: the refusal and why, so that a caller reading the
/// results file learns what happened (issue 11).
void write_refusal(RunOutcome& outcome, const RunOptions& options, RunExit exit, const std::string& message) {
  outcome.exit = exit;
  outcome.diagnostics += message;
  runtime::RunRecord& record = outcome.record;
  record.program = options.program;
  record.status = runtime::RunStatus::Refused;
  if (record.diagnostics.empty())
    record.diagnostics.push_back(!message.empty() && message.back() == '\n' ? message.substr(0, message.size() - 1)
                                                                            : message);
  std::error_code ec;
  if (!std::filesystem::is_directory(options.out_dir, ec)) return;
  const std::string path = (std::filesystem::path(options.out_dir) / "results.json").string();
  if (auto failed = runtime::write_results_file(record, path)) {
    outcome.diagnostics += "error: " + *failed + "\n";
    return;
  }
  outcome.results_path = path;
}
}  // namespace

RunOutcome run_program(const RunOptions& options, const BackendFactory& backend) {
  RunOutcome outcome;
  std::error_code ec;
  std::filesystem::create_directories(options.out_dir, ec);
  if (ec || !std::filesystem::is_directory(options.out_dir, ec)) {
    outcome.exit = RunExit::BadInput;
    outcome.diagnostics = fmt::format("error: cannot create the output directory {}: {}\n", options.out_dir,
                                      ec ? ec.message() : "a file of that name exists");
    return outcome;
  }
  // A program that cannot be read (missing, a directory, a device, too large) is bad input.
  if (auto text = read_input_file(options.program); !text) {
    write_refusal(outcome, options, RunExit::BadInput, "error: " + printable(text.error(), 1000) + "\n");
    return outcome;
  }
  auto built = backend(options.world_path, options.seed);
  if (!built) {
    write_refusal(outcome, options, RunExit::BadInput, "error: " + printable(built.error(), 1000) + "\n");
    return outcome;
  }
  const std::unique_ptr<Session> session = Session::create(std::move(*built));
  Session& s = *session;
  s.runtime().set_output_directory(options.out_dir);
  s.set_include_dirs(options.include_dirs);
  s.interpreter().set_limits(options.limits);
  if (options.on_event) s.runtime().on_event(options.on_event);
  if (options.characterisation_path) {
    auto c = runtime::load_characterisation(*options.characterisation_path);
    if (!c) {
      outcome.record = s.record();
      write_refusal(outcome, options, RunExit::BadInput, "error: " + printable(c.error(), 1000) + "\n");
      return outcome;
    }
    s.runtime().set_characterisation(std::move(*c));
  }
  std::string baseline_note;  // said in the diagnostics and results.json: the run's times are the baseline's
  if (options.touch_baseline) {
    // Refused before any motion: a baseline the controller could not run safely or at all.
    const runtime::MachineCharacterisation* c = s.runtime().characterisation();
    const auto& b = *options.touch_baseline;
    std::string why;
    if (b.two_touch && !b.first_feed_mm_s && !c)
      why = "--touch-baseline two-touch needs a first-touch feed (two-touch:BACKOFF:FEED) or --characterisation";
    else if (b.two_touch && b.first_feed_mm_s && c && *b.first_feed_mm_s > c->max_probe_feed_mm_s)
      why = fmt::format("--touch-baseline: first-touch feed {:.3f} mm/s exceeds the maximum protected feed {:.3f} mm/s",
                        *b.first_feed_mm_s, c->max_probe_feed_mm_s);
    if (!why.empty()) {
      outcome.record = s.record();
      write_refusal(outcome, options, RunExit::BadInput, "error: " + why + "\n");
      return outcome;
    }
    s.runtime().set_touch_baseline(b);
    baseline_note = "note: PTMEAS used the baseline touch cycle: " + runtime::describe(b, c);
  }
  s.compiler().set_parse_options(grammar::ParseOptions{options.strict});
  s.runtime().set_strict(options.strict);
  s.interpreter().set_prompt_answers(options.prompt_answers);
  s.compiler().set_include_dirs(options.include_dirs);
  bool loaded = false;
  bool out_of_memory = false;
  ExecStatus status = ExecStatus::Error;
  try {
    loaded = s.load(options.program);
    if (loaded) status = s.interpreter().run();
  } catch (const std::bad_alloc&) {
    // The memory limit (--max-memory) or the machine's own: stop like the other limits and keep
    // the results so far. The program's variables go first: one of them is most likely the hog,
    // and writing results.json needs memory.
    out_of_memory = true;
    status = ExecStatus::Error;
    s.interpreter().discard_program_state();
  }
  s.runtime().finish();
  runtime::RunRecord& record = s.record();
  // Runtime warnings (collected in the record while running) are printed after the positioned ones.
  const std::vector<std::string> runtime_warnings = record.diagnostics;
  record.diagnostics.clear();
  for (const auto& d : s.sink().items()) record.diagnostics.push_back(format_diagnostic(d, s.sources()));
  outcome.diagnostics = s.take_diagnostics();
  std::vector<std::string> notes = runtime_warnings;
  if (!baseline_note.empty()) notes.push_back(baseline_note);
  for (const auto& w : notes) {
    record.diagnostics.push_back(w);
    outcome.diagnostics += w + "\n";
  }
  switch (status) {
    case ExecStatus::Finished:
    case ExecStatus::Running:
      record.status = runtime::RunStatus::Completed;
      outcome.exit = RunExit::Completed;
      break;
    case ExecStatus::Faulted:
      record.status = runtime::RunStatus::Faulted;
      outcome.exit = RunExit::Faulted;
      break;
    case ExecStatus::Error:
      record.status = runtime::RunStatus::Error;
      outcome.exit = RunExit::ProgramError;
      break;
  }
  if (out_of_memory) {
    const std::string why = fmt::format(
        "the run ran out of memory{} here (--max-memory; docs/limits.md); the results "
        "obtained so far are kept",
        options.limits.max_memory_mib ? fmt::format(" at its limit of {} MiB", options.limits.max_memory_mib)
                                      : std::string());
    const Span at = s.interpreter().executing();
    std::string line = "error: " + why;
    if (at.valid()) {
      const Location l = s.sources().locate(at);
      line = fmt::format("{}:{}:{}: {}", l.path, l.line, l.column, line);
    }
    record.diagnostics.push_back(line);
    outcome.diagnostics += line + "\n";
  }
  if (!s.interpreter().stopped_by().empty() || out_of_memory) {
    record.status = runtime::RunStatus::Interrupted;
    outcome.exit = RunExit::Stopped;
  }
  if (!loaded) record.status = runtime::RunStatus::Refused;  // compile errors: nothing ran
  for (const auto& e : s.runtime().output_errors()) {
    record.diagnostics.push_back("error: " + e);
    outcome.diagnostics += "error: " + e + "\n";
    if (outcome.exit == RunExit::Completed) outcome.exit = RunExit::ProgramError;
  }
  outcome.results_path = (std::filesystem::path(options.out_dir) / "results.json").string();
  if (auto failed = runtime::write_results_file(record, outcome.results_path)) {
    outcome.diagnostics += "error: " + *failed + "\n";
    outcome.results_path.clear();
    if (outcome.exit == RunExit::Completed) outcome.exit = RunExit::ProgramError;
  }
  outcome.record = record;
  return outcome;
}

}  // namespace metron::interpreter
