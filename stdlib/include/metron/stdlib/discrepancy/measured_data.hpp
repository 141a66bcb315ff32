// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <tl/expected.hpp>

/// Measured data for the model-discrepancy analysis (docs/discrepancy.md): a table (CSV or
/// whitespace-separated) plus a JSON description giving every column a role and a unit.
namespace metron::discrepancy {

/// How the data were measured; decides how the base model predicts a row.
enum class DataKind {
  Positioning,  ///< ISO 230-2 runs along an axis: deviation = actual - target = +e(target)
  Artefact,     ///< points of an artefact measured by the CMM: reported - nominal = -e(nominal)
  Grid,         ///< error vectors on a grid: +e(position)
  Drift,        ///< repeated readings over time (displacement sensors): +e(position, t)
};

/// What a column holds.
enum class Role {
  Nominal,       ///< reference/nominal coordinate along `axis` (mm)
  Measured,      ///< measured coordinate along `axis` (mm)
  Deviation,     ///< measured - nominal along `axis` (mm); axis 3 = along the approach vector
  Time,          ///< time of the reading (s)
  Temperature,   ///< a temperature (C), `of` says of what (air, part, scale, structure, ...)
  Direction,     ///< direction of approach of `axis` (+1/-1, or "+"/"-")
  Velocity,      ///< velocity (mm/s)
  Acceleration,  ///< acceleration (mm/s^2)
  Cycle,         ///< cycle (run) number
  Approach,      ///< component `axis` of the approach (probing) vector (unitless)
  Condition,     ///< any other recorded condition (spindle speed, humidity, ...), its own unit
  Ignore,        ///< not used
};

/// One column of the description.
struct ColumnSpec {
  std::string name;  ///< header name (or the name given when the file has no header)
  Role role = Role::Ignore;
  int axis = -1;     ///< 0 x, 1 y, 2 z, 3 n (along the approach vector), -1 none
  std::string unit;  ///< as written in the description
  double scale = 1;  ///< value in metron units = raw * scale + offset
  double offset = 0;
  std::string of;  ///< for temperatures: what was measured
};

/// The description (JSON) of a data file.
struct Description {
  DataKind kind = DataKind::Positioning;
  std::vector<ColumnSpec> columns;                   ///< in file order
  bool whitespace = false;                           ///< columns separated by blanks instead of commas
  int skip_lines = 0;                                ///< lines before the header (or the data)
  bool header = true;                                ///< the first line after skip_lines names the columns
  double noise_mm = std::nan("");                    ///< stated noise of one reading (NaN: estimate it)
  double reference_temperature_c = 20;               ///< ISO 1
  std::array<double, 3> fixed_position_mm{0, 0, 0};  ///< position of axes without a nominal column
  std::string name;                                  ///< for reports
  /// The base model's own table of systematic deviations per nominal position (ISO 230-2's mean
  /// bidirectional deviation per target): what a compensation table holds; effects are then
  /// searched beyond it (reversal, drift, thermal), not in the per-target shape itself.
  bool per_position_table = false;
};

/// A recorded column in metron units.
struct Series {
  std::string name;
  Role role = Role::Ignore;
  int axis = -1;
  std::string of;
  std::vector<double> values;
};

/// A loaded data set: every used column in metron units, and the raw cells (for --predict).
struct MeasuredData {
  std::string file;
  Description description;
  std::size_t rows = 0;
  std::vector<Series> series;                   ///< every non-ignored column
  std::vector<std::vector<std::string>> cells;  ///< raw text per row, per column
  std::vector<std::string> header;              ///< column names in file order

  /// The series with role and axis (-1: any axis), null when absent.
  [[nodiscard]] const Series* find(Role role, int axis = -1) const;
  /// Nominal position of a row (nominal columns, or the fixed position).
  [[nodiscard]] std::array<double, 3> position_mm(std::size_t row) const;
  /// measured - nominal along `axis` (Deviation column, or Measured - Nominal); NaN if not measured.
  [[nodiscard]] double deviation_mm(std::size_t row, int axis) const;
  /// Axes (0..3) that carry a measured deviation.
  [[nodiscard]] std::vector<int> measured_axes() const;
};

/// A loading error: file, 1-based row (0: not a row) and column name where known.
struct DataError {
  std::string file;
  std::size_t row = 0;
  std::string column;
  std::string message;
  /// "file:row: column 'x': message"
  [[nodiscard]] std::string text() const;
};

/// Parses a description (strict: unknown keys and units are errors naming the JSON pointer).
tl::expected<Description, DataError> parse_description(const nlohmann::json& j, const std::string& file);
/// Reads the data file described by `description`.
tl::expected<MeasuredData, DataError> read_measured_data(const std::string& data_file, const Description& description);
/// Reads both files.
tl::expected<MeasuredData, DataError> read_measured_data(const std::string& data_file,
                                                         const std::string& description_file);
/// Reads a table from text (for tests and generators).
tl::expected<MeasuredData, DataError> parse_measured_data(const std::string& text, const std::string& name,
                                                          const Description& description);

/// The same table as CSV with each measured value replaced: `deviation(row, axis)` gives the new
/// measured - nominal (Measured columns get nominal + it, Deviation columns it), in the column's unit.
template <class Deviation>
std::string write_with_deviations(const MeasuredData& data, Deviation deviation);
std::string write_with_deviations_impl(const MeasuredData& data,
                                       const std::vector<std::array<double, 4>>& deviation_mm);

template <class Deviation>
std::string write_with_deviations(const MeasuredData& data, Deviation deviation) {
  std::vector<std::array<double, 4>> d(data.rows);
  for (std::size_t r = 0; r < data.rows; ++r)
    for (int a = 0; a < 4; ++a) d[r][static_cast<std::size_t>(a)] = deviation(r, a);
  return write_with_deviations_impl(data, d);
}

}  // namespace metron::discrepancy
