// SPDX-License-Identifier: GPL-3.0-or-later
// The controller's compensation by an error space (issue 12, docs/error-space.md "Compensation"):
// the decorator at the machine API, its sign checked on a touch against ISO 230-1 by hand, and the
// gain on a ball array against the hidden truth (the balls' design centres) with no map, with the
// map the two-point calibration recovers, and with the ideal map sampled from the hidden errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <numeric>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "ball_array.hpp"
#include "block_probing.hpp"
#include "metron/machine/compensation/compensated_machine.hpp"
#include "metron/machine/error_space/calibration.hpp"
#include "metron/machine/virtual_cmm.hpp"
#include "scan_paths.hpp"

using namespace metron;
using namespace metron::machine;

namespace {

/// e(q) = K q (a constant matrix): a map whose fixed point is known in closed form.
class LinearMap final : public ErrorMap {
 public:
  explicit LinearMap(const Eigen::Matrix3d& k) : m_k(k) {}
  [[nodiscard]] Vec3 error_at_mm(const Vec3& q) const override { return m_k * q; }

 private:
  Eigen::Matrix3d m_k;
};

/// A backend that records what it is commanded and reports fixed positions.
class RecordingMachine final : public Machine {
 public:
  std::vector<Command> commands;
  Vec3 report_mm{100, 200, 300};
  void submit(Command command) override { commands.push_back(std::move(command)); }
  std::vector<Response> execute() override {
    std::vector<Response> out;
    for (const auto& c : commands) {
      Response r;
      r.tag = c.tag;
      if (std::holds_alternative<PtMeas>(c.body)) r.hit = Hit{report_mm, Vec3::UnitZ(), 2, 0};
      out.push_back(r);
    }
    commands.clear();
    return out;
  }
  [[nodiscard]] MachineState state() const override {
    MachineState s;
    s.position_mm = report_mm;
    return s;
  }
  [[nodiscard]] std::vector<Command> queued() const override { return commands; }
};

TEST(CompensatedMachine, CommandsPMinusEAndReportsQPlusE) {
  Eigen::Matrix3d k = Eigen::Matrix3d::Zero();
  k(0, 0) = 40e-6;   // x scale
  k(0, 1) = 5e-6;    // squareness: e_x grows with y
  k(2, 0) = -20e-6;  // e_z along x
  auto inner = std::make_unique<RecordingMachine>();
  RecordingMachine* rec = inner.get();
  CompensatedMachine cmm(std::move(inner), std::make_shared<LinearMap>(k));
  const Vec3 wanted(500, 400, 100);
  cmm.submit({1, GoTo{wanted, std::nullopt}});
  ASSERT_EQ(rec->commands.size(), 1u);
  const Vec3 q = std::get<GoTo>(rec->commands[0].body).target_mm;
  // The tip reaches q + K q: it must be the wanted position. Exactly, q = (I + K)^-1 P.
  const Vec3 exact = (Eigen::Matrix3d::Identity() + k).inverse() * wanted;
  EXPECT_LT((q - exact).norm(), 1e-9) << (q - exact).transpose();
  EXPECT_LT((q + k * q - wanted).norm(), 1e-9);
  EXPECT_EQ(cmm.queued().size(), 1u);
  EXPECT_EQ(std::get<GoTo>(cmm.queued()[0].body).target_mm, wanted);  // as the client sent it
  cmm.execute();
  PtMeas m;
  m.nominal_mm = wanted;
  cmm.submit({2, m});
  const auto r = cmm.execute();
  ASSERT_TRUE(r.at(0).hit);
  const Vec3 reported = rec->report_mm;
  EXPECT_LT((r[0].hit->centre_mm - (reported + k * reported)).norm(), 1e-12);
  EXPECT_LT((cmm.state().position_mm - (reported + k * reported)).norm(), 1e-12);
}

TEST(CompensatedMachine, WithoutAMapItIsTheIdentity) {
  auto inner = std::make_unique<RecordingMachine>();
  RecordingMachine* rec = inner.get();
  CompensatedMachine cmm(std::move(inner), nullptr);
  cmm.submit({1, GoTo{Vec3(1.25, 2.5, 3.75), std::nullopt}});
  EXPECT_EQ(std::get<GoTo>(rec->commands[0].body).target_mm, Vec3(1.25, 2.5, 3.75));
  PtMeas m;
  cmm.submit({2, m});
  const auto r = cmm.execute();
  EXPECT_EQ(r.at(1).hit->centre_mm, rec->report_mm);
}

// ISO 230-1 by hand (as MachineErrorsInTheCmm): with EXX = k x, a face at true X is touched at
// x_e = X / (1 + k). The map e_x = k x (the true error, on a grid where trilinear is exact)
// reports x_e + k x_e = X: the perfect machine's reading. A flipped sign would give X (1 - k)/(1 + k).
double touch_left_face(const World& world, std::shared_ptr<const ErrorMap> map) {
  CompensatedMachine cmm(std::make_unique<VirtualCmm>(world, 1), std::move(map));
  std::uint64_t tag = 0;
  auto run = [&](decltype(Command::body) body) {
    cmm.submit({++tag, std::move(body)});
    auto r = cmm.execute();
    EXPECT_EQ(r.front().status, Response::Status::Done) << (r.front().fault ? r.front().fault->message : "");
    return r.front();
  };
  run(DefineTool{"T1", 4.0});
  run(SelectTool{"T1"});
  run(GoTo{Vec3(290, 250, 60), std::nullopt});
  run(GoTo{Vec3(290, 250, 20), std::nullopt});
  PtMeas m;
  m.nominal_mm = Vec3(300, 250, 20);
  m.normal = -Vec3::UnitX();
  const Response r = run(m);
  return r.hit ? r.hit->centre_mm.x() : 0.0;
}

World default_with(const std::string& errors_json) {
  World w = default_world();
  w.truth.probe.repeatability_mm = 0;
  if (!errors_json.empty()) w.truth.errors = *parse_machine_errors(nlohmann::json::parse(errors_json));
  return w;
}

std::shared_ptr<const ErrorMap> scale_map_file(double k_per_mm) {
  error_space::ErrorSpace s;
  s.grid.axes_mm = {std::vector<double>{0, 600, 1200}, std::vector<double>{0, 1000}, std::vector<double>{-200, 600}};
  s.values_mm[0].resize(s.grid.size());
  for (std::size_t kk = 0; kk < 2; ++kk)
    for (std::size_t j = 0; j < 2; ++j)
      for (std::size_t i = 0; i < 3; ++i) s.values_mm[0][s.grid.index(i, j, kk)] = k_per_mm * s.grid.axes_mm[0][i];
  error_space::ErrorSpaceFile f;
  f.spaces.push_back(s);
  f.sensor_offset_mm = {0, 0, -50};
  return std::make_shared<const ErrorSpaceMap>(*ErrorSpaceMap::build(f));
}

TEST(CompensatedMachine, AScaleErrorIsUndoneOnATouchOfTheVirtualCmm) {
  const double k = 40e-6;
  const double perfect = touch_left_face(default_with(""), nullptr);
  const World scaled = default_with(R"({"axes": {"x": {"tx_mm": {"poly": [0, 4e-5]}}}})");
  const double raw = touch_left_face(scaled, nullptr);
  const double compensated = touch_left_face(scaled, scale_map_file(k));
  EXPECT_NEAR(raw, perfect / (1 + k), 1e-5);
  EXPECT_NEAR(compensated, perfect, 1e-4)
      << "raw " << (raw - perfect) * 1e3 << " um, compensated " << (compensated - perfect) * 1e3 << " um";
}

// The ball array of programs/worlds/cmm_errors_ball_plate.json (its design: the hidden truth).
std::vector<Vec3> ball_centres() {
  std::vector<Vec3> out;
  for (double y : {150, 400, 650})
    for (double x : {150, 350, 550, 750}) out.emplace_back(x, y, 60);
  for (double y : {275, 525})
    for (double x : {250, 450, 650, 850}) out.emplace_back(x, y, 130);
  return out;
}

/// The calibration that covers the ball array: ram grid 100..900 x 100..700 x 100..200 step 50
/// (the tip 50 mm below), all three components, Delta by reversal, 0.1 um sensors.
SpaceCalibrationPlan ball_array_plan() {
  SpaceCalibrationPlan plan;
  plan.head.spacing_mm = 50;
  plan.head.noise_sd_mm = 0.0001;
  plan.head.sensor_offset_mm = Vec3(0, 0, -50);  // the stylus of T1: the Abbe levers match
  for (int i = 0; i < 17; ++i) plan.grid.axes_mm[0].push_back(100 + 50.0 * i);
  for (int i = 0; i < 13; ++i) plan.grid.axes_mm[1].push_back(100 + 50.0 * i);
  for (int i = 0; i < 3; ++i) plan.grid.axes_mm[2].push_back(100 + 50.0 * i);
  plan.components = {true, true, true};
  plan.delta_by_reversal = true;
  return plan;
}

struct Gain {
  test_support::LengthErrors none, calibrated, truth_grid, truth_exact;
};

Gain measure_gain(const SpaceCalibrationPlan& plan) {
  auto world = load_world(std::string(METRON_SOURCE_DIR) + "/programs/worlds/cmm_errors_ball_plate.json");
  EXPECT_TRUE(world) << world.error().message;
  const auto truth = ball_centres();
  const auto measure = [&](std::shared_ptr<const ErrorMap> map) {
    CompensatedMachine cmm(std::make_unique<VirtualCmm>(*world, 3), std::move(map));
    const auto m = test_support::measure_balls(cmm, truth, 20, 200);
    EXPECT_EQ(m.error, "");
    return test_support::length_errors(m.centres_mm, truth);
  };
  const SpaceCalibration run = calibrate_space(world->truth.errors, plan);  // sensors only
  error_space::ErrorSpaceFile file;
  file.spaces.push_back(run.space);
  file.sensor_offset_mm = {0, 0, -50};
  const auto ideal =
      test_support::truth_error_space(world->truth.errors, plan.grid, Vec3(0, 0, -50), file.interpolation);
  Gain g;
  g.none = measure(nullptr);
  g.calibrated = measure(std::make_shared<const ErrorSpaceMap>(*ErrorSpaceMap::build(file)));
  g.truth_grid = measure(std::make_shared<const ErrorSpaceMap>(*ErrorSpaceMap::build(ideal)));
  g.truth_exact = measure(std::make_shared<const test_support::TruthErrorMap>(world->truth.errors, Vec3(0, 0, -50)));
  std::printf(
      "ball array, %zu length errors (um): none RMS %.3f max %.3f | calibrated RMS %.3f max %.3f | "
      "true map on the grid RMS %.3f max %.3f | true errors exactly RMS %.3f max %.3f\n",
      g.none.pairs, 1e3 * g.none.rms_mm, 1e3 * g.none.max_abs_mm, 1e3 * g.calibrated.rms_mm,
      1e3 * g.calibrated.max_abs_mm, 1e3 * g.truth_grid.rms_mm, 1e3 * g.truth_grid.max_abs_mm,
      1e3 * g.truth_exact.rms_mm, 1e3 * g.truth_exact.max_abs_mm);
  return g;
}

TEST(CompensationGain, BallArrayOnTheCmmErrorsWorld) {
  const Gain g = measure_gain(ball_array_plan());
  EXPECT_GT(g.none.rms_mm, 0.003);  // the machine's errors are really there
  EXPECT_LT(g.truth_exact.rms_mm, g.none.rms_mm / 10);
  EXPECT_LT(g.calibrated.rms_mm, g.none.rms_mm / 5);
}

}  // namespace

namespace {

// What limits the calibrated map: the same run with noiseless sensors and laser leaves only the
// method's systematic errors (the machine's angular errors tilting the head, which the seed
// assumes away) and the interpolation.
TEST(CompensationGain, WithNoiselessSensorsOnlyTheMethodsSystematicsRemain) {
  SpaceCalibrationPlan plan = ball_array_plan();
  plan.head.noise_sd_mm = 0;
  plan.laser_noise_sd_mm = 0;
  const Gain g = measure_gain(plan);
  EXPECT_LT(g.calibrated.rms_mm, g.none.rms_mm / 5);
}

}  // namespace

namespace {

// The chain's sensor noise is what limits the gain (above): four runs per plane and eight laser
// cycles halve the floor.
TEST(CompensationGain, FourRunsPerPlaneReachTheTenfoldGain) {
  SpaceCalibrationPlan plan = ball_array_plan();
  plan.runs = 4;
  plan.laser_cycles = 8;
  const Gain g = measure_gain(plan);
  EXPECT_LT(g.calibrated.rms_mm, g.none.rms_mm / 10);
}

}  // namespace

namespace {

// The commanded side, physically: with EXX = -k x (k = 40 um/m) the tip is at q (1 - k) when the
// scales read q, so the ball centre touching the face x = 300 (at true x = 298) reads
// 298 / (1 - k) = 298.012, and the trigger comes about 14 um later (pre-travel and delays). A
// touch told to search only 20 um past the nominal finds nothing without the map (26 um needed),
// succeeds when the map moves the commanded nominal by -e = +12 um (14 um needed), and faults
// again when the sign is flipped (38 um needed).
Response touch_with_short_search(const World& world, std::shared_ptr<const ErrorMap> map, double search_mm = 0.020) {
  CompensatedMachine cmm(std::make_unique<VirtualCmm>(world, 1), std::move(map));
  std::uint64_t tag = 0;
  auto run = [&](decltype(Command::body) body) {
    cmm.submit({++tag, std::move(body)});
    return cmm.execute().front();
  };
  run(DefineTool{"T1", 4.0});
  run(SelectTool{"T1"});
  run(GoTo{Vec3(290, 250, 60), std::nullopt});
  run(GoTo{Vec3(290, 250, 20), std::nullopt});
  PtMeas m;
  m.nominal_mm = Vec3(300, 250, 20);
  m.normal = -Vec3::UnitX();
  m.search_mm = search_mm;
  return run(m);
}

TEST(CompensatedMachine, TheCommandedNominalIsMovedByMinusE) {
  const World long_scale = default_with(R"({"axes": {"x": {"tx_mm": {"poly": [0, -4e-5]}}}})");
  const Response raw = touch_with_short_search(long_scale, nullptr);
  EXPECT_EQ(raw.status, Response::Status::Fault) << (raw.hit ? raw.hit->centre_mm.x() - 298 : 0.0);
  const Response r = touch_with_short_search(long_scale, scale_map_file(-40e-6));
  ASSERT_EQ(r.status, Response::Status::Done) << (r.fault ? r.fault->message : "");
  // (Its reading is not compared here: this close to the search end the probe is already braking
  // at the trigger, so the delays carry it less far; AScaleErrorIsUndone... checks the reading.)
}

}  // namespace

namespace {

// The file's grid is in ram positions of the calibrating sensor: the map answers for the tip at
// grid + sensor_offset_mm, and the offset survives the file.
TEST(ErrorSpaceMap, IsQueriedAtTheTipMinusTheSensorOffsetAndKeepsItInTheFile) {
  error_space::ErrorSpace s;
  s.grid.axes_mm = {std::vector<double>{0, 1000}, std::vector<double>{0, 1000}, std::vector<double>{0, 500}};
  s.values_mm[2].resize(s.grid.size());
  for (std::size_t k = 0; k < 2; ++k)
    for (std::size_t j = 0; j < 2; ++j)
      for (std::size_t i = 0; i < 2; ++i)
        s.values_mm[2][s.grid.index(i, j, k)] = 1e-5 * s.grid.axes_mm[2][k];  // e_z = 1e-5 z_ram
  error_space::ErrorSpaceFile f;
  f.spaces.push_back(s);
  f.sensor_offset_mm = {0, 0, -50};
  const auto back = error_space::from_json(error_space::to_json(f));
  ASSERT_TRUE(back) << back.error().pointer << ": " << back.error().message;
  EXPECT_EQ(back->sensor_offset_mm, f.sensor_offset_mm);
  const auto map = ErrorSpaceMap::build(*back);
  ASSERT_TRUE(map) << map.error();
  // The tip at z = 100 had the ram at z = 150.
  EXPECT_NEAR(map->error_at_mm(Vec3(300, 400, 100)).z(), 1e-5 * 150, 1e-15);
}

}  // namespace

namespace {

// e_z = k x^2 on a 50 mm grid in x (trilinear: at most k h^2 / 4 = 0.125 um from the parabola).
std::shared_ptr<const ErrorMap> bow_map_file(double k_per_mm2) {
  error_space::ErrorSpace s;
  std::vector<double> xs;
  for (int i = 0; i <= 24; ++i) xs.push_back(50.0 * i);
  s.grid.axes_mm = {xs, std::vector<double>{0, 1000}, std::vector<double>{-200, 600}};
  s.values_mm[2].resize(s.grid.size());
  for (std::size_t kk = 0; kk < 2; ++kk)
    for (std::size_t j = 0; j < 2; ++j)
      for (std::size_t i = 0; i < xs.size(); ++i) s.values_mm[2][s.grid.index(i, j, kk)] = k_per_mm2 * xs[i] * xs[i];
  error_space::ErrorSpaceFile f;
  f.spaces.push_back(s);
  f.sensor_offset_mm = {0, 0, -50};
  return std::make_shared<const ErrorSpaceMap>(*ErrorSpaceMap::build(f));
}

// The heights of the block's TOP face (z = 40) scanned along x from 310 to 450 at y 205 (clear of
// the bores and the countersink), surface points of the samples.
std::vector<double> scanned_top_heights(const World& world, std::shared_ptr<const ErrorMap> map) {
  CompensatedMachine cmm(std::make_unique<VirtualCmm>(world, 1), std::move(map));
  test_support::BlockProbing probing(cmm);
  auto run = [&](decltype(Command::body) body) { return probing.run(std::move(body)); };
  run(GoTo{Vec3(305, 205, 60), std::nullopt});
  ScanPath c;
  const double centre_z = 40 + 2 - 0.3;  // ball radius 2, reference deflection 0.3
  scan_test::add_line(c.path, Vec3(310, 205, centre_z), Vec3(450, 205, centre_z), 10, Vec3::UnitZ());
  c.approach_normal = Vec3::UnitZ();
  c.sample_spacing_mm = 1;
  const Response r = run(c);
  std::vector<double> z;
  for (const ScanSample& s : r.scan) z.push_back(s.surface_mm(2.0).z());
  return z;
}

// A bowed X guideway (EZX = k x^2, 19 to 41 um over the scan) makes the flat TOP face scan as a
// 21 um slope; the map of the same bow, applied to the scan's samples, brings it back to the
// perfect machine's flat face. (The scanning probe's own ball radius error is the same in all
// three, so the heights are compared with the perfect machine's, not with 40.)
TEST(CompensatedMachine, AScanOfAFlatFaceOnABowedGuidewayIsFlatAgainWithTheMap) {
  const double k = 2e-7;
  const World bowed = default_with(R"({"axes": {"x": {"tz_mm": {"poly": [0, 0, 2e-7]}}}})");
  const auto perfect = scanned_top_heights(default_with(""), nullptr);
  const auto raw = scanned_top_heights(bowed, nullptr);
  const auto compensated = scanned_top_heights(bowed, bow_map_file(k));
  ASSERT_GT(perfect.size(), 100u);
  auto range = [](const std::vector<double>& v) {
    const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
    return *hi - *lo;
  };
  auto mean = [](const std::vector<double>& v) {
    return std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  };
  std::printf("TOP face heights over the scan, range: perfect %.3f um, bowed %.3f um, bowed with the map %.3f um\n",
              1e3 * range(perfect), 1e3 * range(raw), 1e3 * range(compensated));
  EXPECT_GT(range(raw), 0.018) << "the bow shows: k (450^2 - 310^2) = 21 um";
  EXPECT_LT(range(compensated), range(perfect) + 0.001)
      << "raw " << range(raw) * 1e3 << " um, compensated " << range(compensated) * 1e3 << " um, perfect "
      << range(perfect) * 1e3;
  EXPECT_NEAR(mean(compensated), mean(perfect), 0.001);
}

}  // namespace

namespace {

// The default block's machine with an X scale (10.5 um/m/K, fixed at 0) following an air history
// without lag: a thermometer on the scales reads it.
World warm_block(const std::string& air_json) {
  return default_with(R"({"thermal": {"air_c": )" + air_json +
                      R"(, "scales": {"x": {"alpha_per_k": 10.5e-6, "temperature": {"lag_s": 0}}}}})");
}

// The block's LEFT and RIGHT faces probed (y 250, z 20), each from outside; the ball centres' x
// distance. `wait_s`: a long positioning loop first (the air moves meanwhile).
double block_width(const World& world, std::shared_ptr<const ErrorMap> map, double wait_s = 0) {
  CompensatedMachine cmm(std::make_unique<VirtualCmm>(world, 1), std::move(map));
  test_support::BlockProbing probing(cmm);
  probing.pass_time(wait_s);
  const double left = probing.touch_face(300, -1).centre_mm.x();
  return probing.touch_face(460, 1).centre_mm.x() - left;
}

// An e_x calibration plan (0.1 um sensors, the stylus' 50 mm offset, 8 laser cycles) over a grid
// from `origin` in steps of `step` with `counts` points per axis.
SpaceCalibrationPlan e_x_plan(const Vec3& origin, double step, const std::array<int, 3>& counts) {
  SpaceCalibrationPlan plan;
  plan.head.spacing_mm = step;
  plan.head.noise_sd_mm = 0.0001;
  plan.head.sensor_offset_mm = Vec3(0, 0, -50);
  for (int a = 0; a < 3; ++a)
    for (int i = 0; i < counts[static_cast<std::size_t>(a)]; ++i) plan.grid.axes_mm[a].push_back(origin[a] + step * i);
  plan.components = {true, false, false};
  plan.laser_cycles = 8;
  return plan;
}

// The block's machine calibrated at each of `temperatures` (e_x over the block, the laser giving
// the scale), one file with all the spaces; the controller interpolates them by its thermometer.
error_space::ErrorSpaceFile two_temperature_file(std::vector<double> temperatures) {
  const SpaceCalibrationPlan plan = e_x_plan(Vec3(250, 200, 50), 50, {7, 3, 3});
  error_space::ErrorSpaceFile f;
  f.sensor_offset_mm = {0, 0, -50};
  for (double t : temperatures) {
    const World w = warm_block(fmt::format(R"({{"t_s": [0], "temperature_c": [{}]}})", t));
    f.spaces.push_back(calibrate_space(w.truth.errors, plan).space);
  }
  return f;
}

// The block at 22 C: the map interpolated between 20 and 24 C by the thermometer reads it as the
// perfect machine does; the nearest calibrated space (20 C only) leaves the scale's growth,
// alpha 2 K 160 mm = 3.4 um. The air then warming 20 -> 24 C during the run: the map follows. (A
// map without the thermometer stays at 20 C: the `nearest` figures.)
TEST(CompensatedMachine, AMapAtTwoTemperaturesFollowsTheMachinesThermometer) {
  const auto both = two_temperature_file({20, 24});
  ASSERT_DOUBLE_EQ(both.spaces[0].temperature_c, 20);  // labelled by the thermometer at the calibration
  ASSERT_DOUBLE_EQ(both.spaces[1].temperature_c, 24);
  auto only20 = both;
  only20.spaces.pop_back();
  const auto interpolated = std::make_shared<const ErrorSpaceMap>(*ErrorSpaceMap::build(both));
  const auto nearest = std::make_shared<const ErrorSpaceMap>(*ErrorSpaceMap::build(only20));

  const double perfect = block_width(default_with(""), nullptr);
  const World at22 = warm_block(R"({"t_s": [0], "temperature_c": [22]})");
  const double raw = block_width(at22, nullptr) - perfect;
  const double with_interpolated = block_width(at22, interpolated) - perfect;
  const double with_nearest = block_width(at22, nearest) - perfect;
  // The air warms from 20 to 24 C over 400 s; the block is probed after 300 s (23 C and rising).
  const World warming = warm_block(R"({"t_s": [0, 400], "temperature_c": [20, 24]})");
  const double warming_perfect = block_width(default_with(""), nullptr, 300);
  const double warming_interpolated = block_width(warming, interpolated, 300) - warming_perfect;
  const double warming_nearest = block_width(warming, nearest, 300) - warming_perfect;
  std::printf(
      "block width minus the perfect machine's, um: at 22 C raw %.3f, nearest (20 C) %.3f, interpolated %.3f; "
      "warming to 23 C: nearest %.3f, interpolated %.3f\n",
      1e3 * raw, 1e3 * with_nearest, 1e3 * with_interpolated, 1e3 * warming_nearest, 1e3 * warming_interpolated);
  EXPECT_NEAR(with_nearest, -10.5e-6 * 2 * 160, 0.0005);  // the map at 20 C undoes the 20 C errors only
  EXPECT_NEAR(with_interpolated, 0, 0.0004);
  EXPECT_LT(warming_nearest, -10.5e-6 * 3 * 160);  // 3 K and more by the time of the touches
  EXPECT_NEAR(warming_interpolated, 0, 0.0004);
}

}  // namespace

namespace {

// The effective radius of T1 qualified on the reference sphere (900, 700, 100), as the machine in
// front of the runtime reports it.
double qualified_radius(const World& world, std::shared_ptr<const ErrorMap> map) {
  CompensatedMachine cmm(std::make_unique<VirtualCmm>(world, 1), std::move(map));
  test_support::BlockProbing probing(cmm);
  auto run = [&](decltype(Command::body) body) { return probing.run(std::move(body)); };
  const Response q = run(QualifyTool{});
  EXPECT_TRUE(q.tool && q.tool->qualified);
  EXPECT_EQ(cmm.state().tool->effective_radius_mm, q.tool->effective_radius_mm);
  return q.tool ? q.tool->effective_radius_mm : 0.0;
}

// The qualification is probing too: on the X scale warmed to 24 C (the reference sphere stretched
// along x as the scales see it) the machine's own fit gives another effective radius than the
// perfect machine's; refitted through a map of the sphere's region it is the perfect machine's
// again, and so are the bores and bosses sized with it.
TEST(CompensatedMachine, TheQualificationIsRefittedThroughTheMap) {
  // A map over the sphere (the block's grid does not reach it), calibrated at 24 C.
  error_space::ErrorSpaceFile f;
  f.sensor_offset_mm = {0, 0, -50};
  const World at24 = warm_block(R"({"t_s": [0], "temperature_c": [24]})");
  f.spaces.push_back(calibrate_space(at24.truth.errors, e_x_plan(Vec3(850, 650, 125), 25, {5, 5, 3})).space);
  const auto sphere_map = std::make_shared<const ErrorSpaceMap>(*ErrorSpaceMap::build(f));

  const double perfect = qualified_radius(default_with(""), nullptr);
  const double raw = qualified_radius(at24, nullptr);
  const double compensated = qualified_radius(at24, sphere_map);
  std::printf("effective radius minus the perfect machine's, um: raw %.3f, through the map %.3f\n",
              1e3 * (raw - perfect), 1e3 * (compensated - perfect));
  EXPECT_GT(std::abs(raw - perfect), 0.0002);
  EXPECT_NEAR(compensated, perfect, 0.00005);
}

}  // namespace
