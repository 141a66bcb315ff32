// SPDX-License-Identifier: GPL-3.0-or-later
// The run's outputs: the human report, the DMIS output file lines and results.json
// (schema in docs/results-json.md).
#include "metron/runtime/outputs.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>
#include <string_view>
#include <tuple>
#include <utility>

#include <fmt/format.h>

#include "metron/runtime/feature_parameters.hpp"

namespace metron::runtime {
namespace {

using nlohmann::json;

// ---------------------------------------------------------------- which fields a type has

bool has_direction(FeatureType type) { return type != FeatureType::Sphere; }
bool has_diameter(FeatureType type) {
  return type == FeatureType::Circle || type == FeatureType::Arc || type == FeatureType::Sphere ||
         type == FeatureType::Cylinder || type == FeatureType::Torus ||  // a torus: its major diameter
         type == FeatureType::Ellipse;                                   // an ellipse: its major diameter
}
bool has_minor_diameter(FeatureType type) { return type == FeatureType::Torus || type == FeatureType::Ellipse; }
/// CPARLN: its long axis; ELLIPS: its major axis.
bool has_in_plane_axis(FeatureType type) { return type == FeatureType::ClosedSlot || type == FeatureType::Ellipse; }
bool has_length(const Geometry& g) {
  return g.type == FeatureType::Cylinder || g.type == FeatureType::Cone || g.type == FeatureType::ClosedSlot ||
         (g.type == FeatureType::Line && g.bounded);
}

/// DMIS needs INNER or OUTER on a feature of size; a missing side is written as OUTER.
const char* side_word(const Geometry& g) { return g.side == Side::Inner ? "INNER" : "OUTER"; }

// ---------------------------------------------------------------- human report

enum class Unit { Millimetre, Cosine, Degree };

/// `v` (mm or degrees) in the report's units, and the decimals to write it with.
std::pair<double, int> in_units(double v, Unit unit, const ReportUnits& units, int mm_decimals) {
  switch (unit) {
    case Unit::Cosine: return {v, 6};
    case Unit::Degree: {
      const int d = units.angle_decimals >= 0    ? units.angle_decimals
                    : units.length_decimals >= 0 ? units.length_decimals
                    : units.radians              ? 6
                                                 : 4;
      return {units.radians ? v * std::numbers::pi / 180.0 : v, d};
    }
    case Unit::Millimetre: break;
  }
  return {v / units.mm_per_length,
          units.length_decimals >= 0 ? units.length_decimals : default_length_decimals(units, mm_decimals)};
}

std::string fixed(double v, Unit unit, bool sign, const ReportUnits& units = {}) {
  if (!std::isfinite(v)) return "-";
  const auto [value, decimals] = in_units(v, unit, units, 4);
  std::string s = fmt::format("{:+.{}f}", value, decimals);
  if (s.find_first_not_of("+-0.") == std::string::npos) s[0] = '+';  // no "-0.0000"
  return sign || s[0] == '-' ? s : s.substr(1);
}

struct Row {
  const char* name;
  Unit unit;
  double nominal;
  double actual;  // NaN without an actual
};

std::vector<Row> report_rows(const Geometry& nominal, const Geometry* actual) {
  const double nan = std::nan("");
  const auto act = [&](auto field) { return actual ? field(*actual) : nan; };
  std::vector<Row> rows;
  // A GSURF or GCURVE has no nominal of its own (its points do): the centroid and mean normal
  // of its points are shown without a deviation.
  const bool point_set = is_point_set(nominal.type);
  const char* axes[] = {"X", "Y", "Z"};
  for (int i = 0; i < 3; ++i)
    rows.push_back({axes[i], Unit::Millimetre, point_set ? nan : nominal.position[i],
                    act([i](const Geometry& g) { return g.position[i]; })});
  if (has_direction(nominal.type)) {
    const char* cosines[] = {"I", "J", "K"};
    for (int i = 0; i < 3; ++i)
      rows.push_back({cosines[i], Unit::Cosine, point_set ? nan : nominal.direction[i],
                      act([i](const Geometry& g) { return g.direction[i]; })});
  }
  // An arc is sized by its radius (FEAT/ARC), the others by their diameter.
  if (nominal.type == FeatureType::Arc)
    rows.push_back(
        {"R", Unit::Millimetre, nominal.diameter_mm / 2, act([](const Geometry& g) { return g.diameter_mm / 2; })});
  else if (has_diameter(nominal.type))
    rows.push_back({"D", Unit::Millimetre, nominal.diameter_mm, act([](const Geometry& g) { return g.diameter_mm; })});
  if (has_minor_diameter(nominal.type))
    rows.push_back({"MD", Unit::Millimetre, nominal.minor_diameter_mm,
                    act([](const Geometry& g) { return g.minor_diameter_mm; })});
  if (has_in_plane_axis(nominal.type)) {
    const char* axis_cosines[] = {"AI", "AJ", "AK"};  // the long (major) axis
    for (int i = 0; i < 3; ++i)
      rows.push_back({axis_cosines[i], Unit::Cosine, nominal.slot_axis[i],
                      act([i](const Geometry& g) { return g.slot_axis[i]; })});
  }
  if (nominal.type == FeatureType::ParallelPlanes || nominal.type == FeatureType::ClosedSlot)
    rows.push_back({"W", Unit::Millimetre, nominal.width_mm, act([](const Geometry& g) { return g.width_mm; })});
  if (nominal.type == FeatureType::Arc) {
    rows.push_back(
        {"START", Unit::Degree, nominal.start_angle_deg, act([](const Geometry& g) { return g.start_angle_deg; })});
    rows.push_back({"INCL", Unit::Degree, nominal.included_angle_deg,
                    act([](const Geometry& g) { return g.included_angle_deg; })});
  }
  if (nominal.type == FeatureType::Cone)
    rows.push_back(
        {"ANGLE", Unit::Degree, nominal.apex_angle_deg, act([](const Geometry& g) { return g.apex_angle_deg; })});
  if (has_length(nominal) && (nominal.type != FeatureType::Cone || nominal.length_mm > 0))
    rows.push_back({"L", Unit::Millimetre, nominal.length_mm, act([](const Geometry& g) { return g.length_mm; })});
  return rows;
}

/// "INCH, ANGRAD" for a heading (only written when not the default MM, ANGDEC).
std::string units_words(const ReportUnits& units) {
  return fmt::format("{}, {}", units.length, units.radians ? "ANGRAD" : "ANGDEC");
}

std::string feature_heading(const FeatureReport& report) {
  const Geometry& g = report.nominal;
  std::string out = fmt::format("{}({})  {}", report.actual ? "FA" : "F", report.label, dmis_word(g.type));
  if (has_side(g.type) && g.side != Side::None) out += fmt::format(" {}", dmis_word(g.side));
  if (!report.actual)
    out += "  not measured";
  else if (report.source == ActualSource::Constructed)
    out += "  constructed";
  else
    out += "  measured";
  if (report.point_count > 0) out += fmt::format(", {} points", report.point_count);
  out += fmt::format("  frame {}", report.frame);
  if (!report.units.is_default()) out += fmt::format(", {}", units_words(report.units));
  out += "\n";
  return out;
}

std::string feature_list(const std::vector<std::string>& labels) {
  std::string out;
  for (std::size_t i = 0; i < labels.size(); ++i) out += fmt::format("{}FA({})", i ? "," : "", labels[i]);
  return out;
}

bool is_deviation_kind(ToleranceKind kind) {
  return kind == ToleranceKind::Diam || kind == ToleranceKind::Rad || kind == ToleranceKind::DistB ||
         kind == ToleranceKind::Anglb || kind == ToleranceKind::DistWrt || kind == ToleranceKind::AngWrt ||
         kind == ToleranceKind::Cortol || kind == ToleranceKind::Width || kind == ToleranceKind::Angl;
}

std::string kind_words(const ToleranceResult& result) {
  std::string out = dmis_word(result.kind);
  if (result.kind == ToleranceKind::Pos) out += result.three_d ? " 3D" : " 2D";
  if (!result.tier.empty()) out += " " + result.tier;
  return out;
}

// ---------------------------------------------------------------- DMIS output

/// 5 decimals as in DMIS output files (lengths in the program's units, DECPL when given);
/// never "-0.00000".
std::string dmis_number(double v, ParameterUnit unit = ParameterUnit::Cosine, const ReportUnits& units = {}) {
  int decimals = 5;
  if (unit == ParameterUnit::Length) {
    std::tie(v, decimals) = in_units(v, Unit::Millimetre, units, 5);
  } else if (unit == ParameterUnit::Angle) {
    std::tie(v, decimals) = in_units(v, Unit::Degree, units, 5);
    if (units.angle_decimals < 0 && units.length_decimals < 0) decimals = units.radians ? 7 : 5;
  }
  std::string s = fmt::format("{:.{}f}", v, decimals);
  if (s.find_first_not_of("-0.") == std::string::npos && s[0] == '-') s.erase(0, 1);
  return s;
}

/// DMIS output style (as the NIST reference output): ", " between fields; a statement longer
/// than 80 columns continues with "  $" after the last fitting comma and two spaces of indent.
std::string dmis_statement(const std::string& head, const std::vector<std::string>& fields) {
  constexpr std::size_t k_width = 80;
  std::string one_line = head;
  for (const std::string& f : fields) one_line += ", " + f;
  if (one_line.size() <= k_width) return one_line;
  std::string out = head + ",  $";
  std::string line = "  ";
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const bool last = i + 1 == fields.size();
    const std::string piece = fields[i] + (last ? "" : ",");
    // Room for this piece plus the continuation mark "  $" unless it is the last.
    if (line.size() > 2 && line.size() + 1 + piece.size() + (last ? 0 : 3) > k_width) {
      out += "\n" + line + "  $";
      line = "  ";
    }
    line += (line.size() > 2 ? " " : "") + piece;
  }
  return out + "\n" + line;
}

// ---------------------------------------------------------------- JSON

json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }
json vector(const Vec3& v) { return json::array({number(v.x()), number(v.y()), number(v.z())}); }

json geometry_json(const Geometry& g) {
  json j = {{"type", dmis_word(g.type)}};
  if (has_side(g.type)) j["side"] = g.side == Side::None ? json(nullptr) : json(dmis_word(g.side));
  j["position"] = vector(g.position);
  if (has_direction(g.type)) j["direction"] = vector(g.direction);
  if (g.type == FeatureType::Line) {
    j["normal2"] = vector(g.normal2);
    j["bounded"] = g.bounded;
  }
  if (has_diameter(g.type)) j["diameter_mm"] = number(g.diameter_mm);
  if (has_minor_diameter(g.type)) j["minor_diameter_mm"] = number(g.minor_diameter_mm);
  if (g.type == FeatureType::Ellipse) j["major_axis"] = vector(g.slot_axis);
  if (g.type == FeatureType::ClosedSlot) {
    j["slot_axis"] = vector(g.slot_axis);
    j["ends"] = dmis_word(g.slot_ends);
  }
  if (g.type == FeatureType::ParallelPlanes || g.type == FeatureType::ClosedSlot) j["width_mm"] = number(g.width_mm);
  if (has_length(g)) j["length_mm"] = number(g.length_mm);
  if (g.type == FeatureType::Cone) j["apex_angle_deg"] = number(g.apex_angle_deg);
  if (g.type == FeatureType::Arc) {
    j["start_angle_deg"] = number(g.start_angle_deg);
    j["included_angle_deg"] = number(g.included_angle_deg);
  }
  return j;
}

/// actual - nominal for every numeric field `geometry_json` writes for the nominal's type.
json deviation_json(const Geometry& nominal, const Geometry& actual) {
  json j = {{"position", vector(actual.position - nominal.position)}};
  if (has_direction(nominal.type)) j["direction"] = vector(actual.direction - nominal.direction);
  if (nominal.type == FeatureType::Line) j["normal2"] = vector(actual.normal2 - nominal.normal2);
  if (has_diameter(nominal.type)) j["diameter_mm"] = number(actual.diameter_mm - nominal.diameter_mm);
  if (has_minor_diameter(nominal.type))
    j["minor_diameter_mm"] = number(actual.minor_diameter_mm - nominal.minor_diameter_mm);
  if (nominal.type == FeatureType::Ellipse) j["major_axis"] = vector(actual.slot_axis - nominal.slot_axis);
  if (nominal.type == FeatureType::ClosedSlot) j["slot_axis"] = vector(actual.slot_axis - nominal.slot_axis);
  if (nominal.type == FeatureType::ParallelPlanes || nominal.type == FeatureType::ClosedSlot)
    j["width_mm"] = number(actual.width_mm - nominal.width_mm);
  if (has_length(nominal)) j["length_mm"] = number(actual.length_mm - nominal.length_mm);
  if (nominal.type == FeatureType::Cone) j["apex_angle_deg"] = number(actual.apex_angle_deg - nominal.apex_angle_deg);
  if (nominal.type == FeatureType::Arc) {
    j["start_angle_deg"] = number(actual.start_angle_deg - nominal.start_angle_deg);
    j["included_angle_deg"] = number(actual.included_angle_deg - nominal.included_angle_deg);
  }
  return j;
}

const char* source_word(ActualSource source) {
  return source == ActualSource::Constructed ? "constructed" : "measured";
}

json fit_number(const std::optional<FitFigures>& fit, double FitFigures::*field) {
  return fit ? number((*fit).*field) : json(nullptr);
}

json feature_json(const Feature& f) {
  json points = json::array();
  const bool residuals = f.fit && f.fit->residuals_mm.size() == f.points.size();
  for (std::size_t i = 0; i < f.points.size(); ++i) {
    const MeasuredPoint& p = f.points[i];
    points.push_back({{"centre_mm", vector(p.centre_mm)},
                      {"surface_mm", vector(p.surface_mm())},
                      {"approach", vector(p.normal)},
                      {"ball_radius_mm", number(p.ball_radius_mm)},
                      {"time_s", number(p.time_s)},
                      {"scanned", p.scanned},
                      {"residual_mm", residuals ? number(f.fit->residuals_mm[i]) : json(nullptr)}});
  }
  return {{"label", f.label},
          {"type", dmis_word(f.nominal.type)},
          {"side", f.nominal.side == Side::None ? json(nullptr) : json(dmis_word(f.nominal.side))},
          {"source", source_word(f.source)},
          {"nominal", geometry_json(f.nominal)},
          {"actual", f.actual ? geometry_json(*f.actual) : json(nullptr)},
          {"form_mm", fit_number(f.fit, &FitFigures::form_mm)},
          {"rms_mm", fit_number(f.fit, &FitFigures::rms_mm)},
          {"points", std::move(points)}};
}

json tolerance_json(const ToleranceResult& r) {
  json j = {{"kind", "tolerance"},
            {"label", r.label},
            {"type", dmis_word(r.kind)},
            {"features", r.features},
            {"value", number(r.value)},
            {"actual", number(r.actual)},
            {"nominal", number(r.nominal)},
            {"lower", number(r.lower)},
            {"upper", number(r.upper)},
            {"status", r.in_tolerance ? "IN" : "OUT"},
            {"note", r.note}};
  if (r.kind == ToleranceKind::Pos || r.kind == ToleranceKind::Compos) j["three_d"] = r.three_d;
  if (!r.tier.empty()) j["tier"] = r.tier;
  return j;
}

json listed_points_json(const std::vector<ListedPoint>& points) {
  json out = json::array();
  for (const ListedPoint& p : points)
    out.push_back({{"index", p.index},
                   {"surface_mm", vector(p.surface_mm)},
                   {"approach", vector(p.approach)},
                   {"residual_mm", p.residual_mm ? number(*p.residual_mm) : json(nullptr)}});
  return out;
}

json event_json(const RunEvent& event) {
  if (const auto* f = std::get_if<FeatureReport>(&event)) {
    return {{"kind", "feature"},
            {"label", f->label},
            {"frame", f->frame},
            {"type", dmis_word(f->nominal.type)},
            {"source", source_word(f->source)},
            {"point_count", f->point_count},
            {"nominal", geometry_json(f->nominal)},
            {"actual", f->actual ? geometry_json(*f->actual) : json(nullptr)},
            {"deviation", f->actual ? deviation_json(f->nominal, *f->actual) : json(nullptr)},
            {"form_mm", fit_number(f->fit, &FitFigures::form_mm)},
            {"rms_mm", fit_number(f->fit, &FitFigures::rms_mm)},
            {"listed_points", listed_points_json(f->points)}};
  }
  if (const auto* t = std::get_if<ToleranceResult>(&event)) return tolerance_json(*t);
  if (const auto* text = std::get_if<TextReport>(&event)) return {{"kind", "text"}, {"text", text->text}};
  const auto& fault = std::get<FaultReport>(event);
  return {{"kind", "fault"},
          {"fault", fault.kind},
          {"message", fault.message},
          {"file", fault.statement.file},
          {"line", fault.statement.line},
          {"column", fault.statement.column},
          {"statement", fault.statement_text},
          {"position_mm", vector(fault.position_mm)},
          {"time_s", number(fault.time_s)}};
}

const char* status_word(RunStatus status) {
  switch (status) {
    case RunStatus::Completed: return "completed";
    case RunStatus::Faulted: return "faulted";
    case RunStatus::Error: return "error";
    case RunStatus::Refused: return "refused";
    case RunStatus::Interrupted: return "interrupted";
  }
  return "error";
}

}  // namespace

std::string format_feature_report(const FeatureReport& report) {
  const Geometry* actual = report.actual ? &*report.actual : nullptr;
  std::string out = feature_heading(report);
  if (actual)
    out += fmt::format("{:8}{:>14}{:>14}{:>14}\n", "", "NOMINAL", "ACTUAL", "DEVIATION");
  else
    out += fmt::format("{:8}{:>14}\n", "", "NOMINAL");
  const ReportUnits& u = report.units;
  for (const Row& row : report_rows(report.nominal, actual)) {
    out += fmt::format("  {:6}{:>14}", row.name, fixed(row.nominal, row.unit, false, u));
    if (actual)
      out += fmt::format("{:>14}{:>14}", fixed(row.actual, row.unit, false, u),
                         fixed(row.actual - row.nominal, row.unit, true, u));
    out += "\n";
  }
  if (actual && report.fit) {
    out += fmt::format("  {:6}{:>14}{:>14}\n", "RMS", "", fixed(report.fit->rms_mm, Unit::Millimetre, false, u));
    out += fmt::format("  {:6}{:>14}{:>14}\n", "FORM", "", fixed(report.fit->form_mm, Unit::Millimetre, false, u));
  }
  if (!report.points.empty()) {
    // OUTPUT/FA(x)[first,last]: the probed points, compensated, with their distances from the fit.
    out +=
        fmt::format("  {:6}{:>14}{:>14}{:>14}{:>11}{:>11}{:>11}{:>12}\n", "POINT", "X", "Y", "Z", "I", "J", "K", "DEV");
    for (const ListedPoint& p : report.points) {
      out += fmt::format("  {:<6}{:>14}{:>14}{:>14}", fmt::format("[{}]", p.index),
                         fixed(p.surface_mm.x(), Unit::Millimetre, false, u),
                         fixed(p.surface_mm.y(), Unit::Millimetre, false, u),
                         fixed(p.surface_mm.z(), Unit::Millimetre, false, u));
      for (int k = 0; k < 3; ++k) out += fmt::format("{:>11}", fixed(p.approach[k], Unit::Cosine, false, u));
      out +=
          fmt::format("{:>12}\n", p.residual_mm ? fixed(*p.residual_mm, Unit::Millimetre, true, u) : std::string("-"));
    }
  }
  return out;
}

std::string format_tolerance_result(const ToleranceResult& result) {
  std::string out = fmt::format("T({})  {}  {}  ", result.label, kind_words(result), feature_list(result.features));
  const Unit unit = is_angle_result(result) ? Unit::Degree : Unit::Millimetre;
  const auto mm = [&](double v, bool sign) { return fixed(v, unit, sign, result.units); };
  if (is_deviation_kind(result.kind)) {
    // The nominal the deviation is taken from (DISTB: the tolerance's, not the features').
    out += fmt::format("nominal {}  actual {}  ", mm(result.actual - result.value, false), mm(result.actual, false));
  }
  if (is_deviation_kind(result.kind) || result.kind == ToleranceKind::Profs || result.kind == ToleranceKind::Profl ||
      result.kind == ToleranceKind::Profp)
    out +=
        fmt::format("dev {}  limits [{}, {}]", mm(result.value, true), mm(result.lower, true), mm(result.upper, true));
  else
    out += fmt::format("value {}  zone {}", mm(result.value, false), mm(result.upper, false));
  out += result.in_tolerance ? "  IN" : "  OUT";
  if (!result.units.is_default()) out += fmt::format("  ({})", units_words(result.units));
  out += "\n";
  if (!result.note.empty()) out += "  note: " + result.note + "\n";
  return out;
}

std::string format_fault(const FaultReport& fault) {
  std::string out = "FAULT " + fault.kind;
  if (!fault.statement.file.empty())
    out += fmt::format(" at {}:{}:{}", fault.statement.file, fault.statement.line, fault.statement.column);
  out += ": " + fault.message + "\n";
  std::string_view text = fault.statement_text;
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.remove_suffix(1);
  if (!text.empty()) out += fmt::format("  {}\n", text);
  out +=
      fmt::format("  machine at {}, {}, {} mm, t = {:.3f} s\n", fixed(fault.position_mm.x(), Unit::Millimetre, false),
                  fixed(fault.position_mm.y(), Unit::Millimetre, false),
                  fixed(fault.position_mm.z(), Unit::Millimetre, false), fault.time_s);
  return out;
}

std::string dmis_feature_line(const FeatureReport& report) {
  const Geometry& g = report.actual ? *report.actual : report.nominal;
  std::string head = fmt::format("{}({}) = FEAT/{}", report.actual ? "FA" : "F", report.label, dmis_word(g.type));
  if (g.type == FeatureType::Line) head += g.bounded ? ", BND" : ", UNBND";
  if (has_side(g.type)) head += fmt::format(", {}", side_word(g));
  if (g.type == FeatureType::ClosedSlot) head += fmt::format(", {}", dmis_word(g.slot_ends));
  head += ", CART";
  std::vector<std::string> fields;
  for (const auto& p : feature_parameters(g)) fields.push_back(dmis_number(p.value, p.unit, report.units));
  return dmis_statement(head, fields);
}

std::string dmis_tolerance_line(const ToleranceResult& result) {
  std::vector<std::string> fields;
  if (result.kind == ToleranceKind::Pos) fields.emplace_back(result.three_d ? "3D" : "2D");
  const bool angle = is_angle_result(result);
  fields.push_back(dmis_number(result.value, angle ? ParameterUnit::Angle : ParameterUnit::Length, result.units));
  fields.emplace_back(result.in_tolerance ? "INTOL" : "OUTOL");
  const std::string head = fmt::format("TA({}) = TOL/{}", result.label, dmis_word(result.kind));
  return dmis_statement(head, fields);
}

std::string dmis_composite_line(const ToleranceResult& pattern, const ToleranceResult& feature) {
  std::vector<std::string> fields;
  for (const ToleranceResult* tier : {&pattern, &feature}) {
    fields.push_back(tier->tier);
    fields.push_back(dmis_number(tier->value, ParameterUnit::Length, tier->units));
    fields.emplace_back(tier->in_tolerance ? "INTOL" : "OUTOL");
  }
  return dmis_statement(fmt::format("TA({}) = TOL/COMPOS", pattern.label), fields);
}

nlohmann::json results_json(const RunRecord& record) {
  json features = json::array();
  for (const Feature& f : record.features) features.push_back(feature_json(f));
  json outputs = json::array();
  json tolerances = json::array();
  for (const RunEvent& e : record.events) {
    outputs.push_back(event_json(e));
    if (std::holds_alternative<ToleranceResult>(e)) tolerances.push_back(outputs.back());
  }
  return {{"schema", "metron.results/1"},
          {"program", record.program},
          {"world", record.world},
          {"seed", record.seed},
          {"status", status_word(record.status)},
          {"simulated_time_s", number(record.simulated_time_s)},
          {"diagnostics", record.diagnostics},
          {"machine_log", record.machine_log},
          {"features", std::move(features)},
          {"outputs", std::move(outputs)},
          {"tolerances", std::move(tolerances)}};
}

std::optional<std::string> write_file_atomically(const std::string& path, const std::string& text) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  std::error_code status_error;
  if (fs::exists(target, status_error) && !fs::is_regular_file(target, status_error)) {
    // A device or a pipe (/dev/stdout, /dev/null): written in place. Renaming over it would
    // replace the device node itself (as root, /dev/full became a regular file).
    if (fs::is_directory(target, status_error)) return fmt::format("cannot write {}: it is a directory", path);
    std::ofstream out(target, std::ios::binary);
    out << text;
    out.flush();
    if (!out) return fmt::format("cannot write {}: a write failed", path);
    return std::nullopt;
  }
  const fs::path temp = target.parent_path() / ("." + target.filename().string() + ".partial");
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) return fmt::format("cannot write {}: cannot create {}", path, temp.string());
    out << text;
    out.flush();
    if (!out) {
      out.close();
      std::error_code ec;
      fs::remove(temp, ec);
      return fmt::format("cannot write {}: a write failed (disk full?); the earlier file, if any, is kept", path);
    }
  }
  std::error_code ec;
  fs::rename(temp, target, ec);
  if (ec) {
    fs::remove(temp, ec);
    return fmt::format("cannot write {}: {}", path, ec.message());
  }
  return std::nullopt;
}

std::optional<std::string> write_results_file(const RunRecord& record, const std::string& path) {
  // Program texts, file names and echoed lines may hold any bytes (a Latin-1 TEXT, CHR(200)):
  // they are replaced, never allowed to abort the dump and lose the results.
  return write_file_atomically(
      path, results_json(record).dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

}  // namespace metron::runtime
