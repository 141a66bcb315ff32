// SPDX-License-Identifier: GPL-3.0-or-later
// Per-axis acceleration behaviour, command timing, the two-touch cycle and the acceleration-zone
// error of the virtual CMM (SEEDS.md 3), against closed-form expectations.
#include <gtest/gtest.h>

#include <cmath>

#include <nlohmann/json.hpp>

#include "fixtures.hpp"
#include "metron/machine/touch_cycle/axis_dynamics.hpp"
#include "metron/machine/virtual_cmm.hpp"

using namespace metron;
using namespace metron::machine;

namespace {

using test_support::world_file;

using Body = decltype(Command::body);

struct Cmm {
  explicit Cmm(const World& w, std::uint64_t seed = 1) : cmm(w, seed) {}
  Response run(Body b) {
    cmm.submit({++tag, std::move(b)});
    return cmm.execute().front();
  }
  VirtualCmm cmm;
  std::uint64_t tag = 0;
};

// Duration of a long rest-to-rest move: L / F plus the ramp time Td (SEEDS.md 3), rounded up to
// whole controller cycles.
void expect_duration(const Response& r, double length, double feed, double ramp_s, double dt) {
  ASSERT_EQ(r.status, Response::Status::Done);
  const double t = length / feed + ramp_s;
  EXPECT_GE(r.end_time_s - r.start_time_s, t - 1e-9);
  EXPECT_LE(r.end_time_s - r.start_time_s, t + dt + 1e-9);
}

TEST(AxisDynamics, ConstantTimeReachesAnyFeedInItsTime) {
  const World w = world_file("touch_const_time.json");
  Cmm m(w);
  Vec3 p = w.machine.home_mm;
  for (double feed : {5.0, 50.0, 200.0}) {
    p.x() += 150;
    expect_duration(m.run(GoTo{p, feed}), 150, feed, 0.06, w.machine.dt_s);
  }
}

TEST(AxisDynamics, ConstantRatePerAxis) {
  const World w = world_file("touch_latched.json");
  // x: a = 1500, j = 15000; z: a = 800, j = 8000. Triangular acceleration below a^2 / j.
  const auto td = [](double f, double a, double j) { return f * j < a * a ? 2 * std::sqrt(f / j) : f / a + a / j; };
  Cmm m(w);
  Vec3 p = w.machine.home_mm;
  for (double feed : {10.0, 120.0, 250.0}) {
    p.x() += 200;
    expect_duration(m.run(GoTo{p, feed}), 200, feed, td(feed, 1500, 15000), w.machine.dt_s);
    p.z() -= 150;
    expect_duration(m.run(GoTo{p, feed}), 150, feed, td(feed, 800, 8000), w.machine.dt_s);
    p.z() += 150;
    expect_duration(m.run(GoTo{p, feed}), 150, feed, td(feed, 800, 8000), w.machine.dt_s);
  }
  // A diagonal move is planned at the limits of its most restrictive axis (the z axis here
  // allows a/|u_z| = 800 sqrt(2) along the diagonal, x 1500 sqrt(2)).
  const Vec3 u = Vec3(1, 0, -1).normalized();
  const double feed = 100;
  const Response r = m.run(GoTo{p + 100 * u, feed});
  expect_duration(r, 100, feed, td(feed, 800 * std::sqrt(2.0), 8000 * std::sqrt(2.0)), w.machine.dt_s);
}

TEST(AxisDynamics, DefaultWorldKeepsThePathLimits) {
  const World w = default_world();
  EXPECT_FALSE(w.truth.axes);
  const MotionLimits l = path_limits(w.machine, w.truth.axes, Vec3::UnitX(), 50, 1000);
  EXPECT_EQ(l.acceleration_mm_s2, 1000);
  EXPECT_EQ(l.jerk_mm_s3, 10000);
  EXPECT_EQ(l.speed_mm_s, 50);
}

TEST(AxisDynamics, WorldErrorsNameTheRecord) {
  const auto parse = [](const char* text) { return parse_world(nlohmann::json::parse(text), "w.json"); };
  auto both = parse(R"({"extends": "default", "machine": {"axes": {"x": {"constant_time": {"time_s": 0.05},
                      "constant_rate": {"acceleration_mm_s2": 5}}}}})");
  ASSERT_FALSE(both);
  EXPECT_NE(both.error().message.find("/machine/axes/x"), std::string::npos) << both.error().message;
  auto bad = parse(R"({"extends": "default", "machine": {"axes": {"x": {"constant_time": {"time_s": -1}}}}})");
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("/machine/axes/x/constant_time/time_s"), std::string::npos) << bad.error().message;
  auto typo = parse(R"({"extends": "default", "machine": {"axes": {"w": {"constant_time": {"time_s": 1}}}}})");
  ASSERT_FALSE(typo);
  // An axis not named keeps the path limits.
  auto partial = parse(R"({"extends": "default", "machine": {"axes": {"y": {"constant_time": {"time_s": 0.1}}}}})");
  ASSERT_TRUE(partial) << partial.error().message;
  EXPECT_EQ((*partial->truth.axes)[0].mode, AxisDynamics::Mode::ConstantRate);
  EXPECT_EQ((*partial->truth.axes)[0].acceleration_mm_s2, 1000);
  EXPECT_EQ((*partial->truth.axes)[1].mode, AxisDynamics::Mode::ConstantTime);
}

// The top of the default block (z = 40 at x 300..460, y 200..300).
PtMeas top_point(double approach, double feed) {
  PtMeas p;
  p.nominal_mm = Vec3(380, 250, 40);
  p.normal = Vec3::UnitZ();
  p.approach_mm = approach;
  p.search_mm = 5;
  p.speed_mm_s = feed;
  return p;
}

TEST(TwoTouch, GivesTheSlowTouchFasterThanOneSlowTouch) {
  World w = default_world();
  w.truth.probe.repeatability_mm = 0;
  Cmm m(w);
  ASSERT_EQ(m.run(DefineTool{"T", 4.0}).status, Response::Status::Done);
  ASSERT_EQ(m.run(SelectTool{"T"}).status, Response::Status::Done);
  m.run(GoTo{Vec3(380, 250, 44), {}});
  const Response slow = m.run(top_point(2.0, 2.0));
  ASSERT_TRUE(slow.hit);
  PtMeas two = top_point(2.0, 2.0);
  // First touch at 15 mm/s latches 0.01 + 15 * 0.004 mm past contact; backing off 0.3 mm leaves
  // 0.23 mm to reach 2 mm/s, whose ramp is only 0.028 mm.
  two.two_touch = PtMeas::TwoTouch{15.0, 0.3};
  m.run(GoTo{Vec3(380, 250, 44), {}});
  const Response fast = m.run(two);
  ASSERT_TRUE(fast.hit) << fast.fault->message;
  EXPECT_NEAR(fast.hit->centre_mm.z(), slow.hit->centre_mm.z(), 1e-7);
  EXPECT_LT(fast.end_time_s - fast.start_time_s, 0.7 * (slow.end_time_s - slow.start_time_s));
  // A first touch that finds nothing (a point in the air) is a no-contact fault.
  PtMeas air = two;
  air.nominal_mm.z() = 100;
  air.search_mm = 1;
  const Response r = m.run(air);
  ASSERT_EQ(r.status, Response::Status::Fault);
  EXPECT_EQ(r.fault->kind, FaultKind::NoContact);
  two.two_touch->backoff_mm = 0;
  EXPECT_EQ(m.run(two).fault->kind, FaultKind::BadCommand);
}

// SEEDS.md 3, acceleration zone: a standoff shorter than the ramp distance D1 makes the contact
// happen while accelerating; the delay distance B is then shorter than the constant-feed
// correction A and the point is off by C = B - A. Expected from a linear ramp of 0.06 s (the
// constant-time ramp: 10 % of its time ramping the acceleration up and down, written out here
// independently of MotionProfile).
TEST(AccelerationZone, ErrorVsStandoffFollowsTheRamp) {
  World w = world_file("touch_const_time.json");
  w.machine.skip = SkipInput{};  // latched: no jitter, so single points show the bias
  w.truth.probe.repeatability_mm = 0;
  const double feed = 5, ramp = 0.06, pt = w.truth.probe.pre_travel.vertical_mm;
  const double tau = w.truth.probe.filter_delay_s + w.truth.probe.transmission_delay_s + w.machine.skip.latency_s;
  Cmm m(w);
  m.run(DefineTool{"T", 4.0});
  m.run(SelectTool{"T"});
  const auto hit_z = [&](double approach) {
    m.run(GoTo{Vec3(380, 250, 50), {}});
    const Response r = m.run(top_point(approach, feed));
    EXPECT_TRUE(r.hit);
    return r.hit ? r.hit->centre_mm.z() : 0.0;
  };
  const double reference = hit_z(3.0);  // contact at constant speed
  const double tj = 0.1 * ramp, acc = feed / (0.9 * ramp), jerk = acc / tj;
  const double v1 = acc * tj / 2, x1 = acc * tj * tj / 6;
  const double v2 = v1 + acc * (ramp - 2 * tj), x2 = x1 + v1 * (ramp - 2 * tj) + acc * std::pow(ramp - 2 * tj, 2) / 2;
  const double x3 = x2 + v2 * tj + acc * tj * tj / 2 - jerk * tj * tj * tj / 6;
  const auto x = [&](double t) {
    if (t < tj) return jerk * t * t * t / 6;
    if (t < ramp - tj) return x1 + v1 * (t - tj) + acc * (t - tj) * (t - tj) / 2;
    if (t < ramp) {
      const double u = t - (ramp - tj);
      return x2 + v2 * u + acc * u * u / 2 - jerk * u * u * u / 6;
    }
    return x3 + feed * (t - ramp);
  };
  const auto t_of = [&](double s) {
    double lo = 0, hi = 10;
    for (int i = 0; i < 200; ++i) (x((lo + hi) / 2) < s ? lo : hi) = (lo + hi) / 2;
    return lo;
  };
  EXPECT_NEAR(x3, feed * ramp / 2, 1e-12);  // SEEDS.md 3: D1 = V * Td / 2
  double previous = 1e9;
  for (double s : {0.005, 0.02, 0.05, 0.1, 0.15, 0.25, 0.4}) {
    const double b = x(t_of(s + pt) + tau) - s;  // distance from contact to the latch
    const double a = pt + feed * tau;            // the constant-feed correction
    const double expected = a - b;               // the hit lies this much above the true one
    const double error = hit_z(s) - reference;
    EXPECT_NEAR(error, expected, 0.1e-3) << "standoff " << s;
    EXPECT_LE(error, previous + 1e-9);  // shrinks as the standoff grows
    previous = error;
    if (s < 0.05) {
      EXPECT_GT(error, 0.02) << s;
    }
    if (s >= feed * ramp / 2) {
      EXPECT_LT(std::abs(error), 0.5e-3) << s;
    }
  }
}

}  // namespace
