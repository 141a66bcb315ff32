// SPDX-License-Identifier: GPL-3.0-or-later
// The measured-data reader's errors (file, row, column) and the analysis' numerical pieces against
// independent answers: F-distribution tails from tables, the first-order lag's analytic step response.
#include <cmath>

#include <gtest/gtest.h>

#include "metron/stdlib/discrepancy/analysis.hpp"
#include "metron/stdlib/discrepancy/measured_data.hpp"

namespace {

namespace dc = metron::discrepancy;
using nlohmann::json;

json description() {
  return json::parse(R"({"kind": "positioning", "columns": [
    {"name": "target_mm", "role": "nominal", "axis": "x", "unit": "mm"},
    {"name": "dir", "role": "direction", "axis": "x"},
    {"name": "dev", "role": "deviation", "axis": "x", "unit": "um"}]})");
}

std::string error_of(const std::string& csv, const json& d = description()) {
  auto desc = dc::parse_description(d, "d.json");
  if (!desc) return desc.error().text();
  auto r = dc::parse_measured_data(csv, "data.csv", *desc);
  return r ? std::string("ok") : r.error().text();
}

TEST(DiscrepancyData, ReadsUnitsRolesAndDirections) {
  auto desc = dc::parse_description(description(), "d.json");
  ASSERT_TRUE(desc);
  auto r = dc::parse_measured_data("target_mm,dir,dev\n0,+,1.5\n10,-,-2\n", "data.csv", *desc);
  ASSERT_TRUE(r) << r.error().text();
  EXPECT_EQ(r->rows, 2u);
  EXPECT_DOUBLE_EQ(r->deviation_mm(0, 0), 0.0015);
  EXPECT_DOUBLE_EQ(r->deviation_mm(1, 0), -0.002);
  EXPECT_EQ(r->find(dc::Role::Direction)->values[1], -1);
  EXPECT_EQ(r->position_mm(1)[0], 10);
}

TEST(DiscrepancyData, ErrorsNameFileRowAndColumn) {
  EXPECT_EQ(error_of("target_mm,dev\n0,1\n"), "data.csv:1: column 'dir': missing column (not in the header)");
  EXPECT_EQ(error_of("target_mm,dir,dev\n0,+,1\n5,+,nan\n"), "data.csv:3: column 'dev': not a finite number ('nan')");
  EXPECT_EQ(error_of("target_mm,dir,dev\n0,+,1\n5,+,abc\n"), "data.csv:3: column 'dev': expected a number, got 'abc'");
  EXPECT_EQ(error_of("target_mm,dir,dev\n0,up,1\n"), "data.csv:2: column 'dir': expected a number, got 'up'");
  EXPECT_EQ(error_of("target_mm,dir,dev\n0,+\n"), "data.csv:2: column 'dev': missing value (the row has 2 cells)");
  json d = description();
  d["columns"][2]["unit"] = "furlong";
  EXPECT_EQ(error_of("", d),
            "d.json: /columns/2/unit: bad unit 'furlong' for column 'dev': expected a length (mm, um, nm, m, in)");
  d = description();
  d["columns"][1]["role"] = "speed";
  EXPECT_NE(error_of("", d).find("d.json: /columns/1/role: unknown role 'speed' (expected one of"), std::string::npos);
  d = description();
  d["columns"][0]["unit"] = "s";
  EXPECT_EQ(error_of("", d),
            "d.json: /columns/0/unit: bad unit 's' for column 'target_mm': expected a length (mm, um, nm, m, in)");
  d = description();
  d["colums"] = 1;
  EXPECT_NE(error_of("", d).find("unknown key 'colums'"), std::string::npos);
}

TEST(DiscrepancyData, WhitespaceTablesWithAPreamble) {
  // The SDSS plug-plate layout: two lines of preamble, a header with blanks in names, no header used.
  json d = json::parse(R"({"kind": "artefact", "separator": "whitespace", "skip_lines": 3, "header": false, "columns": [
    {"name": "mx", "role": "measured", "axis": "x", "unit": "mm"}, {"name": "my", "role": "measured", "axis": "y", "unit": "mm"},
    {"name": "nx", "role": "nominal", "axis": "x", "unit": "mm"}, {"name": "ny", "role": "nominal", "axis": "y", "unit": "mm"}]})");
  auto desc = dc::parse_description(d, "d.json");
  ASSERT_TRUE(desc) << desc.error().text();
  auto r = dc::parse_measured_data(
      "Plug Plate: 1\r\nDate: x\r\n  Meas X  Meas Y Nom X Nom Y\r\n -73.126 121.717 -73.140 121.705\r\n", "p", *desc);
  ASSERT_TRUE(r) << r.error().text();
  EXPECT_NEAR(r->deviation_mm(0, 0), 0.014, 1e-12);
  EXPECT_NEAR(r->deviation_mm(0, 1), 0.012, 1e-12);
}

TEST(DiscrepancyStatistics, FTailMatchesTables) {
  // Upper 5 % and 1 % points of F (Abramowitz & Stegun table 26.9).
  EXPECT_NEAR(dc::f_upper_tail(4.10, 2, 10), 0.05, 5e-4);
  EXPECT_NEAR(dc::f_upper_tail(7.56, 2, 10), 0.01, 1e-4);
  EXPECT_NEAR(dc::f_upper_tail(3.00, 2, 1e6), std::exp(-3.0), 1e-4);  // F(2, inf) = chi2(2)/2
  EXPECT_NEAR(dc::f_upper_tail(4.17, 1, 30), 0.05, 5e-4);
}

TEST(DiscrepancyStatistics, FirstOrderLagStepResponse) {
  // A ramp from 20 to 25 C over 1 s then held: the body follows 25 - 5 (e^{1/tau} - 1) tau e^{-t/tau} (t > 1).
  std::vector<double> t{0, 1, 1000, 2000, 4000}, T{20, 25, 25, 25, 25};
  const double tau = 600;
  const auto y = dc::first_order_lag(t, T, tau);
  for (std::size_t i = 2; i < t.size(); ++i)
    EXPECT_NEAR(y[i], 25 - 5 * tau * (std::exp(1 / tau) - 1) * std::exp(-t[i] / tau), 1e-9);
  EXPECT_EQ(dc::first_order_lag(t, T, 0), T);
}

}  // namespace
