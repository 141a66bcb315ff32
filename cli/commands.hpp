// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "metron/interpreter/run_limits.hpp"

namespace CLI {
class App;
}

namespace metron::cli {

/// A subcommand and what to do when it was given.
struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

/// `--include DIR` (repeatable): folders a program may read besides its own (docs/security.md).
void add_include_option(CLI::App& cmd, std::vector<std::string>& dirs);
/// `--seed N`, checked to be an integer in [0, 2^64-1].
void add_seed_option(CLI::App& cmd, std::optional<std::uint64_t>& seed);
/// `--max-steps`, `--max-sim-time`, `--max-wall-time`, `--max-outputs` (docs/limits.md).
void add_limit_options(CLI::App& cmd, interpreter::RunLimits& limits);

/// run, check, compile, fit (commands.cpp).
void add_run_commands(CLI::App& app, std::vector<Command>& commands);
/// debug, repl (debug_command.cpp).
void add_debug_commands(CLI::App& app, std::vector<Command>& commands);
/// characterise (characterise_command.cpp).
void add_characterise_command(CLI::App& app, std::vector<Command>& commands);
/// `metron calibrate wavefront` (calibrate_command.cpp) and `calibrate error-space`.
void add_calibrate_command(CLI::App& app, std::vector<Command>& commands);
/// `metron calibrate error-space` under `calibrate` (calibrate_error_space_command.cpp).
void add_calibrate_error_space_command(CLI::App& calibrate, std::vector<Command>& commands);
/// discrepancy (discrepancy_command.cpp).
void add_discrepancy_command(CLI::App& app, std::vector<Command>& commands);
/// scan-compare (scan_compare_command.cpp).
void add_scan_compare_command(CLI::App& app, std::vector<Command>& commands);
/// test (test_command.cpp).
void add_test_command(CLI::App& app, std::vector<Command>& commands);

}  // namespace metron::cli
