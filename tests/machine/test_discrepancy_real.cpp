// SPDX-License-Identifier: GPL-3.0-or-later
// The model-discrepancy analysis on real measured data (../shared/data/measured, see each README),
// described with the simplest base model (a perfect machine, plus ISO 230-2's per-target table for
// the positioning test). What is asserted is what the data show independently of metron: the 2011
// redrilled plate carries a scale error of both axes of about +34 ppm (its err columns grow linearly
// with X and Y, fitPlugPlateMeas fits a scale for this reason), and the ESS test's only outliers are
// the first two stops of the test (README table). Skips when the data are absent.
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "metron/stdlib/discrepancy/analysis.hpp"
#include "metron/stdlib/discrepancy/measured_data.hpp"

namespace {

namespace dc = metron::discrepancy;
const std::string kData = std::string(METRON_SHARED_DATA) + "/measured/";
const std::string kDescribe = std::string(METRON_SOURCE_DIR) + "/programs/discrepancy/";

dc::Analysis run(const dc::MeasuredData& d) {
  return dc::analyse(dc::make_problem(d, [](std::size_t, int) { return 0.0; }));
}

TEST(DiscrepancyReal, RedrilledPlugPlateHasAScaleErrorOfBothAxes) {
  const std::string f = kData + "sdss-plugplate-cmm/D1597A_redrilled_meas_2011";
  if (!std::filesystem::exists(f)) GTEST_SKIP() << "no " << f;
  auto d = dc::read_measured_data(f, kDescribe + "sdss_plugplate.json");
  ASSERT_TRUE(d) << d.error().text();
  const auto a = run(*d);
  std::map<std::string, double> scale;
  for (const auto& e : a.effects)
    if (e.kind == "scale") scale[e.what] = e.parameters[0].value;
  ASSERT_EQ(scale.size(), 2u);
  for (const auto& [what, ppm] : scale) EXPECT_NEAR(ppm, 34, 5) << what;
  EXPECT_LT(a.cv_rms_after_mm, 0.6 * a.cv_rms_before_mm);
}

TEST(DiscrepancyReal, EssPositioningTestClaimsNothingBeyondItsTable) {
  const std::string f = kData + "ess-slit-iso230-2/report.md_ISO230.dat";
  if (!std::filesystem::exists(f)) GTEST_SKIP() << "no " << f;
  // The converter of programs/discrepancy/ess_iso230_2_to_csv.sh, in C++.
  std::ifstream in(f);
  std::map<int, std::string> target;
  std::map<std::pair<int, int>, std::string> fwd, bwd;
  std::string line;
  std::smatch m;
  const std::regex tgt(R"(^TGT_DATA\[(\d+)\]=(\S+))"), ref(R"(^REF_DATA_(FWD|BWD)\[(\d+),(\d+)\]=(\S+))");
  while (std::getline(in, line)) {
    if (std::regex_search(line, m, tgt)) target[std::stoi(m[1])] = m[2];
    if (std::regex_search(line, m, ref)) (m[1] == "FWD" ? fwd : bwd)[{std::stoi(m[2]), std::stoi(m[3])}] = m[4];
  }
  std::string csv = "seq,cycle,direction,target_mm,reference_mm\n";
  int seq = 0;
  for (int j = 1; j <= 5; ++j) {
    for (int i = 1; i <= 5; ++i) csv += fmt::format("{},{},+,{},{}\n", seq++, j, target[i], fwd[{i, j}]);
    for (int i = 5; i >= 1; --i) csv += fmt::format("{},{},-,{},{}\n", seq++, j, target[i], bwd[{i, j}]);
  }
  std::ifstream dj(kDescribe + "ess_iso230_2.json");
  auto desc = dc::parse_description(nlohmann::json::parse(dj), "ess_iso230_2.json");
  ASSERT_TRUE(desc);
  auto d = dc::parse_measured_data(csv, "ess.csv", *desc);
  ASSERT_TRUE(d) << d.error().text();
  ASSERT_EQ(d->rows, 50u);
  const auto a = run(*d);
  EXPECT_TRUE(a.effects.empty());
  // The start-up transient fits the first two stops but cannot be cross-validated: said so.
  EXPECT_NE(a.stopped_at.find("transient"), std::string::npos) << a.stopped_at;
  EXPECT_NE(a.stopped_at.find("not confirmed by cross-validation"), std::string::npos) << a.stopped_at;
}

}  // namespace
