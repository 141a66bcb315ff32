// SPDX-License-Identifier: GPL-3.0-or-later
#include "commands.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include <CLI/CLI.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "metron/interpreter/run_events.hpp"
#include "metron/interpreter/run_limits.hpp"
#include "metron/interpreter/session.hpp"
#include "metron/machine/compensation/compensated_machine.hpp"
#include "metron/machine/ipp/client_machine.hpp"
#include "metron/runtime/outputs.hpp"
#include "metron/stdlib/file_access.hpp"
#include "metron/stdlib/fitting/fit.hpp"
#include "metron/stdlib/fitting/minimum_zone.hpp"
#include "metron/stdlib/fitting/point_file.hpp"
#include "virtual_cmm_backend.hpp"

namespace metron::cli {
namespace {

struct RunArgs {
  std::string program;
  std::optional<std::string> world;
  std::optional<std::uint64_t> seed;
  std::string out_dir = ".";
  bool quiet = false;
  std::optional<std::string> characterisation;
  std::optional<std::string> touch_baseline;
  std::optional<std::string> machine_url;
  bool dry_run = false;
  std::optional<std::string> compensation;
  bool strict = false;
  std::optional<std::string> answers;
  std::vector<std::string> include_dirs;
  interpreter::RunLimits limits;
};

/// The backend of `metron run --machine ipp://host:port`: an I++ DME server (metron serve, or a
/// controller) instead of the embedded virtual CMM; the world and seed are the server's business.
tl::expected<interpreter::Backend, std::string> ipp_backend(const std::string& url) {
  const auto address = machine::ipp::parse_ipp_url(url);
  if (!address) return tl::unexpected(fmt::format("--machine {}: expected ipp://host[:port]", url));
  try {
    auto client = std::make_unique<machine::ipp::ClientMachine>(address->first, address->second);
    client->on_warning([](const std::string& w) { std::cerr << "warning: " << w << "\n"; });
    return interpreter::Backend{std::move(client), url, 0, {}, {}};
  } catch (const std::runtime_error& e) {
    return tl::unexpected(fmt::format("--machine {}: {}", url, e.what()));
  }
}

struct FitArgs {
  std::string type;
  std::string file;
  std::string format = "text";
};

int run(const RunArgs& args) {
  interpreter::RunOptions options;
  options.program = args.program;
  options.world_path = args.world;
  options.seed = args.seed;
  options.out_dir = args.out_dir;
  options.characterisation_path = args.characterisation;
  if (args.touch_baseline) {
    auto b = runtime::parse_touch_baseline(*args.touch_baseline);
    if (!b) {
      std::cerr << "error: --touch-baseline " << b.error() << "\n";
      return static_cast<int>(interpreter::RunExit::BadInput);
    }
    options.touch_baseline = *b;
  }
  options.strict = args.strict;
  options.include_dirs = args.include_dirs;
  if (args.answers) {
    // Read whole with the input-file rules (docs/security.md): /dev/zero is refused, not streamed.
    auto text = read_input_file(*args.answers);
    if (!text) {
      std::cerr << fmt::format("error: the answers file: {}\n", printable(text.error(), 1000));
      return static_cast<int>(interpreter::RunExit::BadInput);
    }
    std::istringstream in(*text);
    for (std::string line; std::getline(in, line);) {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      options.prompt_answers.push_back(line);
    }
  }
  options.limits = args.limits;
  if (auto failed = interpreter::apply_memory_limit(args.limits.max_memory_mib))
    std::cerr << "warning: " << *failed << "\n";
  // SIGINT/SIGTERM stop the run at the next statement; the results so far are written.
  interpreter::install_stop_signal_handlers();
  std::size_t in_tol = 0, out_tol = 0, faults = 0;
  std::string last_fault_kind;
  options.on_event = [&](const runtime::RunEvent& e) {
    if (const auto* t = std::get_if<runtime::ToleranceResult>(&e)) (t->in_tolerance ? in_tol : out_tol)++;
    if (const auto* f = std::get_if<runtime::FaultReport>(&e)) ++faults, last_fault_kind = f->kind;
    if (!args.quiet || std::holds_alternative<runtime::FaultReport>(e))
      std::cout << interpreter::event_text(e) << std::flush;
  };
  // --compensation: the controller's error map as a decorator at the machine API, over any backend
  // (docs/error-space.md, "Compensation"); without it the backend is used as it is.
  std::shared_ptr<const machine::ErrorMap> map;
  if (args.compensation) {
    auto loaded = machine::load_error_map(*args.compensation);
    if (!loaded) {
      std::cerr << "error: --compensation " << loaded.error() << "\n";
      return static_cast<int>(interpreter::RunExit::BadInput);
    }
    map = std::move(*loaded);
  }
  const interpreter::BackendFactory factory = [&](const std::optional<std::string>& world,
                                                  std::optional<std::uint64_t> seed) {
    auto backend = args.machine_url ? ipp_backend(*args.machine_url)
                   : args.dry_run   ? nominal_backend(world)
                                    : virtual_cmm_backend(world, seed);
    if (!backend) return backend;
    if (auto* compensated = dynamic_cast<machine::CompensatedMachine*>(backend->machine.get()))
      compensated->set_map(map);
    else
      backend->machine = std::make_unique<machine::CompensatedMachine>(std::move(backend->machine), map);
    return backend;
  };
  const auto outcome = interpreter::run_program(options, factory);
  std::cerr << outcome.diagnostics;
  const char* status = outcome.exit == interpreter::RunExit::Completed  ? "completed"
                       : outcome.exit == interpreter::RunExit::Faulted  ? "stopped by a machine fault"
                       : outcome.exit == interpreter::RunExit::BadInput ? "not started"
                       : outcome.exit == interpreter::RunExit::Stopped  ? "stopped by a limit or a signal"
                                                                        : "stopped by an error";
  std::cout << fmt::format("\nrun {}: {} features, {} tolerances in, {} out, {} faults, {:.3f} s simulated\n", status,
                           outcome.record.features.size(), in_tol, out_tol, faults, outcome.record.simulated_time_s);
  if (!outcome.results_path.empty()) std::cout << "results: " << outcome.results_path << "\n";
  // A program written for a part or a machine the world does not hold stops at its first touch
  // or move: say how to follow it to its end anyway.
  if (outcome.exit == interpreter::RunExit::Faulted && !args.dry_run && !args.machine_url &&
      (last_fault_kind == "no contact" || last_fault_kind == "axis limit"))
    std::cout << "hint: if the world does not hold this program's part or machine, `metron run --dry-run` takes every "
                 "point at its nominal and follows the program to its end\n";
  return static_cast<int>(outcome.exit);
}

int check(const std::string& program, bool strict, const std::vector<std::string>& include_dirs) {
  SourceManager sources;
  DiagnosticSink sink;
  interpreter::Compiler compiler(sources, sink);
  compiler.set_parse_options(grammar::ParseOptions{strict});
  compiler.set_include_dirs(include_dirs);
  const auto unit = compiler.compile_file(program);
  for (const auto& d : sink.items()) std::cout << format_diagnostic(d, sources);
  if (!unit && sink.items().empty()) std::cout << fmt::format("error: cannot read {}\n", program);
  const std::size_t errors = sink.error_count();
  const std::size_t notes = static_cast<std::size_t>(std::count_if(
      sink.items().begin(), sink.items().end(), [](const Diagnostic& d) { return d.severity == Severity::Note; }));
  const std::size_t warnings = sink.items().size() - errors - notes;
  std::cout << fmt::format("{}: {} error{}, {} warning{}{}\n", program, errors, errors == 1 ? "" : "s", warnings,
                           warnings == 1 ? "" : "s",
                           notes ? fmt::format(", {} note{}", notes, notes == 1 ? "" : "s") : "");
  if (!unit) return 2;  // the program cannot be read: bad input
  return errors > 0 ? 1 : 0;
}

int compile(const std::string& program, bool emit_ir, const std::vector<std::string>& include_dirs) {
  SourceManager sources;
  DiagnosticSink sink;
  interpreter::Compiler compiler(sources, sink);
  compiler.set_include_dirs(include_dirs);
  const auto unit = compiler.compile_file(program);
  for (const auto& d : sink.items()) std::cerr << format_diagnostic(d, sources);
  if (!unit || sink.has_errors()) {
    if (!unit && sink.items().empty()) std::cerr << fmt::format("error: cannot read {}\n", program);
    return unit ? 1 : 2;
  }
  if (emit_ir) std::cout << interpreter::ir::to_string(compiler.module(), sources);
  return 0;
}

int fit(const FitArgs& args) {
  const auto shape = fitting::shape_from_name(args.type);
  if (!shape) {
    std::cerr << fmt::format(
        "error: unknown fit type '{}': expected point, line, plane, circle, sphere, cylinder or cone\n", args.type);
    return 2;
  }
  auto points = fitting::read_point_file(args.file);
  if (!points) {
    std::cerr << fmt::format("{}:{}: error: {}\n", args.file, points.error().line, points.error().message);
    return 1;
  }
  auto result = fitting::fit(*shape, *points);
  if (!result) {
    std::cerr << fmt::format("{}: error: cannot fit a {} to {} points: {}\n", args.file, args.type, points->size(),
                             fitting::to_string(result.error()));
    return 1;
  }
  const auto& r = *result;
  // ISO 1101 form: the minimum zone beside the least-squares form (plane, circle, line, sphere, cylinder).
  const bool zoned = r.shape == fitting::Shape::Plane || r.shape == fitting::Shape::Circle ||
                     r.shape == fitting::Shape::Line || r.shape == fitting::Shape::Sphere ||
                     r.shape == fitting::Shape::Cylinder;
  const auto mz = zoned ? fitting::minimum_zone(r.shape, *points) : tl::unexpected(fitting::FitFailure::Degenerate);
  if (args.format == "json") {
    nlohmann::json j;
    j["type"] = std::string(fitting::to_string(r.shape));
    j["points"] = points->size();
    j["position"] = {r.position.x(), r.position.y(), r.position.z()};
    j["direction"] = {r.direction.x(), r.direction.y(), r.direction.z()};
    if (r.shape == fitting::Shape::Circle || r.shape == fitting::Shape::Sphere || r.shape == fitting::Shape::Cylinder)
      j["diameter_mm"] = r.diameter_mm;
    if (r.shape == fitting::Shape::Cone) {
      j["apex_angle_deg"] = r.apex_angle_deg;
      j["cone_distance_mm"] = r.cone_distance_mm;
    }
    j["rms_mm"] = r.rms_mm;
    j["form_mm"] = r.form_mm;
    if (mz) j["form_minimum_zone_mm"] = mz->form_mm;
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::cout << fmt::format("{} fit of {} points from {}\n", fitting::to_string(r.shape), points->size(), args.file);
  std::cout << fmt::format("  position   {:.9f} {:.9f} {:.9f}\n", r.position.x(), r.position.y(), r.position.z());
  if (r.shape != fitting::Shape::Point)
    std::cout << fmt::format("  direction  {:.12f} {:.12f} {:.12f}\n", r.direction.x(), r.direction.y(),
                             r.direction.z());
  if (r.diameter_mm > 0) std::cout << fmt::format("  diameter   {:.9f}\n", r.diameter_mm);
  if (r.shape == fitting::Shape::Cone)
    std::cout << fmt::format("  apex angle {:.9f} deg\n  distance   {:.9f}\n", r.apex_angle_deg, r.cone_distance_mm);
  std::cout << fmt::format("  rms        {:.9f}\n  form       {:.9f}   (least squares)\n", r.rms_mm, r.form_mm);
  if (mz) std::cout << fmt::format("  form       {:.9f}   (minimum zone, ISO 1101)\n", mz->form_mm);
  return 0;
}

}  // namespace

void add_include_option(CLI::App& cmd, std::vector<std::string>& dirs) {
  cmd.add_option("--include", dirs,
                 "a folder CALL/EXTERN and CHARACTERISATION may read besides the program's own, also searched for "
                 "CALL/EXTERN,DMIS files written with another machine's path (repeatable; docs/security.md)")
      ->check(CLI::ExistingDirectory);
}

void add_seed_option(CLI::App& cmd, std::optional<std::uint64_t>& seed) {
  // Parsed here, not by CLI11's conversion, which turns -1 and 1e23 into 2^64-1 silently.
  cmd.add_option_function<std::string>(
      "--seed",
      [&seed](const std::string& text) {
        const bool digits = !text.empty() && text.size() <= 20 &&
                            std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; });
        errno = 0;
        const unsigned long long v = digits ? std::strtoull(text.c_str(), nullptr, 10) : 0;
        if (!digits || errno == ERANGE)
          throw CLI::ValidationError("--seed",
                                     "expected an integer from 0 to 18446744073709551615, got '" + text + "'");
        seed = static_cast<std::uint64_t>(v);
      },
      "random seed of the run, 0 to 2^64-1 (default: the world's)");
}

void add_limit_options(CLI::App& cmd, interpreter::RunLimits& limits) {
  const auto non_negative = CLI::Range(0.0, 1e12);
  cmd.add_option("--max-steps", limits.max_steps,
                 "stop after this many executed instructions (0: no limit; docs/limits.md)")
      ->default_val(limits.max_steps)
      ->check(CLI::Range(std::uint64_t{0}, std::uint64_t{1'000'000'000'000}));
  cmd.add_option("--max-sim-time", limits.max_simulated_s, "stop after this much simulated time, s (0: no limit)")
      ->default_val(limits.max_simulated_s)
      ->check(non_negative);
  cmd.add_option("--max-wall-time", limits.max_wall_s, "stop after this much wall-clock time, s (0: no limit)")
      ->default_val(limits.max_wall_s)
      ->check(non_negative);
  cmd.add_option("--max-outputs", limits.max_outputs, "stop after this many reported outputs (0: no limit)")
      ->default_val(limits.max_outputs)
      ->check(CLI::Range(std::uint64_t{0}, std::uint64_t{1'000'000'000'000}));
  cmd.add_option("--max-memory", limits.max_memory_mib,
                 "stop when the heap would grow past this many MiB (0: no limit)")
      ->default_val(limits.max_memory_mib)
      ->check(CLI::Range(std::uint64_t{0}, std::uint64_t{1'000'000'000}));
}

void add_run_commands(CLI::App& app, std::vector<Command>& commands) {
  auto run_args = std::make_shared<RunArgs>();
  auto* run_cmd = app.add_subcommand("run", "run an inspection program on the virtual CMM");
  run_cmd->add_option("program", run_args->program, "the DMIS program")->required();
  run_cmd->add_option("--world", run_args->world, "world description (JSON); default: the embedded default world");
  add_seed_option(*run_cmd, run_args->seed);
  run_cmd->add_option("--characterisation", run_args->characterisation,
                      "machine characterisation file from `metron characterise`: PTMEAS uses its touch strategy");
  run_cmd->add_option(
      "--touch-baseline", run_args->touch_baseline,
      "PTMEAS uses a conventional cycle instead of the characterised one, at the same measuring feed, to "
      "compare program times: one-touch | two-touch:BACKOFF_MM[:FIRST_FEED_MM_S] (docs/touch-trigger.md)");
  run_cmd
      ->add_option("--machine", run_args->machine_url,
                   "run on an I++ DME server instead of the virtual CMM: ipp://host[:port] (docs/ipp-dme.md)")
      ->excludes(run_cmd->get_option("--world"));
  run_cmd
      ->add_flag("--dry-run", run_args->dry_run,
                 "every touch lands on its nominal point and every scan on its path: runs a program whose part the "
                 "world does not hold to its end; the world gives the sensors (docs/language.md \"Dry runs\")")
      ->excludes(run_cmd->get_option("--machine"));
  run_cmd->add_option("--compensation", run_args->compensation,
                      "error-space file (`metron calibrate error-space --out`): the controller corrects commanded and "
                      "measured positions by it (docs/error-space.md)");
  run_cmd->add_option("--out", run_args->out_dir, "directory for results.json and DMIS output files")->default_val(".");
  run_cmd->add_flag("--quiet", run_args->quiet, "print only diagnostics, faults and the summary");
  run_cmd->add_flag("--strict", run_args->strict,
                    "a line that is not a DMIS statement is an error (default: a warning)");
  run_cmd->add_option("--answers", run_args->answers, "operator answers for PROMPT, one per line, used in order");
  add_include_option(*run_cmd, run_args->include_dirs);
  add_limit_options(*run_cmd, run_args->limits);
  commands.push_back({run_cmd, [run_args] { return run(*run_args); }});

  auto check_program = std::make_shared<std::string>();
  auto check_includes = std::make_shared<std::vector<std::string>>();
  auto* check_cmd = app.add_subcommand("check", "check a program and print diagnostics");
  auto check_strict = std::make_shared<bool>(false);
  check_cmd->add_option("program", *check_program, "the DMIS program")->required();
  check_cmd->add_flag("--strict", *check_strict,
                      "a line that is not a DMIS statement is an error (default: a warning)");
  add_include_option(*check_cmd, *check_includes);
  commands.push_back({check_cmd, [check_program, check_strict, check_includes] {
                        return check(*check_program, *check_strict, *check_includes);
                      }});

  auto compile_program = std::make_shared<std::string>();
  auto emit_ir = std::make_shared<bool>(false);
  auto* compile_cmd = app.add_subcommand("compile", "compile a program to IR");
  compile_cmd->add_option("program", *compile_program, "the DMIS program")->required();
  compile_cmd->add_flag("--emit-ir", *emit_ir, "print the IR");
  auto compile_includes = std::make_shared<std::vector<std::string>>();
  add_include_option(*compile_cmd, *compile_includes);
  commands.push_back({compile_cmd, [compile_program, emit_ir, compile_includes] {
                        return compile(*compile_program, *emit_ir, *compile_includes);
                      }});

  auto fit_args = std::make_shared<FitArgs>();
  auto* fit_cmd = app.add_subcommand("fit", "least-squares fit of a point file (NIST .ds or CSV x,y,z)");
  fit_cmd->add_option("type", fit_args->type, "point, line, plane, circle, sphere, cylinder or cone")->required();
  fit_cmd->add_option("file", fit_args->file, "the point file")->required();
  fit_cmd->add_option("--format", fit_args->format, "text or json")
      ->default_val("text")
      ->check(CLI::IsMember({"text", "json"}));
  commands.push_back({fit_cmd, [fit_args] { return fit(*fit_args); }});
}

}  // namespace metron::cli
