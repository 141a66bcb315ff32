// SPDX-License-Identifier: GPL-3.0-or-later
// Expected-results files, their comparison with results.json, discovery, reports (docs/regression.md).
#include "metron/regression/regression.hpp"
#include "metron/stdlib/file_access.hpp"

#include <fnmatch.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace metron::regression {
namespace {

namespace fs = std::filesystem;

const std::vector<std::string> feature_quantities = {"frame",  "points", "actual", "x",        "y",
                                                     "z",      "i",      "j",      "k",        "diameter",
                                                     "length", "angle",  "start",  "included", "form"};
const std::vector<std::string> tolerance_quantities = {"status", "value"};

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

std::vector<std::string> split_words(std::string_view s) {
  std::vector<std::string> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    const std::size_t b = i;
    while (i < s.size() && !std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    if (i > b) out.emplace_back(s.substr(b, i - b));
  }
  return out;
}

std::string join(const std::vector<std::string>& words, std::size_t from, std::size_t to, const char* sep = " ") {
  std::string out;
  for (std::size_t i = from; i < to; ++i) out += (i > from ? sep : "") + words[i];
  return out;
}

std::optional<double> parse_number(std::string_view s) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::string quote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\')
      out += {'\\', c};
    else if (c == '\n')
      out += "\\n";
    else if (c == '\t')
      out += "\\t";
    else
      out += c;
  }
  return out + "\"";
}

// A quoted string at the start of `s`: its value and the rest of the line after it.
tl::expected<std::pair<std::string, std::string_view>, std::string> unquote(std::string_view s) {
  if (s.empty() || s.front() != '"') return tl::unexpected(std::string("expected a quoted string"));
  std::string out;
  for (std::size_t i = 1; i < s.size(); ++i) {
    if (s[i] == '"') return std::pair{out, s.substr(i + 1)};
    if (s[i] == '\\') {
      if (++i == s.size()) break;
      out += s[i] == 'n' ? '\n' : s[i] == 't' ? '\t' : s[i];
    } else {
      out += s[i];
    }
  }
  return tl::unexpected(std::string("unterminated string: expected a closing '\"'"));
}

int decimals_of(QuantityClass cls) { return cls == QuantityClass::Direction ? 8 : 5; }

std::string format_number(double v, int decimals) {
  std::string s = fmt::format("{:.{}f}", v, decimals);
  // -0.00000 would make a diff flicker between runs that round to zero from either side.
  if (s.find_first_not_of("-0.") == std::string::npos && s[0] == '-') s.erase(0, 1);
  return s;
}

std::string format_value(const Value& v) {
  switch (v.kind) {
    case Value::Kind::Number: return v.text.empty() ? fmt::format("{}", v.number) : v.text;
    case Value::Kind::None: return "none";
    case Value::Kind::Word: return v.text;
    case Value::Kind::String: return quote(v.text);
  }
  return {};
}

Value number_value(double v, QuantityClass cls) { return {Value::Kind::Number, v, format_number(v, decimals_of(cls))}; }
Value word(std::string s) { return {Value::Kind::Word, 0, std::move(s)}; }

Entry make_entry(std::string subject, std::string quantity, Value v, QuantityClass cls) {
  Entry e;
  e.subject = std::move(subject);
  e.quantity = std::move(quantity);
  e.value = std::move(v);
  e.cls = cls;
  return e;
}

// `BORE1` or `BORE1@2`: the label and which OUTPUT of it.
bool valid_label(const std::string& s) {
  const auto at = s.find('@');
  const std::string label = s.substr(0, at);
  if (label.empty()) return false;
  if (at == std::string::npos) return true;
  const std::string n = s.substr(at + 1);
  return !n.empty() && n.size() < 6 && std::all_of(n.begin(), n.end(), ::isdigit) && std::stoi(n) >= 2;
}

QuantityClass feature_class(const std::string& q) {
  if (q == "i" || q == "j" || q == "k") return QuantityClass::Direction;
  if (q == "angle" || q == "start" || q == "included") return QuantityClass::Angle;
  if (q == "frame" || q == "points" || q == "actual") return QuantityClass::Exact;
  return QuantityClass::Length;
}

// `line 25 (GOTO/80, 50, 20): collision with TOP at ...`: where and why a run faulted.
std::string summarize_fault(const nlohmann::json& f) {
  const std::string kind = f.value("fault", "?");
  std::string s = fmt::format("line {}", f.value("line", 0));
  const std::string statement = f.value("statement", "");
  if (!statement.empty()) s += fmt::format(" ({})", std::string(trim(statement)));
  std::string message = f.value("message", "");
  if (message.find(kind) == std::string::npos) message = message.empty() ? kind : kind + ": " + message;
  return s + ": " + message;
}

// The first `file:line:col: error: message` of a diagnostics text.
void first_error(const std::string& text, Observed& out) {
  static const std::regex positioned(R"(:(\d+):\d+: error: )");
  std::size_t begin = 0;
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    const std::string line = text.substr(begin, end - begin);
    std::smatch m;
    if (std::regex_search(line, m, positioned)) {
      out.first_error = line;
      out.entries.push_back(make_entry("error", "", word("line " + m[1].str()), QuantityClass::Exact));
      return;
    }
    if (out.first_error.empty() && line.find("error: ") != std::string::npos) out.first_error = line;
    begin = end + 1;
  }
}

std::string xml_escape(const std::string& text) {
  // Expected files and program output may hold any bytes: XML must be valid UTF-8.
  const std::string s = valid_utf8(text);
  std::string out;
  for (unsigned char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default:
        // XML 1.0 has no escape for most control characters: drop them.
        if (c >= 0x20 || c == '\n' || c == '\t') out += static_cast<char>(c);
    }
  }
  return out;
}

}  // namespace

std::string Entry::key() const { return quantity.empty() ? subject : subject + " " + quantity; }

namespace {

// Reads an expected file line by line; each method returns an error message or nothing.
class ExpectedParser {
 public:
  std::optional<std::string> read_line(std::string_view text, int number) {
    const std::string_view line = trim(text);
    if (line.empty()) {
      if (!m_started) m_file.header.emplace_back();
      return std::nullopt;
    }
    if (line.front() == '#') {
      (m_started ? m_pending : m_file.header).emplace_back(line);
      return std::nullopt;
    }
    m_number = number;
    m_words = split_words(line);
    const std::string& head = m_words[0];
    if (head == "world") return world(line);
    if (head == "seed") return seed();
    if (head == "default") return default_tolerance();
    if (head == "skip") {
      if (auto e = directive("skip")) return e;
      m_file.skip = std::string(trim(line.substr(4)));
      return std::nullopt;
    }
    if (head == "status") return status();
    if (head == "fault") return fault();
    if (head == "error") return error();
    if (head == "text") return text_line(line);
    if (head == "file") return file_lines();
    if (head == "feature" || head == "tolerance") return quantity();
    return fmt::format(
        "unknown line '{}': expected world, seed, default, skip, status, feature, tolerance, text, fault, "
        "error, file or a # comment",
        head);
  }

  ExpectedFile finish() {
    while (!m_file.header.empty() && m_file.header.back().empty()) m_file.header.pop_back();
    m_file.trailer = std::move(m_pending);
    return std::move(m_file);
  }

 private:
  std::optional<std::string> directive(const std::string& name) {
    if (!m_directives.insert(name).second) return fmt::format("'{}' is given twice", name);
    // Comments above a directive belong to the header: directives are written right after it.
    for (auto& c : m_pending) m_file.header.push_back(std::move(c));
    m_pending.clear();
    m_started = true;
    return std::nullopt;
  }

  std::optional<std::string> add(Entry e) {
    e.line = m_number;
    const auto [it, fresh] = m_seen.emplace(e.key(), m_number);
    if (!fresh) return fmt::format("a second line for {} (the first is line {})", e.key(), it->second);
    e.comments = std::move(m_pending);
    m_pending.clear();
    m_started = true;
    m_file.entries.push_back(std::move(e));
    return std::nullopt;
  }

  std::optional<std::string> world(std::string_view line) {
    if (m_words.size() < 2) return "expected a world path after 'world'";
    if (auto e = directive("world")) return e;
    m_file.world = std::string(trim(line.substr(5)));
    return std::nullopt;
  }

  std::optional<std::string> seed() {
    std::uint64_t v = 0;
    if (m_words.size() != 2) return "expected an integer seed >= 0 after 'seed'";
    const auto& w = m_words[1];
    const auto [p, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
    if (ec != std::errc() || p != w.data() + w.size())
      return fmt::format("expected an integer seed >= 0 after 'seed', got '{}'", w);
    if (auto e = directive("seed")) return e;
    m_file.seed = v;
    return std::nullopt;
  }

  // default length|direction|angle +-t
  std::optional<std::string> default_tolerance() {
    if (m_words.size() != 3 && !(m_words.size() == 4 && m_words[2] == "+-"))
      return "expected 'default length|direction|angle +-tolerance'";
    const std::string& kind = m_words[1];
    if (kind != "length" && kind != "direction" && kind != "angle")
      return fmt::format("expected length, direction or angle after 'default', got '{}'", kind);
    std::string t = m_words.back();
    if (t.rfind("+-", 0) == 0) t = t.substr(2);
    const auto v = parse_number(t);
    if (!v || *v < 0) return fmt::format("expected a tolerance (a number >= 0) for default {}, got '{}'", kind, t);
    if (auto e = directive("default " + kind)) return e;
    (kind == "length"      ? m_file.defaults.length_mm
     : kind == "direction" ? m_file.defaults.direction
                           : m_file.defaults.angle_deg) = *v;
    m_file.defaults_given.push_back(kind);
    return std::nullopt;
  }

  std::optional<std::string> status() {
    if (m_words.size() != 2 || (m_words[1] != "completed" && m_words[1] != "faulted" && m_words[1] != "error"))
      return "expected completed, faulted or error after 'status'";
    return add(make_entry("status", "", word(m_words[1]), QuantityClass::Exact));
  }

  // fault KIND... line N (kinds have spaces: "no contact")
  std::optional<std::string> fault() {
    const auto n = m_words.size();
    if (n < 4 || m_words[n - 2] != "line" || m_words[n - 1].find_first_not_of("0123456789") != std::string::npos)
      return "expected 'fault KIND line N', e.g. 'fault collision line 14'";
    return add(make_entry("fault", "", word(join(m_words, 1, n)), QuantityClass::Exact));
  }

  std::optional<std::string> error() {
    if (m_words.size() != 3 || m_words[1] != "line" || m_words[2].find_first_not_of("0123456789") != std::string::npos)
      return "expected 'error line N', the line of the first error";
    return add(make_entry("error", "", word(join(m_words, 1, 3)), QuantityClass::Exact));
  }

  // file NAME lines N (a file the run wrote beside results.json, e.g. a DMIS output file)
  std::optional<std::string> file_lines() {
    const auto n = m_words.size();
    if (n < 4 || m_words[n - 2] != "lines" || m_words[n - 1].find_first_not_of("0123456789") != std::string::npos)
      return "expected 'file NAME lines N', e.g. 'file report.dmo lines 12'";
    return add(make_entry("file " + join(m_words, 1, n - 2), "lines", word(m_words[n - 1]), QuantityClass::Exact));
  }

  std::optional<std::string> text_line(std::string_view line) {
    auto s = unquote(trim(line.substr(4)));
    if (!s) return s.error() + " after 'text'";
    if (!trim(s->second).empty()) return fmt::format("unexpected '{}' after the string", std::string(trim(s->second)));
    return add(
        make_entry(fmt::format("text {}", ++m_texts), "", {Value::Kind::String, 0, s->first}, QuantityClass::Exact));
  }

  // feature LABEL[@N] QUANTITY VALUE [+-t]  |  tolerance LABEL[@N] status|value VALUE [+-t]
  std::optional<std::string> quantity() {
    const std::string& head = m_words[0];
    if (m_words.size() < 4) return fmt::format("expected '{} LABEL QUANTITY VALUE'", head);
    if (!valid_label(m_words[1]))
      return fmt::format("expected a label, or LABEL@N with N >= 2 for its N-th output, got '{}'", m_words[1]);
    const std::string& q = m_words[2];
    const auto& allowed = head == "feature" ? feature_quantities : tolerance_quantities;
    if (std::find(allowed.begin(), allowed.end(), q) == allowed.end())
      return fmt::format("unknown {} quantity '{}': expected {}", head, q, join(allowed, 0, allowed.size(), ", "));
    Entry e = make_entry(head + " " + m_words[1], q, {}, head == "feature" ? feature_class(q) : QuantityClass::Exact);
    const std::string& v = m_words[3];
    std::size_t next = 4;
    if (head == "tolerance" && q == "status") {
      if (v != "IN" && v != "OUT") return fmt::format("expected IN or OUT, got '{}'", v);
      e.value = word(v);
    } else if (q == "frame") {
      e.value = word(v);
    } else if (q == "actual") {
      if (v != "none") return "expected 'none' after 'actual' (a feature reported without an actual)";
      e.value = word(v);
    } else if (q == "points") {
      if (v.find_first_not_of("0123456789") != std::string::npos)
        return fmt::format("expected a point count, got '{}'", v);
      e.value = word(v);
    } else if (v == "none") {
      e.value = {Value::Kind::None, 0, ""};
    } else {
      const auto x = parse_number(v);
      if (!x) return fmt::format("expected a number or 'none' for {} {}, got '{}'", e.subject, q, v);
      e.value = {Value::Kind::Number, *x, v};
      if (next < m_words.size()) {
        std::string t = m_words[next++];
        if (t == "+-" && next < m_words.size())
          t = m_words[next++];
        else if (t.rfind("+-", 0) == 0)
          t = t.substr(2);
        else
          return fmt::format("expected '+-tolerance' or the end of the line after the value, got '{}'", t);
        if (t.empty()) return "expected a tolerance (a number >= 0) after '+-'";
        const auto tol = parse_number(t);
        if (!tol || *tol < 0) return fmt::format("expected a tolerance (a number >= 0) after '+-', got '{}'", t);
        e.tolerance = *tol;
      }
    }
    if (next < m_words.size())
      return fmt::format("unexpected '{}' after the {}", m_words[next], e.tolerance ? "tolerance" : "value");
    return add(std::move(e));
  }

  ExpectedFile m_file;
  std::vector<std::string> m_pending;  // comment lines waiting for the entry below them
  bool m_started = false;              // a directive or entry was seen: comments stop being header
  std::map<std::string, int> m_seen;   // key -> line, for duplicates
  std::set<std::string> m_directives;
  int m_texts = 0;
  int m_number = 0;
  std::vector<std::string> m_words;
};

}  // namespace

tl::expected<ExpectedFile, ParseError> parse_expected(std::string_view text) {
  ExpectedParser parser;
  int number = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (auto error = parser.read_line(line, ++number)) return tl::unexpected(ParseError{number, std::move(*error)});
  }
  return parser.finish();
}

std::string format_expected(const ExpectedFile& file) {
  std::string out;
  for (const auto& h : file.header) out += h + "\n";
  if (file.world) out += "world " + *file.world + "\n";
  if (file.seed) out += fmt::format("seed {}\n", *file.seed);
  for (const auto& kind : file.defaults_given) {
    const double v = kind == "length"      ? file.defaults.length_mm
                     : kind == "direction" ? file.defaults.direction
                                           : file.defaults.angle_deg;
    out += fmt::format("default {} +-{}\n", kind, v);
  }
  if (file.skip) out += "skip " + *file.skip + "\n";
  std::string subject;
  for (const auto& e : file.entries) {
    // A blank line between subjects: a diff then reads one OUTPUT at a time.
    const bool grouped = e.subject.rfind("text ", 0) == 0 ? subject.rfind("text ", 0) == 0 : e.subject == subject;
    if (!out.empty() && (!grouped || !e.comments.empty())) out += "\n";
    subject = e.subject;
    for (const auto& c : e.comments) out += c + "\n";
    if (e.subject.rfind("text ", 0) == 0)
      out += "text";
    else
      out += e.subject;
    if (!e.quantity.empty()) out += " " + e.quantity;
    out += " " + format_value(e.value);
    if (e.tolerance) out += fmt::format(" +-{}", *e.tolerance);
    out += "\n";
  }
  if (!file.trailer.empty()) out += "\n";
  for (const auto& c : file.trailer) out += c + "\n";
  return out;
}

Observed observe_results(const nlohmann::json& results) {
  Observed o;
  o.status = results.value("status", "");
  o.seed = results.value("seed", std::uint64_t{0});
  o.entries.push_back(make_entry("status", "", word(o.status), QuantityClass::Exact));
  std::map<std::string, int> occurrences;
  int texts = 0;
  const auto subject = [&](const std::string& kind, const std::string& label) {
    const int n = ++occurrences[kind + " " + label];
    return n == 1 ? kind + " " + label : fmt::format("{} {}@{}", kind, label, n);
  };
  const auto number = [&](const nlohmann::json& v, QuantityClass cls) {
    return v.is_number() ? number_value(v.get<double>(), cls) : Value{Value::Kind::None, 0, ""};
  };
  for (const auto& e : results.value("outputs", nlohmann::json::array())) {
    const std::string kind = e.value("kind", "");
    if (kind == "feature") {
      const std::string s = subject("feature", e.value("label", "?"));
      const auto add = [&](const std::string& q, Value v) {
        o.entries.push_back(make_entry(s, q, std::move(v), feature_class(q)));
      };
      add("frame", word(e.value("frame", "")));
      add("points", word(std::to_string(e.value("point_count", 0))));
      const auto& a = e.contains("actual") ? e["actual"] : nlohmann::json();
      if (!a.is_object()) {
        add("actual", word("none"));
        continue;
      }
      if (a.contains("position"))
        for (int i = 0; i < 3; ++i) add(std::string(1, "xyz"[i]), number(a["position"][i], QuantityClass::Length));
      if (a.contains("direction"))
        for (int i = 0; i < 3; ++i) add(std::string(1, "ijk"[i]), number(a["direction"][i], QuantityClass::Direction));
      static const std::vector<std::pair<const char*, const char*>> sizes = {{"diameter_mm", "diameter"},
                                                                             {"length_mm", "length"},
                                                                             {"apex_angle_deg", "angle"},
                                                                             {"start_angle_deg", "start"},
                                                                             {"included_angle_deg", "included"}};
      for (const auto& [field, q] : sizes)
        if (a.contains(field)) add(q, number(a[field], feature_class(q)));
      if (e.contains("form_mm") && e["form_mm"].is_number()) add("form", number(e["form_mm"], QuantityClass::Length));
    } else if (kind == "tolerance") {
      const std::string s = subject("tolerance", e.value("label", "?"));
      const QuantityClass cls = e.value("type", "") == "ANGLB" ? QuantityClass::Angle : QuantityClass::Length;
      o.entries.push_back(make_entry(s, "status", word(e.value("status", "")), QuantityClass::Exact));
      o.entries.push_back(
          make_entry(s, "value", number(e.contains("value") ? e["value"] : nlohmann::json(), cls), cls));
    } else if (kind == "text") {
      o.entries.push_back(make_entry(fmt::format("text {}", ++texts), "", {Value::Kind::String, 0, e.value("text", "")},
                                     QuantityClass::Exact));
    } else if (kind == "fault") {
      o.entries.push_back(make_entry("fault", "",
                                     word(fmt::format("{} line {}", e.value("fault", "?"), e.value("line", 0))),
                                     QuantityClass::Exact));
      if (o.fault_summary.empty()) o.fault_summary = summarize_fault(e);
    }
  }
  if (o.status == "error") {
    std::string diagnostics;
    for (const auto& d : results.value("diagnostics", nlohmann::json::array()))
      if (d.is_string()) diagnostics += d.get<std::string>() + "\n";
    first_error(diagnostics, o);
  }
  return o;
}

Observed observe_diagnostics(const std::string& diagnostics) {
  Observed o;
  o.status = "error";
  o.entries.push_back(make_entry("status", "", word("error"), QuantityClass::Exact));
  first_error(diagnostics, o);
  return o;
}

void observe_files(const fs::path& out_dir, Observed& observed) {
  std::vector<std::pair<std::string, std::size_t>> files;
  std::error_code ec;
  for (fs::directory_iterator it(out_dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file() || it->path().filename() == "results.json") continue;
    std::ifstream in(it->path(), std::ios::binary);
    const auto lines = static_cast<std::size_t>(
        std::count(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>(), '\n'));
    files.emplace_back(it->path().filename().string(), lines);
  }
  std::sort(files.begin(), files.end());  // directory order is not deterministic
  for (const auto& [name, lines] : files)
    observed.entries.push_back(make_entry("file " + name, "lines", word(std::to_string(lines)), QuantityClass::Exact));
}

std::vector<Difference> compare(const ExpectedFile& expected, const Observed& observed) {
  std::vector<Difference> out;
  std::map<std::string, const Entry*> got;
  std::set<std::string> got_subjects, expected_subjects, missing_reported;
  for (const auto& e : observed.entries) {
    got[e.key()] = &e;
    got_subjects.insert(e.subject);
  }
  for (const auto& e : expected.entries) expected_subjects.insert(e.subject);

  // The status first: when it differs, the rest is a consequence.
  const auto st = std::find_if(expected.entries.begin(), expected.entries.end(),
                               [](const Entry& e) { return e.subject == "status"; });
  const std::string want = st == expected.entries.end() ? "completed" : st->value.text;
  if (want != observed.status) out.push_back({"status", fmt::format("expected {}, got {}", want, observed.status)});

  for (const auto& e : expected.entries) {
    if (e.subject == "status") continue;
    const auto it = got.find(e.key());
    if (it == got.end()) {
      if (!got_subjects.count(e.subject)) {
        if (missing_reported.insert(e.subject).second)
          out.push_back({e.subject, e.subject.rfind("text ", 0) == 0
                                        ? fmt::format("expected {}, not reported", format_value(e.value))
                                    : e.quantity.empty()
                                        ? fmt::format("expected {}, not reported", format_value(e.value))
                                        : "expected, not reported"});
      } else {
        out.push_back({e.key(), fmt::format("expected {}, not reported", format_value(e.value))});
      }
      continue;
    }
    const Entry& g = *it->second;
    if (e.value.kind == Value::Kind::Number && g.value.kind == Value::Kind::Number) {
      const double tol = e.tolerance                         ? *e.tolerance
                         : g.cls == QuantityClass::Direction ? expected.defaults.direction
                         : g.cls == QuantityClass::Angle     ? expected.defaults.angle_deg
                                                             : expected.defaults.length_mm;
      const double diff = g.value.number - e.value.number;
      if (std::abs(diff) > tol) {
        const int d = decimals_of(g.cls);
        out.push_back(
            {e.key(), fmt::format("expected {}, got {} (difference {}{}, tolerance +-{})", format_value(e.value),
                                  format_value(g.value), diff >= 0 ? "+" : "", format_number(diff, d), tol)});
      }
    } else if (e.value.kind != g.value.kind || e.value.text != g.value.text) {
      out.push_back({e.key(), fmt::format("expected {}, got {}", format_value(e.value), format_value(g.value))});
    }
  }
  for (const auto& g : observed.entries) {
    if (expected_subjects.count(g.subject) || g.subject == "status") continue;
    expected_subjects.insert(g.subject);  // one line per unexpected subject
    out.push_back({g.subject, g.quantity.empty() ? fmt::format("got {}, not expected", format_value(g.value))
                                                 : "reported, not expected"});
  }
  return out;
}

ExpectedFile updated_expected(const ExpectedFile& previous, const Observed& observed) {
  ExpectedFile f = previous;
  f.seed = observed.seed;
  f.entries.clear();
  std::map<std::string, const Entry*> old;
  for (const auto& e : previous.entries) old[e.key()] = &e;
  for (Entry e : observed.entries) {
    if (const auto it = old.find(e.key()); it != old.end()) {
      if (e.value.kind == Value::Kind::Number) e.tolerance = it->second->tolerance;
      e.comments = it->second->comments;
    }
    f.entries.push_back(std::move(e));
  }
  return f;
}

tl::expected<std::vector<Case>, std::string> discover_cases(const std::vector<std::string>& roots) {
  std::map<std::string, Case> found;  // by name: sorted, and a file reached through two roots counts once
  const auto consider = [&](const fs::path& p) {
    const auto ext = p.extension();
    if (ext != ".dmi" && ext != ".expected") return;
    fs::path program = p, expected = p;
    program.replace_extension(".dmi");
    expected.replace_extension(".expected");
    // A directory named NAME.expected is not an expected file (it was read as an empty one).
    std::error_code ec;
    if (!fs::is_regular_file(expected, ec)) return;
    const std::string name = program.lexically_normal().generic_string();
    found.emplace(name, Case{name, program.lexically_normal(), expected.lexically_normal()});
  };
  for (const auto& r : roots) {
    const fs::path root(r);
    std::error_code ec;
    if (fs::is_regular_file(root, ec)) {
      consider(root);
      continue;
    }
    if (!fs::is_directory(root, ec)) return tl::unexpected(fmt::format("{}: no such directory", r));
    for (fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, ec), end; it != end;
         it.increment(ec)) {
      if (ec) return tl::unexpected(fmt::format("{}: {}", it->path().string(), ec.message()));
      if (it->is_regular_file()) consider(it->path());
    }
  }
  std::vector<Case> out;
  for (auto& [name, c] : found) out.push_back(std::move(c));
  return out;
}

bool matches_filter(const std::string& name, const std::string& pattern) {
  if (pattern.find_first_of("*?[") != std::string::npos) return ::fnmatch(pattern.c_str(), name.c_str(), 0) == 0;
  return name.find(pattern) != std::string::npos;
}

std::string format_case_result(const CaseResult& r) {
  static const char* tags[] = {"PASS", "FAIL", "SKIP", "UPDATED"};
  std::string out = fmt::format("{}  {}", tags[static_cast<int>(r.verdict)], r.test.name);
  if (r.wall_s > 0) out += fmt::format("  {:.2f} s", r.wall_s);  // 0: it never ran
  if (!r.reason.empty()) out += "  " + r.reason;
  out += "\n";
  for (const auto& d : r.details) out += "      " + d + "\n";
  return out;
}

std::string format_summary(const std::vector<CaseResult>& results) {
  std::size_t n[4] = {0, 0, 0, 0};
  for (const auto& r : results) ++n[static_cast<int>(r.verdict)];
  std::string out = fmt::format("{} passed, {} failed", n[0], n[1]);
  if (n[2]) out += fmt::format(", {} skipped", n[2]);
  if (n[3]) out += fmt::format(", {} updated", n[3]);
  return out;
}

std::string junit_xml(const std::vector<CaseResult>& results, double total_wall_s) {
  std::size_t failures = 0, skipped = 0;
  for (const auto& r : results) {
    failures += r.verdict == Verdict::Fail;
    skipped += r.verdict == Verdict::Skip;
  }
  std::string body;
  for (const auto& r : results) {
    const fs::path p(r.test.name);
    std::string classname = p.parent_path().generic_string();
    std::replace(classname.begin(), classname.end(), '/', '.');
    if (classname.empty()) classname = "metron";
    body += fmt::format("    <testcase classname=\"{}\" name=\"{}\" file=\"{}\" time=\"{:.3f}\"", xml_escape(classname),
                        xml_escape(p.filename().string()), xml_escape(r.test.name), r.wall_s);
    if (r.verdict == Verdict::Fail) {
      std::string text;
      for (const auto& d : r.details) text += d + "\n";
      body += fmt::format(">\n      <failure message=\"{}\" type=\"regression\">{}</failure>\n    </testcase>\n",
                          xml_escape(r.reason), xml_escape(text));
    } else if (r.verdict == Verdict::Skip) {
      body += fmt::format(">\n      <skipped message=\"{}\"/>\n    </testcase>\n", xml_escape(r.reason));
    } else {
      body += "/>\n";
    }
  }
  const std::string counts = fmt::format("tests=\"{}\" failures=\"{}\" errors=\"0\" skipped=\"{}\" time=\"{:.3f}\"",
                                         results.size(), failures, skipped, total_wall_s);
  return fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites name=\"metron test\" {}>\n"
      "  <testsuite name=\"metron test\" {}>\n{}  </testsuite>\n</testsuites>\n",
      counts, counts, body);
}

}  // namespace metron::regression
