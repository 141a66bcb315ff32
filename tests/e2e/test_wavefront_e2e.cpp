// SPDX-License-Identifier: GPL-3.0-or-later
// End to end: the wavefront station's calibration called from a DMIS program
// (CALL/EXTERN,SYS,'CALIBRATE WAVEFRONT world [step]', docs/wavefront.md), through the same
// session and backend as `metron run`. Expected values are the world file's hidden geometry.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include <nlohmann/json.hpp>

#include "cli/virtual_cmm_backend.hpp"
#include "fixtures.hpp"
#include "metron/interpreter/session.hpp"

namespace {

namespace fs = std::filesystem;
using metron::interpreter::run_program;
using metron::interpreter::RunExit;
using metron::interpreter::RunOptions;
using nlohmann::json;

const fs::path source_dir = METRON_SOURCE_DIR;
constexpr double kRad = std::numbers::pi / 180;

fs::path out_dir(const std::string& name) { return metron::test_support::out_dir("metron_wavefront", name); }

// The worlds are outside the programs' folders: the file policy (docs/security.md) needs --include.
metron::interpreter::RunOutcome run(const fs::path& program, const std::string& out) {
  RunOptions o;
  o.program = program.string();
  o.out_dir = out_dir(out).string();
  o.include_dirs = {(source_dir / "programs/worlds").string()};
  return run_program(o, metron::cli::virtual_cmm_backend);
}

json read_json(const fs::path& p) {
  std::ifstream in(p);
  EXPECT_TRUE(in) << p;
  return json::parse(in);
}

fs::path write_program(const std::string& out, const std::string& body) {
  const fs::path prog = out_dir(out) / "p.dmi";
  std::ofstream(prog) << "DMISMN/'wavefront', 5.0\n" << body << "ENDFIL\n";
  return prog;
}

// Example 08: one step and the whole procedure, each into its own file in the output folder.
TEST(WavefrontE2e, CalibrateWavefrontFromAProgram) {
  const auto o = run(source_dir / "programs/examples/08_wavefront_calibration.dmi", "example08");
  ASSERT_EQ(o.exit, RunExit::Completed) << o.diagnostics;
  const json world = read_json(source_dir / "programs/worlds/wavefront_sphere_machine.json");
  const json& hidden = world["hidden"];
  const json focus = read_json(out_dir("example08") / "wavefront-calibration-focus.json");
  EXPECT_EQ(focus["kind"], "wavefront-calibration");
  EXPECT_EQ(focus["step"], "focus");
  EXPECT_TRUE(focus.contains("focus"));
  EXPECT_FALSE(focus.contains("b_rotation"));
  const json all = read_json(out_dir("example08") / "wavefront-calibration.json");
  EXPECT_EQ(all["step"], "all");
  // Hidden truth from the world file; tolerances a few times the spread over noise seeds
  // (docs/wavefront.md "Evidence"): step sizes 6 ppm, B tilt 0.002 urad, yc 1 nm, clocking 4 urad.
  const auto& ar = all["axis_response"];
  EXPECT_NEAR(ar["step_mm"][0].get<double>() / hidden["step_mm"][0].get<double>(), 1, 30e-6);
  EXPECT_NEAR(ar["step_mm"][1].get<double>() / hidden["step_mm"][1].get<double>(), 1, 30e-6);
  EXPECT_NEAR(ar["gauge_clocking_rad"].get<double>(), hidden["gauge_clocking_deg"].get<double>() * kRad, 20e-6);
  const auto& b = all["b_rotation"];
  EXPECT_NEAR(b["b_axis_tilt_rad"].get<double>(), hidden["b_axis_tilt_deg"].get<double>() * kRad, 0.02e-6);
  EXPECT_NEAR(all["c_rotation"]["yc_mm"].get<double>(), hidden["yc_mm"].get<double>(), 0.01e-3);
  EXPECT_TRUE(all["a_to_z"]["converged"].get<bool>());
  // The stitched form of the ball is in the file (ball_low: 10 nm of astigmatism).
  ASSERT_TRUE(b.contains("form"));
  const auto& f = b["form"]["height_nm"];
  EXPECT_NEAR(std::hypot(f[0].get<double>(), f[1].get<double>()), std::sqrt(6.0) * 10, 0.5);  // Z6 = sqrt6 (x^2 - y^2)
  // The run's live report has the summary.
  bool said = false;
  for (const auto& e : o.record.events)
    if (const auto* t = std::get_if<metron::runtime::TextReport>(&e);
        t && t->text.find("wavefront calibration (all") != std::string::npos)
      said = true;
  EXPECT_TRUE(said);
}

// Mistakes are positioned: an unknown step or a missing world word at compile time, a missing
// world file or a world of the wrong kind at run time.
TEST(WavefrontE2e, BadCallsArePositionedErrors) {
  {
    const auto o = run(write_program("bad_step", "CALL/EXTERN, SYS, 'CALIBRATE WAVEFRONT w.json nulls'\n"), "bad_step");
    EXPECT_EQ(o.exit, RunExit::ProgramError);
    EXPECT_NE(o.diagnostics.find("p.dmi:2:"), std::string::npos) << o.diagnostics;
    EXPECT_NE(o.diagnostics.find("unknown wavefront calibration step 'nulls'"), std::string::npos) << o.diagnostics;
  }
  {
    const auto o = run(write_program("no_world", "CALL/EXTERN, SYS, 'CALIBRATE WAVEFRONT'\n"), "no_world");
    EXPECT_EQ(o.exit, RunExit::ProgramError);
    EXPECT_NE(o.diagnostics.find("name the wavefront world"), std::string::npos) << o.diagnostics;
  }
  {
    const auto o =
        run(write_program("missing", "CALL/EXTERN, SYS, 'CALIBRATE WAVEFRONT nothing_here.json a-z'\n"), "missing");
    EXPECT_EQ(o.exit, RunExit::ProgramError);
    EXPECT_NE(o.diagnostics.find("p.dmi:2:"), std::string::npos) << o.diagnostics;
    EXPECT_NE(o.diagnostics.find("nothing_here.json"), std::string::npos) << o.diagnostics;
    EXPECT_FALSE(fs::exists(out_dir("missing") / "wavefront-calibration-a-z.json"));
  }
  {
    const std::string cmm = (source_dir / "programs/worlds/touch_const_time.json").string();
    const auto o =
        run(write_program("cmm_world", "CALL/EXTERN, SYS, 'CALIBRATE WAVEFRONT " + cmm + " a-z'\n"), "cmm_world");
    EXPECT_EQ(o.exit, RunExit::ProgramError);
    EXPECT_NE(o.diagnostics.find("wavefront"), std::string::npos) << o.diagnostics;
  }
}

}  // namespace
