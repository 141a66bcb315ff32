// SPDX-License-Identifier: GPL-3.0-or-later
// Unknown-contour scanning (docs/scanning.md, "Unknown contours"): the probe follows a surface
// nobody told it about, held in a plane or on a cylinder, until its end condition. Expected
// values come from the simulated world's hidden truth: where the part really is and what form
// it really has, never from the commanded start or the design.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <numbers>

#include "metron/machine/active_scanning/contour_scan.hpp"
#include "metron/machine/virtual_cmm.hpp"
#include "metron/machine/world_solid.hpp"
#include "metron/stdlib/fitting/fit.hpp"

using namespace metron;
using namespace metron::machine;

namespace {

constexpr double ball_r = 2;     // 4 mm stylus ball
const Vec3 origin(100, 100, 0);  // design pose of the test parts
constexpr double deg = std::numbers::pi / 180;

World world_with(csg::Node design, const Vec3& offset = Vec3::Zero()) {
  World w = default_world();
  PartSpec part;
  part.design = std::move(design);
  part.pose.translation_mm = origin + offset;
  part.seed = 5;
  w.truth.part = part;
  w.truth.probe.repeatability_mm = 0;
  return w;
}

struct ContourRun {
  ScanOutcome out;
  std::vector<ScanCycle> cycles;  // scanning phase only
};

ContourRun contour(const World& world, const ContourScan& cmd) {
  const auto solid = make_world_solid(world.truth);
  ScanSetup setup{solid.get(), ball_r, world.machine, world.truth.scanning, 9};
  ContourRun r;
  r.out = run_contour_scan(cmd, setup, contour_approach_point(cmd), 0, [&](const ScanCycle& c) {
    if (c.scanning) r.cycles.push_back(c);
  });
  return r;
}

csg::Node half_space(const char* name, const Vec3& point, const Vec3& normal) {
  csg::Node n;
  n.primitive = {name, csg::HalfSpace{point, normal}};
  return n;
}

// A 40 x 30 x 20 block standing on the table, its design corner at the origin.
csg::Node block() {
  csg::Node b;
  b.op = csg::Node::Op::Intersection;
  b.children = {half_space("TOP", {20, 15, 20}, Vec3::UnitZ()),   half_space("BOTTOM", {20, 15, 0}, -Vec3::UnitZ()),
                half_space("LEFT", {0, 15, 10}, -Vec3::UnitX()),  half_space("RIGHT", {40, 15, 10}, Vec3::UnitX()),
                half_space("FRONT", {20, 0, 10}, -Vec3::UnitY()), half_space("BACK", {20, 30, 10}, Vec3::UnitY())};
  return b;
}

}  // namespace

// A 36 mm bore with a hidden 5-lobe form of 1.8 um, followed round in the plane z = 15 with no
// path: the scan sets off from the start along +y and ends when the ball centre comes back into
// a 1 mm sphere about the start. The samples show the hidden form and the true diameter.
TEST(ContourScan, AnUnknownLobedBoreIsFollowedRoundAndShowsItsHiddenForm) {
  const double bore_r = 18, amplitude = 0.0018, phase_deg = 10;
  csg::Node ring, bore, part;
  ring.primitive = {"RING", csg::Cylinder{Vec3::Zero(), Vec3::UnitZ(), 80.0, 30.0}};
  bore.primitive = {"BORE", csg::Cylinder{Vec3::Zero(), Vec3::UnitZ(), 2 * bore_r, std::nullopt}};
  part.op = csg::Node::Op::Difference;
  part.children = {ring, bore};
  World w = world_with(part);
  csg::Deviation dev;
  dev.lobing = csg::Lobing{5, amplitude, phase_deg};
  w.truth.part->deviations["BORE"] = dev;

  ContourScan c;
  c.start_mm = origin + Vec3(bore_r - ball_r, 0, 15);
  c.start_normal = -Vec3::UnitX();
  c.direction = Vec3::UnitY();
  c.section = {ContourSection::Kind::Plane, c.start_mm, Vec3::UnitZ()};
  c.end = {ContourEnd::Kind::Sphere, c.start_mm, Vec3::UnitZ(), 1.0, 1};
  c.sample_spacing_mm = 0.2;
  const ContourRun r = contour(w, c);
  ASSERT_TRUE(r.out.completed) << r.out.fault->message;

  std::vector<Vec3> pts;
  double worst_z = 0, turned = 0, last_angle = 0;
  for (std::size_t i = 0; i < r.out.samples.size(); ++i) {
    const ScanSample& s = r.out.samples[i];
    pts.push_back(s.surface_mm(ball_r));
    worst_z = std::max(worst_z, std::abs(s.centre_mm.z() - 15));
    const double a = std::atan2(s.centre_mm.y() - origin.y(), s.centre_mm.x() - origin.x());
    if (i > 0) turned += std::remainder(a - last_angle, 2 * std::numbers::pi);
    last_angle = a;
  }
  // Once round, counterclockwise (the way it set off), and back within the end sphere.
  EXPECT_NEAR(turned, 2 * std::numbers::pi, 0.2);
  EXPECT_LT((r.out.samples.back().centre_mm - c.start_mm).norm(), 0.5 + 0.01);
  EXPECT_LT(worst_z, 0.005);  // held in its plane

  fitting::FitOptions o;
  o.inner = true;
  o.direction_hint = Vec3::UnitZ();
  const auto f = fitting::fit(fitting::Shape::Circle, pts, o);
  ASSERT_TRUE(f);
  std::complex<double> h = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Vec3 v = pts[i] - f->position;
    h += f->residuals_mm[i] * std::exp(std::complex<double>(0, -5 * std::atan2(v.y(), v.x())));
  }
  h *= 2.0 / static_cast<double>(pts.size());
  std::printf(
      "[figures] unknown lobed bore: %zu samples, diameter %.5f mm (true 36), 5th harmonic %.5f mm (hidden %.4f) "
      "at %.2f deg (hidden %.0f), centre off the plane at most %.5f mm\n",
      pts.size(), f->diameter_mm, std::abs(h), amplitude, -std::arg(h) / 5 / deg, phase_deg, worst_z);
  EXPECT_NEAR(f->diameter_mm, 2 * bore_r, 0.001);
  EXPECT_NEAR(std::abs(h), amplitude, 0.1 * amplitude);
  EXPECT_NEAR(-std::arg(h) / 5 / deg, phase_deg, 3);
}

// From the table into a block's side, up the side, over its top edge and along the top until
// the ball centre crosses the plane x = 120: a concave and a convex corner nobody described.
// The block stands 0.031 mm off its design in x (hidden): the ball centre keeps the ball's
// radius from the true surfaces all the way, and the side is found where it truly is.
TEST(ContourScan, ClimbsAnUndescribedStepAndFindsItsHiddenPosition) {
  const Vec3 offset(0.031, 0, 0);
  const World w = world_with(block(), offset);
  ContourScan c;
  c.start_mm = Vec3(155, 115, ball_r);  // on the table, 15 mm right of the block's design side
  c.start_normal = Vec3::UnitZ();
  c.direction = -Vec3::UnitX();
  c.section = {ContourSection::Kind::Plane, c.start_mm, Vec3::UnitY()};
  c.end = {ContourEnd::Kind::Plane, Vec3(120, 0, 0), Vec3::UnitX(), 0, 1};
  c.sample_spacing_mm = 0.2;
  const ContourRun r = contour(w, c);
  ASSERT_TRUE(r.out.completed) << r.out.fault->message;

  // The true distance from the table and the true block (its corner at origin + offset).
  const Vec3 lo = origin + offset, hi = lo + Vec3(40, 30, 20);
  auto true_distance = [&](const Vec3& p) {
    const Vec3 out = (p - hi).cwiseMax(lo - p).cwiseMax(0.0);
    return std::min(out.norm(), p.z());
  };
  // Round the convex top edge the world's CSG block is not exact: its distance is the larger of
  // the two faces' (docs/world.md, a sharp box instead of a rounded one), so the ball there goes
  // round a square corner of the faces' extensions. Those samples are counted, not checked.
  double worst = 0, side_sum = 0;
  int side = 0, top = 0, edge = 0;
  for (const ScanSample& s : r.out.samples) {
    if (s.centre_mm.z() > 5 && s.centre_mm.z() < 15) side_sum += s.centre_mm.x(), ++side;
    if (s.centre_mm.x() < hi.x() - 1) ++top;
    if (s.centre_mm.x() > hi.x() && s.centre_mm.z() > hi.z())
      ++edge;
    else
      worst = std::max(worst, std::abs(true_distance(s.centre_mm) - ball_r));
  }
  const double side_x = side_sum / side;
  std::printf(
      "[figures] unknown step: %zu samples (%d on the side, %d beyond the edge where the CSG model is not exact, "
      "%d on the top), ball centre from the true surfaces %.5f mm at worst off the ball radius elsewhere; side found "
      "at x = %.5f (true %.3f)\n",
      r.out.samples.size(), side, edge, top, worst, side_x - ball_r, hi.x());
  EXPECT_LT(worst, 0.003);
  EXPECT_GT(side, 30);
  EXPECT_GT(edge, 5);
  EXPECT_GT(top, 50);
  EXPECT_NEAR(side_x - ball_r, hi.x(), 0.001);
  EXPECT_NEAR(r.out.samples.back().centre_mm.x(), 120, 0.25);  // it ended at the plane
  EXPECT_NEAR(r.out.samples.back().centre_mm.z(), hi.z() + ball_r, 0.005);
}

// A boss cut by a plane tilted 30 deg from its cross-section: the surface normal leans out of the
// section by 0.5 sin(theta) of the way round, so the deflection pushes the ball out of the plane
// by up to E0 * 0.5 = 0.15 mm, changing all the way. The section term holds the ball centre in
// the plane, and the centre stays at R + r from the boss's hidden axis. Half a turn: to the plane
// y = 100.
TEST(ContourScan, HoldsItsSectionWhereTheSurfaceLeansOutOfIt) {
  csg::Node boss;
  boss.primitive = {"BOSS", csg::Cylinder{Vec3::Zero(), Vec3::UnitZ(), 30.0, 40.0}};
  const Vec3 offset(0.02, -0.015, 0);
  const World w = world_with(boss, offset);
  const double a = 30 * deg;
  const Vec3 m(0, std::sin(a), std::cos(a));  // the section plane's normal
  ContourScan c;
  c.start_mm = origin + Vec3(15 + ball_r, 0, 20);
  c.start_normal = Vec3::UnitX();
  c.direction = Vec3(0, std::cos(a), -std::sin(a));
  c.section = {ContourSection::Kind::Plane, c.start_mm, m};
  c.end = {ContourEnd::Kind::Plane, origin, Vec3::UnitY(), 0, 1};
  c.sample_spacing_mm = 0.2;
  const ContourRun r = contour(w, c);
  ASSERT_TRUE(r.out.completed) << r.out.fault->message;
  const Vec3 axis = origin + offset;
  double worst_plane = 0, worst_r = 0;
  for (const ScanSample& s : r.out.samples) {
    worst_plane = std::max(worst_plane, std::abs((s.centre_mm - c.start_mm).dot(m)));
    worst_r =
        std::max(worst_r, std::abs(std::hypot(s.centre_mm.x() - axis.x(), s.centre_mm.y() - axis.y()) - (15 + ball_r)));
  }
  std::printf(
      "[figures] boss cut by a tilted plane: %zu samples, ball centre off the section plane at most %.5f mm, "
      "off R + r from the hidden axis at most %.5f mm\n",
      r.out.samples.size(), worst_plane, worst_r);
  EXPECT_GT(r.out.samples.size(), 200u);
  EXPECT_LT(worst_plane, 0.01);  // without the section term: up to E0 * 0.5 = 0.15 mm
  EXPECT_LT(worst_r, 0.003);
  EXPECT_NEAR(r.out.samples.back().centre_mm.x(), axis.x() - 15 - ball_r, 0.25);
}

// I++ DME's ScanUnknownHint(minRadius): a contour expected to bend as tightly as 0.05 mm is
// scanned no faster than sqrt(a_c * 0.05) = 5 mm/s (a_c = 500 mm/s^2) from its start, where the
// same bore without the hint runs at the 10 mm/s feed.
TEST(ContourScan, TheLeastRadiusHintSlowsTheFeedFromTheStart) {
  csg::Node ring, bore, part;
  ring.primitive = {"RING", csg::Cylinder{Vec3::Zero(), Vec3::UnitZ(), 80.0, 30.0}};
  bore.primitive = {"BORE", csg::Cylinder{Vec3::Zero(), Vec3::UnitZ(), 36.0, std::nullopt}};
  part.op = csg::Node::Op::Difference;
  part.children = {ring, bore};
  const World w = world_with(part);
  ContourScan c;
  c.start_mm = origin + Vec3(16, 0, 15);
  c.start_normal = -Vec3::UnitX();
  c.direction = Vec3::UnitY();
  c.section = {ContourSection::Kind::Plane, c.start_mm, Vec3::UnitZ()};
  c.end = {ContourEnd::Kind::Plane, origin, Vec3::UnitX(), 0, 1};  // the plane x = 100: a quarter turn
  auto fastest = [&](std::optional<double> hint) {
    c.min_radius_mm = hint;
    const ContourRun r = contour(w, c);
    EXPECT_TRUE(r.out.completed);
    double v = 0;
    for (const ScanCycle& k : r.cycles) v = std::max(v, k.tangential_speed_mm_s);
    return v;
  };
  const double free_run = fastest(std::nullopt), hinted = fastest(0.05);
  std::printf("[figures] least-radius hint: fastest %.3f mm/s without, %.3f mm/s with ScanUnknownHint(0.05)\n",
              free_run, hinted);
  EXPECT_GT(free_run, 9);
  EXPECT_LT(hinted, 5.0 * 1.05);
}

// What cannot be scanned is said, not attempted: no surface at the start, an end that never
// comes, a section that lies in the surface.
TEST(ContourScan, FaultsAreNamed) {
  const World w = world_with(block());
  ContourScan c;
  c.start_mm = Vec3(120, 115, 60);  // 40 mm above the top: nothing to touch
  c.start_normal = Vec3::UnitZ();
  c.direction = Vec3::UnitX();
  c.section = {ContourSection::Kind::Plane, c.start_mm, Vec3::UnitY()};
  c.end = {ContourEnd::Kind::Sphere, Vec3(0, 0, 0), Vec3::UnitZ(), 1.0, 1};
  ContourRun r = contour(w, c);
  ASSERT_TRUE(r.out.fault);
  EXPECT_EQ(r.out.fault->kind, FaultKind::NoContact) << r.out.fault->message;

  c.start_mm = Vec3(120, 115, 20 + ball_r);  // on the top, toward +x; the end sphere is elsewhere
  c.max_length_mm = 15;
  r = contour(w, c);
  ASSERT_TRUE(r.out.fault);
  EXPECT_EQ(r.out.fault->kind, FaultKind::Stalled) << r.out.fault->message;
  EXPECT_NE(r.out.fault->message.find("did not meet its end"), std::string::npos) << r.out.fault->message;

  // On the table (an unbounded plane) toward -x with its end elsewhere: the soft limit at x = -100.
  c.start_mm = Vec3(50, 50, ball_r);
  c.direction = -Vec3::UnitX();
  c.section = {ContourSection::Kind::Plane, c.start_mm, Vec3::UnitY()};
  c.max_length_mm = 5000;
  r = contour(w, c);
  ASSERT_TRUE(r.out.fault);
  EXPECT_EQ(r.out.fault->kind, FaultKind::AxisLimit) << r.out.fault->message;
  EXPECT_NEAR(r.out.fault->position_mm.x(), -100, 0.1);

  // Round the block's four sides at z = 10 with the end sphere elsewhere: a closed contour that
  // never meets its end is stopped after its second round, not scanned 5000 mm.
  c.start_mm = Vec3(140 + ball_r, 115, 10);
  c.start_normal = Vec3::UnitX();
  c.direction = Vec3::UnitY();
  c.section = {ContourSection::Kind::Plane, c.start_mm, Vec3::UnitZ()};
  c.end = {ContourEnd::Kind::Sphere, Vec3(0, 0, 300), Vec3::UnitZ(), 1.0, 1};
  r = contour(w, c);
  ASSERT_TRUE(r.out.fault);
  EXPECT_EQ(r.out.fault->kind, FaultKind::Stalled) << r.out.fault->message;
  EXPECT_NE(r.out.fault->message.find("went round a closed contour 2 times"), std::string::npos)
      << r.out.fault->message;
  EXPECT_LT(r.out.stats.reached_mm, 3 * 2 * (40 + 30 + 2 * std::numbers::pi * ball_r));

  c.section.direction = Vec3::UnitX();  // the section plane is the side face's own plane
  EXPECT_NE(validate_contour_scan(c).find("parallel"), std::string::npos);
}
