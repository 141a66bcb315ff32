// SPDX-License-Identifier: GPL-3.0-or-later
// The intrinsics that need the run rather than their arguments: the run's date and time, the
// simulated seconds since the start, the end of an input file, a feature's number of points,
// vectors turned between the part and machine systems, the machine's thermometer (QTEMP) and
// whether the last measurement failed under BADTST (BADPT, BADGT), and RAND's sequence.
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>

#include <fmt/format.h>

#include "metron/interpreter/interpreter.hpp"
#include "metron/runtime/measurement_runtime.hpp"

namespace metron::interpreter {

namespace {

/// SOURCE_DATE_EPOCH (the reproducible-builds convention) when set to a whole number of seconds,
/// else the wall clock now.
std::int64_t clock_start_s() {
  if (const char* fixed = std::getenv("SOURCE_DATE_EPOCH")) {
    char* end = nullptr;
    errno = 0;
    const long long v = std::strtoll(fixed, &end, 10);
    if (errno == 0 && end != fixed && *end == '\0' && v >= 0) return v;
  }
  return std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// A date-time as SDATETIME writes it, 'YYYY/MM/DD HH:MM:SS' (or STIME's 'HH:MM:SS' alone), in
// seconds since 1970 (UTC, as the run's clock).
std::optional<std::int64_t> seconds_of(const std::string& text) {
  std::tm t{};
  int year = 1970, month = 1, day = 1, hour = 0, minute = 0, second = 0;
  char rest = 0;
  if (std::sscanf(text.c_str(), "%d/%d/%d %d:%d:%d %c", &year, &month, &day, &hour, &minute, &second, &rest) != 6 &&
      std::sscanf(text.c_str(), " %d:%d:%d %c", &hour, &minute, &second, &rest) != 3)
    return std::nullopt;
  if (month < 1 || month > 12 || day < 1 || day > 31 || hour < 0 || hour > 23 || minute < 0 || minute > 59 ||
      second < 0 || second > 60)
    return std::nullopt;
  t.tm_year = year - 1900;
  t.tm_mon = month - 1;
  t.tm_mday = day;
  t.tm_hour = hour;
  t.tm_min = minute;
  t.tm_sec = second;
  return static_cast<std::int64_t>(timegm(&t));
}

// SELAPSETIME(start, end, LONG|SHORT): 'HH:MM:SS' (hours past 99 written in full) or whole seconds.
tl::expected<Value, std::string> elapsed_between(const std::string& start, const std::string& end,
                                                 const std::string& format) {
  const auto from = seconds_of(start), to = seconds_of(end);
  if (!from || !to)
    return tl::unexpected(
        fmt::format("SELAPSETIME: '{}' is not a date-time as SDATETIME writes it "
                    "('YYYY/MM/DD HH:MM:SS')",
                    !from ? start : end));
  const std::int64_t s = *to - *from;
  if (format == "SHORT") return Value::string(std::to_string(s));
  const std::int64_t a = s < 0 ? -s : s;
  return Value::string(fmt::format("{}{:02d}:{:02d}:{:02d}", s < 0 ? "-" : "", a / 3600, a / 60 % 60, a % 60));
}

}  // namespace

std::optional<tl::expected<Value, std::string>> Interpreter::run_function(const ir::Expr& e) {
  const std::string& name = e.name;
  if (name == "SDATE" || name == "STIME" || name == "SDATETIME" || name == "SELAPSETIME") {
    if (m_clock_start_s == 0) m_clock_start_s = clock_start_s();
    const double elapsed_s = m_runtime.machine().state().time_s;
    if (name == "SELAPSETIME" && e.args.empty()) return Value::real(elapsed_s);
    if (name == "SELAPSETIME") {
      std::vector<std::string> texts;
      for (const auto& a : e.args) {
        auto v = evaluate(a);
        if (!v) return tl::unexpected(v.error());
        if (v->type != ValueType::String) return tl::unexpected(std::string("SELAPSETIME takes date-time strings"));
        texts.push_back(v->text);
      }
      return elapsed_between(texts[0], texts[1], texts.size() > 2 ? texts[2] : "LONG");
    }
    // The run's clock: its start plus the simulated time, in UTC (a report does not depend on the
    // time zone of the computer that ran it).
    const std::time_t now = static_cast<std::time_t>(m_clock_start_s + static_cast<std::int64_t>(elapsed_s));
    std::tm utc{};
    gmtime_r(&now, &utc);
    const std::string date = fmt::format("{:04d}/{:02d}/{:02d}", utc.tm_year + 1900, utc.tm_mon + 1, utc.tm_mday);
    const std::string time = fmt::format("{:02d}:{:02d}:{:02d}", utc.tm_hour, utc.tm_min, utc.tm_sec);
    if (name == "SDATE") return Value::string(date);
    if (name == "STIME") return Value::string(time);
    return Value::string(date + " " + time);
  }
  if (name == "EOF" || name == "EOLN") {
    const std::string device = label_name(e.args.at(0).label);
    auto it = m_inputs.find(device);
    if (it == m_inputs.end())
      return tl::unexpected(fmt::format("{}(DID({})): the device is not open for INPUT", name, device));
    const InputFile& file = it->second;
    if (file.next >= file.fields.size()) return Value::boolean_value(true);
    // EOLN: READ has taken the last field of its line (the next one starts a new line).
    return Value::boolean_value(name == "EOLN" && file.next > 0 && file.lines[file.next] != file.lines[file.next - 1]);
  }
  if (name == "VMCS" || name == "VPCS") {
    // A vector of the current part system in machine coordinates (VMCS), or one of the machine
    // system in the part system (VPCS): directions turn only, they do not shift.
    auto v = evaluate(e.args.at(0));
    if (!v) return v;
    if (v->type != ValueType::Vector)
      return tl::unexpected(fmt::format("{} takes a VECTOR, got a {}", name, to_string(v->type)));
    const runtime::Alignment& a = m_runtime.alignment();
    const Vec3 u(v->components[0], v->components[1], v->components[2]);
    const Vec3 w = name == "VMCS" ? a.to_machine_vector(u) : a.to_part_vector(u);
    return Value::vector(w.x(), w.y(), w.z());
  }
  if (name == "EXIST") {
    const ir::LabelOperand& l = e.args.at(0).label;
    const std::string label = label_name(l);
    if (l.prefix == "DID")
      return Value::boolean_value(m_inputs.count(label) > 0 || m_runtime.label_exists("DID", label));
    return Value::boolean_value(m_runtime.label_exists(l.prefix, label));
  }
  if (name == "DMESYS") {
    // The measuring system's answers (docs/language.md, "DMESYS"): the folder of the running
    // file (MODUS's key), the system's name; any other key an empty string, with a warning.
    auto key = evaluate(e.args.at(0));
    if (!key) return key;
    if (key->type != ValueType::String) return tl::unexpected(std::string("DMESYS takes a string"));
    std::string k = key->text;
    std::transform(k.begin(), k.end(), k.begin(), [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
    if (k == "CURRENT_DMIS_MODULE_PATH" || k == "PROGRAM_PATH") {
      std::string folder = std::filesystem::path(m_sources.file(e.span.file).path).parent_path().string();
      if (!folder.empty() && folder.back() != '/') folder += '/';
      return Value::string(folder);
    }
    if (k == "DME" || k == "SYSTEM" || k == "NAME") return Value::string("metron");
    m_runtime.warning(e.span, fmt::format("DMESYS('{}'): metron does not know this key; answered ''", key->text));
    return Value::string("");
  }
  if (name == "QTEMP") {
    // QTEMP(sensor) (DMIS 5.2): a temperature sensor's reading. Every sensor reads the machine's
    // thermometer, the one its controller compensates by (the world's scale temperature); a
    // machine without one answers the reference temperature of ISO 1, 20 C, with a warning once.
    if (!e.args.empty()) {
      auto sensor = evaluate(e.args.at(0));
      if (!sensor) return sensor;
    }
    // In the program's temperature unit (UNITS/...,TEMPC|TEMPF): F = C * 9/5 + 32.
    const auto shown = [&](double c) { return Value::real(m_fahrenheit ? c * 9.0 / 5.0 + 32.0 : c); };
    if (const auto t = m_runtime.machine().state().temperature_c) return shown(*t);
    if (!m_no_thermometer_warned) {
      m_no_thermometer_warned = true;
      m_runtime.warning(e.span,
                        "QTEMP: this machine has no thermometer (its world models no temperature); answered the "
                        "reference temperature 20 C (told once)");
    }
    return shown(20.0);
  }
  if (name == "RAND") {
    // RAND([flag]) read as Fortran's (g77) RAND: 0 or none, the next number of the sequence; 1,
    // the sequence restarted; another value, a new seed (no public text of DMIS's RAND was
    // found). Uniform in [0, 1), from the 53 high bits so that every platform draws the same.
    if (!e.args.empty()) {
      auto flag = evaluate(e.args.at(0));
      if (!flag) return flag;
      if (!flag->is_number()) return tl::unexpected(std::string("RAND takes a number"));
      const auto seed = static_cast<std::int64_t>(flag->number);
      if (seed == 1)
        m_random.seed(0);
      else if (seed != 0)
        m_random.seed(static_cast<std::uint64_t>(seed));
    }
    return Value::real(static_cast<double>(m_random() >> 11) * 0x1.0p-53);
  }
  if (name == "SCSNS") return Value::string(m_runtime.active_sensor());
  if (name == "SCFEAT") return Value::string(m_current_feature);
  if (name == "SCDAT") return Value::string(m_runtime.alignment().label);
  if (name == "SERROR") {
    // The last machine fault the run went on after (ERROR/..., BADTST/ON), by ERROR's condition
    // words where it has one; '' before any.
    if (!m_last_fault || m_handled_faults == 0) return Value::string("");
    if (const char* condition = error_condition(m_last_fault->kind)) return Value::string(condition);
    std::string word = machine::to_string(m_last_fault->kind);
    std::transform(word.begin(), word.end(), word.begin(),
                   [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
    return Value::string(word);
  }
  if (name == "SMODE") {
    switch (m_runtime.mode()) {
      case runtime::Mode::Auto: return Value::string("AUTO");
      case runtime::Mode::ProgMan: return Value::string("PROG,MAN");
      case runtime::Mode::Man: return Value::string("MAN");
    }
  }
  if (name.rfind("VALUE/SNSET,", 0) == 0) {  // the distance in force, in the program's length unit
    const auto& p = m_runtime.probe_settings();
    const std::string word = name.substr(12);
    const double mm = word == "APPRCH"   ? p.approach_mm
                      : word == "RETRCT" ? p.retract_mm
                      : word == "SEARCH" ? p.search_mm
                      : word == "CLRSRF" ? p.clearance_mm
                                         : p.depth_mm;
    return Value::real(mm / m_length_mm);
  }
  if (name.rfind("VALUE/FEDRAT,", 0) == 0) {  // the feed in force, mm/s
    const auto state = m_runtime.machine().state();
    const std::string word = name.substr(13);
    return Value::real(word == "POSVEL"   ? state.positioning_feed_mm_s
                       : word == "SCNVEL" ? m_runtime.scan_settings().feed_mm_s.value_or(state.measuring_feed_mm_s)
                                          : state.measuring_feed_mm_s);
  }
  if (name == "BADPT") return Value::boolean_value(m_bad_point);
  if (name == "BADGT") return Value::boolean_value(m_bad_geometry);
  if (name == "PTDATA") {
    const std::string label = label_name(e.args.at(0).label);
    const runtime::Feature* f = m_runtime.find_feature(label);
    if (!f) return tl::unexpected(fmt::format("PTDATA: feature {} is not defined", label));
    return Value::integer(static_cast<double>(f->points.size()));
  }
  return std::nullopt;
}

}  // namespace metron::interpreter
