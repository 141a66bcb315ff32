// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>
#include <tl/expected.hpp>

// The program regression suite behind `metron test` (docs/regression.md): expected-results files
// (NAME.expected beside NAME.dmi), their comparison with a run's results.json, running the
// programs as child processes, and JUnit XML.
namespace metron::regression {

/// How a quantity is compared: which default tolerance applies and how it is written.
enum class QuantityClass {
  Length,     ///< mm: positions, diameters, lengths, form, tolerance values (5 decimals)
  Direction,  ///< unit vector components (8 decimals)
  Angle,      ///< degrees: cone apex angle, arc angles, ANGLB values (5 decimals)
  Exact,      ///< words, counts and strings: must be equal
};

/// A value in an expected file or a result.
struct Value {
  enum class Kind {
    Number,  ///< a finite number
    None,    ///< null in results.json (written `none`)
    Word,    ///< a word compared exactly: `IN`, `PART`, `completed`, `collision line 14`
    String,  ///< a quoted string (TEXT output)
  } kind = Kind::Number;
  double number = 0;
  std::string text;  ///< Word, String; for Number: the digits as written or to be written
};

/// One line of results: `feature BORE1 diameter 20.01200 +-0.001`.
struct Entry {
  std::string subject;   ///< `feature BORE1`, `feature BORE1@2`, `tolerance T1`, `text 3`, `file x.dmo`, `status`,
                         ///< `fault`, `error`
  std::string quantity;  ///< `x`, `diameter`, `value`, ...; empty for status, fault, error and text
  Value value;
  std::optional<double> tolerance;           ///< expected files: this line's own tolerance (`+-t`)
  QuantityClass cls = QuantityClass::Exact;  ///< observed entries: how the quantity compares
  int line = 0;                              ///< expected files: 1-based line number
  std::vector<std::string> comments;         ///< expected files: the `#` lines just above it (kept by --update)
  /// `feature BORE1 diameter`: what messages call it.
  [[nodiscard]] std::string key() const;
};

/// Default tolerances of an expected file (`default length +-0.0005`, ...).
struct Defaults {
  double length_mm = 0.0005;
  double direction = 1e-5;
  double angle_deg = 0.001;
};

/// A parsed NAME.expected file.
struct ExpectedFile {
  std::vector<std::string> header;    ///< comment and blank lines before the first directive or entry, kept by --update
  std::optional<std::string> world;   ///< world path relative to the expected file; empty: the embedded default
  std::optional<std::uint64_t> seed;  ///< empty: the world's seed
  Defaults defaults;
  std::vector<std::string>
      defaults_given;                ///< which defaults the file sets (`length`, ...), in order: --update keeps them
  std::optional<std::string> skip;   ///< `skip REASON`: the program is not run
  std::vector<Entry> entries;        ///< status, quantities, texts, fault, error
  std::vector<std::string> trailer;  ///< `#` lines after the last entry
};

/// A corrupt expected file: where and why.
struct ParseError {
  int line = 0;         ///< 1-based
  std::string message;  ///< lowercase, says what was expected
};

/// Parses the text of an expected file.
tl::expected<ExpectedFile, ParseError> parse_expected(std::string_view text);
/// Writes an expected file: the header, the directives, then the entries (parse_expected reads it back).
std::string format_expected(const ExpectedFile& file);

/// A run's results as entries, in report order (docs/regression.md lists the quantities).
struct Observed {
  std::vector<Entry> entries;
  std::string status;         ///< completed, faulted, error
  std::string fault_summary;  ///< `line 14 (GOTO/...): message`, when faulted
  std::string first_error;    ///< the first error diagnostic, when status is error
  std::uint64_t seed = 0;
};

/// Entries of a results.json document (schema metron.results/1).
Observed observe_results(const nlohmann::json& results);
/// A run that wrote no results.json (a compile error): status error from the diagnostics text.
Observed observe_diagnostics(const std::string& diagnostics);
/// Adds `file NAME lines N` for each file the run wrote in `out_dir` besides results.json.
void observe_files(const std::filesystem::path& out_dir, Observed& observed);

/// One difference between expected and observed.
struct Difference {
  std::string key;      ///< `feature BORE1 diameter`
  std::string message;  ///< `expected 20.01300, got 20.01200 (difference -0.00100, tolerance +-0.00050)`
};

/// Compares: every expected entry must be observed within its tolerance; every observed subject
/// (an OUTPUT, a text, a fault) must be expected. Empty when they agree.
std::vector<Difference> compare(const ExpectedFile& expected, const Observed& observed);

/// The expected file --update writes: `previous`'s header, directives and per-line tolerances,
/// with the observed entries.
ExpectedFile updated_expected(const ExpectedFile& previous, const Observed& observed);

/// A program of the suite.
struct Case {
  std::string name;                ///< the program path as shown (root-relative as given)
  std::filesystem::path program;   ///< NAME.dmi (may not exist: an orphan expected file)
  std::filesystem::path expected;  ///< NAME.expected
};

/// Finds NAME.dmi files with a NAME.expected beside them under the roots (directories,
/// recursively, or single files), and expected files without a program. Sorted by name.
/// An error names a root that does not exist.
tl::expected<std::vector<Case>, std::string> discover_cases(const std::vector<std::string>& roots);

/// `--filter`: a glob (`*`, `?`, `[...]`) matched against the whole name, else a substring.
bool matches_filter(const std::string& name, const std::string& pattern);

/// How a case ended.
enum class Verdict {
  Pass,     ///< results agree with the expected file
  Fail,     ///< a difference, a crash, a timeout, a corrupt expected file, ...
  Skip,     ///< the expected file says `skip`
  Updated,  ///< --update rewrote the expected file
};

/// The outcome of one case.
struct CaseResult {
  Case test;
  Verdict verdict = Verdict::Pass;
  double wall_s = 0;                 ///< wall-clock time of the child process; 0 when none ran
  std::string reason;                ///< one line: why it failed, was skipped or updated
  std::vector<std::string> details;  ///< one line each: the differences, stderr of a crash
};

/// How to run the suite.
struct RunnerOptions {
  std::string executable;  ///< the metron binary (`run PROGRAM --out DIR --quiet ...`)
  unsigned jobs = 1;       ///< at most this many programs at once
  double timeout_s = 120;  ///< wall-clock limit of each program; then it is killed
  bool update = false;     ///< rewrite expected files from the results
  /// Polled while running: when it returns true (SIGINT/SIGTERM to `metron test`), every child
  /// gets SIGTERM (SIGKILL 2 s later), no new one starts, the temporary folder is removed and the
  /// cases not finished fail as "interrupted".
  std::function<bool()> stop_requested;
};

/// Runs the cases as child processes, at most `jobs` at once, and compares. `on_result` is
/// called for each case in the order of `cases` (so output is deterministic), as soon as it and
/// every case before it are done. Returns the results in the order of `cases`.
std::vector<CaseResult> run_cases(const std::vector<Case>& cases, const RunnerOptions& options,
                                  const std::function<void(const CaseResult&)>& on_result = {});

/// `PASS  name  0.18 s` and, indented, the details.
std::string format_case_result(const CaseResult& result);
/// `N passed, N failed` (`, N skipped`, `, N updated` when there are any).
std::string format_summary(const std::vector<CaseResult>& results);
/// JUnit XML (one testsuite, a testcase per program; failure and skipped elements).
std::string junit_xml(const std::vector<CaseResult>& results, double total_wall_s);

}  // namespace metron::regression
