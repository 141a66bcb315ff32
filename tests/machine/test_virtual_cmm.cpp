// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <random>

#include "fixtures.hpp"
#include "metron/machine/mesh_solid.hpp"
#include "metron/machine/virtual_cmm.hpp"
#include "metron/stdlib/fitting/fit.hpp"

using namespace metron;
using namespace metron::machine;

namespace {

const Vec3 part_origin(300, 200, 0);  // the block's corner in the machine (default pose)
constexpr double deg = std::numbers::pi / 180;

using test_support::world_file;

World noiseless(World w) {
  w.truth.probe.repeatability_mm = 0;
  return w;
}

using Body = decltype(Command::body);

// Drives a VirtualCmm one command at a time, the way a runtime would.
class Cmm {
 public:
  explicit Cmm(const World& world, std::uint64_t seed = 1) : m_cmm(world, seed) {}

  Response run(Body body) {
    m_cmm.submit({++m_tag, std::move(body)});
    auto r = m_cmm.execute();
    EXPECT_EQ(r.size(), 1u);
    return r.front();
  }
  void ok(Body body) {
    const Response r = run(std::move(body));
    ASSERT_EQ(r.status, Response::Status::Done) << r.fault->message;
  }
  void tool(double diameter_mm, const std::string& name = "T1") {
    ok(DefineTool{name, diameter_mm});
    ok(SelectTool{name});
  }
  ToolInfo qualify() {
    const Response r = run(QualifyTool{});
    EXPECT_EQ(r.status, Response::Status::Done) << (r.fault ? r.fault->message : "");
    return r.tool.value_or(ToolInfo{});
  }
  void go(const Vec3& p) { ok(GoTo{p, std::nullopt}); }
  Hit point(const Vec3& nominal, const Vec3& normal, double approach = 2, double search = 5,
            std::optional<double> speed = std::nullopt) {
    PtMeas m;
    m.nominal_mm = nominal;
    m.normal = normal.normalized();
    m.approach_mm = approach;
    m.search_mm = search;
    m.speed_mm_s = speed;
    const Response r = run(m);
    EXPECT_EQ(r.status, Response::Status::Done) << (r.fault ? r.fault->message : "");
    return r.hit.value_or(Hit{});
  }
  VirtualCmm& machine() { return m_cmm; }

 private:
  VirtualCmm m_cmm;
  std::uint64_t m_tag = 0;
};

std::vector<Vec3> centres(const std::vector<Hit>& hits) {
  std::vector<Vec3> out;
  for (const Hit& h : hits) out.push_back(h.centre_mm);
  return out;
}

fitting::FitOptions compensated(const std::vector<Hit>& hits, bool inner) {
  fitting::FitOptions o;
  fitting::Compensation c;
  c.ball_radius_mm = hits.front().ball_radius_mm;
  for (const Hit& h : hits) c.approach.push_back(h.normal);
  o.compensation = c;
  o.inner = inner;
  return o;
}

fitting::FitResult fit(fitting::Shape shape, const std::vector<Hit>& hits, fitting::FitOptions options) {
  auto f = fitting::fit(shape, centres(hits), options);
  if (!f) throw std::runtime_error("fit failed: " + fitting::to_string(f.error()));
  return *f;
}

// TOP plane points (part x, y), away from the holes, the boss and the sphere.
std::vector<Hit> probe_top(Cmm& cmm) {
  std::vector<Hit> hits;
  for (const Vec2& xy : {Vec2(10, 10), Vec2(150, 10), Vec2(150, 90), Vec2(10, 90), Vec2(100, 50), Vec2(60, 30)}) {
    const Vec3 p = part_origin + Vec3(xy.x(), xy.y(), 40);
    cmm.go(p + Vec3(0, 0, 20));
    hits.push_back(cmm.point(p, Vec3::UnitZ()));
  }
  return hits;
}

// A circle of points on an axial (vertical) round feature, probed along the radius.
std::vector<Hit> probe_round(Cmm& cmm, const Vec3& axis_point_machine, double radius_mm, double z_mm, int n, bool inner,
                             double phase_deg = 0) {
  std::vector<Hit> hits;
  const Vec3 c(axis_point_machine.x(), axis_point_machine.y(), z_mm);
  if (inner) {
    cmm.go(c + Vec3(0, 0, 60 - z_mm + 10));
    cmm.go(c);
  }
  for (int i = 0; i < n; ++i) {
    const double a = (phase_deg + 360.0 * i / n) * deg;
    const Vec3 radial(std::cos(a), std::sin(a), 0);
    const Vec3 nominal = c + radius_mm * radial;
    if (!inner) {
      const Vec3 over = nominal + 6 * radial;
      cmm.go(Vec3(over.x(), over.y(), 80));
    }
    hits.push_back(cmm.point(nominal, inner ? -radial : radial));
    if (!inner)
      cmm.go(Vec3(hits.back().centre_mm.x() + 2 * radial.x(), hits.back().centre_mm.y() + 2 * radial.y(), 80));
  }
  cmm.go(Vec3(c.x(), c.y(), 80));
  return hits;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Exactness: an ideal probe on a perfect part returns the design within 0.1 um.

TEST(VirtualCmm, PerfectPartPlaneIsExact) {
  Cmm cmm(world_file("perfect.json"));
  cmm.tool(4);
  const auto hits = probe_top(cmm);
  for (const Hit& h : hits) EXPECT_NEAR(h.surface_mm().z(), 40, 1e-4);
  const auto f = fit(fitting::Shape::Plane, hits, compensated(hits, false));
  EXPECT_NEAR(f.position.z(), 40, 1e-4);
  EXPECT_NEAR(f.direction.dot(Vec3::UnitZ()), 1, 1e-12);
  EXPECT_LT(f.form_mm, 1e-4);
  RecordProperty("top_plane_error_um", std::to_string((f.position.z() - 40) * 1000));
}

TEST(VirtualCmm, PerfectPartBoreIsExact) {
  Cmm cmm(world_file("perfect.json"));
  cmm.tool(4);
  auto hits = probe_round(cmm, part_origin + Vec3(40, 50, 0), 10, 30, 8, true);
  const auto upper = probe_round(cmm, part_origin + Vec3(40, 50, 0), 10, 20, 8, true, 22.5);
  hits.insert(hits.end(), upper.begin(), upper.end());
  auto options = compensated(hits, true);
  options.direction_hint = Vec3::UnitZ();
  const auto f = fit(fitting::Shape::Cylinder, hits, options);
  EXPECT_NEAR(f.diameter_mm, 20, 1e-4);
  EXPECT_NEAR(f.position.x(), 340, 1e-4);
  EXPECT_NEAR(f.position.y(), 250, 1e-4);
  EXPECT_NEAR(std::abs(f.direction.z()), 1, 1e-10);
  EXPECT_LT(f.form_mm, 1e-4);
  std::cout << "perfect BORE1: diameter error " << (f.diameter_mm - 20) * 1e3 << " um, axis error "
            << std::hypot(f.position.x() - 340, f.position.y() - 250) * 1e3 << " um\n";
}

TEST(VirtualCmm, PerfectPartSphereIsExact) {
  Cmm cmm(world_file("perfect.json"));
  cmm.tool(4);
  const Vec3 c = part_origin + Vec3(75, 75, 48);
  std::vector<Hit> hits;
  cmm.go(c + Vec3(0, 0, 30));
  hits.push_back(cmm.point(c + Vec3(0, 0, 10), Vec3::UnitZ()));
  for (double el : {0.0, 30.0, 60.0}) {
    for (int i = 0; i < 6; ++i) {
      const double az = (60.0 * i + el) * deg, e = el * deg;
      const Vec3 d(std::cos(e) * std::cos(az), std::cos(e) * std::sin(az), std::sin(e));
      const Vec3 over = c + 14 * d;
      cmm.go(Vec3(over.x(), over.y(), c.z() + 30));
      hits.push_back(cmm.point(c + 10 * d, d));
    }
  }
  const auto f = fit(fitting::Shape::Sphere, hits, compensated(hits, false));
  EXPECT_NEAR(f.diameter_mm, 20, 1e-4);
  EXPECT_LT((f.position - c).norm(), 1e-4);
  std::cout << "perfect SPHERE1: diameter error " << (f.diameter_mm - 20) * 1e3 << " um, centre error "
            << (f.position - c).norm() * 1e3 << " um\n";
}

TEST(VirtualCmm, PerfectPartConeIsExact) {
  Cmm cmm(world_file("perfect.json"));
  cmm.tool(2);  // r = 1 fits in the countersink
  const Vec3 apex = part_origin + Vec3(40, 20, 32);
  const Vec3 air_side(0, 0, 1);
  std::vector<Hit> hits;
  cmm.go(apex + Vec3(0, 0, 40));
  cmm.go(apex + Vec3(0, 0, 6.5));
  for (double h : {3.0, 6.0}) {
    for (int i = 0; i < 8; ++i) {
      const double a = (45.0 * i + 10 * h) * deg;
      const Vec3 radial(std::cos(a), std::sin(a), 0);
      const Vec3 wall = apex + h * radial + h * air_side;  // half-angle 45: radius = height
      const Vec3 normal = (-radial + air_side).normalized();
      hits.push_back(cmm.point(wall, normal, 1, 1));
    }
  }
  auto options = compensated(hits, true);
  options.direction_hint = Vec3::UnitZ();
  const auto f = fit(fitting::Shape::Cone, hits, options);
  EXPECT_NEAR(f.apex_angle_deg, 90, 1e-5);
  // The apex from the NIST convention: radius at `position` = distance / cos(half angle).
  const double half = f.apex_angle_deg / 2 * deg;
  const Vec3 fitted_apex = f.position - f.cone_distance_mm / std::cos(half) / std::tan(half) * f.direction;
  EXPECT_LT((fitted_apex - apex).norm(), 1e-4) << fitted_apex.transpose();
  EXPECT_LT(f.form_mm, 1e-4);
  std::cout << "perfect CONE1: apex error " << (fitted_apex - apex).norm() * 1e3 << " um, angle error "
            << (f.apex_angle_deg - 90) * 3600 << " arcsec\n";
}

// ---------------------------------------------------------------------------------------------
// Qualification and the probe's hidden parameters.

TEST(VirtualCmm, QualificationFindsTheEffectiveRadius) {
  // Analytic: the ball centre stops short by pre-travel + feed * (filter + transmission + latency).
  const World w = noiseless(default_world());
  const double expected =
      2 - w.truth.probe.pre_travel.horizontal_mm -
      w.machine.measuring_feed_mm_s *
          (w.truth.probe.filter_delay_s + w.truth.probe.transmission_delay_s + w.machine.skip.latency_s);
  for (const char* file : {"default.json", "block_deviations.json"}) {
    Cmm cmm(noiseless(world_file(file)));
    cmm.tool(4);
    const ToolInfo t = cmm.qualify();
    EXPECT_TRUE(t.qualified);
    EXPECT_NEAR(t.effective_radius_mm, expected, 0.0002) << file;
    EXPECT_LT(t.qualification_form_mm, 0.0002);
    EXPECT_EQ(cmm.machine().state().tool->effective_radius_mm, t.effective_radius_mm);
    std::cout << file << ": effective radius " << t.effective_radius_mm << " mm, analytic " << expected
              << " mm, difference " << (t.effective_radius_mm - expected) * 1e3 << " um, form "
              << t.qualification_form_mm * 1e3 << " um, time " << cmm.machine().simulated_time_s() << " s\n";
  }
}

// The qualification ends where it began (over the safe height it left by): the program's next
// move starts where the program put the probe. Ending over the reference sphere, a straight move
// from there to the part crossed the boss of the default block.
TEST(VirtualCmm, QualificationReturnsToWhereItStarted) {
  Cmm cmm(noiseless(default_world()));
  cmm.tool(4);
  const Vec3 start(400, 250, 60);  // over the block (part 100, 50, 60)
  cmm.go(start);
  EXPECT_TRUE(cmm.qualify().qualified);
  EXPECT_LT((cmm.machine().state().position_mm - start).norm(), 1e-9);
  // And the first point after it, on the top face beside the boss, is reached without a collision.
  const Hit h = cmm.point({400, 250, 40}, Vec3::UnitZ());
  EXPECT_NEAR(h.centre_mm.z(), 40 + 2, 0.05);
}

TEST(VirtualCmm, QualificationAbsorbsBallRadiusError) {
  World w = noiseless(default_world());
  w.truth.probe.ball_radius_error_mm = -0.003;
  Cmm cmm(w);
  cmm.tool(4);
  const double expected = 2 - 0.003 - 0.010 - 3 * (0.004 + 4e-6);
  EXPECT_NEAR(cmm.qualify().effective_radius_mm, expected, 0.0002);
}

TEST(VirtualCmm, BoreAfterQualificationHasItsTrueDiameter) {
  // Pre-travel 10 um and 4 ms of delays: unqualified, the bore measures 2 x 22 um too large.
  Cmm cmm(noiseless(default_world()));
  cmm.tool(4);
  auto raw = probe_round(cmm, part_origin + Vec3(40, 50, 0), 10, 30, 12, true);
  auto options = compensated(raw, true);
  options.direction_hint = Vec3::UnitZ();
  options.circle_in_plane_of_hint = true;
  const double raw_d = fit(fitting::Shape::Circle, raw, options).diameter_mm;
  EXPECT_NEAR(raw_d, 20 + 2 * 0.022012, 0.0002);

  cmm.qualify();
  const auto hits = probe_round(cmm, part_origin + Vec3(40, 50, 0), 10, 30, 12, true);
  options = compensated(hits, true);
  options.direction_hint = Vec3::UnitZ();
  options.circle_in_plane_of_hint = true;
  const auto f = fit(fitting::Shape::Circle, hits, options);
  EXPECT_NEAR(f.diameter_mm, 20, 0.0002);
  std::cout << "BORE1 after qualification: " << f.diameter_mm << " mm (unqualified " << raw_d << " mm)\n";
}

TEST(VirtualCmm, HiddenDeviationsAreRecovered) {
  Cmm cmm(noiseless(world_file("block_deviations.json")));
  cmm.tool(4);
  cmm.qualify();
  // BORE1: +0.012 diameter, offset +0.03 in x.
  const auto bore = probe_round(cmm, part_origin + Vec3(40, 50, 0), 10, 30, 12, true);
  auto options = compensated(bore, true);
  options.direction_hint = Vec3::UnitZ();
  options.circle_in_plane_of_hint = true;
  const auto b = fit(fitting::Shape::Circle, bore, options);
  EXPECT_NEAR(b.diameter_mm, 20.012, 0.0005);
  EXPECT_NEAR(b.position.x(), 340.03, 0.0005);
  EXPECT_NEAR(b.position.y(), 250, 0.0005);
  // TOP: tilted 0.05 degrees about x.
  const auto top = probe_top(cmm);
  const auto t = fit(fitting::Shape::Plane, top, compensated(top, false));
  EXPECT_NEAR(t.direction.y(), -std::sin(0.05 * deg), 2e-6);
  // BOSS1: 3 lobes of amplitude 5 um -> roundness 10 um.
  const auto boss = probe_round(cmm, part_origin + Vec3(120, 70, 0), 12, 47, 36, false);
  options = compensated(boss, false);
  options.direction_hint = Vec3::UnitZ();
  options.circle_in_plane_of_hint = true;
  const auto o = fit(fitting::Shape::Circle, boss, options);
  EXPECT_NEAR(o.form_mm, 0.010, 0.0005);
  EXPECT_NEAR(o.diameter_mm, 24, 0.0005);
  std::cout << "recovered: BORE1 d=" << b.diameter_mm << " x=" << b.position.x() << ", TOP tilt "
            << std::asin(-t.direction.y()) / deg << " deg, BOSS1 roundness " << o.form_mm * 1e3 << " um\n";
}

TEST(VirtualCmm, LobedPreTravelShowsAfterQualification) {
  // Qualification absorbs the mean pre-travel; the 3-lobe part remains as apparent roundness
  // (2 x 3 um peak-to-valley on the bore).
  Cmm cmm(noiseless(world_file("lobed_probe.json")));
  cmm.tool(4);
  cmm.qualify();
  const auto hits = probe_round(cmm, part_origin + Vec3(40, 50, 0), 10, 30, 36, true);
  auto options = compensated(hits, true);
  options.direction_hint = Vec3::UnitZ();
  options.circle_in_plane_of_hint = true;
  const auto f = fit(fitting::Shape::Circle, hits, options);
  EXPECT_NEAR(f.form_mm, 0.006, 0.0005);
}

// ---------------------------------------------------------------------------------------------
// Faults.

TEST(VirtualCmm, GoToThroughTheBlockIsACollision) {
  Cmm cmm(default_world());
  cmm.tool(4);
  cmm.go(part_origin + Vec3(80, 50, 100));
  const Response r = cmm.run(GoTo{part_origin + Vec3(80, 50, 20), std::nullopt});
  ASSERT_EQ(r.status, Response::Status::Fault);
  EXPECT_EQ(r.fault->kind, FaultKind::Collision);
  EXPECT_NEAR((r.fault->position_mm - (part_origin + Vec3(80, 50, 42))).norm(), 0, 1e-8);
  EXPECT_NE(r.fault->message.find("with TOP"), std::string::npos) << r.fault->message;
  EXPECT_EQ(cmm.machine().state().position_mm, r.fault->position_mm);
  // Sideways into the LEFT face.
  cmm.go(part_origin + Vec3(-20, 50, 100));
  cmm.go(part_origin + Vec3(-20, 50, 20));
  const Response side = cmm.run(GoTo{part_origin + Vec3(50, 50, 20), std::nullopt});
  ASSERT_EQ(side.status, Response::Status::Fault);
  EXPECT_NEAR(side.fault->position_mm.x(), 298, 1e-8);
  // Moving away from a contact is allowed.
  cmm.ok(GoTo{part_origin + Vec3(-20, 50, 20), std::nullopt});
}

TEST(VirtualCmm, TheReferencePostIsAnObstacle) {
  Cmm cmm(default_world());
  cmm.tool(4);
  cmm.go(Vec3(900, 650, 100));
  cmm.go(Vec3(900, 650, 50));
  const Response r = cmm.run(GoTo{Vec3(900, 750, 50), std::nullopt});
  ASSERT_EQ(r.status, Response::Status::Fault);
  EXPECT_EQ(r.fault->kind, FaultKind::Collision);
  EXPECT_NEAR(r.fault->position_mm.y(), 700 - 5 - 2, 1e-8);
  EXPECT_NE(r.fault->message.find("REFERENCE_POST"), std::string::npos);
}

TEST(VirtualCmm, ProbingInAirIsNoContact) {
  Cmm cmm(default_world());
  cmm.tool(4);
  PtMeas m;
  m.nominal_mm = Vec3(600, 600, 100);
  m.normal = Vec3::UnitZ();
  m.search_mm = 5;
  const Response r = cmm.run(m);
  ASSERT_EQ(r.status, Response::Status::Fault);
  EXPECT_EQ(r.fault->kind, FaultKind::NoContact);
  EXPECT_NE(r.fault->message.find("5.000 mm"), std::string::npos) << r.fault->message;
  EXPECT_NEAR(r.fault->position_mm.z(), 100 + 2 - 5, 1e-9);  // stopped at the end of the search
}

TEST(VirtualCmm, FastProbingOverTravels) {
  World w = default_world();
  w.truth.probe.over_travel_mm = 0.2;
  w.machine.data_sheet = data_sheet_of(w.truth);  // its data sheet says so
  Cmm cmm(w);
  cmm.tool(4);
  const Vec3 p = part_origin + Vec3(20, 20, 40);
  cmm.go(p + Vec3(0, 0, 40));
  // At 3 mm/s the stop is ~0.08 mm past contact: fine.
  cmm.point(p, Vec3::UnitZ());
  PtMeas m;
  m.nominal_mm = p;
  m.normal = Vec3::UnitZ();
  m.approach_mm = 20;  // at cruise (100 mm/s after 10 mm) when it touches
  m.search_mm = 20;
  m.speed_mm_s = 100;
  const Response r = cmm.run(m);
  ASSERT_EQ(r.status, Response::Status::Fault);
  EXPECT_EQ(r.fault->kind, FaultKind::OverTravel);
  EXPECT_EQ(r.fault->message.rfind("probe over-travel: stopped ", 0), 0u) << r.fault->message;
  EXPECT_NE(r.fault->message.find("past contact, limit 0.200 mm"), std::string::npos) << r.fault->message;
  // The speed at contact, which tells a user why (cruise: 100 mm/s).
  EXPECT_NE(r.fault->message.find("touching at 100.0 mm/s"), std::string::npos) << r.fault->message;
  // Past contact: pre-travel + feed * delays (0.410 mm), up to one cycle before the interpolator
  // reacts (0.1 mm), then the jerk-limited stop from 100 mm/s: 100 * (2 * sqrt(100 / 10000)) / 2.
  const double past = r.fault->position_mm.z() - 2 - 40;  // negative: below the contact
  EXPECT_GT(-past, 0.4104 + 10 - 1e-6);
  EXPECT_LT(-past, 0.4104 + 0.1 + 10 + 1e-6);
  std::cout << r.fault->message << "\n";
}

TEST(VirtualCmm, TargetsOutsideTheTravelAreRefusedBeforeMoving) {
  Cmm cmm(default_world());
  cmm.tool(4);
  const Vec3 before = cmm.machine().state().position_mm;
  const double t0 = cmm.machine().simulated_time_s();
  const Response r = cmm.run(GoTo{Vec3(500, 500, 700), std::nullopt});
  ASSERT_EQ(r.status, Response::Status::Fault);
  EXPECT_EQ(r.fault->kind, FaultKind::AxisLimit);
  EXPECT_NE(r.fault->message.find("z travel [-200, 600]"), std::string::npos) << r.fault->message;
  EXPECT_EQ(cmm.machine().state().position_mm, before);
  EXPECT_EQ(cmm.machine().simulated_time_s(), t0);
  PtMeas m;
  m.nominal_mm = Vec3(1099, 0, 100);
  m.normal = Vec3::UnitX();
  EXPECT_EQ(cmm.run(m).fault->kind, FaultKind::AxisLimit);
}

TEST(VirtualCmm, AFaultAbortsTheRestOfTheQueue) {
  VirtualCmm cmm(default_world(), 1);
  cmm.submit({1, DefineTool{"T1", 4}});
  cmm.submit({2, SelectTool{"T1"}});
  cmm.submit({3, GoTo{Vec3(0, 0, 5000), std::nullopt}});
  cmm.submit({4, GoTo{Vec3(0, 0, 400), std::nullopt}});
  cmm.submit({5, QualifyTool{}});
  EXPECT_EQ(cmm.state().queued_commands, 5u);
  EXPECT_EQ(cmm.queued().size(), 5u);
  const auto r = cmm.execute();
  ASSERT_EQ(r.size(), 5u);
  EXPECT_EQ(r[1].status, Response::Status::Done);
  EXPECT_EQ(r[2].fault->kind, FaultKind::AxisLimit);
  EXPECT_EQ(r[3].fault->kind, FaultKind::Aborted);
  EXPECT_EQ(r[4].tag, 5u);
  EXPECT_EQ(r[4].fault->kind, FaultKind::Aborted);
  EXPECT_EQ(cmm.state().queued_commands, 0u);
  EXPECT_EQ(cmm.state().executed_commands, 3u);
}

TEST(VirtualCmm, ToolFaults) {
  Cmm cmm(default_world());
  PtMeas m;
  m.nominal_mm = Vec3(600, 600, 100);
  EXPECT_EQ(cmm.run(m).fault->kind, FaultKind::NoTool);
  EXPECT_EQ(cmm.run(QualifyTool{}).fault->kind, FaultKind::NoTool);
  EXPECT_EQ(cmm.run(SelectTool{"NOPE"}).fault->kind, FaultKind::UnknownTool);
  EXPECT_EQ(cmm.run(DefineTool{"BAD", -1}).fault->kind, FaultKind::BadCommand);
  cmm.tool(3);
  m.normal = Vec3::Zero();
  EXPECT_EQ(cmm.run(m).fault->kind, FaultKind::BadCommand);
  const ToolInfo t = cmm.machine().state().tool.value();
  EXPECT_EQ(t.nominal_radius_mm, 1.5);
  EXPECT_EQ(t.effective_radius_mm, 1.5);
  EXPECT_FALSE(t.qualified);
}

// ---------------------------------------------------------------------------------------------
// Timing, skip input, determinism.

TEST(VirtualCmm, MovesTakeWholeControllerCycles) {
  Cmm cmm(default_world());
  cmm.ok(SetFeeds{300, 0, 0});
  cmm.go(Vec3(0, 0, 400));
  const double t0 = cmm.machine().simulated_time_s();
  std::vector<TraceSample> trace;
  cmm.machine().set_trace([&](const TraceSample& s) { trace.push_back(s); });
  cmm.go(Vec3(1000, 0, 400));
  const double t_move = 1000.0 / 300 + 300.0 / 1000 + 1000.0 / 10000;  // jerk-limited, analytic
  EXPECT_NEAR(cmm.machine().simulated_time_s() - t0, std::ceil(t_move / 0.001) * 0.001, 1e-9);
  ASSERT_EQ(trace.size(), static_cast<std::size_t>(std::ceil(t_move / 0.001)));
  double peak = 0;
  for (const auto& s : trace) peak = std::max(peak, s.speed_mm_s);
  EXPECT_NEAR(peak, 300, 1e-9);
  EXPECT_EQ(trace.back().position_mm, Vec3(1000, 0, 400));
  // Speeds are clamped to the machine's limit.
  cmm.ok(SetFeeds{5000, 0, 0});
  EXPECT_EQ(cmm.machine().state().positioning_feed_mm_s, 300);
}

TEST(VirtualCmm, ScannedSkipJittersLatchedDoesNot) {
  const double feed = 10, period = 0.004;
  const auto spread = [&](const World& w, double& sd) {
    Cmm cmm(w, 42);
    cmm.tool(4);
    const Vec3 p = part_origin + Vec3(20, 20, 40);
    cmm.go(p + Vec3(0, 0, 20));
    std::vector<double> z;
    for (int i = 0; i < 60; ++i) z.push_back(cmm.point(p, Vec3::UnitZ(), 2, 2, feed).centre_mm.z());
    double mean = 0;
    for (double v : z) mean += v / static_cast<double>(z.size());
    double var = 0;
    for (double v : z) var += (v - mean) * (v - mean) / static_cast<double>(z.size() - 1);
    sd = std::sqrt(var);
    return *std::max_element(z.begin(), z.end()) - *std::min_element(z.begin(), z.end());
  };
  double sd_scanned = 0, sd_latched = 0;
  const double range_scanned = spread(noiseless(world_file("scanned_skip.json")), sd_scanned);
  const double range_latched = spread(noiseless(default_world()), sd_latched);
  // Latency uniform over one period: range -> feed * period, sd = feed * period / sqrt(12).
  EXPECT_GT(range_scanned, 0.8 * feed * period);
  EXPECT_LE(range_scanned, feed * period * (1 + 1e-9));
  EXPECT_NEAR(sd_scanned, feed * period / std::sqrt(12.0), 0.25 * feed * period / std::sqrt(12.0));
  EXPECT_LT(range_latched, 1e-9);
  std::cout << "scanned 4 ms at 10 mm/s: range " << range_scanned * 1e3 << " um, sd " << sd_scanned * 1e3
            << " um (expected " << feed * period / std::sqrt(12.0) * 1e3 << "); latched: range " << range_latched * 1e3
            << " um\n";
  double sd_noisy = 0;
  spread(default_world(), sd_noisy);
  EXPECT_NEAR(sd_noisy, 0.0002, 0.00006);  // the repeatability, 0.2 um
}

TEST(VirtualCmm, SameSeedSameHitsOtherSeedOtherNoise) {
  const auto run = [](std::uint64_t seed) {
    Cmm cmm(world_file("block_deviations.json"), seed);
    cmm.tool(4);
    cmm.qualify();
    auto hits = probe_top(cmm);
    return std::make_pair(hits, cmm.machine().state().tool->effective_radius_mm);
  };
  const auto a = run(7), b = run(7), c = run(8);
  ASSERT_EQ(a.first.size(), b.first.size());
  EXPECT_EQ(a.second, b.second);
  bool any_different = a.second != c.second;
  for (std::size_t i = 0; i < a.first.size(); ++i) {
    EXPECT_EQ(a.first[i].centre_mm, b.first[i].centre_mm);  // bit-identical
    EXPECT_EQ(a.first[i].time_s, b.first[i].time_s);
    any_different = any_different || a.first[i].centre_mm != c.first[i].centre_mm;
    EXPECT_LT((a.first[i].centre_mm - c.first[i].centre_mm).norm(), 0.005);
  }
  EXPECT_TRUE(any_different);
}

// ---------------------------------------------------------------------------------------------
// A CAD part.

namespace {

// The perfect probe on a CAD world.
World perfect_cad(const std::string& name) {
  World w = world_file(name);
  w.truth.probe = world_file("perfect.json").truth.probe;
  w.machine.skip.latency_s = 0;
  return w;
}

bool shared_data(const std::string& file) {
  return std::filesystem::exists(std::string(METRON_SHARED_DATA) + "/" + file);
}

}  // namespace

TEST(VirtualCmm, StepPartIsExact) {
  if (!shared_data("nist-simple-part/ipp_simple.stp"))
    GTEST_SKIP() << "shared data folder absent: " << METRON_SHARED_DATA;
  World w = perfect_cad("nist_simple_part.json");
  Cmm cmm(w);
  cmm.tool(4);
  // The NIST simple part: a 100 x 100 x 50 block with a diameter 50 blind bore at (50, 50) from
  // z = 25 up, placed where its DMIS program expects it: model frame = machine frame. Contact
  // is exact on its analytic faces, not limited by the 1 um tessellation.
  std::vector<Hit> top;
  for (const Vec2& xy : {Vec2(10, 10), Vec2(90, 10), Vec2(90, 90), Vec2(10, 90), Vec2(50, 12.3)}) {
    cmm.go(Vec3(xy.x(), xy.y(), 80));
    top.push_back(cmm.point(Vec3(xy.x(), xy.y(), 50), Vec3::UnitZ()));
    EXPECT_NEAR(top.back().surface_mm().z(), 50, 1e-4);
  }
  const auto plane = fit(fitting::Shape::Plane, top, compensated(top, false));
  EXPECT_NEAR(plane.position.z(), 50, 1e-4);
  const auto bore = probe_round(cmm, Vec3(50, 50, 0), 25, 40, 8, true, 7);
  auto options = compensated(bore, true);
  options.direction_hint = Vec3::UnitZ();
  options.circle_in_plane_of_hint = true;
  const auto f = fit(fitting::Shape::Circle, bore, options);
  EXPECT_NEAR(f.diameter_mm, 50, 1e-4);
  EXPECT_LT((f.position - Vec3(50, 50, 40)).norm(), 1e-4);
  EXPECT_LT(f.form_mm, 1e-4);
  std::printf("  STEP simple part: top %.7f, bore %.7f mm at (%.7f, %.7f)\n", plane.position.z(), f.diameter_mm,
              f.position.x(), f.position.y());
  const Response r = cmm.run(GoTo{Vec3(50, 50, 10), std::nullopt});
  EXPECT_EQ(r.status, Response::Status::Fault);  // the bore's bottom at z = 25
  EXPECT_NEAR(r.fault->position_mm.z(), 27, 1e-6);
  EXPECT_NE(r.fault->message.find("collision with face"), std::string::npos) << r.fault->message;

  // A Gaussian bump of the deviation field raises the top by its amplitude at its centre.
  w.truth.part->bumps = {Bump{Vec3(10, 10, 50), 0.004, 3}};
  Cmm bumped(w);
  bumped.tool(4);
  bumped.go(Vec3(10, 10, 80));
  EXPECT_NEAR(bumped.point(Vec3(10, 10, 50), Vec3::UnitZ()).surface_mm().z(), 50.004, 1e-6);
  bumped.go(Vec3(12, 10, 80));
  EXPECT_NEAR(bumped.point(Vec3(12, 10, 50), Vec3::UnitZ()).surface_mm().z(), 50 + 0.004 * std::exp(-4.0 / 18), 1e-6);
}

TEST(VirtualCmm, DcxStepCylinderAndSphereAreExact) {
  if (!shared_data("nist-dcx-part/DaimlerChryslerTestPartAP203.stp"))
    GTEST_SKIP() << "shared data folder absent: " << METRON_SHARED_DATA;
  const World w = perfect_cad("nist_dcx_part.json");
  {
    // Solid level, part coordinates: every recognised face is used exactly, and next to them
    // the exact distance differs from the mesh's by at most the guard of 1.5 chord tolerances.
    const auto& cad = std::get<CadDesign>(w.truth.part->design);
    ASSERT_TRUE(cad.faces);
    const MeshSolid exact(cad.mesh, Frame::Identity(), {}, *cad.faces, cad.chord_tolerance_mm);
    const MeshSolid mesh_only(cad.mesh, Frame::Identity());
    std::size_t analytic = 0;
    for (const auto& face : *cad.faces) analytic += face.kind != geometry::CadFace::Kind::Other;
    EXPECT_EQ(exact.analytic_face_count(), analytic);
    std::mt19937_64 g(5);
    std::uniform_real_distribution<double> offset(-3, 3);
    int points = 0;
    double largest = 0;
    for (const auto& face : *cad.faces) {
      if (face.kind == geometry::CadFace::Kind::Other) continue;
      for (std::size_t i = 0; i < face.triangles.size(); i += 1 + face.triangles.size() / 20) {
        const auto t = face.triangles[i];
        const auto& tri = cad.mesh->faces()[t];
        const Vec3 centroid =
            (cad.mesh->vertices()[tri[0]] + cad.mesh->vertices()[tri[1]] + cad.mesh->vertices()[tri[2]]) / 3;
        const Vec3 p = centroid + offset(g) * cad.mesh->face_normal(t);
        const double v = exact.signed_distance(p), m = mesh_only.signed_distance(p);
        ASSERT_LE(std::abs(v - m), 1.5 * cad.chord_tolerance_mm + 1e-7) << p.transpose();
        largest = std::max(largest, std::abs(v - m));
        ++points;
      }
    }
    std::printf("  STEP DCX: %zu of %zu faces analytic; at %d points near them |exact - mesh| <= %.2g mm\n",
                exact.analytic_face_count(), cad.faces->size(), points, largest);
  }
  Cmm cmm(w);
  cmm.tool(4);
  // Model frame to machine: Rz(180) * p + (355, 91, -80). CYL1 is the diameter 31 bore on the
  // model's z axis from z = 14 to 26, opening upward; probed like IMTS_M_clean.dmi does, in two
  // rings of four at model z = 17 and 23.
  const Vec3 axis(355, 91, 0);
  auto hits = probe_round(cmm, axis, 15.5, 23 - 80, 4, true, 45);
  const auto lower = probe_round(cmm, axis, 15.5, 17 - 80, 4, true, 0);
  hits.insert(hits.end(), lower.begin(), lower.end());
  ASSERT_EQ(hits.size(), 8u);
  auto options = compensated(hits, true);
  options.direction_hint = Vec3::UnitZ();
  options.start_from_hint = true;
  const auto f = fit(fitting::Shape::Cylinder, hits, options);
  EXPECT_NEAR(f.diameter_mm, 31, 1e-4);
  EXPECT_NEAR(f.position.x(), 355, 1e-4);
  EXPECT_NEAR(f.position.y(), 91, 1e-4);
  EXPECT_NEAR(std::abs(f.direction.z()), 1, 1e-9);
  EXPECT_LT(f.form_mm, 1e-4);
  std::printf("  STEP DCX CYL1: %.7f mm, axis at (%.7f, %.7f), form %.2g mm\n", f.diameter_mm, f.position.x(),
              f.position.y(), f.form_mm);

  // The sphere of diameter 25 at model (68, -34, 41.5): its pole and two rings of six.
  const Vec3 c(355 - 68, 91 + 34, 41.5 - 80);
  std::vector<Hit> sphere;
  cmm.go(c + Vec3(0, 0, 30));
  sphere.push_back(cmm.point(c + Vec3(0, 0, 12.5), Vec3::UnitZ()));
  for (double el : {15.0, 50.0}) {
    for (int i = 0; i < 6; ++i) {
      const double az = (60.0 * i + el) * deg, e = el * deg;
      const Vec3 d(std::cos(e) * std::cos(az), std::cos(e) * std::sin(az), std::sin(e));
      const Vec3 over = c + 18.5 * d;
      cmm.go(Vec3(over.x(), over.y(), c.z() + 30));
      sphere.push_back(cmm.point(c + 12.5 * d, d));
    }
  }
  const auto g = fit(fitting::Shape::Sphere, sphere, compensated(sphere, false));
  EXPECT_NEAR(g.diameter_mm, 25, 1e-4);
  EXPECT_LT((g.position - c).norm(), 1e-4);
  EXPECT_LT(g.form_mm, 1e-4);
  std::printf("  STEP DCX sphere: %.7f mm, centre error %.2g mm\n", g.diameter_mm, (g.position - c).norm());
}

// A stop request during a GoTo (Machine::stop_last_motion, I++ DME AbortE). Expected values are
// kinematic, not the profile's code: a jerk-limited ramp's speed curve is point-symmetric about
// its middle, so in the cruise the move lags v*T/2 behind v*t (T the ramp time), and a stop from
// the cruise at the same limits travels v*T/2 more: the machine comes to rest at exactly v*tau
// from the start, T after the request. T = 2*sqrt(v/j) when v < a^2/j (no constant-acceleration
// phase), v/a + a/j otherwise.
TEST(VirtualCmm, AStopRequestCutsAGoToWhereTheMachineWas) {
  const World world = world_file("perfect.json");
  Cmm cmm(world);
  const Vec3 start = world.machine.home_mm, target = start + Vec3(100, 0, 0);
  const double v = 20, a = world.machine.max_acceleration_mm_s2, j = world.machine.max_jerk_mm_s3;
  const double ramp_s = v < a * a / j ? 2 * std::sqrt(v / j) : v / a + a / j;
  const double t0 = cmm.machine().simulated_time_s();
  ASSERT_EQ(cmm.run(GoTo{target, v}).status, Response::Status::Done);
  EXPECT_NEAR(cmm.machine().state().position_mm.x(), target.x(), 1e-12);

  const double tau = 2.0;
  const auto stopped = cmm.machine().stop_last_motion(tau);
  ASSERT_TRUE(stopped);
  EXPECT_EQ(stopped->tag, 1u);
  EXPECT_EQ(stopped->status, Response::Status::Fault);
  ASSERT_TRUE(stopped->fault);
  EXPECT_EQ(stopped->fault->kind, FaultKind::Aborted);
  const Vec3 p = cmm.machine().state().position_mm;
  EXPECT_NEAR(p.x(), start.x() + v * tau, 1e-9);
  EXPECT_NEAR((p - Vec3(p.x(), start.y(), start.z())).norm(), 0, 1e-12);
  EXPECT_NEAR(cmm.machine().simulated_time_s() - t0, tau + ramp_s, world.machine.dt_s + 1e-9);
  EXPECT_NEAR(stopped->end_time_s - stopped->start_time_s, tau + ramp_s, world.machine.dt_s + 1e-9);

  // Only once, only a GoTo, only while it moved; the machine goes on from where it stopped.
  EXPECT_FALSE(cmm.machine().stop_last_motion(tau / 2));
  cmm.go(target);
  EXPECT_FALSE(cmm.machine().stop_last_motion(1e3));  // the 2 s move was over by then
  EXPECT_FALSE(cmm.machine().stop_last_motion(-1));
  cmm.ok(SetFeeds{40, 0, 0});
  EXPECT_FALSE(cmm.machine().stop_last_motion(0.01));  // the last command was no move
  EXPECT_NEAR(cmm.machine().state().position_mm.x(), target.x(), 1e-12);
}

// A stop request during a point measurement: the machine stops where it was, by the same
// kinematics as a GoTo (above): in the cruise of a move at speed v, it comes to rest v*tau from
// that move's start. The hit is lost (the last hit is the one before). Geometry from perfect.json:
// the block's top at z = 40, a 4 mm ball.
TEST(VirtualCmm, AStopRequestCutsAPointMeasurementWhereTheMachineWas) {
  const World world = world_file("perfect.json");
  const double a = world.machine.max_acceleration_mm_s2, j = world.machine.max_jerk_mm_s3;
  const auto ramp_s = [&](double v) { return v < a * a / j ? 2 * std::sqrt(v / j) : v / a + a / j; };
  const Vec3 top = part_origin + Vec3(100, 50, 40);
  const auto ptmeas = [&](double approach, double speed) {
    PtMeas m;
    m.nominal_mm = top;
    m.approach_mm = approach;
    m.search_mm = 5;
    m.speed_mm_s = speed;
    return m;
  };

  // In its approach: 100 mm down at the positioning feed, stopped 2 s in.
  {
    Cmm cmm(world);
    cmm.tool(4);
    cmm.ok(SetFeeds{20, 0, 0});
    const Hit before = cmm.point(part_origin + Vec3(10, 10, 40), Vec3::UnitZ());
    cmm.go(top + Vec3(0, 0, 144));
    const double t0 = cmm.machine().simulated_time_s();
    const Response r = cmm.run(ptmeas(2, 2));
    ASSERT_EQ(r.status, Response::Status::Done);
    const auto stopped = cmm.machine().stop_last_motion(2.0);
    ASSERT_TRUE(stopped);
    EXPECT_EQ(stopped->tag, r.tag);
    ASSERT_TRUE(stopped->fault);
    EXPECT_EQ(stopped->fault->kind, FaultKind::Aborted);
    EXPECT_NE(stopped->fault->message.find("point measurement"), std::string::npos) << stopped->fault->message;
    const MachineState s = cmm.machine().state();
    EXPECT_NEAR(s.position_mm.z(), top.z() + 144 - 20 * 2.0, 1e-9);
    EXPECT_NEAR((s.position_mm - Vec3(top.x(), top.y(), s.position_mm.z())).norm(), 0, 1e-9);
    EXPECT_NEAR(s.time_s - t0, 2.0 + ramp_s(20), world.machine.dt_s + 1e-9);
    ASSERT_TRUE(s.last_hit);
    EXPECT_EQ(s.last_hit->time_s, before.time_s);
  }
  // In its probing move, before the contact: from rest at the approach point, 10 mm above the
  // surface, at 2 mm/s, stopped 2 s in.
  {
    Cmm cmm(world);
    cmm.tool(4);
    const Vec3 approach = top + Vec3(0, 0, 2 + 10);
    cmm.go(approach);
    const double t0 = cmm.machine().simulated_time_s();
    ASSERT_EQ(cmm.run(ptmeas(10, 2)).status, Response::Status::Done);
    ASSERT_TRUE(cmm.machine().stop_last_motion(2.0));
    const MachineState s = cmm.machine().state();
    EXPECT_NEAR(s.position_mm.z(), approach.z() - 2 * 2.0, 1e-9);
    EXPECT_NEAR(s.time_s - t0, 2.0 + ramp_s(2), world.machine.dt_s + 1e-9);
    EXPECT_FALSE(s.last_hit);
  }
  // After its trigger: the probing move was stopping already (from v at the next cycle, over
  // v*sqrt(v/j), as above), and the stop request changes nothing: the machine rests where the
  // touch stopped, the ball in contact, not retracted. No retract, so that the request falls
  // in that stop; the machine then moves off the surface.
  {
    Cmm cmm(world);
    cmm.tool(4);
    cmm.go(top + Vec3(0, 0, 12));
    const double t0 = cmm.machine().simulated_time_s();
    PtMeas m = ptmeas(10, 2);
    m.retract_mm = 0;
    const Response r = cmm.run(m);
    ASSERT_TRUE(r.hit);
    const double stop_mm = 2 * std::sqrt(2 / j), latched_z = r.hit->centre_mm.z();
    ASSERT_TRUE(cmm.machine().stop_last_motion(r.hit->time_s - t0 + 0.02));
    const double z = cmm.machine().state().position_mm.z();
    EXPECT_LT(z, top.z() + 2);
    EXPECT_LE(z, latched_z - stop_mm + 1e-9);
    EXPECT_GE(z, latched_z - stop_mm - 2 * world.machine.dt_s - 1e-9);  // v*dt: the brake waits up to a cycle
    cmm.go(top + Vec3(0, 0, 20));
  }
}
