// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>

namespace metron::runtime {

/// The units and precision a report is written in: the program's UNITS and DECPL in force at the
/// OUTPUT. Reports on the console and DMIS output files use them; results.json stays in mm and
/// degrees (docs/results-json.md).
struct ReportUnits {
  double mm_per_length = 1;   ///< 25.4 for INCH, 10 for CM ...
  std::string length = "MM";  ///< the UNITS word: MM, CM, M, INCH, FEET
  bool radians = false;       ///< ANGRAD
  int length_decimals = -1;   ///< DECPL; -1: the default (4 on reports, 5 in files; one more for INCH)
  int angle_decimals = -1;    ///< DECPL for angles; -1: as lengths
  [[nodiscard]] bool is_default() const {
    return mm_per_length == 1 && !radians && length_decimals < 0 && angle_decimals < 0;
  }
};

/// Default decimals of a length in `units` on reports: `mm_decimals` in mm, and as many more as
/// the unit is larger (CM 5, INCH 5, FEET 6, M 7 from 4), so the resolution stays the same.
inline int default_length_decimals(const ReportUnits& units, int mm_decimals) {
  return mm_decimals + static_cast<int>(std::lround(std::log10(std::max(units.mm_per_length, 1.0))));
}

/// The unit a report line names after a length: "mm", else the UNITS word (INCH, CM ...).
inline std::string unit_word(const ReportUnits& units) { return units.length == "MM" ? "mm" : units.length; }

/// A number as a note writes it, without the sign of a zero ("-0.0000" is "0.0000").
inline std::string without_negative_zero(std::string text) {
  if (text.starts_with('-') && text.find_first_not_of("0.", 1) == std::string::npos) text.erase(0, 1);
  return text;
}

/// A length given in mm, written in `units` with their decimals (for the notes of a report).
inline std::string length_text(double mm, const ReportUnits& units, int mm_decimals = 4) {
  const int decimals = units.length_decimals >= 0 ? units.length_decimals : default_length_decimals(units, mm_decimals);
  return fmt::format("{:.{}f}", mm / units.mm_per_length, decimals);
}

}  // namespace metron::runtime
