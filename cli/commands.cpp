// SPDX-License-Identifier: GPL-3.0-or-later
#include "commands.hpp"

#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "metron/interpreter/run_events.hpp"
#include "metron/interpreter/session.hpp"
#include "metron/runtime/outputs.hpp"
#include "metron/stdlib/fitting/fit.hpp"
#include "metron/stdlib/fitting/point_file.hpp"
#include "metron/machine/ipp/client_machine.hpp"
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
  std::optional<std::string> machine_url;
};

/// The backend of `metron run --machine ipp://host:port`: an I++ DME server (metron serve, or a
/// controller) instead of the embedded virtual CMM; the world and seed are the server's business.
tl::expected<interpreter::Backend, std::string> ipp_backend(const std::string& url) {
  const auto address = machine::ipp::parse_ipp_url(url);
  if (!address) return tl::unexpected(fmt::format("--machine {}: expected ipp://host[:port]", url));
  try {
    return interpreter::Backend{std::make_unique<machine::ipp::ClientMachine>(address->first, address->second), url, 0, {}};
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
  std::size_t in_tol = 0, out_tol = 0, faults = 0;
  options.on_event = [&](const runtime::RunEvent& e) {
    if (const auto* t = std::get_if<runtime::ToleranceResult>(&e)) (t->in_tolerance ? in_tol : out_tol)++;
    if (std::holds_alternative<runtime::FaultReport>(e)) ++faults;
    if (!args.quiet || std::holds_alternative<runtime::FaultReport>(e)) std::cout << interpreter::event_text(e) << std::flush;
  };
  const auto outcome =
      args.machine_url ? interpreter::run_program(options, [&](const auto&, auto) { return ipp_backend(*args.machine_url); })
                       : interpreter::run_program(options, virtual_cmm_backend);
  std::cerr << outcome.diagnostics;
  const char* status = outcome.exit == interpreter::RunExit::Completed ? "completed"
                       : outcome.exit == interpreter::RunExit::Faulted ? "stopped by a machine fault"
                       : outcome.exit == interpreter::RunExit::BadInput ? "not started"
                                                                        : "stopped by an error";
  std::cout << fmt::format("\nrun {}: {} features, {} tolerances in, {} out, {} faults, {:.3f} s simulated\n", status,
                           outcome.record.features.size(), in_tol, out_tol, faults, outcome.record.simulated_time_s);
  if (!outcome.results_path.empty()) std::cout << "results: " << outcome.results_path << "\n";
  return static_cast<int>(outcome.exit);
}

int check(const std::string& program) {
  SourceManager sources;
  DiagnosticSink sink;
  interpreter::Compiler compiler(sources, sink);
  const auto unit = compiler.compile_file(program);
  for (const auto& d : sink.items()) std::cout << format_diagnostic(d, sources);
  if (!unit && sink.items().empty()) std::cout << fmt::format("error: cannot read {}\n", program);
  const std::size_t errors = sink.error_count();
  const std::size_t warnings = sink.items().size() - errors;
  std::cout << fmt::format("{}: {} error{}, {} warning{}\n", program, errors, errors == 1 ? "" : "s", warnings, warnings == 1 ? "" : "s");
  return errors > 0 || !unit ? 1 : 0;
}

int compile(const std::string& program, bool emit_ir) {
  SourceManager sources;
  DiagnosticSink sink;
  interpreter::Compiler compiler(sources, sink);
  const auto unit = compiler.compile_file(program);
  for (const auto& d : sink.items()) std::cerr << format_diagnostic(d, sources);
  if (!unit || sink.has_errors()) {
    if (!unit && sink.items().empty()) std::cerr << fmt::format("error: cannot read {}\n", program);
    return 1;
  }
  if (emit_ir) std::cout << interpreter::ir::to_string(compiler.module(), sources);
  return 0;
}

int fit(const FitArgs& args) {
  const auto shape = fitting::shape_from_name(args.type);
  if (!shape) {
    std::cerr << fmt::format("error: unknown fit type '{}': expected point, line, plane, circle, sphere, cylinder or cone\n", args.type);
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
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::cout << fmt::format("{} fit of {} points from {}\n", fitting::to_string(r.shape), points->size(), args.file);
  std::cout << fmt::format("  position   {:.9f} {:.9f} {:.9f}\n", r.position.x(), r.position.y(), r.position.z());
  if (r.shape != fitting::Shape::Point)
    std::cout << fmt::format("  direction  {:.12f} {:.12f} {:.12f}\n", r.direction.x(), r.direction.y(), r.direction.z());
  if (r.diameter_mm > 0) std::cout << fmt::format("  diameter   {:.9f}\n", r.diameter_mm);
  if (r.shape == fitting::Shape::Cone)
    std::cout << fmt::format("  apex angle {:.9f} deg\n  distance   {:.9f}\n", r.apex_angle_deg, r.cone_distance_mm);
  std::cout << fmt::format("  rms        {:.9f}\n  form       {:.9f}\n", r.rms_mm, r.form_mm);
  return 0;
}

}  // namespace

void add_run_commands(CLI::App& app, std::vector<Command>& commands) {
  auto run_args = std::make_shared<RunArgs>();
  auto* run_cmd = app.add_subcommand("run", "run an inspection program on the virtual CMM");
  run_cmd->add_option("program", run_args->program, "the DMIS program")->required();
  run_cmd->add_option("--world", run_args->world, "world description (JSON); default: the embedded default world");
  run_cmd->add_option("--seed", run_args->seed, "random seed of the run (default: the world's)");
  run_cmd->add_option("--characterisation", run_args->characterisation,
                      "machine characterisation file from `metron characterise`: PTMEAS uses its touch strategy");
  run_cmd->add_option("--machine", run_args->machine_url,
                      "run on an I++ DME server instead of the virtual CMM: ipp://host[:port] (docs/ipp-dme.md)")
      ->excludes(run_cmd->get_option("--world"));
  run_cmd->add_option("--out", run_args->out_dir, "directory for results.json and DMIS output files")->default_val(".");
  run_cmd->add_flag("--quiet", run_args->quiet, "print only diagnostics, faults and the summary");
  commands.push_back({run_cmd, [run_args] { return run(*run_args); }});

  auto check_program = std::make_shared<std::string>();
  auto* check_cmd = app.add_subcommand("check", "check a program and print diagnostics");
  check_cmd->add_option("program", *check_program, "the DMIS program")->required();
  commands.push_back({check_cmd, [check_program] { return check(*check_program); }});

  auto compile_program = std::make_shared<std::string>();
  auto emit_ir = std::make_shared<bool>(false);
  auto* compile_cmd = app.add_subcommand("compile", "compile a program to IR");
  compile_cmd->add_option("program", *compile_program, "the DMIS program")->required();
  compile_cmd->add_flag("--emit-ir", *emit_ir, "print the IR");
  commands.push_back({compile_cmd, [compile_program, emit_ir] { return compile(*compile_program, *emit_ir); }});

  auto fit_args = std::make_shared<FitArgs>();
  auto* fit_cmd = app.add_subcommand("fit", "least-squares fit of a point file (NIST .ds or CSV x,y,z)");
  fit_cmd->add_option("type", fit_args->type, "point, line, plane, circle, sphere, cylinder or cone")->required();
  fit_cmd->add_option("file", fit_args->file, "the point file")->required();
  fit_cmd->add_option("--format", fit_args->format, "text or json")->default_val("text")->check(CLI::IsMember({"text", "json"}));
  commands.push_back({fit_cmd, [fit_args] { return fit(*fit_args); }});
}

}  // namespace metron::cli
