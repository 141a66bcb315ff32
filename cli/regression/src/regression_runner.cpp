// SPDX-License-Identifier: GPL-3.0-or-later
// `metron test`: runs each regression program as a child process (`metron run ... --quiet`), at
// most `jobs` at once with a wall-clock timeout, and compares its results.json.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <thread>
#include <variant>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "metron/regression/regression.hpp"

extern char** environ;

namespace metron::regression {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr std::size_t max_details = 20;

std::string slurp(const fs::path& p, std::size_t limit = 1 << 20) {
  std::ifstream in(p, std::ios::binary);
  std::string s(limit, '\0');
  in.read(s.data(), static_cast<std::streamsize>(limit));
  s.resize(static_cast<std::size_t>(in.gcount()));
  return s;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);)
    if (!l.empty()) out.push_back(l);
  return out;
}

std::vector<std::string> tail(const std::string& text, std::size_t n) {
  auto l = lines_of(text);
  if (l.size() > n) l.erase(l.begin(), l.end() - static_cast<std::ptrdiff_t>(n));
  return l;
}

CaseResult fail(const Case& c, std::string reason, std::vector<std::string> details = {}, double wall_s = 0) {
  return {c, Verdict::Fail, wall_s, std::move(reason), std::move(details)};
}

// A case that is ready to run: its parsed expected file and where its outputs go.
struct Prepared {
  ExpectedFile expected;
  std::string expected_text;
  fs::path dir;
};

// Reads the expected file; a result instead when there is nothing to run.
std::variant<Prepared, CaseResult> prepare(const Case& c, const fs::path& dir) {
  if (!fs::exists(c.program))
    return fail(c, fmt::format("no program {} beside {}", c.program.filename().string(), c.expected.string()));
  std::error_code ec;
  if (!fs::is_regular_file(c.expected, ec))
    return fail(c, fmt::format("{} is not a regular file", c.expected.string()));
  Prepared p;
  p.expected_text = slurp(c.expected);
  auto parsed = parse_expected(p.expected_text);
  if (!parsed)
    return fail(c, fmt::format("{}:{}: error: {}", c.expected.string(), parsed.error().line, parsed.error().message));
  p.expected = std::move(*parsed);
  if (p.expected.skip) return CaseResult{c, Verdict::Skip, 0, *p.expected.skip, {}};
  p.dir = dir;
  return p;
}

tl::expected<pid_t, std::string> spawn(const Case& c, const Prepared& p, const std::string& executable) {
  std::error_code ec;
  fs::create_directories(p.dir / "out", ec);
  if (ec) return tl::unexpected(fmt::format("cannot create {}: {}", (p.dir / "out").string(), ec.message()));
  std::vector<std::string> args = {executable, "run", c.program.string(), "--out", (p.dir / "out").string(), "--quiet"};
  if (p.expected.world && *p.expected.world != "default") {
    args.emplace_back("--world");
    args.push_back((c.expected.parent_path() / *p.expected.world).lexically_normal().string());
  }
  if (p.expected.seed) {
    args.emplace_back("--seed");
    args.push_back(std::to_string(*p.expected.seed));
  }
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const std::string out = (p.dir / "stdout").string(), err = (p.dir / "stderr").string();
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, executable.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return tl::unexpected(fmt::format("cannot start {}: {}", executable, std::strerror(rc)));
  return pid;
}

// The one-line reason of a comparison failure: what the run did instead, else how many differ.
std::string headline(const std::vector<Difference>& diffs, const Observed& observed) {
  if (!diffs.empty() && diffs.front().key == "status") {
    if (observed.status == "faulted") return "faulted at " + observed.fault_summary;
    if (observed.status == "error") return "program error: " + observed.first_error;
    return "status: " + diffs.front().message;
  }
  return fmt::format("{} difference{}", diffs.size(), diffs.size() == 1 ? "" : "s");
}

std::vector<std::string> detail_lines(const std::vector<Difference>& diffs) {
  std::vector<std::string> out;
  for (const auto& d : diffs) {
    if (out.size() == max_details) {
      out.push_back(fmt::format("... and {} more", diffs.size() - max_details));
      break;
    }
    out.push_back(d.key + ": " + d.message);
  }
  return out;
}

// How a child ended: exit status, signal, or killed at the timeout.
struct ProcessEnd {
  enum class Kind { Exited, Signaled, TimedOut } kind = Kind::Exited;
  int code = 0;
  double wall_s = 0;
};

CaseResult evaluate(const Case& c, const Prepared& p, const ProcessEnd& end, const RunnerOptions& options) {
  const std::string err = slurp(p.dir / "stderr", 64 * 1024);
  const double t = end.wall_s;
  if (end.kind == ProcessEnd::Kind::TimedOut)
    return fail(c, fmt::format("timed out after {} s: killed", options.timeout_s), {}, t);
  if (end.kind == ProcessEnd::Kind::Signaled)
    return fail(c, fmt::format("crashed: killed by signal {} ({})", end.code, ::strsignal(end.code)), tail(err, 10), t);
  if (end.code == 2) {
    auto l = lines_of(err);
    std::string why = l.empty() ? "" : l.front();
    if (why.rfind("error: ", 0) == 0) why.erase(0, 7);
    return fail(c, "bad input: " + why, {}, t);
  }
  if (end.code != 0 && end.code != 1 && end.code != 3)
    return fail(c, fmt::format("unexpected exit status {}", end.code), tail(err, 10), t);

  Observed observed;
  const fs::path results = p.dir / "out" / "results.json";
  if (fs::exists(results)) {
    const auto j = nlohmann::json::parse(slurp(results, 256 << 20), nullptr, false);
    if (j.is_discarded() || !j.is_object()) return fail(c, "results.json is not valid JSON", {}, t);
    observed = observe_results(j);
    observe_files(p.dir / "out", observed);
  } else if (end.code == 1) {
    observed = observe_diagnostics(err);  // a compile error: no results.json
  } else {
    return fail(c, fmt::format("no results.json written (exit status {})", end.code), tail(err, 10), t);
  }
  const char* status_of_code = end.code == 0 ? "completed" : end.code == 1 ? "error" : "faulted";
  if (observed.status != status_of_code)
    return fail(c, fmt::format("exit status {} but results.json says status {}", end.code, observed.status), {}, t);

  const auto diffs = compare(p.expected, observed);
  // A file centred on the hidden truth (its header says so) is edited by hand: --update would
  // write metron's own values over the truth (docs/regression.md).
  const bool centred_on_truth = p.expected_text.find("Centred on the hidden truth") != std::string::npos;
  if (options.update && centred_on_truth && !diffs.empty())
    return fail(c, "not updated: the file is centred on the hidden truth; edit it by hand", detail_lines(diffs), t);
  if (options.update && !centred_on_truth) {
    const std::string text = format_expected(updated_expected(p.expected, observed));
    if (text == p.expected_text) return {c, Verdict::Pass, t, "", {}};
    std::ofstream out(c.expected, std::ios::binary | std::ios::trunc);
    out << text;
    if (!out) return fail(c, fmt::format("cannot write {}", c.expected.string()), {}, t);
    if (p.expected.entries.empty()) return {c, Verdict::Updated, t, "written from the results", {}};
    return {c, Verdict::Updated, t, diffs.empty() ? "rewritten, same results" : headline(diffs, observed),
            detail_lines(diffs)};
  }
  if (diffs.empty()) return {c, Verdict::Pass, t, "", {}};
  return fail(c, headline(diffs, observed), detail_lines(diffs), t);
}

struct Running {
  std::size_t index = 0;
  pid_t pid = 0;
  Clock::time_point start;
  Prepared prepared;
};

}  // namespace

std::vector<CaseResult> run_cases(const std::vector<Case>& cases, const RunnerOptions& options,
                                  const std::function<void(const CaseResult&)>& on_result) {
  std::vector<std::optional<CaseResult>> done(cases.size());
  std::size_t reported = 0;
  const auto flush = [&] {
    for (; reported < done.size() && done[reported]; ++reported)
      if (on_result) on_result(*done[reported]);
  };

  std::string pattern = (fs::temp_directory_path() / "metron-test-XXXXXX").string();
  const bool have_root = ::mkdtemp(pattern.data()) != nullptr;
  const fs::path root = pattern;

  std::vector<Running> running;
  std::size_t next = 0;
  const unsigned jobs = std::max(1u, options.jobs);
  bool stopping = false;
  Clock::time_point stop_time{};
  while (next < cases.size() || !running.empty()) {
    if (!stopping && options.stop_requested && options.stop_requested()) {
      // Forward the stop to the children (metron run writes its results on SIGTERM) and start no
      // more; a child that does not end within 2 s is killed below.
      stopping = true;
      stop_time = Clock::now();
      for (auto& r : running) ::kill(r.pid, SIGTERM);
      for (; next < cases.size(); ++next) done[next] = fail(cases[next], "interrupted: not run");
    }
    while (!stopping && running.size() < jobs && next < cases.size()) {
      const std::size_t i = next++;
      const Case& c = cases[i];
      if (!have_root) {
        done[i] = fail(c, fmt::format("cannot create a temporary directory: {}", std::strerror(errno)));
        continue;
      }
      auto prepared = prepare(c, root / std::to_string(i));
      if (auto* r = std::get_if<CaseResult>(&prepared)) {
        done[i] = std::move(*r);
        continue;
      }
      auto& p = std::get<Prepared>(prepared);
      const auto start = Clock::now();
      const auto pid = spawn(c, p, options.executable);
      if (!pid) {
        done[i] = fail(c, pid.error());
        continue;
      }
      running.push_back({i, *pid, start, std::move(p)});
    }
    flush();

    bool reaped = false;
    for (auto it = running.begin(); it != running.end();) {
      int status = 0;
      const auto now = Clock::now();
      const double wall_s = std::chrono::duration<double>(now - it->start).count();
      ProcessEnd end;
      end.wall_s = wall_s;
      pid_t r = ::waitpid(it->pid, &status, WNOHANG);
      if (r == 0 && stopping && std::chrono::duration<double>(now - stop_time).count() > 2) {
        ::kill(it->pid, SIGKILL);
        r = ::waitpid(it->pid, &status, 0);
        end.kind = ProcessEnd::Kind::TimedOut;
      } else if (r == 0 && wall_s > options.timeout_s) {
        ::kill(it->pid, SIGKILL);
        r = ::waitpid(it->pid, &status, 0);
        end.kind = ProcessEnd::Kind::TimedOut;
      } else if (r == it->pid && WIFSIGNALED(status)) {
        end.kind = ProcessEnd::Kind::Signaled;
        end.code = WTERMSIG(status);
      } else if (r == it->pid) {
        end.code = WEXITSTATUS(status);
      }
      if (r == 0) {
        ++it;
        continue;
      }
      if (r < 0) {
        done[it->index] =
            fail(cases[it->index], fmt::format("lost the child process: {}", std::strerror(errno)), {}, wall_s);
      } else {
        done[it->index] = stopping ? fail(cases[it->index], "interrupted by a signal to metron test", {}, wall_s)
                                   : evaluate(cases[it->index], it->prepared, end, options);
      }
      std::error_code ec;
      fs::remove_all(it->prepared.dir, ec);
      it = running.erase(it);
      reaped = true;
    }
    flush();
    // Polling keeps one thread and no signal handlers; 5 ms is nothing next to a program run.
    if (!reaped && !running.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  flush();
  if (have_root) {
    std::error_code ec;
    fs::remove_all(root, ec);
  }
  std::vector<CaseResult> out;
  out.reserve(done.size());
  for (auto& d : done) out.push_back(std::move(*d));
  return out;
}

}  // namespace metron::regression
