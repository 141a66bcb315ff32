// SPDX-License-Identifier: GPL-3.0-or-later
// The hidden machine error model against hand-computed ISO 230-1 cases: Abbe errors of pitch and
// yaw with a probe offset, squareness, tables, grid fields, scale and part expansion with
// first-order lags (against the analytic step response and a fine Euler integration), the parser.
#include <cmath>

#include <gtest/gtest.h>

#include "metron/machine/machine_errors/error_model.hpp"
#include "metron/machine/machine_errors/grid_field.hpp"
#include "metron/machine/machine_errors/rigid_body.hpp"
#include "metron/machine/machine_errors/thermal.hpp"

namespace metron::machine {
namespace {

MachinePose pose(double x, double y, double z, Vec3 offset = Vec3::Zero()) {
  MachinePose p;
  p.axes_mm = {x, y, z};
  p.probe_offset_mm = offset;
  return p;
}

TEST(RigidBody, PitchOfXWithAProbeOffsetGivesTheAbbeError) {
  std::array<AxisErrors, 3> axes;
  const double theta = 5e-6;  // EBX: rotation of X about y
  axes[0].rotation_rad[1] = AxisFunction::polynomial({theta});
  const RigidBodyTerm term(axes, {});
  // Tip 150 mm below the ram reference, Z at 0: eps x lever = (0, th, 0) x (0, 0, -150) = (-150 th, 0, 0).
  const Vec3 e = term.displacement(pose(300, 200, 0, {0, 0, -150}), 0);
  EXPECT_NEAR(e.x(), -150 * theta, 1e-15);
  EXPECT_NEAR(e.y(), 0, 1e-15);
  EXPECT_NEAR(e.z(), 0, 1e-15);
  // The ram carried by X moves the tip: z = 400 with the same offset, lever z + t_z = +250 mm.
  EXPECT_NEAR(term.displacement(pose(300, 200, 400, {0, 0, -150}), 0).x(), 250 * theta, 1e-15);
}

TEST(RigidBody, YawOfTheBridgeActsOnTheCarriagePosition) {
  std::array<AxisErrors, 3> axes;
  axes[1].rotation_rad[2] = AxisFunction::polynomial({0, 1e-8});  // ECY = 1e-8 rad/mm * y
  const RigidBodyTerm term(axes, {});
  // Y carries X and Z: lever (x, 0, z) + t; eps = (0, 0, g): e = (-g * t_y, g * (x + t_x), 0).
  const double g = 1e-8 * 500;
  const Vec3 e = term.displacement(pose(400, 500, 100, {20, 30, -100}), 0);
  EXPECT_NEAR(e.x(), -g * 30, 1e-15);
  EXPECT_NEAR(e.y(), g * 420, 1e-15);
  EXPECT_NEAR(e.z(), 0, 1e-15);
}

TEST(RigidBody, SquarenessPositioningAndStraightness) {
  std::array<AxisErrors, 3> axes;
  axes[0].translation_mm[0] =
      AxisFunction::table({0, 500, 1000}, {0, 0.004, 0.010}, AxisFunction::Interpolation::Linear);
  axes[0].translation_mm[2] = AxisFunction::polynomial({0, 0, 1e-8});  // EZX = 1e-8 x^2
  Squareness sq{3e-6, -2e-6, 4e-6};
  const RigidBodyTerm term(axes, sq);
  const Vec3 e = term.displacement(pose(750, 600, 300), 0);
  EXPECT_NEAR(e.x(), 0.007 + 3e-6 * 600 - 2e-6 * 300, 1e-15);
  EXPECT_NEAR(e.y(), 4e-6 * 300, 1e-15);
  EXPECT_NEAR(e.z(), 1e-8 * 750 * 750, 1e-15);
}

TEST(AxisFunctionTable, CubicPassesThroughTheEntriesAndReproducesLines) {
  const auto f =
      AxisFunction::table({0, 100, 250, 400}, {0.001, 0.003, -0.002, 0.0}, AxisFunction::Interpolation::Cubic);
  EXPECT_NEAR(f(100), 0.003, 1e-15);
  EXPECT_NEAR(f(250), -0.002, 1e-15);
  EXPECT_NEAR(f(-50), 0.001, 1e-15);  // held beyond the ends
  const auto line = AxisFunction::table({0, 100, 250, 400}, {0, 1, 2.5, 4}, AxisFunction::Interpolation::Cubic);
  EXPECT_NEAR(line(333), 3.33, 1e-12);
}

TEST(GridField, BilinearBetweenNodes) {
  error_space::Grid g;
  g.axes_mm = {std::vector<double>{0, 1000}, std::vector<double>{0, 800}, std::vector<double>{0.0}};
  const GridFieldTerm term(2, g, {0, 0.004, 0.002, 0.010});
  const Vec3 e = term.displacement(pose(250, 200, 123), 0);
  // (1-.25)(1-.25)*0 + .25*.75*.004 + .75*.25*.002 + .25*.25*.010
  EXPECT_NEAR(e.z(), 0.25 * 0.75 * 0.004 + 0.75 * 0.25 * 0.002 + 0.0625 * 0.010, 1e-15);
  EXPECT_EQ(e.x(), 0);
}

TEST(Thermal, LagFollowsTheAnalyticStepAndAFineIntegration) {
  // Air jumps 20 -> 22 within 1 s, then ramps to 21 over an hour; body lag 600 s from 20 C.
  const TemperatureHistory h({0, 1, 3601}, {20, 22, 21}, 600, 20);
  double t_euler = 20, t = 0;
  const double dt = 0.01;
  while (t < 3000) {
    t_euler += dt * (h.air_c(t + 0.5 * dt) - t_euler) / 600;
    t += dt;
  }
  EXPECT_NEAR(h.body_c(3000), t_euler, 1e-4);
  const TemperatureHistory step({0}, {22}, 600, 20);
  EXPECT_NEAR(step.body_c(600), 22 - 2 * std::exp(-1.0), 1e-12);
  // Scale: alpha 10e-6, 2 K warm, fixed at 100: at reading 600 the carriage is 10 um further.
  const TemperatureHistory warm({0}, {22}, 0, 22);
  std::array<ScaleThermalTerm::Scale, 3> scales;
  scales[0] = {10e-6, 100, std::make_shared<TemperatureHistory>(warm)};
  EXPECT_NEAR(ScaleThermalTerm(scales).displacement(pose(600, 0, 0), 5).x(), 0.010, 1e-15);
  // Part: 2 K warm, steel, fixed point at the origin: a point at x = 500 reads 11.5 um long, so the
  // tip, seen from the part, stands 11.5 um short.
  const PartThermalTerm part(11.5e-6, Vec3::Zero(), std::make_shared<TemperatureHistory>(warm));
  EXPECT_NEAR(part.displacement(pose(500, 0, 0), 0).x(), -0.0115, 1e-15);
  EXPECT_EQ(part.acts(), ErrorTerm::Acts::Part);
}

TEST(ErrorModelJson, ParsesEveryTermAndRejectsUnknownKeysByPointer) {
  const auto j = nlohmann::json::parse(R"({
    "stacking": ["y", "x", "z"],
    "axes": {"x": {"tx_mm": {"at_mm": [0, 1000], "values": [0, 0.01]}, "ry_rad": 5e-6}},
    "squareness_rad": {"xy": 3e-6},
    "reversal_mm": {"x": 0.002},
    "fields": [{"component": "z", "x_mm": [0, 1000], "y_mm": [0, 800], "values_mm": [0, 0.004, 0.002, 0.010]}],
    "thermal": {"air_c": {"t_s": [0], "temperature_c": [21]},
                "scales": {"x": {"alpha_per_k": 1e-5, "temperature": {"lag_s": 0}}},
                "part": {"alpha_per_k": 1.15e-5, "fixed_point_mm": [0, 0, 0]}}
  })");
  auto m = parse_machine_errors(j);
  ASSERT_TRUE(m) << m.error().pointer << ": " << m.error().message;
  EXPECT_EQ(m->terms().size(), 5u);
  MachinePose p = pose(500, 400, 0, {0, 0, -100});
  p.approach = {1, 0, 0};
  const Vec3 e = m->tool_displacement(p, 0);
  // 5 um positioning + Abbe -100*5e-6 + squareness 3e-6*400 + reversal +1 um + scale 1e-5*1*500
  EXPECT_NEAR(e.x(), 0.005 - 100 * 5e-6 + 3e-6 * 400 + 0.001 + 0.005, 1e-14);
  EXPECT_NEAR(e.z(), 0.25 * (0 + 0.004 + 0.002 + 0.010), 1e-15);  // the field at the cell centre
  EXPECT_NEAR(m->displacement(p, 0).x() - e.x(), -1.15e-5 * 1 * 500, 1e-14);

  auto bad = j;
  bad["axes"]["x"]["ry_deg"] = 1;
  EXPECT_EQ(parse_machine_errors(bad).error().pointer, "/machine/errors/axes/x/ry_deg");
  bad = j;
  bad["fields"][0]["values_mm"] = {1, 2};
  EXPECT_EQ(parse_machine_errors(bad).error().pointer, "/machine/errors/fields/0/values_mm");
  bad = j;
  bad["stacking"] = {"y", "y", "z"};
  EXPECT_EQ(parse_machine_errors(bad).error().pointer, "/machine/errors/stacking/1");
  EXPECT_TRUE(parse_machine_errors(nlohmann::json())->empty());
}

}  // namespace
}  // namespace metron::machine
