// SPDX-License-Identifier: GPL-3.0-or-later
// Touch-trigger characterisation (SEEDS.md 3) against the hidden truth of the touch worlds.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "fixtures.hpp"
#include "metron/machine/touch_cycle/axis_dynamics.hpp"
#include "metron/machine/virtual_cmm.hpp"
#include "metron/runtime/characterisation.hpp"

using namespace metron;
using namespace metron::runtime;

namespace {

using test_support::world_file;

struct Characterised {
  machine::World world;
  MachineCharacterisation c;
};

Characterised run(const std::string& name, std::uint64_t seed = 1) {
  machine::World w = name.empty() ? machine::default_world() : world_file(name);
  machine::VirtualCmm cmm(w, seed);
  auto c = characterise(cmm, CharacterisationSettings{});
  if (!c) throw std::runtime_error(c.error());
  return {w, *c};
}

double true_delay_s(const machine::World& w) {
  return w.truth.probe.filter_delay_s + w.truth.probe.transmission_delay_s +
         (w.machine.skip.kind == machine::SkipInput::Kind::Latched ? w.machine.skip.latency_s : 0);
}
double true_jitter_s(const machine::World& w) {
  return w.machine.skip.kind == machine::SkipInput::Kind::Scanned ? w.machine.skip.period_s : 0;
}

class Recovery : public ::testing::TestWithParam<std::pair<const char*, std::uint64_t>> {};

// Issue 4, figure 1: acceleration distance within 1 %, jitter class right, the maximum feed
// never lets the (true, worst-case) stop distance exceed the over-travel.
TEST_P(Recovery, RecoversTheHiddenTruth) {
  const auto [name, seed] = GetParam();
  const auto [w, c] = run(name, seed);
  for (int i = 0; i < 3; ++i) {
    const Vec3 e = Vec3::Unit(i);
    const auto& truth = w.truth.axes ? (*w.truth.axes)[static_cast<std::size_t>(i)] : machine::AxisDynamics{};
    if (w.truth.axes) {
      EXPECT_EQ(c.axes[static_cast<std::size_t>(i)].mode == AxisAcceleration::Mode::ConstantTime,
                truth.mode == machine::AxisDynamics::Mode::ConstantTime)
          << name << " axis " << i;
    }
    // Measured feeds and feeds between them (the fitted function is the lookup).
    for (double f : {1.0, 2.0, 3.5, 7.0, 10.0, 33.0, 75.0, 150.0}) {
      const double d_true = f * machine::ramp_time_s(w.machine, w.truth.axes, e, f) / 2;
      EXPECT_NEAR(c.acceleration_distance_mm(e, f), d_true, 0.01 * d_true) << name << " axis " << i << " feed " << f;
    }
  }
  EXPECT_EQ(c.response.scanned, w.machine.skip.kind == machine::SkipInput::Kind::Scanned) << name;
  EXPECT_NEAR(c.response.jitter_s, true_jitter_s(w), 0.15 * true_jitter_s(w) + 1e-6) << name;
  // The mean latency (delay + jitter / 2) is the slope of the mean latched position over feed;
  // with a scanned input each mean scatters by F * period / sqrt(12 N), so the split into delay
  // and jitter carries the jitter's 1/N range error as well.
  EXPECT_NEAR(c.response.delay_s + c.response.jitter_s / 2, true_delay_s(w) + true_jitter_s(w) / 2,
              0.02 * true_delay_s(w) + 0.02 * true_jitter_s(w)) << name;
  EXPECT_NEAR(c.response.delay_s, true_delay_s(w), 0.02 * true_delay_s(w) + 0.05 * true_jitter_s(w)) << name;
  EXPECT_NEAR(c.dt_s, w.machine.dt_s, 1e-9);
  EXPECT_DOUBLE_EQ(c.over_travel_mm, w.truth.probe.over_travel_mm);
  // The true worst case at the maximum feed of each axis direction: the largest pre-travel, 4
  // sigma of trigger noise, the delays, the whole scan period, one interpolator cycle, braking.
  for (int i = 0; i < 3; ++i) {
    const Vec3 e = Vec3::Unit(i);
    const double f = c.max_feed_mm_s(e);
    EXPECT_GT(f, 1.0);
    const double pt = std::max(w.truth.probe.pre_travel.horizontal_mm, w.truth.probe.pre_travel.vertical_mm) +
                      w.truth.probe.pre_travel.lobe_amplitude_mm + 4 * w.truth.probe.repeatability_mm;
    const double stop = pt + f * (true_delay_s(w) + true_jitter_s(w) + w.machine.dt_s) +
                        f * machine::ramp_time_s(w.machine, w.truth.axes, e, f) / 2;
    EXPECT_LT(stop, w.truth.probe.over_travel_mm) << name << " axis " << i;
  }
  EXPECT_LE(c.max_probe_feed_mm_s, c.max_feed_mm_s(Vec3::UnitZ()) + 1e-9);
}

INSTANTIATE_TEST_SUITE_P(Worlds, Recovery,
                         ::testing::Values(std::pair{"touch_latched.json", 1ull}, std::pair{"touch_scanned_4ms.json", 1ull},
                                           std::pair{"touch_scanned_4ms.json", 7ull}, std::pair{"touch_const_time.json", 1ull},
                                           std::pair{"touch_const_time.json", 11ull}, std::pair{"touch_mixed.json", 1ull},
                                           std::pair{"scanned_skip.json", 3ull}, std::pair{"default.json", 1ull}));

// Seed's strategy rule: latched controllers one-touch, a 4 ms scanned one two-touch with a
// second-touch feed whose spread meets the threshold.
TEST(Characterisation, StrategyFollowsTheSpread) {
  const auto latched = run("touch_latched.json").c;
  EXPECT_TRUE(latched.one_touch);
  EXPECT_NEAR(latched.measuring_feed_mm_s, latched.max_probe_feed_mm_s, 1e-9);
  const auto scanned = run("touch_scanned_4ms.json").c;
  EXPECT_FALSE(scanned.one_touch);
  EXPECT_LE(scanned.response.spread_mm(scanned.measuring_feed_mm_s), scanned.threshold_mm + 1e-12);
  EXPECT_GT(scanned.response.spread_mm(scanned.first_feed_mm_s), scanned.threshold_mm);
  // The standoff is D1 + D2 + D3 (SEEDS.md 3) from the recovered values.
  const Vec3 down = -Vec3::UnitZ();
  const double fs = scanned.measuring_feed_mm_s, ff = scanned.first_feed_mm_s;
  EXPECT_NEAR(scanned.standoff_mm(down, fs, ff, 0),
              fs * scanned.ramp_time_s(down, fs) / 2 + ff * scanned.response.jitter_s +
                  fs * (scanned.response.delay_s + scanned.response.jitter_s),
              1e-12);
}

TEST(Characterisation, FileRoundTrip) {
  const auto c = run("touch_mixed.json").c;
  const std::string path = (std::filesystem::temp_directory_path() / "metron_char_roundtrip.json").string();
  ASSERT_TRUE(save_characterisation(c, path));
  auto back = load_characterisation(path);
  ASSERT_TRUE(back) << back.error();
  EXPECT_EQ(to_json(*back), to_json(c));
  for (double f : {1.0, 10.0, 40.0}) EXPECT_DOUBLE_EQ(back->acceleration_distance_mm(Vec3::UnitX(), f), c.acceleration_distance_mm(Vec3::UnitX(), f));
  // A damaged file names what is wrong.
  nlohmann::json j = to_json(c);
  j["axes"]["y"]["mode"] = "bouncy";
  auto bad = characterisation_from_json(j);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().find("/axes/y/mode"), std::string::npos) << bad.error();
  j = to_json(c);
  j.erase("max_probe_feed_mm_s");
  EXPECT_FALSE(characterisation_from_json(j));
  EXPECT_FALSE(load_characterisation("/nonexistent/char.json"));
  std::filesystem::remove(path);
}

// At the maximum protected feed the real machine never faults on over-travel (many touches,
// every random scan phase), while a feed well above it does.
TEST(Characterisation, MaximumFeedIsSafeOnTheMachine) {
  for (const char* name : {"touch_scanned_4ms.json", "touch_mixed.json"}) {
    const auto [w, c] = run(name);
    machine::VirtualCmm cmm(w, 5);
    std::uint64_t tag = 1;
    const auto one = [&](decltype(machine::Command::body) b) {
      cmm.submit({tag++, std::move(b)});
      return cmm.execute().front();
    };
    one(machine::DefineTool{"T", 4.0, -Vec3::UnitZ(), 50});
    one(machine::SelectTool{"T"});
    // The top of the test block (z = 40), probed straight down at the maximum feed.
    const auto touch = [&](double feed) {
      machine::PtMeas p;
      p.nominal_mm = Vec3(380, 250, 40);
      p.normal = Vec3::UnitZ();
      p.approach_mm = 2 * c.acceleration_distance_mm(-Vec3::UnitZ(), feed) + 0.5;
      p.search_mm = 2 * c.acceleration_distance_mm(-Vec3::UnitZ(), feed) + 3;
      p.speed_mm_s = feed;
      return one(p);
    };
    for (int k = 0; k < 100; ++k) {
      const auto r = touch(c.max_probe_feed_mm_s);
      ASSERT_EQ(r.status, machine::Response::Status::Done) << name << ": " << r.fault->message;
    }
    const auto r = touch(2.5 * c.max_probe_feed_mm_s);
    ASSERT_EQ(r.status, machine::Response::Status::Fault) << name;
    EXPECT_EQ(r.fault->kind, machine::FaultKind::OverTravel) << name;
  }
}

}  // namespace

namespace {

// Issue 4, figure 2: with the characterised standoff the point is within 0.5 um of a
// constant-speed measurement, one-touch and two-touch (latched input: single points show the
// bias without jitter), while a too-small standoff is off by tens of um.
TEST(Characterisation, OptimalStandoffRemovesTheAccelerationZoneError) {
  machine::World w = world_file("touch_const_time.json");
  w.machine.skip = machine::SkipInput{};
  w.truth.probe.repeatability_mm = 0;
  MachineCharacterisation c;
  {
    machine::VirtualCmm probe_cmm(w, 1);
    auto got = characterise(probe_cmm, CharacterisationSettings{});
    ASSERT_TRUE(got) << got.error();
    c = *got;
  }
  machine::VirtualCmm cmm(w, 2);
  std::uint64_t tag = 1;
  const auto exec = [&](decltype(machine::Command::body) b) {
    cmm.submit({tag++, std::move(b)});
    return cmm.execute().front();
  };
  exec(machine::DefineTool{"T", 4.0, -Vec3::UnitZ(), 50});
  exec(machine::SelectTool{"T"});
  const Vec3 nominal(380, 250, 40), n = Vec3::UnitZ();
  const auto hit = [&](const TouchPlan& plan) {
    exec(machine::GoTo{nominal + Vec3(0, 0, 12), {}});
    machine::PtMeas p;
    p.nominal_mm = nominal;
    p.normal = n;
    p.approach_mm = plan.approach_mm;
    p.search_mm = 5;
    p.speed_mm_s = plan.feed_mm_s;
    if (plan.two_touch) p.two_touch = machine::PtMeas::TwoTouch{plan.first_feed_mm_s, plan.backoff_mm};
    const auto r = exec(p);
    EXPECT_TRUE(r.hit) << (r.fault ? r.fault->message : "");
    return r.hit ? r.hit->centre_mm.z() : 0.0;
  };
  for (double feed : {2.0, 5.0, 15.0, c.max_probe_feed_mm_s}) {
    TouchPlan constant;
    constant.feed_mm_s = feed;
    constant.approach_mm = 4 * c.acceleration_distance_mm(-n, feed) + 1;
    const double reference = hit(constant);
    TouchPlan one = c.plan(n, feed, std::nullopt);
    one.two_touch = false;
    one.approach_mm = c.standoff_mm(-n, feed, 0, 0);
    EXPECT_NEAR(hit(one), reference, 0.5e-3) << "one-touch at " << feed;
    TouchPlan too_small = one;
    too_small.approach_mm = 0.2 * c.acceleration_distance_mm(-n, feed);
    EXPECT_GT(hit(too_small) - reference, 2e-3) << "feed " << feed;
    if (feed < c.max_probe_feed_mm_s) {
      MachineCharacterisation two = c;
      two.one_touch = false;
      TouchPlan p2 = two.plan(n, feed, std::nullopt);
      ASSERT_TRUE(p2.two_touch);
      EXPECT_NEAR(hit(p2), reference, 0.5e-3) << "two-touch at " << feed;
    }
  }
}

}  // namespace
