// SPDX-License-Identifier: GPL-3.0-or-later
// The machine errors act in the state the virtual CMM is in while it runs: time-dependent terms
// (a scale warming with the air) follow the controller's clock, and reversal terms follow each
// axis' direction of motion. Expected values come from the hidden error model itself, evaluated
// at the trigger times the controller reports, and from the reversal's definition.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "block_probing.hpp"
#include "metron/machine/machine_errors/error_model.hpp"
#include "metron/machine/virtual_cmm.hpp"
#include "metron/machine/world.hpp"

namespace metron::machine {
namespace {

World block_on(const std::string& errors_json) {
  World w = default_world();
  w.truth.probe.repeatability_mm = 0;
  if (!errors_json.empty()) w.truth.errors = *parse_machine_errors(nlohmann::json::parse(errors_json));
  return w;
}

/// The default block probed on a virtual CMM of `world`.
struct Session {
  VirtualCmm cmm;
  test_support::BlockProbing probing{cmm};
  explicit Session(const World& world) : cmm(world, 1) {}
  Response run(decltype(Command::body) body) { return probing.run(std::move(body)); }
  Hit touch_face(double x, double outward) { return probing.touch_face(x, outward); }
};

// The air warms 20 -> 30 C over the first minute and the X scale (alpha 10.5e-6) follows it without
// lag: the same face probed early and after a minute of moves reads the scale's growth at the two
// trigger times, e_x = alpha (T(t) - 20) x (ScaleThermalTerm, fixed at 0).
TEST(MachineErrorsInARun, ThermalErrorsFollowTheControllersClock) {
  const std::string errors = R"({"thermal": {"air_c": {"t_s": [0, 60], "temperature_c": [20, 30]},
                                 "scales": {"x": {"alpha_per_k": 10.5e-6, "temperature": {"lag_s": 0}}}}})";
  const World world = block_on(errors);
  Session s(world);
  const Hit early = s.touch_face(300, -1);
  s.probing.pass_time(70);
  const Hit late = s.touch_face(300, -1);
  ASSERT_GT(late.time_s, 70);

  auto scale_error = [&](const Hit& h) {
    MachinePose p;
    p.axes_mm = h.centre_mm;
    return world.truth.errors.displacement(p, h.time_s).x();
  };
  const double expected_shift =
      -(scale_error(late) - scale_error(early));  // the encoders read short where the scale grew
  const double shift = late.centre_mm.x() - early.centre_mm.x();
  EXPECT_LT(expected_shift, -0.02);  // about 31 um: the test can tell time from no time
  EXPECT_NEAR(shift, expected_shift, 0.0003) << "early t " << early.time_s << " s, late t " << late.time_s << " s";

  // On a machine without errors the same sequence reads the same face the same.
  Session perfect(block_on(""));
  const double a = perfect.touch_face(300, -1).centre_mm.x();
  perfect.probing.pass_time(70);
  EXPECT_NEAR(perfect.touch_face(300, -1).centre_mm.x(), a, 1e-9);
}

// A reversal of 4 um in X: approaching + the carriage stands 2 um further, approaching - 2 um
// short (ReversalTerm). Probing LEFT moves + and RIGHT moves -, so the ball centres read 4 um further apart.
TEST(MachineErrorsInARun, ReversalFollowsTheDirectionOfEachProbingMove) {
  Session reversal(block_on(R"({"reversal_mm": {"x": 0.004}})"));
  Session perfect(block_on(""));
  auto width = [](Session& s) {
    const double left = s.touch_face(300, -1).centre_mm.x();
    const double right = s.touch_face(460, 1).centre_mm.x();
    return right - left;
  };
  EXPECT_NEAR(width(reversal) - width(perfect), 0.004, 2e-5);
}

}  // namespace
}  // namespace metron::machine
