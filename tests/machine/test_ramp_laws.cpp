// SPDX-License-Identifier: GPL-3.0-or-later
// Issue 11 item 7, the simulated truth: tabulated ramps and braking by its own law (docs/world.md,
// `machine.axes`), against closed-form expectations written here from the world records.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "fixtures.hpp"
#include "metron/machine/motion_profile.hpp"
#include "metron/machine/touch_cycle/axis_dynamics.hpp"
#include "metron/machine/virtual_cmm.hpp"

using namespace metron;
using namespace metron::machine;

namespace {

using test_support::world_file;

// SEEDS.md 3, constant rate: T = V/a + a/j, or 2 sqrt(V/j) below V = a^2/j.
double rate_ramp_s(double feed, double a, double j) {
  return feed * j < a * a ? 2 * std::sqrt(feed / j) : feed / a + a / j;
}

// A table read by hand: linear between points, held beyond.
double table_s(const std::vector<std::pair<double, double>>& t, double feed) {
  if (feed <= t.front().first) return t.front().second;
  if (feed >= t.back().first) return t.back().second;
  std::size_t k = 0;
  while (t[k + 1].first < feed) ++k;
  return t[k].second + (feed - t[k].first) / (t[k + 1].first - t[k].first) * (t[k + 1].second - t[k].second);
}

struct Cmm {
  explicit Cmm(const World& w, std::uint64_t seed = 1) : cmm(w, seed) {}
  Response run(decltype(Command::body) b) {
    cmm.submit({++tag, std::move(b)});
    return cmm.execute().front();
  }
  VirtualCmm cmm;
  std::uint64_t tag = 0;
};

// A long rest-to-rest move takes L / V + (Ta + Tb) / 2, in whole controller cycles.
void expect_move(const Response& r, double length, double feed, double ta, double tb, double dt) {
  ASSERT_EQ(r.status, Response::Status::Done);
  const double t = length / feed + (ta + tb) / 2;
  EXPECT_GE(r.end_time_s - r.start_time_s, t - 1e-9) << "feed " << feed;
  EXPECT_LE(r.end_time_s - r.start_time_s, t + dt + 1e-9) << "feed " << feed;
}

TEST(RampLaws, TabulatedRampIsInterpolatedOverTheAxisFeed) {
  const World w = world_file("touch_tabulated.json");
  const std::vector<std::pair<double, double>> x{{1, 0.02},  {5, 0.05},   {15, 0.09},
                                                 {40, 0.12}, {80, 0.125}, {300, 0.125}};
  Cmm m(w);
  Vec3 p = w.machine.home_mm;
  for (double feed : {0.5, 3.0, 12.0, 27.0, 60.0, 200.0}) {
    const double len = feed * 0.3 + 5;
    p.x() += len;
    expect_move(m.run(GoTo{p, feed}), len, feed, table_s(x, feed), table_s(x, feed), w.machine.dt_s);
    EXPECT_NEAR(ramp_time_s(w.machine, w.truth.axes, Vec3::UnitX(), feed), table_s(x, feed), 1e-12);
  }
}

TEST(RampLaws, BrakingByItsOwnLaw) {
  const World w = world_file("touch_braking.json");
  Cmm m(w);
  Vec3 p = w.machine.home_mm;
  for (double feed : {4.0, 30.0, 120.0}) {
    const double len = feed * 0.4 + 5;
    p.x() += len;
    // x: accelerates at 1000/10000, brakes at 3000/40000.
    expect_move(m.run(GoTo{p, feed}), len, feed, rate_ramp_s(feed, 1000, 10000), rate_ramp_s(feed, 3000, 40000),
                w.machine.dt_s);
    EXPECT_NEAR(braking_time_s(w.machine, w.truth.axes, Vec3::UnitX(), feed), rate_ramp_s(feed, 3000, 40000), 1e-12);
    p.y() += len;
    // y: constant time 60 ms up, 20 ms down.
    expect_move(m.run(GoTo{p, feed}), len, feed, 0.06, 0.02, w.machine.dt_s);
    p.z() -= len;
    expect_move(m.run(GoTo{p, feed}), len, feed, rate_ramp_s(feed, 1000, 10000), rate_ramp_s(feed, 400, 2000),
                w.machine.dt_s);
  }
}

// After a trigger at constant feed the machine stops V Tb / 2 past the point where it braked
// (one controller cycle after the latch at most): seen in the motion trace.
TEST(RampLaws, TouchStopsByTheBrakingLaw) {
  World w = world_file("touch_braking.json");
  w.truth.probe.over_travel_mm = 5;
  Cmm m(w);
  double lowest = 1e9;
  m.cmm.set_trace([&](const TraceSample& s) { lowest = std::min(lowest, s.position_mm.z()); });
  ASSERT_EQ(m.run(DefineTool{"T", 4.0}).status, Response::Status::Done);
  ASSERT_EQ(m.run(SelectTool{"T"}).status, Response::Status::Done);
  for (double feed : {5.0, 12.0}) {
    PtMeas p;
    p.nominal_mm = Vec3(380, 250, 40);
    p.normal = Vec3::UnitZ();
    p.approach_mm = feed * rate_ramp_s(feed, 1000, 10000) + 0.5;  // at the feed before the contact
    p.search_mm = 4;
    p.speed_mm_s = feed;
    lowest = 1e9;
    const Response r = m.run(p);
    ASSERT_TRUE(r.hit) << r.fault->message;
    const double braking = feed * rate_ramp_s(feed, 400, 2000) / 2;
    const double past = r.hit->centre_mm.z() - lowest;
    EXPECT_GE(past, braking - 1e-9) << "feed " << feed;
    EXPECT_LE(past, braking + feed * w.machine.dt_s + 1e-9) << "feed " << feed;
  }
}

// Braking limits on a profile: the second half brakes by them; a stop while still accelerating
// first ends the acceleration at the ramp's jerk, so the speed never exceeds where the ramp was
// heading, then brakes.
TEST(RampLaws, AsymmetricProfiles) {
  const MotionLimits up{200, 1000, 10000};
  const BrakingLimits down{3000, 40000};
  const double d = 100;
  const MotionProfile p = MotionProfile::rest_to_rest(d, up, down);
  const double t = d / 200 + (rate_ramp_s(200, 1000, 10000) + rate_ramp_s(200, 3000, 40000)) / 2;
  EXPECT_NEAR(p.duration_s(), t, 1e-12);
  EXPECT_NEAR(rest_to_rest_time_s(d, up, down), t, 1e-12);
  EXPECT_DOUBLE_EQ(p.end_position_mm(), d);
  EXPECT_NEAR(p.at(p.duration_s() * (1 - 1e-12)).position_mm, d, 1e-6);
  // Short: the peak falls where both ramps just fit.
  const MotionProfile s = MotionProfile::rest_to_rest(1.0, up, down);
  EXPECT_NEAR(s.at(s.duration_s() * (1 - 1e-12)).position_mm, 1.0, 1e-6);
  EXPECT_NEAR(s.duration_s(), rest_to_rest_time_s(1.0, up, down), 1e-12);
  // A stop from the middle of a ramp to 20 mm/s (speed 10, acceleration at its peak 447).
  const MotionProfile ramp = MotionProfile::rest_to_rest(50, MotionLimits{20, 1000, 10000});
  const MotionState mid = ramp.at(rate_ramp_s(20, 1000, 10000) / 2);
  ASSERT_GT(mid.acceleration_mm_s2, 400);
  const BrakingLimits soft{400, 2000};
  const MotionProfile stop = MotionProfile::stop(mid, MotionLimits{20, 1000, 10000}, soft);
  double top = 0;
  for (double tt = 0; tt <= stop.duration_s(); tt += 1e-4) top = std::max(top, stop.at(tt).speed_mm_s);
  EXPECT_LE(top, 20 + 1e-9);
  EXPECT_EQ(stop.at(stop.duration_s()).speed_mm_s, 0);
  // Ending the acceleration at 10000 mm/s^3 takes a0/j; then a stop from there at the soft law.
  const double v1 = mid.speed_mm_s + mid.acceleration_mm_s2 * mid.acceleration_mm_s2 / (2 * 10000);
  EXPECT_NEAR(stop.duration_s(), mid.acceleration_mm_s2 / 10000 + rate_ramp_s(v1, 400, 2000), 1e-9);
}

TEST(RampLaws, WorldErrorsNameTheRecord) {
  const auto parse = [](const std::string& axes) {
    return parse_world(nlohmann::json::parse(R"({"extends": "default", "machine": {"axes": )" + axes + "}}"), "w.json");
  };
  const auto refused = [&](const std::string& axes, const std::string& pointer) {
    auto w = parse(axes);
    ASSERT_FALSE(w) << axes;
    EXPECT_NE(w.error().message.find(pointer + ":"), std::string::npos) << w.error().message;
  };
  refused(R"({"x": {"tabulated": {"feed_mm_s": [1, 5, 3], "ramp_time_s": [0.02, 0.05, 0.04]}}})",
          "/machine/axes/x/tabulated/feed_mm_s/2");
  refused(R"({"x": {"tabulated": {"feed_mm_s": [1, 5], "ramp_time_s": [0.02]}}})",
          "/machine/axes/x/tabulated/ramp_time_s");
  refused(R"({"y": {"tabulated": {"feed_mm_s": [1, 5], "ramp_time_s": [0.02, -0.01]}}})",
          "/machine/axes/y/tabulated/ramp_time_s/1");
  refused(R"({"y": {"tabulated": {"feed_mm_s": [1, 5], "ramp_time_s": [0.02, 60000]}}})",
          "/machine/axes/y/tabulated/ramp_time_s/1");
  refused(R"({"z": {"tabulated": {"feed_mm_s": [0, 5], "ramp_time_s": [0.02, 0.03]}}})",
          "/machine/axes/z/tabulated/feed_mm_s/0");
  refused(R"({"z": {"tabulated": {"feed_mm_s": [5], "ramp_time_s": [0.02]}}})", "/machine/axes/z/tabulated/feed_mm_s");
  refused(R"({"z": {"tabulated": {"feed_mm_s": [1, 5]}}})", "/machine/axes/z/tabulated");
  refused(
      R"({"x": {"constant_time": {"time_s": 0.05}, "tabulated": {"feed_mm_s": [1, 5], "ramp_time_s": [0.02, 0.03]}}})",
      "/machine/axes/x");
  refused(R"({"x": {"constant_time": {"time_s": 0.05}, "braking": {}}})", "/machine/axes/x/braking");
  refused(R"({"x": {"constant_time": {"time_s": 0.05}, "braking": {"constant_time": {"time_s": 0}}}})",
          "/machine/axes/x/braking/constant_time/time_s");
  refused(R"({"x": {"constant_time": {"time_s": 0.05}, "brakes": {"constant_time": {"time_s": 0.02}}}})",
          "/machine/axes/x/brakes");
  // A braking law's limits not given are the path limits, as the acceleration's.
  auto ok =
      parse(R"({"z": {"constant_rate": {"jerk_mm_s3": 20000}, "braking": {"constant_rate": {"jerk_mm_s3": 30000}}}})");
  ASSERT_TRUE(ok) << ok.error().message;
  const AxisDynamics& z = (*ok->truth.axes)[2];
  ASSERT_TRUE(z.braking);
  EXPECT_EQ(z.braking->acceleration_mm_s2, 1000);
  EXPECT_EQ(z.braking->jerk_mm_s3, 30000);
  EXPECT_FALSE((*ok->truth.axes)[0].braking);
}

}  // namespace
