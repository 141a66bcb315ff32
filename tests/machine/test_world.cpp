// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include "scratch.hpp"

#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "metron/machine/virtual_cmm.hpp"
#include "metron/machine/wavefront/wavefront_world.hpp"
#include "metron/machine/world.hpp"

using namespace metron;
using namespace metron::machine;

namespace {

const std::string worlds_dir = std::string(METRON_SOURCE_DIR) + "/programs/worlds";

std::string error_of(const std::string& json_text, const std::string& name = "world.json") {
  auto w = parse_world(nlohmann::json::parse(json_text, nullptr, true, true), name);
  return w ? std::string("<no error>") : w.error().message;
}

}  // namespace

TEST(World, EmbeddedDefaultIsTheDefaultFile) {
  std::ifstream in(worlds_dir + "/default.json", std::ios::binary);
  ASSERT_TRUE(in);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), default_world_json());
}

TEST(World, DefaultWorldContents) {
  const World w = default_world();
  EXPECT_EQ(w.name, "default");
  EXPECT_EQ(w.machine.travel[0].min_mm, -100);
  EXPECT_EQ(w.machine.travel[2].max_mm, 600);
  EXPECT_EQ(w.machine.max_speed_mm_s, 300);
  EXPECT_EQ(w.machine.dt_s, 0.001);
  EXPECT_EQ(w.machine.skip.kind, SkipInput::Kind::Latched);
  EXPECT_EQ(w.machine.skip.latency_s, 4e-6);
  EXPECT_EQ(w.truth.probe.pre_travel.at(Vec3::UnitX()), 0.010);
  EXPECT_EQ(w.truth.probe.pre_travel.at(-Vec3::UnitZ()), 0.010);
  EXPECT_EQ(w.truth.probe.repeatability_mm, 0.0002);
  EXPECT_EQ(w.machine.reference_sphere.certified_diameter_mm, 25);
  ASSERT_TRUE(w.truth.part);
  EXPECT_TRUE((w.truth.part->pose.part_to_machine() * Vec3(1, 2, 3) - Vec3(301, 202, 3)).norm() < 1e-12);
  EXPECT_TRUE(w.truth.part->deviations.empty());
}

TEST(World, AllWorldFilesLoad) {
  for (const auto& entry : std::filesystem::directory_iterator(worlds_dir)) {
    if (entry.path().extension() != ".json") continue;
    if (entry.path().filename() == "nist_simple_part.json" &&
        !std::filesystem::exists(std::string(METRON_SHARED_DATA) + "/nist-simple-part/ipp_simple.stp"))
      continue;
    if (entry.path().filename().string().rfind("wavefront_", 0) == 0) {
      // another machine kind: the CMM loader refuses it by name, its own loader reads it
      auto cmm = load_world(entry.path().string());
      ASSERT_FALSE(cmm);
      EXPECT_NE(cmm.error().message.find("metron calibrate wavefront"), std::string::npos) << cmm.error().message;
      auto w = wavefront::load_wavefront_world(entry.path().string());
      EXPECT_TRUE(w) << (w ? "" : w.error());
      continue;
    }
    auto w = load_world(entry.path().string());
    EXPECT_TRUE(w) << (w ? "" : w.error().message);
  }
}

// Issue 15: the wavefront world loader used nlohmann's parser directly: 1e400 threw an uncaught
// out_of_range (abort), /dev/zero grew memory, and syntax errors printed the library's text.
TEST(World, WavefrontWorldsAreReadByTheStrictReader) {
  const auto dir = metron::test_support::scratch_root("metron_wavefront_hostile");
  std::filesystem::create_directories(dir);
  const auto file = dir / "station.json";
  std::ofstream(file) << R"({"kind": "wavefront", "seed": 1e400})";
  auto big = wavefront::load_wavefront_world(file.string());
  ASSERT_FALSE(big);
  EXPECT_NE(big.error().find("number overflow"), std::string::npos) << big.error();
  EXPECT_NE(big.error().find(file.string()), std::string::npos) << big.error();
  auto zero = wavefront::load_wavefront_world("/dev/zero");
  ASSERT_FALSE(zero);
  EXPECT_NE(zero.error().find("not a regular file"), std::string::npos) << zero.error();
  std::filesystem::remove_all(dir);
}

TEST(World, ExtendsMergesOverTheBase) {
  auto w = load_world(worlds_dir + "/block_deviations.json");
  ASSERT_TRUE(w) << w.error().message;
  EXPECT_EQ(w->name, "block_deviations");
  EXPECT_EQ(w->machine.max_speed_mm_s, 300);  // from default.json
  EXPECT_EQ(w->truth.part->deviations.at("BORE1").size_mm, 0.012);
  EXPECT_EQ(w->truth.part->deviations.at("BORE1").offset_mm, Vec3(0.03, 0, 0));
  EXPECT_EQ(w->truth.part->deviations.at("TOP").tilt_deg, Vec2(0.05, 0));
  EXPECT_EQ(w->truth.part->deviations.at("BOSS1").lobing->lobes, 3);
  EXPECT_EQ(w->truth.reference_sphere.true_centre_mm, Vec3(900, 700, 100));
  EXPECT_EQ(w->machine.reference_sphere.nominal_centre_mm, Vec3(899.6, 700.3, 99.8));

  auto scanned = parse_world(nlohmann::json::parse(R"({"extends": "default",
      "machine": {"skip": {"scanned": {"period_s": 0.003}}}})"),
                             "s.json");
  ASSERT_TRUE(scanned) << scanned.error().message;
  EXPECT_EQ(scanned->machine.skip.kind, SkipInput::Kind::Scanned);
  EXPECT_EQ(scanned->machine.skip.period_s, 0.003);
}

TEST(World, ErrorsNameTheFileAndTheJsonPath) {
  EXPECT_EQ(error_of(R"({"extends": "default", "part": {"deviations": {"BORE1": {"diameter_mm": "big"}}}})"),
            "world.json: /part/deviations/BORE1/diameter_mm: expected a number");
  EXPECT_EQ(error_of(R"({"machine": {"max_speed_mm_s": -3}})"),
            "world.json: /machine/max_speed_mm_s: expected a positive number");
  EXPECT_EQ(error_of(R"({"machine": {"home_mm": [1, 2]}})"),
            "world.json: /machine/home_mm: expected an array of 3 numbers");
  EXPECT_EQ(error_of(R"({"machine": {"home_mm": [0, 0, 5000]}})"),
            "world.json: /machine/home_mm: outside the axis travel");
  EXPECT_EQ(error_of(R"({"machine": {"skip": {}}})"),
            "world.json: /machine/skip: expected exactly one of 'latched' or 'scanned'");
  EXPECT_EQ(error_of(R"({"part": {"design": {"type": "cylindre"}}})"),
            "world.json: /part/design/type: unknown primitive type 'cylindre' (expected half_space, cylinder, sphere, "
            "cone, torus or "
            "elliptic_cylinder)");
  EXPECT_EQ(error_of(R"({"part": {"design": {"union": [{"type": "sphere", "centre": [0, 0, 0]}]}}})"),
            "world.json: /part/design/union/0: missing key 'diameter_mm'");
  EXPECT_EQ(error_of(R"({"extends": "default", "part": {"deviations": {"BORE3": {}}}})"),
            "world.json: /part/deviations/BORE3: no primitive named 'BORE3' in the design");
  EXPECT_EQ(error_of(R"({"extends": "default", "part": {"deviations": {"TOP": {"diameter_mm": 0.1}}}})"),
            "world.json: /part/deviations/TOP/diameter_mm: unknown key 'diameter_mm' "
            "(expected one of: form, offset_mm, size_mm, tilt_deg)");
  EXPECT_EQ(error_of(R"({"extends": "default", "part": {"deviations": {"TOP": {"form": {"lobes": 3}}}}})"),
            "world.json: /part/deviations/TOP/form/lobes: unknown key 'lobes' "
            "(expected one of: amplitude_mm, phase_deg, wavelength_mm)");
  EXPECT_EQ(
      error_of(R"({"part": {"design": {"type": "cone", "apex": [0,0,0], "axis": [0,0,0], "half_angle_deg": 30}}})"),
      "world.json: /part/design/axis: expected a non-zero direction");
}

// part.setups: the poses the virtual operator puts the part in at the program's PAUSEs, in turn
// (tests/e2e/test_run.cpp PartSetups.* run a program across two).
TEST(World, PartSetupsAreReadAsPoses) {
  auto w = load_world(worlds_dir + "/block_two_setups.json");
  ASSERT_TRUE(w) << w.error().message;
  ASSERT_TRUE(w->truth.part);
  ASSERT_EQ(w->truth.part->setups.size(), 1U);
  EXPECT_EQ(w->truth.part->setups[0].translation_mm, Vec3(600.8, 449.5, 0));
  EXPECT_EQ(w->truth.part->setups[0].rotation_deg, Vec3(0, 0, 180.35));
  EXPECT_EQ(w->truth.part->pose.translation_mm, Vec3(300.4, 199.7, 0));
  EXPECT_EQ(error_of(R"({"extends": "default", "part": {"setups": {"translation_mm": [0, 0, 0]}}})"),
            "world.json: /part/setups: expected an array of poses (translation_mm, rotation_deg)");
  EXPECT_EQ(error_of(R"({"extends": "default", "part": {"setups": [{"translation": [0, 0, 0]}]}})"),
            "world.json: /part/setups/0/translation: unknown key 'translation' (expected one of: rotation_deg, "
            "translation_mm)");
}

TEST(World, UnknownKeysAreErrorsWithASuggestion) {
  EXPECT_EQ(error_of(R"({"probe": {"pre_travle": {}}})"),
            "world.json: /probe/pre_travle: unknown key 'pre_travle' (did you mean 'pre_travel'?)");
  EXPECT_EQ(error_of(R"({"colour": "red"})"),
            "world.json: /colour: unknown key 'colour' "
            "(expected one of: description, kind, machine, name, part, probe, probe_library, reference_sphere, "
            "scanning, seed)");
  EXPECT_EQ(error_of(R"([1, 2])"), "world.json: /: expected an object");
}

TEST(World, FileErrors) {
  auto missing = load_world("/nonexistent/world.json");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().message, "/nonexistent/world.json: cannot read the file");

  const std::string path = (std::filesystem::temp_directory_path() / "metron_bad_world.json").string();
  std::ofstream(path) << "{\n  \"name\": \"x\",\n  \"seed\": \n}\n";
  auto bad = load_world(path);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find(path + ": invalid JSON: parse error at line 4"), std::string::npos)
      << bad.error().message;

  std::ofstream(path) << R"({"extends": "default", "part": {"design": {"cad": "no_such_part.stp"}}})";
  auto cad = load_world(path);
  ASSERT_FALSE(cad);
  EXPECT_EQ(cad.error().message.rfind(path + ": /part/design/cad: ", 0), 0u) << cad.error().message;
  std::filesystem::remove(path);
}

TEST(World, PreTravelModel) {
  PreTravel p;
  p.horizontal_mm = 0.008;
  p.vertical_mm = 0.015;
  p.lobes = 3;
  p.lobe_amplitude_mm = 0.003;
  p.lobe_phase_deg = 0;
  EXPECT_NEAR(p.at(Vec3::UnitX()), 0.011, 1e-15);
  EXPECT_NEAR(p.at(Vec3(std::cos(std::numbers::pi / 3), std::sin(std::numbers::pi / 3), 0)), 0.005, 1e-15);
  EXPECT_NEAR(p.at(-Vec3::UnitZ()), 0.015, 1e-15);
  EXPECT_NEAR(p.at(Vec3(1, 0, 1).normalized()), (0.011 + 0.015) / 2, 1e-15);
}

// The probe library (issue 14): named sensors the controller knows; a library name is defined as
// a tool on its first selection with the library's tip, an unknown name stays an unknown tool.
TEST(World, ProbeLibraryIsReadCheckedAndSelectsTools) {
  auto w = parse_world(nlohmann::json::parse(R"({"probe_library": [
      {"name": "T1A0B0", "tip_diameter_mm": 3, "offset_mm": [0, 0, -50]},
      {"name": "Star_2", "tip_diameter_mm": 2}]})"),
                       "world.json");
  ASSERT_TRUE(w) << w.error().message;
  ASSERT_EQ(w->machine.probe_library.size(), 2u);
  EXPECT_EQ(w->machine.probe_library[1].offset_mm, metron::Vec3(0, 0, -50));
  EXPECT_EQ(
      error_of(R"({"probe_library": [{"name": "A", "tip_diameter_mm": 3}, {"name": "a", "tip_diameter_mm": 2}]})"),
      "world.json: /probe_library/1/name: sensor 'a' is listed twice");
  EXPECT_EQ(error_of(R"({"probe_library": [{"name": "A"}]})"),
            "world.json: /probe_library/0: missing key 'tip_diameter_mm'");

  metron::machine::VirtualCmm cmm(*w, 1);
  cmm.submit({1, metron::machine::SelectTool{"t1a0b0"}});  // names are case-insensitive
  cmm.submit({2, metron::machine::SelectTool{"NOT_THERE"}});
  const auto r = cmm.execute();
  ASSERT_EQ(r.size(), 2u);
  ASSERT_TRUE(r[0].tool);
  EXPECT_DOUBLE_EQ(r[0].tool->nominal_radius_mm, 1.5);
  EXPECT_EQ(r[1].status, metron::machine::Response::Status::Fault);
  ASSERT_TRUE(r[1].fault);
  EXPECT_EQ(r[1].fault->kind, metron::machine::FaultKind::UnknownTool);
}
