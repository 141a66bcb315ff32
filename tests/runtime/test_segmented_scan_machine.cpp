// SPDX-License-Identifier: GPL-3.0-or-later
// Segmented scanning end to end through the command interface (SEEDS.md 2 over SEEDS.md 1): the
// runtime splits a scan longer than the machine's command buffer and writes it command by
// command (ScanBufferWrite); the VirtualCmm runs the segmented controller on the real scanning
// probe against the simulated part.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "fixtures.hpp"
#include "metron/machine/active_scanning/scan_controller.hpp"
#include "metron/machine/virtual_cmm.hpp"
#include "metron/runtime/scan_segmentation.hpp"
#include "metron/stdlib/fitting/fit.hpp"
#include "scan_paths.hpp"

namespace {

using namespace metron;
using namespace metron::machine;

constexpr double ball_r = 2, e0 = 0.3;

using test_support::world_file;

// Each segment cut into `pieces` Hermite segments (normals interpolated): a long path of short
// segments over the same curve.
geometry::PccPath subdivided(const geometry::PccPath& p, int pieces) {
  geometry::PccPath out;
  for (std::size_t k = 0; k < p.segments.size(); ++k) {
    const auto& g = p.segments[k];
    for (int i = 0; i < pieces; ++i) {
      const double u0 = g.d_mm * i / pieces, u1 = g.d_mm * (i + 1) / pieces;
      out.segments.push_back(geometry::PccSegment::hermite(g.point(u0), g.point(u1), g.tangent(u0), g.tangent(u1)));
      const double w = static_cast<double>(i) / pieces;
      out.normals.push_back(((1 - w) * p.normals[k] + w * p.normals[k + 1]).normalized());
    }
  }
  out.normals.push_back(p.normals.back());
  return out;
}

void start_machine(VirtualCmm& cmm) {
  cmm.submit({1, DefineTool{"T1", 2 * ball_r}});
  cmm.submit({2, SelectTool{"T1"}});
  for (const Response& r : cmm.execute()) ASSERT_EQ(r.status, Response::Status::Done);
}

// One ordered point set: a sample every spacing of path, never twice the same place, none
// missing: a gap may exceed the spacing only by what the foot travels in one cycle (`extra_mm`).
void expect_continuous(const std::vector<ScanSample>& s, double spacing_mm, double length_mm, double extra_mm) {
  ASSERT_GT(s.size(), 10u);
  for (std::size_t i = 1; i < s.size(); ++i) {
    const double ds = s[i].path_s_mm - s[i - 1].path_s_mm;
    ASSERT_GE(ds, spacing_mm - 1e-9) << "sample " << i;
    ASSERT_LT(ds, spacing_mm + extra_mm) << "sample " << i << " at s " << s[i].path_s_mm;
    ASSERT_GT(s[i].time_s, s[i - 1].time_s);
  }
  EXPECT_LT(s.front().path_s_mm, spacing_mm);
  EXPECT_GT(s.back().path_s_mm, length_mm - spacing_mm - extra_mm);
}

const char* name(segmented::SegmentedMode m) {
  using enum segmented::SegmentedMode;
  return m == Conventional ? "conventional" : m == Seed ? "seed" : "look-ahead";
}

}  // namespace

// The world record, its defaults and its errors.
TEST(SegmentedScanMachine, WorldRecordConfiguresTheBuffers) {
  const World d = default_world();
  EXPECT_GE(d.machine.scanning.segmented.buffer_segments, 100000u);  // every usual scan fits one buffer
  const auto j = nlohmann::json::parse(R"({"segmented": {"buffer_segments": 50, "mode": "look_ahead",
                                           "planning_s_per_segment": 0.001, "low_speed_mm_s": 2}})");
  ScanningSpec spec;
  ScanningTruth truth;
  const auto parse = [&](const nlohmann::json& json) { return parse_scanning_spec(json, "/scanning", spec, truth); };
  ASSERT_TRUE(parse(j));
  const ScanningSpec* s = &spec;
  EXPECT_EQ(s->segmented.buffer_segments, 50u);
  EXPECT_EQ(s->segmented.mode, segmented::SegmentedMode::LookAhead);
  EXPECT_DOUBLE_EQ(s->segmented.planning_s_per_segment, 0.001);
  EXPECT_DOUBLE_EQ(s->segmented.low_speed_mm_s, 2);
  const auto bad_mode = parse(nlohmann::json::parse(R"({"segmented": {"mode": "fast"}})"));
  ASSERT_FALSE(bad_mode);
  EXPECT_EQ(bad_mode.error().pointer, "/scanning/segmented/mode");
  const auto bad_low = parse(nlohmann::json::parse(R"({"segmented": {"low_speed_mm_s": 8}})"));
  ASSERT_FALSE(bad_low);
  EXPECT_EQ(bad_low.error().pointer, "/scanning/segmented/low_speed_mm_s");
}

// Three turns around the lobed boss world (2,500 segments) through buffers of 100 segments.
TEST(SegmentedScanMachine, LobedBossThroughSmallBuffersInEveryMode) {
  World w = world_file("scan_lobed_circle.json");
  w.machine.scanning.segmented.buffer_segments = 100;
  ScanPath c;
  const double r = 25 + ball_r - e0;
  c.path = scan_test::circle_path(Vec3(200, 300, 15), r, true, 0, 3 * 360.0);
  c.path = subdivided(c.path, 30);  // 10 degree arcs in 30: 0.157 mm segments
  c.approach_normal = Vec3::UnitX();
  c.sample_spacing_mm = 0.2;
  ASSERT_GT(c.path.segments.size(), 3000u);
  for (const auto mode :
       {segmented::SegmentedMode::Conventional, segmented::SegmentedMode::Seed, segmented::SegmentedMode::LookAhead}) {
    w.machine.scanning.segmented.mode = mode;
    VirtualCmm cmm(w, 1);
    start_machine(cmm);
    cmm.submit({3, GoTo{scan_approach_point(c) + Vec3(0, 0, 40), std::nullopt}});  // clear of the boss top
    ASSERT_EQ(cmm.execute().front().status, Response::Status::Done);
    EXPECT_EQ(cmm.state().scan_buffer_segments, 100u);
    // The machine refuses a path longer than its buffer: splitting is the host's job.
    cmm.submit({4, c});
    const auto refused = cmm.execute();
    ASSERT_EQ(refused.front().status, Response::Status::Fault);
    EXPECT_EQ(refused.front().fault->kind, FaultKind::BadCommand);
    const double t0 = cmm.simulated_time_s();
    const runtime::SegmentedScanResult res = runtime::scan_segmented(cmm, c, 5);
    ASSERT_FALSE(res.fault) << res.fault->message;
    EXPECT_EQ(res.commands, runtime::command_sizes(c.path.segments.size(), 100).size());
    // The machine's own account: every boundary a stop in the conventional mode, none else
    // (Tp = 1.3 * 100 * 1 us by default fits in every command).
    ASSERT_FALSE(res.log.empty());
    const std::string stops = mode == segmented::SegmentedMode::Conventional
                                  ? fmt::format("{} stops, {} retracts", res.commands - 1, res.commands)
                                  : std::string("0 stops, 1 retracts");
    EXPECT_NE(res.log.back().find(stops), std::string::npos) << res.log.back();
    // A smooth circle: the foot moves with the head, 0.01 mm per cycle at 10 mm/s.
    expect_continuous(res.samples, c.sample_spacing_mm, c.path.length(), 0.05);
    const auto f = metron::scan_test::fit_scanned_boss(res.samples, ball_r);
    ASSERT_TRUE(f);
    EXPECT_NEAR(f->form_mm, 0.005, 0.001);  // the world's hidden 3-lobe form
    EXPECT_NEAR(f->position.x(), 200.15, 0.001);
    EXPECT_NEAR(f->position.y(), 299.9, 0.001);
    // The session is over: ordinary commands run again.
    cmm.submit({6, GoTo{scan_approach_point(c) + Vec3(0, 0, 40), std::nullopt}});
    EXPECT_EQ(cmm.execute().front().status, Response::Status::Done);
    std::printf("[figures] VirtualCmm lobed boss, P = 100, %s: %zu commands, %zu samples, scan %.2f s, form %.5f mm\n",
                name(mode), res.commands, res.samples.size(), cmm.simulated_time_s() - t0, f->form_mm);
  }
}

// The free-form world's section (about 2,600 segments of 0.02 mm) through buffers of 50: the
// hidden 10 um bump is found in every mode.
TEST(SegmentedScanMachine, FreeFormBumpThroughSmallBuffers) {
  World w = world_file("scan_freeform_bump.json");
  w.machine.scanning.segmented.buffer_segments = 50;
  const auto height = [](double x) { return 20 + 1.5 * std::sin(x / 12); };  // at y = 0
  std::vector<Vec3> section;
  for (double x = 4; x <= 56 + 1e-9; x += 2) section.emplace_back(x, 0, height(x));
  geometry::PccPath p = scan_test::profile_path_xz(section, ball_r - e0, 2.0);
  for (auto& s : p.segments) s.k.col(0) += Vec3(100, 100, 0);
  ScanPath c;
  c.path = subdivided(p, 50);
  c.approach_normal = c.path.normals.front();
  ASSERT_GT(c.path.segments.size(), 2000u);
  for (const auto mode :
       {segmented::SegmentedMode::Conventional, segmented::SegmentedMode::Seed, segmented::SegmentedMode::LookAhead}) {
    w.machine.scanning.segmented.mode = mode;
    VirtualCmm cmm(w, 1);
    start_machine(cmm);
    const double t0 = cmm.simulated_time_s();
    const runtime::SegmentedScanResult res = runtime::scan_segmented(cmm, c, 5);
    ASSERT_FALSE(res.fault) << res.fault->message;
    // At the section's corners (every 2 mm) the ball rolls round the mesh edge inside the
    // path's 2 mm fillets and the foot runs several times faster than the head (an unsegmented
    // scan of this path shows the same 0.13 mm gaps): no sample may be missing, i.e. every gap
    // stays below two spacings.
    expect_continuous(res.samples, c.sample_spacing_mm, c.path.length(), c.sample_spacing_mm);
    double peak = 0, at = 0;
    for (const ScanSample& s : res.samples) {
      const Vec3 q = s.surface_mm(ball_r) - Vec3(100, 100, 0);
      const double x0 = 2 * std::floor(q.x() / 2), z0 = height(x0), z1 = height(x0 + 2);
      const double dev = (q.z() - (z0 + (z1 - z0) * (q.x() - x0) / 2)) * std::cos(std::atan((z1 - z0) / 2));
      if (dev > peak) peak = dev, at = q.x();
    }
    EXPECT_NEAR(peak, 0.010, 0.001);
    EXPECT_NEAR(at, 30, 0.5);
    std::printf(
        "[figures] VirtualCmm free-form bump, P = 50, %s: %zu commands, %zu samples, scan %.2f s, "
        "peak %.5f mm at x %.2f\n",
        name(mode), res.commands, res.samples.size(), cmm.simulated_time_s() - t0, peak, at);
  }
}

// The buffer-write protocol: a session starts with command 0, takes its commands in order and
// nothing else; a fault ends it.
TEST(SegmentedScanMachine, BufferWritesFollowTheProtocol) {
  World w = world_file("scan_lobed_circle.json");
  w.machine.scanning.segmented.buffer_segments = 100;
  ScanPath c;
  c.path = subdivided(scan_test::circle_path(Vec3(200, 300, 15), 25 + ball_r - e0, true, 0, 90), 30);
  c.approach_normal = Vec3::UnitX();
  const auto commands = runtime::split_commands(c.path, 100);
  ASSERT_EQ(commands.size(), 3u);  // 270 segments
  const auto write = [&](std::size_t i) {
    ScanBufferWrite b;
    b.scan = c;
    b.scan.path = {};
    b.command = commands[i];
    return b;
  };
  VirtualCmm cmm(w, 1);
  start_machine(cmm);
  cmm.submit({3, GoTo{scan_approach_point(c) + Vec3(0, 0, 40), std::nullopt}});
  ASSERT_EQ(cmm.execute().front().status, Response::Status::Done);
  cmm.submit({4, write(1)});  // no session yet
  auto r = cmm.execute();
  ASSERT_EQ(r.front().status, Response::Status::Fault);
  EXPECT_NE(r.front().fault->message.find("without a segmented scan"), std::string::npos);
  cmm.submit({5, write(0)});
  r = cmm.execute();
  ASSERT_EQ(r.front().status, Response::Status::Done) << r.front().fault->message;
  cmm.submit({6, GoTo{Vec3(0, 0, 0), std::nullopt}});  // not while scanning
  r = cmm.execute();
  ASSERT_EQ(r.front().status, Response::Status::Fault);
  EXPECT_NE(r.front().fault->message.find("in progress"), std::string::npos);
  cmm.submit({7, write(2)});  // out of order: the controller refuses it, the session ends
  r = cmm.execute();
  ASSERT_EQ(r.front().status, Response::Status::Fault);
  EXPECT_NE(r.front().fault->message.find("out of order"), std::string::npos);
  cmm.submit({8, GoTo{scan_approach_point(c) + Vec3(0, 0, 40), std::nullopt}});
  EXPECT_EQ(cmm.execute().front().status, Response::Status::Done);
  // And a whole session in order scans the quarter circle.
  std::vector<ScanSample> all;
  for (std::size_t i = 0; i < commands.size(); ++i) {
    cmm.submit({9 + i, write(i)});
    r = cmm.execute();
    ASSERT_EQ(r.front().status, Response::Status::Done) << r.front().fault->message;
    all.insert(all.end(), r.front().scan.begin(), r.front().scan.end());
  }
  expect_continuous(all, c.sample_spacing_mm, c.path.length(), 0.05);
}
