// SPDX-License-Identifier: GPL-3.0-or-later
// metron: run, check, compile, debug, test and fit DMIS part programs on the virtual CMM.
#include <CLI/CLI.hpp>

#include <exception>
#include <iostream>

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
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every usage error is bad input, exit 2 (docs/cli.md), not
    // CLI11's own codes 104-109.
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  try {
    for (const auto& c : commands)
      if (c.app->parsed()) return c.run();
  } catch (const std::exception& e) {
    // A last line of defence: no library exception text ends the process with an abort.
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 2;
}
