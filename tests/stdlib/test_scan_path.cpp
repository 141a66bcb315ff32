// SPDX-License-Identifier: GPL-3.0-or-later
// Scan paths from design data (SEEDS.md 1) against analytic answers: offset radii, curvature,
// helix pitch, chord tolerance checked densely against the exact curves, normals, mesh sections.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include "metron/stdlib/geometry/contour.hpp"
#include "metron/stdlib/geometry/mesh.hpp"
#include "metron/stdlib/geometry/scan_path.hpp"

namespace {

using namespace metron;
using namespace metron::geometry;
// Calls f(point, segment index) at n samples of every segment, ends included.
template <class F>
void each_sample(const PccPath& path, int n, F f) {
  for (std::size_t i = 0; i < path.segments.size(); ++i)
    for (int k = 0; k <= n; ++k) f(path.segments[i].point(path.segments[i].d_mm * k / n), i);
}

double radial(const Vec3& p, const Vec3& c, const Vec3& axis) {
  const Vec3 q = p - c;
  return (q - q.dot(axis) * axis).norm();
}

// Closed cylinder of radius r about z from z0 to z1 with n facets around, outward winding.
Mesh cylinder_mesh(double r, double z0, double z1, int n) {
  std::vector<Vec3> v;
  std::vector<Mesh::Face> f;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    v.emplace_back(r * std::cos(a), r * std::sin(a), z0);
    v.emplace_back(r * std::cos(a), r * std::sin(a), z1);
  }
  const auto bottom = static_cast<std::uint32_t>(v.size());
  v.emplace_back(0, 0, z0);
  v.emplace_back(0, 0, z1);
  for (int i = 0; i < n; ++i) {
    const auto a0 = static_cast<std::uint32_t>(2 * i), a1 = a0 + 1;
    const auto b0 = static_cast<std::uint32_t>(2 * ((i + 1) % n)), b1 = b0 + 1;
    f.push_back({a0, b0, b1});
    f.push_back({a0, b1, a1});
    f.push_back({bottom, b0, a0});
    f.push_back({bottom + 1, a1, b1});
  }
  auto m = Mesh::from_triangles(std::move(v), std::move(f));
  if (!m) throw std::runtime_error(m.error().message);
  return *m;
}

TEST(ScanPath, BoreCircleOffsetCurvatureSpeedAndTolerance) {
  ArcSpec bore;
  bore.centre = Vec3(10, 20, 5);
  bore.axis = Vec3(0, 0, 1);
  bore.radius_mm = 10;
  bore.inner = true;
  ScanPathOptions o;
  o.ball_radius_mm = 2;
  o.reference_deflection_mm = 0.3;
  o.chord_tolerance_mm = 0.001;
  o.feed_mm_s = 20;
  o.centripetal_accel_mm_s2 = 20;
  auto plan = make_scan_path(arc_contour(bore, 0.02), o);
  ASSERT_TRUE(plan) << plan.error().message;
  const double rc = 10 - (2 - 0.3);  // ball centre radius in a bore: R - (r - E0)
  const PccPath& path = plan->path;
  ASSERT_GE(path.segments.size(), 4u);
  double worst = 0;
  each_sample(path, 50, [&](const Vec3& p, std::size_t) {
    worst = std::max(worst, std::abs(radial(p, bore.centre, bore.axis) - rc));
    EXPECT_NEAR(p.z(), 5.0, 1e-9);
  });
  EXPECT_LE(worst, o.chord_tolerance_mm);
  EXPECT_LE(plan->max_deviation_mm, o.chord_tolerance_mm);
  // A chain: every end is the next start; closed.
  for (std::size_t i = 0; i + 1 < path.segments.size(); ++i)
    EXPECT_LT((path.segments[i].end() - path.segments[i + 1].start()).norm(), 1e-12);
  EXPECT_LT((path.segments.back().end() - path.segments.front().start()).norm(), 1e-12);
  // S is close to arc length: the chain's length is the circumference.
  EXPECT_NEAR(path.length(), 2 * std::numbers::pi * rc, 2 * std::numbers::pi * rc * 1e-4);
  // Curvature 1/rc at every interpolation point; normals point to the axis; speed sqrt(a rc) < feed.
  ASSERT_EQ(plan->curvature_per_mm.size(), path.segments.size() + 1);
  ASSERT_EQ(path.normals.size(), path.segments.size() + 1);
  for (std::size_t k = 0; k < path.normals.size(); ++k) {
    EXPECT_NEAR(plan->curvature_per_mm[k], 1 / rc, 0.01 / rc);
    const Vec3 p = k < path.segments.size() ? path.segments[k].start() : path.segments.back().end();
    Vec3 to_axis = bore.centre - p;
    to_axis.z() = 0;
    EXPECT_GT(path.normals[k].dot(to_axis.normalized()), std::cos(1e-6));
  }
  for (double v : path.speed_mm_s) EXPECT_NEAR(v, std::sqrt(20 * rc), 0.02 * std::sqrt(20 * rc));
}

TEST(ScanPath, ChordToleranceHonouredAndSegmentCountFollowsTheFourthRoot) {
  ArcSpec boss;
  boss.radius_mm = 25;
  boss.inner = false;
  boss.start_deg = 30;
  boss.sweep_deg = -200;
  ScanPathOptions o;
  std::vector<double> counts;
  for (double tol : {1e-2, 1e-3, 1e-4}) {
    o.chord_tolerance_mm = tol;
    auto plan = make_scan_path(arc_contour(boss, 0.01), o);
    ASSERT_TRUE(plan);
    double worst = 0;
    each_sample(plan->path, 100, [&](const Vec3& p, std::size_t) {
      worst = std::max(worst, std::abs(radial(p, boss.centre, boss.axis) - (25 + 1.7)));
    });
    EXPECT_LE(worst, tol) << "tolerance " << tol;
    counts.push_back(static_cast<double>(plan->path.segments.size()));
    // The path starts and ends where the arc does (angle 30 and -170 degrees).
    const Vec3 s = plan->path.segments.front().start(), e = plan->path.segments.back().end();
    EXPECT_NEAR(std::atan2(s.y(), s.x()) * 180 / std::numbers::pi, 30, 1e-9);
    EXPECT_NEAR(std::atan2(e.y(), e.x()) * 180 / std::numbers::pi, -170, 1e-9);
  }
  // A cubic's chord error goes with D^4: ten times tighter needs about 10^(1/4) = 1.8x the segments
  // (between 1.2x and 3x allowing for the power-of-two splitting).
  for (std::size_t i = 0; i + 1 < counts.size(); ++i) {
    EXPECT_GT(counts[i + 1] / counts[i], 1.2);
    EXPECT_LT(counts[i + 1] / counts[i], 3.0);
  }
}

TEST(ScanPath, HelixPitchRadiusAndCurvature) {
  ArcSpec helix;
  helix.radius_mm = 5;
  helix.inner = false;
  helix.pitch_mm = 2;
  helix.sweep_deg = 720;
  ScanPathOptions o;
  o.chord_tolerance_mm = 5e-4;
  auto plan = make_scan_path(arc_contour(helix, 0.01), o);
  ASSERT_TRUE(plan) << plan.error().message;
  const double rc = 5 + 1.7, c = 2 / (2 * std::numbers::pi);
  // Dense samples stay on the helix: radius rc and z = c * angle (unwrapped).
  double worst_r = 0, worst_z = 0, prev_angle = 0, turns = 0;
  bool first = true;
  each_sample(plan->path, 40, [&](const Vec3& p, std::size_t) {
    worst_r = std::max(worst_r, std::abs(radial(p, Vec3::Zero(), Vec3::UnitZ()) - rc));
    double a = std::atan2(p.y(), p.x());
    if (!first && a < prev_angle - std::numbers::pi) turns += 1;
    first = false;
    prev_angle = a;
    const double unwrapped = a + 2 * std::numbers::pi * turns;
    // Distance from the helix along z is at most the tolerance over the helix's slope.
    worst_z = std::max(worst_z, std::abs(p.z() - c * unwrapped));
  });
  EXPECT_LE(worst_r, o.chord_tolerance_mm);
  EXPECT_LE(worst_z, 2 * o.chord_tolerance_mm);
  EXPECT_NEAR(plan->path.segments.back().end().z(), 4.0, 1e-9);  // two turns of pitch 2
  EXPECT_NEAR(plan->path.length(), 4 * std::numbers::pi * std::hypot(rc, c), 1e-3);
  const double kappa = rc / (rc * rc + c * c);  // helix curvature
  for (double k : plan->curvature_per_mm) EXPECT_NEAR(k, kappa, 0.01 * kappa);
  // Normals are radial (no axial part) and outward.
  for (std::size_t k = 0; k < plan->path.segments.size(); ++k) {
    const Vec3 p = plan->path.segments[k].start();
    EXPECT_NEAR(plan->path.normals[k].z(), 0, 1e-12);
    EXPECT_GT(plan->path.normals[k].dot(Vec3(p.x(), p.y(), 0).normalized()), std::cos(1e-6));
  }
}

TEST(ScanPath, LineOnAPlaneIsOneStraightSegmentAtFeed) {
  const Vec3 n = Vec3(0, 1, 1).normalized();
  ScanPathOptions o;
  o.feed_mm_s = 12;
  auto plan = make_scan_path(line_contour(Vec3(0, 0, 0), Vec3(40, 0, 0), n, 0.1), o);
  ASSERT_TRUE(plan);
  ASSERT_EQ(plan->path.segments.size(), 1u);
  EXPECT_LT((plan->path.segments[0].start() - 1.7 * n).norm(), 1e-12);
  EXPECT_LT((plan->path.segments[0].end() - (Vec3(40, 0, 0) + 1.7 * n)).norm(), 1e-12);
  EXPECT_NEAR(plan->path.segments[0].d_mm, 40, 1e-12);
  EXPECT_NEAR(plan->path.speed_mm_s[0], 12, 1e-12);
  EXPECT_NEAR(plan->curvature_per_mm[0], 0, 1e-9);
  // max_segment_mm splits it.
  o.max_segment_mm = 15;
  auto split = make_scan_path(line_contour(Vec3(0, 0, 0), Vec3(40, 0, 0), n, 0.1), o);
  ASSERT_TRUE(split);
  EXPECT_EQ(split->path.segments.size(), 4u);
  for (const auto& s : split->path.segments) EXPECT_LE(s.d_mm, 15);
}

TEST(ScanPath, PlaneSectionOfAMeshCylinder) {
  const double r = 20;
  const int facets = 256;
  const Mesh mesh = cylinder_mesh(r, 0, 30, facets);
  auto contours = mesh_section_contours(mesh, Vec3(0, 0, 12), Vec3::UnitZ(), 0.05);
  ASSERT_EQ(contours.size(), 1u);
  auto contour = nearest_contour(contours, Vec3(30, 0, 12));
  ASSERT_TRUE(contour);
  ASSERT_TRUE(contour->closed);
  EXPECT_LT((contour->points.front().position - Vec3(r, 0, 12)).norm(), 0.05);
  ScanPathOptions o;
  o.chord_tolerance_mm = 0.005;  // larger than the facets' sagitta, so the fit smooths them
  auto plan = make_scan_path(*contour, o);
  ASSERT_TRUE(plan) << plan.error().message;
  const double sagitta = r * (1 - std::cos(std::numbers::pi / facets));
  double lo = 1e9, hi = -1e9;
  each_sample(plan->path, 20, [&](const Vec3& p, std::size_t) {
    const double rho = radial(p, Vec3::Zero(), Vec3::UnitZ());
    lo = std::min(lo, rho);
    hi = std::max(hi, rho);
    EXPECT_NEAR(p.z(), 12, 1e-9);
  });
  // Outward ball-centre path: between the facets' flats and vertices, offset by r - E0, plus tolerance.
  EXPECT_GE(lo, r - sagitta + 1.7 - o.chord_tolerance_mm);
  EXPECT_LE(hi, r + 1.7 + o.chord_tolerance_mm);
  // Normals are outward and radial within half a facet angle.
  for (std::size_t k = 0; k < plan->path.segments.size(); ++k) {
    const Vec3 p = plan->path.segments[k].start();
    EXPECT_GT(plan->path.normals[k].dot(Vec3(p.x(), p.y(), 0).normalized()),
              std::cos(std::numbers::pi / facets) - 1e-9);
  }
  // Counterclockwise about +z (Mesh::section's orientation for an outer boundary).
  const Vec3 t = plan->path.segments.front().tangent(0);
  EXPECT_GT(t.y(), 0.99);
  EXPECT_EQ(plan->corner_count, 0u);
  // Curvature of a fit to facets: right on average; each knot within 25 % (the offset polygon
  // alternates flats and small arcs, which the 5 um tolerance only partly smooths).
  double sum = 0;
  for (double k : plan->curvature_per_mm) {
    EXPECT_NEAR(k, 1 / (r + 1.7), 0.25 / (r + 1.7));
    sum += k;
  }
  EXPECT_NEAR(sum / static_cast<double>(plan->curvature_per_mm.size()), 1 / (r + 1.7), 0.02 / (r + 1.7));
  std::printf("mesh cylinder r=%g, %d facets: %zu segments, max deviation %.2e mm\n", r, facets,
              plan->path.segments.size(), plan->max_deviation_mm);
}

TEST(ScanPath, FreeFormSectionFollowsTheSurfaceOffset) {
  const HeightField f = [](double x, double y) { return 2 * std::sin(x / 10) * std::cos(y / 15) + 0.01 * x; };
  const auto contour = height_field_contour(f, Vec2(-20, 3), Vec2(20, 3), 0.02);
  ScanPathOptions o;
  o.chord_tolerance_mm = 0.001;
  o.ball_radius_mm = 1.5;
  o.reference_deflection_mm = 0.2;
  auto plan = make_scan_path(contour, o);
  ASSERT_TRUE(plan) << plan.error().message;
  // Normals at the interpolation points are the analytic surface normals.
  for (std::size_t k = 0; k < plan->path.segments.size(); ++k) {
    const Vec3 c = plan->path.segments[k].start() - 1.3 * plan->path.normals[k];  // back on the surface
    EXPECT_NEAR(c.z(), f(c.x(), c.y()), 1e-9);
    const double fx = 0.2 * std::cos(c.x() / 10) * std::cos(c.y() / 15) + 0.01;
    const double fy = -2.0 / 15 * std::sin(c.x() / 10) * std::sin(c.y() / 15);
    EXPECT_GT(plan->path.normals[k].dot(Vec3(-fx, -fy, 1).normalized()), std::cos(1e-6));
  }
  // Every point of the chain is r - E0 from the surface (distance to a fine sampling of the surface
  // line's offset), to within the chord tolerance.
  const auto fine = offset_contour(height_field_contour(f, Vec2(-20, 3), Vec2(20, 3), 0.002), 1.3);
  double worst = 0;
  each_sample(plan->path, 20, [&](const Vec3& p, std::size_t) {
    double best = 1e9;
    for (std::size_t i = 0; i + 1 < fine.points.size(); ++i) {
      const Vec3 a = fine.points[i].position, b = fine.points[i + 1].position;
      const double t = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      best = std::min(best, (a + t * (b - a) - p).norm());
    }
    worst = std::max(worst, best);
  });
  EXPECT_LE(worst, o.chord_tolerance_mm + 1e-5);
  // Slower where it is more curved: the speed ranks follow the curvature ranks.
  const auto& k = plan->segment_curvature_per_mm;
  const auto& v = plan->path.speed_mm_s;
  for (std::size_t i = 0; i < v.size(); ++i)
    EXPECT_NEAR(v[i], curvature_speed_mm_s(k[i], o.feed_mm_s, o.centripetal_accel_mm_s2), 1e-12);
}

TEST(ScanPath, BallThatDoesNotFitAndBadOptionsAreErrors) {
  ArcSpec small;
  small.radius_mm = 1.0;
  small.inner = true;
  ScanPathOptions o;  // r - E0 = 1.7 > 1: the offset folds over
  auto plan = make_scan_path(arc_contour(small), o);
  ASSERT_FALSE(plan);
  EXPECT_NE(plan.error().message.find("folds over"), std::string::npos);
  o.chord_tolerance_mm = 0;
  EXPECT_FALSE(make_scan_path(line_contour(Vec3::Zero(), Vec3::UnitX(), Vec3::UnitZ()), o));
}

// A concave fillet of radius 3 tessellated at 2 degrees per facet, as a mesh section gives it
// (facet normals along each facet, the mean normal at a concave vertex, samples every 0.05 mm and
// one 10 um before each edge, where the section crossed a diagonal):
// r - E0 = 1.7 < 3, so the ball fits; the points each vertex shadows are dropped, and the ball
// centre runs on the 1.3 mm arc within the facets' sagitta (issue 11 item 11).
TEST(ScanPath, AFacetedConcaveFilletWiderThanTheBallIsScanned) {
  const double radius = 3, facet = 2 * std::numbers::pi / 180;
  Contour c;
  const int facets = 45;  // a quarter turn
  auto vertex = [&](int k) { return Vec3(radius * std::cos(k * facet), radius * std::sin(k * facet), 0); };
  auto facet_normal = [&](int k) { return Vec3(-(vertex(k) + vertex(k + 1)).normalized()); };  // toward the centre
  for (int k = 0; k < facets; ++k) {
    const Vec3 n = k == 0 ? facet_normal(0) : Vec3((facet_normal(k - 1) + facet_normal(k)).normalized());
    c.points.push_back({vertex(k), n});
    const int m = static_cast<int>(std::ceil((vertex(k + 1) - vertex(k)).norm() / 0.05));
    for (int j = 1; j < m; ++j) c.points.push_back({vertex(k) + (vertex(k + 1) - vertex(k)) * j / m, facet_normal(k)});
    // Where the section crosses a triangle's diagonal just before the facet's edge, a point 10 um
    // short of the vertex: its offset lies beyond the vertex's (1.7 sin 1 deg = 30 um back).
    c.points.push_back({vertex(k + 1) - 0.01 * (vertex(k + 1) - vertex(k)).normalized(), facet_normal(k)});
  }
  c.points.push_back({vertex(facets), facet_normal(facets - 1)});
  const auto plan = make_scan_path(c, ScanPathOptions{});
  ASSERT_TRUE(plan) << plan.error().message;
  double worst = 0;
  for (const auto& seg : plan->path.segments)
    for (int i = 0; i <= 10; ++i) worst = std::max(worst, std::abs(seg.point(seg.d_mm * i / 10).norm() - 1.3));
  // Facet sagitta 3 (1 - cos 1 deg) = 0.46 um, plus the chord tolerance.
  EXPECT_LT(worst, 0.0005 + ScanPathOptions{}.chord_tolerance_mm);
  std::printf("faceted concave fillet R 3 at 2 deg: ball-centre path within %.5f mm of the 1.3 mm arc\n", worst);
}

TEST(ScanPath, BoxSectionHasFourCornersAndStaysOnTheOffsetSides) {
  // A box section is a rectangle: the ball centre rolls around its four corners.
  std::vector<Vec3> v = {{0, 0, 0},  {30, 0, 0},  {30, 20, 0},  {0, 20, 0},
                         {0, 0, 10}, {30, 0, 10}, {30, 20, 10}, {0, 20, 10}};
  std::vector<Mesh::Face> f = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                               {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
  auto mesh = Mesh::from_triangles(v, f);
  ASSERT_TRUE(mesh);
  auto contour = nearest_contour(mesh_section_contours(*mesh, Vec3(0, 0, 5), Vec3::UnitZ(), 0.1), Vec3(15, -5, 5));
  ASSERT_TRUE(contour);
  ScanPathOptions o;
  o.centripetal_accel_mm_s2 = 20;  // sqrt(a (r - E0)) = 5.8 mm/s around the corners, below the 10 mm/s feed
  auto plan = make_scan_path(*contour, o);
  ASSERT_TRUE(plan) << plan.error().message;
  EXPECT_EQ(plan->corner_count, 0u);  // convex edges become arcs of radius r - E0 around them
  EXPECT_LE(plan->max_deviation_mm, 0.001);
  // Every point of the path is r - E0 = 1.7 from the rectangle 0..30 x 0..20 (sides and corner arcs).
  double worst = 0;
  each_sample(plan->path, 20, [&](const Vec3& p, std::size_t) {
    const double dx = std::max({-p.x(), p.x() - 30, 0.0}), dy = std::max({-p.y(), p.y() - 20, 0.0});
    worst = std::max(worst, std::abs(std::hypot(dx, dy) - 1.7));
    EXPECT_NEAR(p.z(), 5, 1e-9);
  });
  EXPECT_LE(worst, 0.001);
  // The corner arcs (curvature 1/1.7) run slower than the sides.
  const auto [lo, hi] = std::minmax_element(plan->path.speed_mm_s.begin(), plan->path.speed_mm_s.end());
  // The speed comes from the fitted cubics' largest curvature: where a side meets a corner arc
  // (curvature 0 -> 1/1.7, tangent but not curvature continuous) a cubic overshoots the arc's
  // curvature, so the slowest segment is somewhat slower than sqrt(a (r - E0)), never faster.
  EXPECT_LE(*lo, std::sqrt(20 * 1.7) * 1.001);
  EXPECT_GE(*lo, std::sqrt(20 * 1.7) * 0.8);
  EXPECT_NEAR(*hi, 10, 1e-12);
}

}  // namespace
