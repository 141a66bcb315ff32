// SPDX-License-Identifier: GPL-3.0-or-later
// Touch-trigger characterisation (SEEDS.md 3) against the hidden truth of the touch worlds.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "direct_machine.hpp"
#include "fixtures.hpp"
#include "metron/machine/touch_cycle/axis_dynamics.hpp"
#include "metron/machine/touch_cycle/cycle_limit.hpp"
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
              0.02 * true_delay_s(w) + 0.02 * true_jitter_s(w))
      << name;
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

INSTANTIATE_TEST_SUITE_P(
    Worlds, Recovery,
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
  for (double f : {1.0, 10.0, 40.0})
    EXPECT_DOUBLE_EQ(back->acceleration_distance_mm(Vec3::UnitX(), f), c.acceleration_distance_mm(Vec3::UnitX(), f));
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

// Issue 15: a characterisation file was checked for its shape only; a hand-raised maximum feed
// (then a 500 mm/s probing feed went through into an over-travel), a negative delay or a margin
// above the whole over-travel were accepted. The file's feeds must be the ones its own
// measurements protect.
TEST(Characterisation, AFileCannotClaimFeedsItsMeasurementsDoNotProtect) {
  const auto c = run("touch_scanned_4ms.json").c;
  ASSERT_TRUE(characterisation_from_json(to_json(c)));  // as written: consistent
  const auto refused = [](nlohmann::json j, const std::string& pointer) {
    auto r = characterisation_from_json(j);
    ASSERT_FALSE(r) << pointer;
    EXPECT_EQ(r.error().rfind(pointer + ":", 0), 0u) << r.error();
  };
  nlohmann::json j = to_json(c);
  j["max_probe_feed_mm_s"] = 500.0;
  refused(j, "/max_probe_feed_mm_s");
  j = to_json(c);
  j["max_probe_feed_mm_s"] = c.max_probe_feed_mm_s * 1.01;  // 1 % above is already unprotected
  refused(j, "/max_probe_feed_mm_s");
  j = to_json(c);
  j["strategy"]["measuring_feed_mm_s"] = 500.0;
  refused(j, "/strategy/measuring_feed_mm_s");
  j = to_json(c);
  j["strategy"]["first_feed_mm_s"] = c.max_probe_feed_mm_s * 2;
  refused(j, "/strategy/first_feed_mm_s");
  j = to_json(c);
  j["response"]["delay_s"] = -0.004;
  refused(j, "/response/delay_s");
  j = to_json(c);
  j["pre_travel_mm"] = -0.01;
  refused(j, "/pre_travel_mm");
  j = to_json(c);
  j["over_travel_margin"] = 1.5;
  refused(j, "/over_travel_margin");
  j = to_json(c);
  j["over_travel_mm"] = c.over_travel_mm / 2;  // a smaller probe: the stated feed is no longer protected
  refused(j, "/max_probe_feed_mm_s");
}

// At the maximum protected feed the real machine never faults on over-travel (many touches,
// every random scan phase), while a feed well above it does.
TEST(Characterisation, MaximumFeedIsSafeOnTheMachine) {
  for (const char* name : {"touch_scanned_4ms.json", "touch_mixed.json"}) {
    const auto [w, c] = run(name);
    test_support::DirectMachine direct(w, 5);
    const auto one = [&](decltype(machine::Command::body) b) { return direct.exec(std::move(b)); };
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
    const auto r = touch(4 * c.max_probe_feed_mm_s);
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
  test_support::DirectMachine direct(w, 2);
  const auto exec = [&](decltype(machine::Command::body) b) { return direct.exec(std::move(b)); };
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

namespace {

// A bench for one-point cycles on the default block's top face (z = 40), probed along -z.
struct CycleBench {
  machine::VirtualCmm cmm;
  std::uint64_t tag = 1;
  double radius_mm = 2;
  double qualification_feed_mm_s = 0;
  const Vec3 nominal{380, 250, 40};
  CycleBench(const machine::World& w, std::uint64_t seed) : cmm(w, seed) {
    exec(machine::DefineTool{"T", 4.0, -Vec3::UnitZ(), 50});
    exec(machine::SelectTool{"T"});
    radius_mm = exec(machine::QualifyTool{}).tool->effective_radius_mm;
    qualification_feed_mm_s = cmm.state().measuring_feed_mm_s;
    machine::SetFeeds f;
    f.positioning_mm_s = 200;
    exec(f);
    const Vec3 at = cmm.state().position_mm;
    exec(machine::GoTo{Vec3(at.x(), at.y(), 150), {}});
    exec(machine::GoTo{nominal + Vec3(0, 0, 110), {}});
  }
  machine::Response exec(decltype(machine::Command::body) b) {
    cmm.submit({tag++, std::move(b)});
    return cmm.execute().front();
  }
  // One cycle with the nominal `offset` below the true surface (the surface `offset` above its
  // nominal), starting at rest `rest_mm` above nominal + effective radius.
  machine::Response cycle(machine::PtMeas p, double offset, double rest_mm = 2.0) {
    p.nominal_mm = nominal - offset * Vec3::UnitZ();
    p.normal = Vec3::UnitZ();
    p.retract_mm = rest_mm;
    exec(machine::GoTo{p.nominal_mm + (radius_mm + rest_mm) * Vec3::UnitZ(), {}});
    return exec(p);
  }
};

machine::PtMeas ptmeas_of(const TouchPlan& plan) {
  machine::PtMeas p;
  apply_touch_plan(plan, p);
  return p;
}

// Issue 11 item 3: the limit's feed must be reached by the earliest possible contact,
// clearance - q - tol from the start (q = pre-travel + F_q * mean delay: the contact is q nearer
// the start than nominal + effective radius). Checked by running the machine: a blended touch
// that reaches the feed exactly there measures a surface at the top of the band as a
// constant-speed touch does; one that reaches it at clearance + q - tol (the old sign) is
// still accelerating at contact and measures it wrong. A large pre-travel makes q large.
TEST(TouchCycleLimit, FeedIsReachedAtTheEarliestPossibleContact) {
  machine::World w = world_file("touch_latched.json");
  // A long interface delay makes q large (q = pre-travel + F_q * delay, 0.17 mm here): the
  // latch then comes a long way after the contact, still on the ramp with the old sign.
  w.truth.probe.filter_delay_s = 0.05;
  w.truth.probe.over_travel_mm = 5;
  w.truth.probe.repeatability_mm = 0;
  CycleBench b(w, 3);
  // A band wider than q, so that the old sign's reach point (tol - q before the nominal) is
  // still a valid blended move.
  const double clearance = 2.0, tol = 0.5, feed = 20;
  const auto lim = machine::touch_cycle_limit(w.machine, w.truth, -Vec3::UnitZ(), feed, clearance, tol, 200,
                                              b.qualification_feed_mm_s);
  // Hidden truth by hand: pre-travel 0.01 mm, delay 50 + 2 ms + 4 us latch.
  EXPECT_NEAR(lim.q_mm, 0.01 + b.qualification_feed_mm_s * (0.052 + 4e-6), 1e-12);
  EXPECT_NEAR(lim.reach_mm, clearance - lim.q_mm - tol, 1e-12);
  machine::PtMeas reference;
  reference.approach_mm = clearance + 4.0;
  reference.speed_mm_s = feed;
  const auto ref = b.cycle(reference, tol, clearance + 4.0);
  ASSERT_TRUE(ref.hit);
  const auto blended = [&](double reach_mm) {
    machine::PtMeas p;
    p.approach_mm = clearance;
    p.speed_mm_s = feed;
    p.blend_mm = clearance - reach_mm;
    const auto r = b.cycle(p, tol, clearance);
    EXPECT_TRUE(r.hit) << (r.fault ? r.fault->message : "");
    return r.hit ? r.hit->centre_mm.z() : 0.0;
  };
  EXPECT_NEAR(blended(lim.reach_mm), ref.hit->centre_mm.z(), 0.5e-3);
  // The old sign is seen by the machine: the touch is still accelerating at the contact.
  EXPECT_GT(std::abs(blended(clearance + lim.q_mm - tol) - ref.hit->centre_mm.z()), 5e-3);
  // And the limit is a lower bound of every measured cycle over the band (blended at the limit's
  // reach point, controller-cycle rounding included), the no-jerk bound below it.
  double mean = 0;
  for (int k = 0; k < 20; ++k) {
    machine::PtMeas p;
    p.approach_mm = clearance;
    p.speed_mm_s = feed;
    p.blend_mm = clearance - lim.reach_mm;
    const auto r = b.cycle(p, tol * (2 * (k + 0.5) / 20 - 1), clearance);
    ASSERT_TRUE(r.hit);
    mean += (r.end_time_s - r.start_time_s) / 20;
  }
  EXPECT_GE(mean, lim.time_s);
  EXPECT_LT(mean, 1.05 * lim.time_s);
  EXPECT_LT(lim.no_jerk_time_s, lim.time_s);
}

// Issue 11 item 3: the seed's plan starts the touch where the head already rests when that is
// beyond its standoff (probing the extra distance beats a rest-to-rest move closer), so on the
// latched controller it is no slower than a plain one-touch from the clearance, and faster than
// the plan that first moves to the standoff.
TEST(Characterisation, PlanProbesFromWhereTheHeadRests) {
  const auto [w, c] = run("touch_latched.json");
  ASSERT_TRUE(c.one_touch);
  const Vec3 n = Vec3::UnitZ();
  const double fs = c.measuring_feed_mm_s;
  const TouchPlan closer = c.plan(n, fs, std::nullopt);
  ASSERT_LT(closer.approach_mm, 2.0);
  const TouchPlan rested = c.plan(n, fs, std::nullopt, RestingHead{2.0, 200});
  EXPECT_DOUBLE_EQ(rested.approach_mm, 2.0);
  // Resting inside the standoff: the standoff stands.
  EXPECT_DOUBLE_EQ(c.plan(n, fs, std::nullopt, RestingHead{0.5 * closer.approach_mm, 200}).approach_mm,
                   closer.approach_mm);
  // Resting far away: a fast move closer wins over probing 100 mm at the measuring feed.
  EXPECT_DOUBLE_EQ(c.plan(n, fs, std::nullopt, RestingHead{100.0, 200}).approach_mm, closer.approach_mm);
  // An explicit approach (SNSET/APPRCH) is kept.
  EXPECT_DOUBLE_EQ(c.plan(n, fs, 1.0, RestingHead{2.0, 200}).approach_mm, 1.0);
  CycleBench b(w, 4);
  const auto mean_time = [&](const machine::PtMeas& p) {
    double t = 0;
    for (int k = 0; k < 10; ++k) {
      const auto r = b.cycle(p, 0.2 * (2 * (k + 0.5) / 10 - 1));
      EXPECT_TRUE(r.hit) << (r.fault ? r.fault->message : "");
      t += (r.end_time_s - r.start_time_s) / 10;
    }
    return t;
  };
  machine::PtMeas plain;
  plain.approach_mm = 2.0;
  plain.speed_mm_s = fs;
  const double t_plain = mean_time(plain), t_rested = mean_time(ptmeas_of(rested)),
               t_closer = mean_time(ptmeas_of(closer));
  EXPECT_LE(t_rested, t_plain + 1e-9);
  EXPECT_LT(t_rested, 0.95 * t_closer);
}

// Issue 11 item 2: the maximum protected feed is protected wherever on the ramp the contact
// comes: at that feed from rest, a surface anywhere between the start and the nominal stops
// within the rated over-travel, on every touch world (many scan phases). Surfaces within the
// stated tolerance are touched at constant feed by the characterised cycle and measured right.
class RampProtection : public ::testing::TestWithParam<const char*> {};

TEST_P(RampProtection, MaximumFeedIsSafeAnywhereOnTheRamp) {
  const char* name = GetParam();
  const auto [w, c] = run(name);
  EXPECT_DOUBLE_EQ(c.nominal_tolerance_mm, default_nominal_tolerance_mm);
  CycleBench b(w, 5);
  const double f = c.max_probe_feed_mm_s, d1 = c.acceleration_distance_mm(-Vec3::UnitZ(), f);
  // From rest 1.2 D1 + 0.3 mm out: contacts from just after the start to past the ramp.
  const double start = 1.2 * d1 + 0.3;
  int touches = 0;
  for (int k = 0; k <= 60; ++k) {
    // The surface this far above the nominal (up to just short of the start's contact point).
    const double offset = (start - c.qualified_offset_mm() - 0.03) * k / 60;
    machine::PtMeas p;
    p.approach_mm = start;
    p.search_mm = start + 2 * d1 + 2;
    p.speed_mm_s = f;
    for (int rep = 0; rep < 3; ++rep) {
      const auto r = b.cycle(p, offset, start + 0.5);
      ASSERT_EQ(r.status, machine::Response::Status::Done)
          << name << ": surface " << offset << " mm above nominal at " << f << " mm/s: " << r.fault->message;
      ++touches;
    }
  }
  EXPECT_EQ(touches, 183);
  // The characterised cycle measures surfaces up to the tolerance above (and below) the nominal
  // without fault, and within the threshold of the constant-speed touch at the measuring feed.
  machine::PtMeas reference;
  reference.approach_mm = 4 * c.acceleration_distance_mm(-Vec3::UnitZ(), c.measuring_feed_mm_s) + 1;
  reference.speed_mm_s = c.measuring_feed_mm_s;
  for (double offset : {-c.nominal_tolerance_mm, 0.0, 0.5 * c.nominal_tolerance_mm, c.nominal_tolerance_mm}) {
    const auto ref = b.cycle(reference, offset, reference.approach_mm);
    ASSERT_TRUE(ref.hit);
    const auto r = b.cycle(ptmeas_of(c.plan(Vec3::UnitZ(), std::nullopt, std::nullopt)), offset);
    ASSERT_TRUE(r.hit) << name << " offset " << offset << ": " << r.fault->message;
    EXPECT_NEAR(r.hit->centre_mm.z() - offset, ref.hit->centre_mm.z() - offset, c.threshold_mm)
        << name << " offset " << offset;
  }
  // Beyond the tolerance a one-touch cycle touches the surface before reaching its feed: no
  // over-travel (above), and the hit is reported as early (the runtime warns), with the
  // surface's height above its nominal. Within the tolerance it is not.
  const TouchPlan plan = c.plan(Vec3::UnitZ(), std::nullopt, std::nullopt);
  // Up to just short of the start's own contact point.
  const double highest = plan.approach_mm - c.qualified_offset_mm() - 0.03;
  for (double offset : {0.0, c.nominal_tolerance_mm, 0.5 * (c.nominal_tolerance_mm + highest), highest}) {
    if (plan.two_touch) break;  // the second touch starts from the surface found
    machine::PtMeas p = ptmeas_of(plan);
    const auto r = b.cycle(p, offset);
    ASSERT_TRUE(r.hit) << name << " offset " << offset << ": " << r.fault->message;
    p.nominal_mm = b.nominal - offset * Vec3::UnitZ();
    p.normal = Vec3::UnitZ();
    const auto early = c.early_contact_mm(p, *r.hit);
    if (offset <= c.nominal_tolerance_mm) {
      EXPECT_FALSE(early) << name << " offset " << offset << ": " << *early;
    } else {
      ASSERT_TRUE(early) << name << " offset " << offset;
      // Estimated with the feed's delay distance: a touch still accelerating covers less, so
      // the estimate is high by at most that whole distance.
      EXPECT_GE(*early, offset - 2e-3) << name;
      EXPECT_LE(*early, offset + plan.feed_mm_s * (c.response.delay_s + c.response.jitter_s) + 2e-3) << name;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Worlds, RampProtection,
                         ::testing::Values("touch_scanned_4ms.json", "touch_const_time.json", "touch_mixed.json",
                                           "touch_latched.json", "touch_tabulated.json", "touch_braking.json"));

}  // namespace

namespace {

// Issue 11 item 6: the probe's own scatter (1 sigma of the trigger, hidden truth
// probe.repeatability_mm) is recovered over several seeds on scanned and latched inputs. Until
// issue 11 the 4 ms controller gave 0.91, 0.34, 0.00, 0.00 um for a true 0.2 um (the variance at
// 2 mm/s less the jitter's, a difference of two large numbers). 60 touches estimate sigma to
// about 9 % (1 / sqrt(2 (N - 1))); 35 % is four of those.
TEST(Characterisation, ProbeNoiseMatchesTheTruthOverSeeds) {
  for (const char* name : {"touch_scanned_4ms.json", "touch_const_time.json", "touch_latched.json"}) {
    for (std::uint64_t seed : {1ull, 2ull, 3ull, 4ull}) {
      const auto [w, c] = run(name, seed);
      const double truth = w.truth.probe.repeatability_mm;
      ASSERT_GT(truth, 0);
      EXPECT_NEAR(c.response.noise_mm, truth, 0.35 * truth) << name << " seed " << seed;
    }
  }
}

}  // namespace

namespace {

// Issue 11 item 8: the controller plans with its data sheet, not the hidden truth. A world whose
// published over-travel (machine.data_sheet) is half the true one gives a characterisation that
// knows the published value and a lower protected feed; the switch still trips at the truth.
TEST(Characterisation, UsesTheDataSheetNotTheTruth) {
  const std::string dir = std::string(METRON_SOURCE_DIR) + "/programs/worlds";
  nlohmann::json j = {{"extends", "touch_scanned_4ms.json"},
                      {"machine", {{"data_sheet", {{"rated_over_travel_mm", 0.5}, {"scanning_stiffness_n_mm", 0.9}}}}}};
  auto w = machine::parse_world(j, "sheet", dir);
  ASSERT_TRUE(w) << w.error().message;
  EXPECT_DOUBLE_EQ(w->truth.probe.over_travel_mm, 1.0);
  EXPECT_DOUBLE_EQ(w->machine.data_sheet.rated_over_travel_mm, 0.5);
  EXPECT_DOUBLE_EQ(w->machine.data_sheet.scanning_stiffness_n_mm, 0.9);
  EXPECT_DOUBLE_EQ(w->machine.data_sheet.scanning_stylus_mass_g, w->truth.scanning.probe.stylus_mass_g);
  machine::VirtualCmm cmm(*w, 1);
  auto c = characterise(cmm, CharacterisationSettings{});
  ASSERT_TRUE(c) << c.error();
  EXPECT_DOUBLE_EQ(c->over_travel_mm, 0.5);
  const auto plain = run("touch_scanned_4ms.json").c;
  EXPECT_DOUBLE_EQ(plain.over_travel_mm, 1.0);
  EXPECT_LT(c->max_probe_feed_mm_s, 0.8 * plain.max_probe_feed_mm_s);
  // A damaged data sheet names its key.
  j["machine"]["data_sheet"] = {{"rated_over_travel", 0.5}};
  auto bad = machine::parse_world(j, "sheet", dir);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("data_sheet"), std::string::npos) << bad.error().message;
}

}  // namespace
