// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/discrepancy/measured_data.hpp"

#include <charconv>
#include <fstream>
#include <map>
#include <sstream>

#include <fmt/format.h>

#include "metron/stdlib/json_reader.hpp"

namespace metron::discrepancy {
namespace {

using nlohmann::json;
using namespace strict_json;

enum class Dim { Length, Time, Temperature, Velocity, Acceleration, Unitless, Any };

struct Unit {
  Dim dim;
  double scale, offset;
};

// Units accepted per dimension, converted to metron units (mm, s, C, mm/s, mm/s^2).
const std::map<std::string, Unit>& units() {
  static const std::map<std::string, Unit> u{
      {"mm", {Dim::Length, 1, 0}},
      {"um", {Dim::Length, 1e-3, 0}},
      {"µm", {Dim::Length, 1e-3, 0}},
      {"nm", {Dim::Length, 1e-6, 0}},
      {"m", {Dim::Length, 1e3, 0}},
      {"in", {Dim::Length, 25.4, 0}},
      {"s", {Dim::Time, 1, 0}},
      {"ms", {Dim::Time, 1e-3, 0}},
      {"min", {Dim::Time, 60, 0}},
      {"h", {Dim::Time, 3600, 0}},
      {"C", {Dim::Temperature, 1, 0}},
      {"degC", {Dim::Temperature, 1, 0}},
      {"K", {Dim::Temperature, 1, -273.15}},
      {"mm/s", {Dim::Velocity, 1, 0}},
      {"mm/min", {Dim::Velocity, 1.0 / 60, 0}},
      {"m/s", {Dim::Velocity, 1e3, 0}},
      {"mm/s2", {Dim::Acceleration, 1, 0}},
      {"m/s2", {Dim::Acceleration, 1e3, 0}},
      {"1", {Dim::Unitless, 1, 0}},
      {"rpm", {Dim::Any, 1, 0}},
      {"%", {Dim::Any, 1, 0}},
      {"deg", {Dim::Any, 1, 0}},
      {"rad", {Dim::Any, 1, 0}},
      {"bar", {Dim::Any, 1, 0}},
  };
  return u;
}

Dim role_dim(Role r) {
  switch (r) {
    case Role::Nominal:
    case Role::Measured:
    case Role::Deviation: return Dim::Length;
    case Role::Time: return Dim::Time;
    case Role::Temperature: return Dim::Temperature;
    case Role::Velocity: return Dim::Velocity;
    case Role::Acceleration: return Dim::Acceleration;
    case Role::Direction:
    case Role::Cycle:
    case Role::Approach: return Dim::Unitless;
    case Role::Condition:
    case Role::Ignore: return Dim::Any;
  }
  return Dim::Any;
}

const char* dim_name(Dim d) {
  switch (d) {
    case Dim::Length: return "a length (mm, um, nm, m, in)";
    case Dim::Time: return "a time (s, ms, min, h)";
    case Dim::Temperature: return "a temperature (C, degC, K)";
    case Dim::Velocity: return "a velocity (mm/s, mm/min, m/s)";
    case Dim::Acceleration: return "an acceleration (mm/s2, m/s2)";
    case Dim::Unitless: return "no unit (\"1\")";
    case Dim::Any: return "a unit";
  }
  return "a unit";
}

Role parse_role(const json& j, const std::string& p) {
  static const std::map<std::string, Role> roles{
      {"nominal", Role::Nominal},   {"measured", Role::Measured},         {"deviation", Role::Deviation},
      {"time", Role::Time},         {"temperature", Role::Temperature},   {"direction", Role::Direction},
      {"velocity", Role::Velocity}, {"acceleration", Role::Acceleration}, {"cycle", Role::Cycle},
      {"approach", Role::Approach}, {"condition", Role::Condition},       {"ignore", Role::Ignore}};
  const std::string s = string(j, p);
  auto it = roles.find(s);
  if (it == roles.end()) {
    std::string list;
    for (const auto& [k, v] : roles) list += (list.empty() ? "" : ", ") + k;
    fail(p, fmt::format("unknown role '{}' (expected one of {})", s, list));
  }
  return it->second;
}

Description parse(const json& j) {
  Description d;
  Object o(j, "");
  d.kind = [&] {
    const std::string k = one_of(o.required("kind"), o.at("kind"), {"positioning", "artefact", "grid", "drift"});
    if (k == "artefact") return DataKind::Artefact;
    if (k == "grid") return DataKind::Grid;
    if (k == "drift") return DataKind::Drift;
    return DataKind::Positioning;
  }();
  if (const json* n = o.find("name")) d.name = string(*n, o.at("name"));
  if (const json* s = o.find("separator"))
    d.whitespace = one_of(*s, o.at("separator"), {"comma", "whitespace"}) == "whitespace";
  if (const json* s = o.find("skip_lines")) d.skip_lines = static_cast<int>(integer(*s, o.at("skip_lines"), 0));
  if (const json* h = o.find("header")) d.header = boolean(*h, o.at("header"));
  if (const json* n = o.find("noise_mm")) d.noise_mm = positive(*n, o.at("noise_mm"));
  o.number("reference_temperature_c", d.reference_temperature_c);
  if (const json* b = o.find("base"))
    d.per_position_table = one_of(*b, o.at("base"), {"world", "world+per-position-table"}) != "world";
  if (const json* f = o.find("fixed_position_mm")) {
    const auto v = numbers(*f, o.at("fixed_position_mm"), 3);
    d.fixed_position_mm = {v[0], v[1], v[2]};
  }
  const json& cols = o.required("columns");
  if (!cols.is_array() || cols.empty()) fail(o.at("columns"), "expected a non-empty array of columns");
  for (std::size_t i = 0; i < cols.size(); ++i) {
    const std::string p = fmt::format("/columns/{}", i);
    Object c(cols[i], p);
    ColumnSpec col;
    col.name = string(c.required("name"), c.at("name"));
    col.role = parse_role(c.required("role"), c.at("role"));
    if (const json* a = c.find("axis")) {
      const std::string s = one_of(*a, c.at("axis"), {"x", "y", "z", "n"});
      col.axis = s == "x" ? 0 : s == "y" ? 1 : s == "z" ? 2 : 3;
    }
    const bool needs_axis = col.role == Role::Nominal || col.role == Role::Measured || col.role == Role::Deviation ||
                            col.role == Role::Approach;
    if (needs_axis && col.axis < 0) fail(p, fmt::format("column '{}' needs an \"axis\" for its role", col.name));
    if (col.axis == 3 && col.role != Role::Deviation) fail(c.at("axis"), "axis \"n\" is only for deviations");
    if (const json* of = c.find("of")) col.of = string(*of, c.at("of"));
    const Dim want = role_dim(col.role);
    if (const json* u = c.find("unit")) {
      col.unit = string(*u, c.at("unit"));
      auto it = units().find(col.unit);
      if (it == units().end() ||
          (want != Dim::Any && it->second.dim != want && !(want == Dim::Unitless && it->second.dim == Dim::Unitless)))
        fail(c.at("unit"),
             fmt::format("bad unit '{}' for column '{}': expected {}", col.unit, col.name, dim_name(want)));
      col.scale = it->second.scale;
      col.offset = it->second.offset;
    } else if (want != Dim::Any && want != Dim::Unitless) {
      fail(p, fmt::format("column '{}' needs a \"unit\" ({})", col.name, dim_name(want)));
    }
    c.finish();
    d.columns.push_back(col);
  }
  o.finish();
  return d;
}

std::vector<std::string> split(const std::string& line, bool whitespace) {
  std::vector<std::string> out;
  if (whitespace) {
    std::istringstream in(line);
    std::string s;
    while (in >> s) out.push_back(s);
    return out;
  }
  std::string cur;
  for (char c : line) {
    if (c == ',') {
      out.push_back(cur);
      cur.clear();
    } else if (c != '\r') {
      cur += c;
    }
  }
  out.push_back(cur);
  for (auto& s : out) {  // trim blanks and quotes
    const auto b = s.find_first_not_of(" \t\"");
    const auto e = s.find_last_not_of(" \t\"");
    s = b == std::string::npos ? std::string{} : s.substr(b, e - b + 1);
  }
  return out;
}

bool parse_number(const std::string& s, double& v) {
  if (s.empty()) return false;
  const char* b = s.data();
  const char* e = s.data() + s.size();
  if (*b == '+') ++b;
  auto r = std::from_chars(b, e, v);
  return r.ec == std::errc{} && r.ptr == e;
}

}  // namespace

std::string DataError::text() const {
  std::string out = file;
  if (row > 0) out += fmt::format(":{}", row);
  out += ": ";
  if (!column.empty()) out += fmt::format("column '{}': ", column);
  return out + message;
}

const Series* MeasuredData::find(Role role, int axis) const {
  for (const auto& s : series)
    if (s.role == role && (axis < 0 || s.axis == axis)) return &s;
  return nullptr;
}

std::array<double, 3> MeasuredData::position_mm(std::size_t row) const {
  std::array<double, 3> p = description.fixed_position_mm;
  for (int a = 0; a < 3; ++a)
    if (const Series* s = find(Role::Nominal, a)) p[static_cast<std::size_t>(a)] = s->values[row];
  return p;
}

double MeasuredData::deviation_mm(std::size_t row, int axis) const {
  if (const Series* d = find(Role::Deviation, axis)) return d->values[row];
  const Series* m = find(Role::Measured, axis);
  const Series* n = find(Role::Nominal, axis);
  if (m && n) return m->values[row] - n->values[row];
  return std::nan("");
}

std::vector<int> MeasuredData::measured_axes() const {
  std::vector<int> out;
  for (int a = 0; a < 4; ++a)
    if (find(Role::Deviation, a) || (find(Role::Measured, a) && find(Role::Nominal, a))) out.push_back(a);
  return out;
}

tl::expected<Description, DataError> parse_description(const json& j, const std::string& file) {
  auto r = strict_json::read([&] { return parse(j); });
  if (!r) return tl::unexpected(DataError{file, 0, {}, fmt::format("{}: {}", r.error().pointer, r.error().message)});
  return *r;
}

tl::expected<MeasuredData, DataError> parse_measured_data(const std::string& text, const std::string& name,
                                                          const Description& description) {
  MeasuredData data;
  data.file = name;
  data.description = description;
  std::istringstream in(text);
  std::string line;
  std::size_t line_no = 0;
  for (int i = 0; i < description.skip_lines && std::getline(in, line); ++i) ++line_no;
  const std::size_t ncol = description.columns.size();
  std::vector<int> index(ncol);  // file column of each described column
  if (description.header) {
    do {
      if (!std::getline(in, line)) return tl::unexpected(DataError{name, line_no + 1, {}, "missing header line"});
      ++line_no;
    } while (line.find_first_not_of(" \t\r") == std::string::npos);
    data.header = split(line, description.whitespace);
    for (std::size_t c = 0; c < ncol; ++c) {
      auto it = std::find(data.header.begin(), data.header.end(), description.columns[c].name);
      if (it == data.header.end())
        return tl::unexpected(
            DataError{name, line_no, description.columns[c].name, "missing column (not in the header)"});
      index[c] = static_cast<int>(it - data.header.begin());
    }
  } else {
    for (std::size_t c = 0; c < ncol; ++c) {
      index[c] = static_cast<int>(c);
      data.header.push_back(description.columns[c].name);
    }
  }
  std::vector<std::size_t> used;
  for (std::size_t c = 0; c < ncol; ++c) {
    const auto& spec = description.columns[c];
    if (spec.role == Role::Ignore) continue;
    data.series.push_back(Series{spec.name, spec.role, spec.axis, spec.of, {}});
    used.push_back(c);
  }
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    auto cells = split(line, description.whitespace);
    for (std::size_t k = 0; k < used.size(); ++k) {
      const auto& spec = description.columns[used[k]];
      const auto fc = static_cast<std::size_t>(index[used[k]]);
      if (fc >= cells.size())
        return tl::unexpected(
            DataError{name, line_no, spec.name, fmt::format("missing value (the row has {} cells)", cells.size())});
      double v = 0;
      const std::string& s = cells[fc];
      if (spec.role == Role::Direction && (s == "+" || s == "-")) {
        v = s == "+" ? 1 : -1;
      } else if (!parse_number(s, v)) {
        return tl::unexpected(DataError{name, line_no, spec.name, fmt::format("expected a number, got '{}'", s)});
      }
      if (!std::isfinite(v))
        return tl::unexpected(DataError{name, line_no, spec.name, fmt::format("not a finite number ('{}')", s)});
      if (spec.role == Role::Direction && v != 1 && v != -1)
        return tl::unexpected(
            DataError{name, line_no, spec.name, fmt::format("expected a direction +1/-1 or +/-, got '{}'", s)});
      data.series[k].values.push_back(v * spec.scale + spec.offset);
    }
    data.cells.push_back(std::move(cells));
  }
  data.rows = data.cells.size();
  if (data.rows == 0) return tl::unexpected(DataError{name, 0, {}, "no data rows"});
  if (data.measured_axes().empty())
    return tl::unexpected(
        DataError{name,
                  0,
                  {},
                  "the description gives no measured values (a 'deviation' column, or 'measured' with its 'nominal')"});
  return data;
}

tl::expected<MeasuredData, DataError> read_measured_data(const std::string& data_file, const Description& description) {
  std::ifstream in(data_file, std::ios::binary);
  if (!in) return tl::unexpected(DataError{data_file, 0, {}, "cannot open the file"});
  std::ostringstream s;
  s << in.rdbuf();
  return parse_measured_data(s.str(), data_file, description);
}

tl::expected<MeasuredData, DataError> read_measured_data(const std::string& data_file,
                                                         const std::string& description_file) {
  std::ifstream in(description_file, std::ios::binary);
  if (!in) return tl::unexpected(DataError{description_file, 0, {}, "cannot open the file"});
  json j;
  try {
    j = json::parse(in, nullptr, true, true);
  } catch (const json::parse_error& e) {
    return tl::unexpected(DataError{description_file, 0, {}, fmt::format("invalid JSON: {}", e.what())});
  }
  auto d = parse_description(j, description_file);
  if (!d) return tl::unexpected(d.error());
  return read_measured_data(data_file, *d);
}

std::string write_with_deviations_impl(const MeasuredData& data, const std::vector<std::array<double, 4>>& dev) {
  std::string out;
  const auto& cols = data.description.columns;
  for (std::size_t c = 0; c < data.header.size(); ++c) out += (c ? "," : "") + data.header[c];
  out += "\n";
  // Which file column each described column is.
  std::vector<std::pair<std::size_t, const ColumnSpec*>> spec_of;
  for (const auto& spec : cols) {
    auto it = std::find(data.header.begin(), data.header.end(), spec.name);
    spec_of.emplace_back(static_cast<std::size_t>(it - data.header.begin()), &spec);
  }
  for (std::size_t r = 0; r < data.rows; ++r) {
    std::vector<std::string> cells = data.cells[r];
    const auto pos = data.position_mm(r);
    for (const auto& [fc, spec] : spec_of) {
      if (fc >= cells.size() || spec->axis < 0) continue;
      const double d = dev[r][static_cast<std::size_t>(spec->axis)];
      double v;
      if (spec->role == Role::Deviation)
        v = d;
      else if (spec->role == Role::Measured && spec->axis < 3)
        v = pos[static_cast<std::size_t>(spec->axis)] + d;
      else
        continue;
      cells[fc] = fmt::format("{:.9g}", (v - spec->offset) / spec->scale);
    }
    for (std::size_t c = 0; c < cells.size(); ++c) out += (c ? "," : "") + cells[c];
    out += "\n";
  }
  return out;
}

}  // namespace metron::discrepancy
