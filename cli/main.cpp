// SPDX-License-Identifier: GPL-3.0-or-later
// metron: run, check, compile and fit DMIS part programs on the virtual CMM.
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"metron: a toolchain for CMM part programs (DMIS) with a virtual CMM"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "metron 0.1.0");

  metron::cli::RunArgs run;
  auto* run_cmd = app.add_subcommand("run", "run an inspection program on the virtual CMM");
  run_cmd->add_option("program", run.program, "the DMIS program")->required();
  run_cmd->add_option("--world", run.world, "world description (JSON); default: the embedded default world");
  run_cmd->add_option("--seed", run.seed, "random seed of the run (default: the world's)");
  run_cmd->add_option("--out", run.out_dir, "directory for results.json and DMIS output files")->default_val(".");
  run_cmd->add_flag("--quiet", run.quiet, "print only diagnostics and the summary");

  std::string check_program;
  auto* check_cmd = app.add_subcommand("check", "check a program and print diagnostics");
  check_cmd->add_option("program", check_program, "the DMIS program")->required();

  std::string compile_program;
  bool emit_ir = false;
  auto* compile_cmd = app.add_subcommand("compile", "compile a program to IR");
  compile_cmd->add_option("program", compile_program, "the DMIS program")->required();
  compile_cmd->add_flag("--emit-ir", emit_ir, "print the IR");

  metron::cli::FitArgs fit;
  auto* fit_cmd = app.add_subcommand("fit", "least-squares fit of a point file (NIST .ds or CSV x,y,z)");
  fit_cmd->add_option("type", fit.type, "point, line, plane, circle, sphere, cylinder or cone")->required();
  fit_cmd->add_option("file", fit.file, "the point file")->required();
  fit_cmd->add_option("--format", fit.format, "text or json")->default_val("text")->check(CLI::IsMember({"text", "json"}));

  CLI11_PARSE(app, argc, argv);

  if (*run_cmd) return metron::cli::run(run);
  if (*check_cmd) return metron::cli::check(check_program);
  if (*compile_cmd) return metron::cli::compile(compile_program, emit_ir);
  if (*fit_cmd) return metron::cli::fit(fit);
  return 2;
}
