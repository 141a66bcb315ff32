// SPDX-License-Identifier: GPL-3.0-or-later
// `metron test`: the program regression suite (docs/regression.md).
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <thread>

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdlib>

#include <fmt/format.h>

#include "commands.hpp"
#include "metron/interpreter/run_limits.hpp"
#include "metron/regression/regression.hpp"
#include "metron/runtime/outputs.hpp"

namespace metron::cli {
namespace {

struct TestArgs {
  std::vector<std::string> roots;
  bool update = false;
  std::string filter;
  std::string junit;
  unsigned jobs = 0;
  double timeout_s = 120;
};

// The running binary: each program runs in a child of the same metron.
std::string self_path() {
  std::error_code ec;
  const auto p = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string("metron") : p.string();
}

int test(const TestArgs& args) {
  const std::vector<std::string> roots = args.roots.empty() ? std::vector<std::string>{"programs"} : args.roots;
  auto found = regression::discover_cases(roots);
  if (!found) {
    std::cerr << "error: " << found.error() << "\n";
    return 2;
  }
  std::vector<regression::Case> cases;
  for (auto& c : *found)
    if (args.filter.empty() || regression::matches_filter(c.name, args.filter)) cases.push_back(std::move(c));
  if (cases.empty()) {
    std::string where;
    for (const auto& r : roots) where += (where.empty() ? "" : ", ") + r;
    std::cerr << fmt::format("error: no programs with an expected-results file under {}{}\n", where,
                             args.filter.empty() ? "" : " match --filter " + args.filter);
    return 2;
  }

  regression::RunnerOptions options;
  options.executable = self_path();
  options.jobs = args.jobs ? args.jobs : std::max(1u, std::thread::hardware_concurrency());
  options.timeout_s = args.timeout_s;
  options.update = args.update;
  // SIGINT/SIGTERM: the children are stopped and the temporary folder removed (docs/limits.md).
  interpreter::install_stop_signal_handlers();
  options.stop_requested = [] { return interpreter::stop_requested() != 0; };
  const auto start = std::chrono::steady_clock::now();
  const auto results = regression::run_cases(cases, options, [](const regression::CaseResult& r) {
    std::cout << regression::format_case_result(r) << std::flush;
  });
  const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  bool failed = false;
  for (const auto& r : results) failed |= r.verdict == regression::Verdict::Fail;
  if (!args.junit.empty()) {
    if (auto error = runtime::write_file_atomically(args.junit, regression::junit_xml(results, total_s))) {
      std::cerr << "error: " << *error << "\n";
      failed = true;
    }
  }
  std::cout << regression::format_summary(results) << "\n";
  if (interpreter::stop_requested() != 0) return 4;
  return failed ? 1 : 0;
}

}  // namespace

void add_test_command(CLI::App& app, std::vector<Command>& commands) {
  auto args = std::make_shared<TestArgs>();
  auto* cmd = app.add_subcommand("test", "run the program regression suite: programs with a NAME.expected beside them");
  cmd->add_option("dirs", args->roots, "directories (searched recursively) or programs; default: programs");
  cmd->add_flag("--update", args->update, "rewrite the expected files from the current results (review the diff)");
  cmd->add_option("--filter", args->filter, "only programs whose path contains PATTERN (or matches it, with * ? [ ])");
  cmd->add_option("--junit", args->junit, "also write JUnit XML to FILE");
  cmd->add_option("--jobs,-j", args->jobs, "programs run at once (default: the number of cores)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--timeout", args->timeout_s, "wall-clock limit of each program, seconds")
      ->default_val(120)
      ->check(CLI::Validator(
          [](const std::string& text) -> std::string {
            // CLI11's PositiveNumber lets nan through and 1e308 never fires: a finite (0, 1 day].
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            if (end == text.c_str() || *end != '\0' || !std::isfinite(v) || !(v > 0) || v > 86400)
              return "expected a number of seconds in (0, 86400], got '" + text + "'";
            return {};
          },
          "SECONDS"));
  commands.push_back({cmd, [args] { return test(*args); }});
}

}  // namespace metron::cli
