// SPDX-License-Identifier: GPL-3.0-or-later
// The hidden machine errors reach the virtual CMM's measurements (issue 12, docs/error-space.md):
// a touch reports encoder positions, and the encoders are wrong by the error model. Expected values
// are ISO 230-1 by hand, independent of the error model's code: with a positioning error
// EXX = k x, a face at true X is touched at x_e = X / (1 + k); with a pitch EBX = a of the X carriage
// below the Z ram, the ball moves along x by a times its height, so a face touched at two heights
// reads a * dz apart.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "metron/machine/machine_errors/error_model.hpp"
#include "metron/machine/virtual_cmm.hpp"

using namespace metron;
using namespace metron::machine;

namespace {

World with_errors(const std::string& errors_json) {
  World w = default_world();
  w.truth.probe.repeatability_mm = 0;
  if (!errors_json.empty()) {
    auto e = parse_machine_errors(nlohmann::json::parse(errors_json));
    EXPECT_TRUE(e) << (e ? "" : e.error().pointer + ": " + e.error().message);
    if (e) w.truth.errors = *e;
  }
  return w;
}

// The ball centre's x where it touches the block's LEFT face (machine x = 300) at height z.
double touch_left_face(const World& world, double z_mm) {
  VirtualCmm cmm(world, 1);
  std::uint64_t tag = 0;
  auto run = [&](decltype(Command::body) body) {
    cmm.submit({++tag, std::move(body)});
    auto r = cmm.execute();
    EXPECT_EQ(r.size(), 1u);
    EXPECT_EQ(r.front().status, Response::Status::Done) << (r.front().fault ? r.front().fault->message : "");
    return r.front();
  };
  run(DefineTool{"T1", 4.0});
  run(SelectTool{"T1"});
  run(GoTo{Vec3(290, 250, 60), std::nullopt});
  run(GoTo{Vec3(290, 250, z_mm), std::nullopt});
  PtMeas m;
  m.nominal_mm = Vec3(300, 250, z_mm);
  m.normal = -Vec3::UnitX();
  const Response r = run(m);
  return r.hit ? r.hit->centre_mm.x() : 0.0;
}

TEST(MachineErrorsInTheCmm, PositioningErrorShiftsATouchByTheScaleError) {
  const double k = 40e-6;  // 40 um/m
  const double perfect = touch_left_face(with_errors(""), 20);
  const double wrong = touch_left_face(with_errors(R"({"axes": {"x": {"tx_mm": {"poly": [0, 4e-5]}}}})"), 20);
  // The ball's true centre at contact, X = perfect (pre-travel and delays alike in both runs).
  EXPECT_NEAR(wrong, perfect / (1 + k), 1e-5) << "shift " << (wrong - perfect) * 1000 << " um";
  EXPECT_LT(wrong - perfect, -0.010);  // about -11.9 um: the errors are really there
}

TEST(MachineErrorsInTheCmm, PitchOfTheCarriageGivesAnAbbeErrorGrowingWithHeight) {
  const double a = 200e-6;  // EBX, rad
  const World pitched = with_errors(R"({"stacking": ["y", "x", "z"], "axes": {"x": {"ry_rad": 2e-4}}})");
  const World perfect = with_errors("");
  const double low = touch_left_face(pitched, 10) - touch_left_face(perfect, 10);
  const double high = touch_left_face(pitched, 35) - touch_left_face(perfect, 35);
  // e_x = a * (lever height): the ball sits further by a * z, so the encoders read less by that.
  EXPECT_NEAR(high - low, -a * (35 - 10), 2e-6) << "low " << low * 1000 << " um, high " << high * 1000 << " um";
}

TEST(MachineErrorsInTheCmm, AWorldFileCarriesTheErrors) {
  auto w = load_world(std::string(METRON_SOURCE_DIR) + "/programs/worlds/cmm_errors.json");
  ASSERT_TRUE(w) << w.error().message;
  EXPECT_FALSE(w->truth.errors.empty());
  auto bad = parse_world(nlohmann::json::parse(R"({"machine": {"errors": {"axes": {"x": {"tq_mm": 1}}}}})"), "w.json");
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("/machine/errors/axes/x/tq_mm"), std::string::npos) << bad.error().message;
}

}  // namespace
