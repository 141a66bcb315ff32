// SPDX-License-Identifier: GPL-3.0-or-later
// `metron run --compensation` (and CALL/EXTERN,SYS,'COMPENSATION file') as a user runs it (issue 12,
// docs/error-space.md "The gain of compensation"): calibrate the error space of
// programs/worlds/cmm_errors_ball_plate.json with the two-point rig, then measure the world's 20 balls with
// programs/error_space/ball_array.dmi with and without the map. Expected values are the hidden truth: the balls' design
// centres (written here by hand from the world file; the part sits at the machine origin), whose distances the measured
// centres must reproduce.
#include <gtest/gtest.h>

#include "shell.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace {

using metron::test_support::shell;

using Point = std::array<double, 3>;

std::map<std::string, Point> true_centres() {
  std::map<std::string, Point> out;
  int n = 0;
  for (double y : {150, 400, 650})
    for (double x : {150, 350, 550, 750}) out["BALL" + std::to_string(++n)] = {x, y, 60};
  for (double y : {275, 525})
    for (double x : {250, 450, 650, 850}) out["BALL" + std::to_string(++n)] = {x, y, 130};
  return out;
}

double dist(const Point& a, const Point& b) { return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]); }

// RMS of every pair's measured minus true distance, mm (ISO 10360-2 style length errors).
double length_error_rms(const std::string& results_json) {
  std::ifstream in(results_json);
  const auto j = nlohmann::json::parse(in);
  std::map<std::string, Point> got;
  for (const auto& f : j.at("features")) {
    const auto& p = f.at("actual").at("position");
    got[f.at("label").get<std::string>()] = {p[0].get<double>(), p[1].get<double>(), p[2].get<double>()};
  }
  const auto truth = true_centres();
  EXPECT_EQ(got.size(), truth.size());
  double sum = 0;
  int pairs = 0;
  for (auto a = truth.begin(); a != truth.end(); ++a)
    for (auto b = std::next(a); b != truth.end(); ++b) {
      const double e = dist(got[a->first], got[b->first]) - dist(a->second, b->second);
      sum += e * e;
      ++pairs;
    }
  return std::sqrt(sum / pairs);
}

// The map that covers the ball array (docs/error-space.md, "The gain of compensation").
std::pair<int, std::string> calibrate_ball_array_map(const std::string& map) {
  return shell(std::string(METRON_BINARY) + " calibrate error-space --world " + METRON_SOURCE_DIR +
               "/programs/worlds/cmm_errors_ball_plate.json --components xyz --reversal --sensor-offset 0,0,-50"
               " --size 17,13,3 --origin 100,100,100 --runs 4 --laser-cycles 8 --out " +
               map);
}

TEST(RunCompensationCli, TheCalibratedMapCutsTheBallArraysLengthErrorsTenfold) {
  const auto dir = std::filesystem::temp_directory_path() / "metron_run_compensation";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "none");
  std::filesystem::create_directories(dir / "map");
  const std::string bin = METRON_BINARY, src = METRON_SOURCE_DIR;
  const std::string world = src + "/programs/worlds/cmm_errors_ball_plate.json";
  const std::string map = (dir / "map.json").string();
  auto [code, out] = calibrate_ball_array_map(map);
  ASSERT_EQ(code, 0) << out;
  const std::string program = src + "/programs/error_space/ball_array.dmi";
  std::tie(code, out) =
      shell(bin + " run " + program + " --world " + world + " --quiet --out " + (dir / "none").string());
  ASSERT_EQ(code, 0) << out;
  std::tie(code, out) = shell(bin + " run " + program + " --world " + world + " --quiet --compensation " + map +
                              " --out " + (dir / "map").string());
  ASSERT_EQ(code, 0) << out;
  const double none = length_error_rms((dir / "none" / "results.json").string());
  const double compensated = length_error_rms((dir / "map" / "results.json").string());
  std::printf("ball array length errors: none RMS %.3f um, calibrated map RMS %.3f um, gain %.1f\n", 1e3 * none,
              1e3 * compensated, none / compensated);
  EXPECT_GT(none, 0.003);             // the machine's errors are there (4.3 um)
  EXPECT_LT(compensated, none / 10);  // the issue's goal (measured: 0.22 um, 19x)

  // The same map loaded by the program itself (CALL/EXTERN,SYS,'COMPENSATION file', a path relative
  // to the program), then the ball array called as a file: the same centres as --compensation.
  std::filesystem::create_directories(dir / "dmis");
  std::ofstream(dir / "compensated.dmi") << "DMISMN/'compensation from the program', 5.0\n"
                                            "CALL/EXTERN, SYS, 'COMPENSATION map.json'\n"
                                            "CALL/EXTERN, DMIS, '"
                                         << program
                                         << "'\n"
                                            "ENDFIL\n";
  // The ball array lives outside this program's folder: --include lets it be read (docs/security.md).
  std::tie(code, out) =
      shell(bin + " run " + (dir / "compensated.dmi").string() + " --world " + world + " --include " +
            std::filesystem::path(program).parent_path().string() + " --quiet --out " + (dir / "dmis").string());
  ASSERT_EQ(code, 0) << out;
  EXPECT_NEAR(length_error_rms((dir / "dmis" / "results.json").string()), compensated, 1e-12);
}

// CALL/EXTERN,SYS,'CALIBRATE ERROR-SPACE ...' in an installation program: the same grid, instruments
// and seed as the command line give the same map (written into --out), and the ball array measured
// after it in the same run reads exactly as with that map loaded by --compensation.
TEST(RunCompensationCli, AProgramCalibratesTheErrorSpaceAndCompensatesByIt) {
  const auto dir = std::filesystem::temp_directory_path() / "metron_run_calibrate_error_space";
  std::filesystem::remove_all(dir);
  for (const char* d : {"cli", "program", "none"}) std::filesystem::create_directories(dir / d);
  const std::string bin = METRON_BINARY, src = METRON_SOURCE_DIR;
  const std::string world = src + "/programs/worlds/cmm_errors_ball_plate.json";
  const std::string map = (dir / "map.json").string();
  auto [code, out] = calibrate_ball_array_map(map);
  ASSERT_EQ(code, 0) << out;
  std::tie(code, out) = shell(bin + " run " + src + "/programs/error_space/ball_array.dmi --world " + world +
                              " --quiet --compensation " + map + " --out " + (dir / "cli").string());
  ASSERT_EQ(code, 0) << out;
  std::tie(code, out) = shell(bin + " run " + src + "/programs/error_space/ball_array.dmi --world " + world +
                              " --quiet --out " + (dir / "none").string());
  ASSERT_EQ(code, 0) << out;
  std::tie(code, out) = shell(bin + " run " + src + "/programs/error_space/calibrate_then_measure.dmi --world " +
                              world + " --out " + (dir / "program").string());
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("error space 17 x 13 x 3 written to error-space.json"), std::string::npos) << out;

  auto read = [](const std::filesystem::path& p) {
    std::ifstream in(p);
    return nlohmann::json::parse(in);
  };
  const auto from_cli = read(map), from_program = read(dir / "program" / "error-space.json");
  EXPECT_EQ(from_cli.at("temperatures"), from_program.at("temperatures"));
  EXPECT_EQ(from_cli.at("sensor_offset_mm"), from_program.at("sensor_offset_mm"));
  EXPECT_TRUE(std::filesystem::file_size(dir / "program" / "error-space.svg") > 1000);

  const double none = length_error_rms((dir / "none" / "results.json").string());
  const double by_program = length_error_rms((dir / "program" / "results.json").string());
  EXPECT_NEAR(by_program, length_error_rms((dir / "cli" / "results.json").string()), 1e-12);
  EXPECT_LT(by_program, none / 10);

  // Bad words are positioned errors before anything runs.
  std::ofstream(dir / "bad.dmi") << "DMISMN/'bad', 5.0\n"
                                    "CALL/EXTERN, SYS, 'CALIBRATE ERROR-SPACE SIZE=17,13 STEP=50'\n"
                                    "ENDFIL\n";
  std::tie(code, out) = shell(bin + " check " + (dir / "bad.dmi").string());
  EXPECT_NE(code, 0);
  EXPECT_NE(out.find("bad.dmi:2:19: error: CALIBRATE ERROR-SPACE: SIZE=17,13: expected three numbers"),
            std::string::npos)
      << out;
  std::ofstream(dir / "huge.dmi") << "DMISMN/'huge', 5.0\n"
                                     "CALL/EXTERN, SYS, 'CALIBRATE ERROR-SPACE SIZE=1000,1000,3 RUNS=7'\n"
                                     "ENDFIL\n";
  std::tie(code, out) = shell(bin + " check " + (dir / "huge.dmi").string());
  EXPECT_NE(out.find("3000000 grid points; at most 250000"), std::string::npos) << out;
}

// The part-frame deviations of the example block's features after its datum alignment (what an
// inspection reports; a machine offset the alignment absorbs does not count): positions across each
// axis, plane positions along the normal, diameters; mm, in a fixed order.
std::vector<double> block_deviations(const std::string& results_json) {
  std::ifstream in(results_json);
  const auto j = nlohmann::json::parse(in);
  std::vector<double> out;
  for (const char* label : {"BORE1", "BORE2", "BOSS1", "BOSS_TOP", "SPHERE1", "CSINK"}) {
    const nlohmann::json* f = nullptr;
    for (const auto& g : j.at("features"))
      if (g.at("label") == label) f = &g;
    EXPECT_NE(f, nullptr) << label;
    if (!f) return out;
    const auto& a = f->at("actual");
    const auto& n = f->at("nominal");
    Point d{};
    for (int i = 0; i < 3; ++i) d[i] = a.at("position")[i].get<double>() - n.at("position")[i].get<double>();
    const std::string type = a.at("type");
    if (type == "CYLNDR" || type == "CIRCLE" || type == "PLANE") {
      Point axis{};
      for (int i = 0; i < 3; ++i) axis[i] = n.at("direction")[i].get<double>();
      const double along = d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2];
      if (type == "PLANE") {
        out.push_back(along);
      } else {
        out.push_back(d[0] - along * axis[0]);  // the axes are vertical: x and y across them
        out.push_back(d[1] - along * axis[1]);
      }
    } else {
      out.insert(out.end(), d.begin(), d.end());
    }
    if (a.contains("diameter_mm")) out.push_back(a.at("diameter_mm").get<double>() - n.at("diameter_mm").get<double>());
  }
  return out;
}

double rms_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(s / static_cast<double>(std::max<std::size_t>(1, a.size())));
}

// The example block (programs/examples/02_block_inspection.dmi) on the machine of
// programs/worlds/cmm_errors.json, with and without a map calibrated over the block and the reference
// sphere, against the same program on a perfect machine with the same seed (the same probe noise):
// what the machine's errors add to the inspection's results, before and after compensation.
TEST(RunCompensationCli, TheExampleBlockReadsAsOnAPerfectMachineAfterCompensation) {
  const auto dir = std::filesystem::temp_directory_path() / "metron_run_compensation_block";
  std::filesystem::remove_all(dir);
  for (const char* d : {"perfect", "none", "map"}) std::filesystem::create_directories(dir / d);
  const std::string bin = METRON_BINARY, src = METRON_SOURCE_DIR;
  const std::string world = src + "/programs/worlds/cmm_errors.json",
                    program = src + "/programs/examples/02_block_inspection.dmi";
  const std::string map = (dir / "map.json").string();
  auto [code, out] = shell(bin + " calibrate error-space --world " + world +
                           " --components xyz --reversal --sensor-offset 0,0,-50 --size 15,13,4 --origin 250,150,50"
                           " --runs 4 --laser-cycles 8 --out " +
                           map);
  ASSERT_EQ(code, 0) << out;
  for (const auto& [folder, options] : {std::pair<std::string, std::string>{"perfect", ""},
                                        {"none", " --world " + world},
                                        {"map", " --world " + world + " --compensation " + map}}) {
    std::tie(code, out) = shell(bin + " run " + program + options + " --quiet --out " + (dir / folder).string());
    ASSERT_EQ(code, 0) << out;
  }
  const auto perfect = block_deviations((dir / "perfect" / "results.json").string());
  const double none = rms_difference(block_deviations((dir / "none" / "results.json").string()), perfect);
  const double compensated = rms_difference(block_deviations((dir / "map" / "results.json").string()), perfect);
  std::printf(
      "example block, machine errors' share of 17 part-frame deviations: none RMS %.3f um, map RMS %.3f um (%.1fx)\n",
      1e3 * none, 1e3 * compensated, none / compensated);
  EXPECT_GT(none, 0.0005);  // the errors show in the part frame (measured 0.78 um)
  // Measured 0.072 um, 10.8x (0.086 um with the tool qualification left uncompensated); over seeds
  // 1-6 of calibration and run 4.7x to 10.8x (docs/error-space.md), so the bound is the worst seed's.
  EXPECT_LT(compensated, none / 4);
}

// The block at 22 C with maps calibrated at 20 and 24 C in one file (`--append`): the controller
// interpolates them by its thermometer; the 20 C map alone leaves the scales' growth
// (docs/error-space.md, "Temperature").
TEST(RunCompensationCli, AMapAppendedAtASecondTemperatureIsInterpolatedByTheThermometer) {
  const auto dir = std::filesystem::temp_directory_path() / "metron_run_compensation_temperature";
  std::filesystem::remove_all(dir);
  for (const char* d : {"perfect", "only20", "both"}) std::filesystem::create_directories(dir / d);
  const std::string bin = METRON_BINARY, src = METRON_SOURCE_DIR, worlds = src + "/programs/worlds/";
  const std::string program = src + "/programs/examples/02_block_inspection.dmi";
  auto calibrate = [&](int t, const std::string& map, bool append) {
    return shell(bin + " calibrate error-space --world " + worlds + "cmm_errors_at_" + std::to_string(t) + "c.json" +
                 " --components xyz --reversal --sensor-offset 0,0,-50 --size 15,13,4 --origin 250,150,50 --runs 4"
                 " --laser-cycles 8 --out " +
                 map + (append ? " --append" : ""));
  };
  const std::string only20 = (dir / "only20.json").string(), both = (dir / "both.json").string();
  auto [code, out] = calibrate(20, only20, false);
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("machine at 20.00 C"), std::string::npos) << out;
  std::filesystem::copy_file(only20, both);
  std::tie(code, out) = calibrate(24, both, true);
  ASSERT_EQ(code, 0) << out;
  std::tie(code, out) = calibrate(20, both, true);
  EXPECT_EQ(code, 2);
  EXPECT_NE(out.find("already holds a space at 20.00 C"), std::string::npos) << out;
  std::ifstream in(both);
  const auto j = nlohmann::json::parse(in);
  ASSERT_EQ(j.at("temperatures").size(), 2u);
  EXPECT_EQ(j.at("temperatures")[1].at("temperature_c"), 24.0);

  std::tie(code, out) = shell(bin + " run " + program + " --quiet --out " + (dir / "perfect").string());
  ASSERT_EQ(code, 0) << out;
  for (const auto& [folder, map] : {std::pair<std::string, std::string>{"only20", only20}, {"both", both}}) {
    std::tie(code, out) =
        shell(bin + " run " + program + " --world " + worlds + "cmm_errors_at_22c.json --compensation " + map +
              " --quiet --out " + (dir / folder).string());
    ASSERT_EQ(code, 0) << out;
  }
  const auto perfect = block_deviations((dir / "perfect" / "results.json").string());
  const double nearest = rms_difference(block_deviations((dir / "only20" / "results.json").string()), perfect);
  const double interpolated = rms_difference(block_deviations((dir / "both" / "results.json").string()), perfect);
  std::printf(
      "example block at 22 C, machine errors' share: 20 C map RMS %.3f um, 20 and 24 C interpolated RMS %.3f um\n",
      1e3 * nearest, 1e3 * interpolated);
  EXPECT_GT(nearest, 0.0008);            // measured 1.06 um
  EXPECT_LT(interpolated, nearest / 5);  // measured 0.072 um
}

TEST(RunCompensationCli, ABadCompensationFileIsRefusedNamingWhere) {
  const auto dir = std::filesystem::temp_directory_path() / "metron_run_compensation_bad";
  std::filesystem::create_directories(dir);
  const auto bad = (dir / "bad.json").string();
  std::ofstream(bad)
      << R"({"format": "metron-error-space", "version": 1, "grid": {"x_mm": [0, 1], "y_mm": [0], "z_mm": [0]},
    "interpolation": {"method": "trilinear"}, "temperatures": [{"temperature_c": 20, "components": {"x": {"values_mm": [0]}}}]})";
  const auto [code, out] = shell(std::string(METRON_BINARY) + " run " + METRON_SOURCE_DIR +
                                 "/programs/examples/01_first_circle.dmi --quiet --compensation " + bad);
  EXPECT_EQ(code, 2) << out;
  EXPECT_NE(out.find("/temperatures/0/components/x/values_mm"), std::string::npos) << out;
}

}  // namespace
