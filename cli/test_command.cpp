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

#include <fmt/format.h>

#include "commands.hpp"
#include "metron/regression/regression.hpp"

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
  const auto start = std::chrono::steady_clock::now();
  const auto results = regression::run_cases(cases, options, [](const regression::CaseResult& r) {
    std::cout << regression::format_case_result(r) << std::flush;
  });
  const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  bool failed = false;
  for (const auto& r : results) failed |= r.verdict == regression::Verdict::Fail;
  if (!args.junit.empty()) {
    std::ofstream out(args.junit);
    out << regression::junit_xml(results, total_s);
    if (!out) {
      std::cerr << fmt::format("error: cannot write {}\n", args.junit);
      failed = true;
    }
  }
  std::cout << regression::format_summary(results) << "\n";
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
  cmd->add_option("--jobs,-j", args->jobs, "programs run at once (default: the number of cores)")->check(CLI::PositiveNumber);
  cmd->add_option("--timeout", args->timeout_s, "wall-clock limit of each program, seconds")->default_val(120)->check(CLI::PositiveNumber);
  commands.push_back({cmd, [args] { return test(*args); }});
}

}  // namespace metron::cli
