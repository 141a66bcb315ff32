// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>

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

}  // namespace metron::runtime
