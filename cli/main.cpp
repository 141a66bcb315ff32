// SPDX-License-Identifier: GPL-3.0-or-later
// metron: run, check, compile, debug, test and fit DMIS part programs on the virtual CMM.
#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "serve_command.hpp"

int main(int argc, char** argv) {
  CLI::App app{"metron: a toolchain for CMM part programs (DMIS) with a virtual CMM"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "metron 0.1.0");
  std::vector<metron::cli::Command> commands;
  metron::cli::add_run_commands(app, commands);
  metron::cli::add_debug_commands(app, commands);
  metron::cli::add_test_command(app, commands);
  metron::cli::add_characterise_command(app, commands);
  metron::cli::add_serve_command(app, commands);
  metron::cli::add_calibrate_command(app, commands);
  metron::cli::add_discrepancy_command(app, commands);
  metron::cli::add_scan_compare_command(app, commands);
  CLI11_PARSE(app, argc, argv);
  for (const auto& c : commands)
    if (c.app->parsed()) return c.run();
  return 2;
}
