// SPDX-License-Identifier: GPL-3.0-or-later
// Minimum-zone form against analytic answers: point sets built so the narrowest zone is known
// exactly (all points inside a zone of width t, with the alternating contact points that make it
// minimal, ISO 12181-1 / 12781-1 / 12180-1), and biased so that least squares is wider.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "metron/stdlib/fitting/minimum_zone.hpp"

using metron::Vec3;
using metron::fitting::minimum_zone;
using metron::fitting::Shape;

namespace {
constexpr double pi = std::numbers::pi;
Vec3 polar(double r, double deg, double z = 0) {
  return {r * std::cos(deg * pi / 180), r * std::sin(deg * pi / 180), z};
}
}  // namespace

// Straightness in a plane: the minimum zone of a point set is the minimum width of its convex
// hull. Hull (0,0), (3,0), (0.5,1): its smallest altitude is 1 (onto the base y = 0).
TEST(MinimumZone, StraightnessIsTheHullsMinimumWidth) {
  const std::vector<Vec3> pts = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}, {0.5, 1, 0}};
  const auto mz = minimum_zone(Shape::Line, pts, Vec3::UnitZ());
  ASSERT_TRUE(mz);
  EXPECT_NEAR(mz->form_mm, 1.0, 1e-9);
  EXPECT_GT(mz->least_squares_form_mm, 1.0 + 1e-3);  // least squares is tilted by the outlier
  EXPECT_NEAR(std::abs(mz->direction.x()), 1.0, 1e-9);
  // The zone's middle line is y = 0.5 (GEOALG/LINE,MINMAX reports it).
  EXPECT_NEAR(mz->position.y(), 0.5, 1e-9);
  // A plane normal along the line holds no plane: the zone is taken in space, the narrowest
  // cylinder about a line (it was a zero width: the in-plane direction had no length). Points on
  // the z axis and one 1 off it: the cylinder about x = 0.5, diameter 1.
  const std::vector<Vec3> up = {{0, 0, 0}, {0, 0, 1}, {0, 0, 2}, {0, 0, 3}, {1, 0, 1.5}};
  const auto spatial = minimum_zone(Shape::Line, up, Vec3::UnitZ());
  ASSERT_TRUE(spatial);
  EXPECT_NEAR(spatial->form_mm, 1.0, 1e-6);
  EXPECT_NEAR(spatial->position.x(), 0.5, 1e-6);
}

// Flatness: a 100 mm grid on z = 0 and three points at z = t clustered over one corner. Every
// point lies in 0 <= z <= t and the high points project inside the grid, so no slab is thinner.
TEST(MinimumZone, FlatnessOfTwoLevelsIsTheirGap) {
  const double t = 0.01;
  std::vector<Vec3> pts;
  for (int i = 0; i <= 4; ++i)
    for (int j = 0; j <= 4; ++j) pts.push_back({25.0 * i, 25.0 * j, 0});
  for (const auto& p : {Vec3(10, 10, t), Vec3(15, 10, t), Vec3(10, 15, t)}) pts.push_back(p);
  const auto mz = minimum_zone(Shape::Plane, pts);
  ASSERT_TRUE(mz);
  EXPECT_NEAR(mz->form_mm, t, 1e-9);
  EXPECT_GT(mz->least_squares_form_mm, t * 1.05);
  EXPECT_NEAR(std::abs(mz->direction.z()), 1.0, 1e-9);
}

// Roundness: outer points (R + t) at 0 and 180 deg, inner points (R) at 90 and 270 deg alternate,
// so the annulus about the origin is minimal (the four-point criterion); a cluster of inner points
// near 20 deg pulls the least-squares centre away from it.
TEST(MinimumZone, RoundnessWithAlternatingContactsIsTheAnnulusWidth) {
  const double r = 10, t = 0.02;
  std::vector<Vec3> pts = {polar(r + t, 0), polar(r, 90), polar(r + t, 180), polar(r, 270)};
  for (double a = 10; a <= 40; a += 5) pts.push_back(polar(r, a));
  const auto mz = minimum_zone(Shape::Circle, pts);
  ASSERT_TRUE(mz);
  EXPECT_NEAR(mz->form_mm, t, 1e-9);
  EXPECT_NEAR(mz->position.norm(), 0.0, 1e-6);
  EXPECT_GT(mz->least_squares_form_mm, t * 1.05);
}

// Sphericity: outer points on +-x, inner points on +-y and +-z: moving the centre along any axis
// widens the shell, so the shell about the origin (width t) is minimal; an inner cluster biases LS.
TEST(MinimumZone, SphericityWithAlternatingContactsIsTheShellWidth) {
  const double r = 12.5, t = 0.015;
  std::vector<Vec3> pts = {{r + t, 0, 0}, {-(r + t), 0, 0}, {0, r, 0}, {0, -r, 0}, {0, 0, r}, {0, 0, -r}};
  for (double a = 20; a <= 60; a += 10)
    pts.push_back(r * Vec3(std::cos(a * pi / 180), 0.3, std::sin(a * pi / 180)).normalized());
  const auto mz = minimum_zone(Shape::Sphere, pts);
  ASSERT_TRUE(mz);
  EXPECT_NEAR(mz->form_mm, t, 1e-9);
  EXPECT_GT(mz->least_squares_form_mm, t * 1.02);
}

// Cylindricity: the roundness configuration in two sections 40 mm apart about the z axis.
TEST(MinimumZone, CylindricityOfTwoAlternatingSectionsIsTheShellWidth) {
  const double r = 8, t = 0.01;
  std::vector<Vec3> pts;
  for (double z : {0.0, 40.0}) {
    for (const auto& p : {polar(r + t, 0, z), polar(r, 90, z), polar(r + t, 180, z), polar(r, 270, z)})
      pts.push_back(p);
    for (double a = 10; a <= 40; a += 5) pts.push_back(polar(r, a, z));
  }
  const auto mz = minimum_zone(Shape::Cylinder, pts);
  ASSERT_TRUE(mz);
  EXPECT_NEAR(mz->form_mm, t, 1e-8);
  EXPECT_GT(mz->least_squares_form_mm, t * 1.05);
  EXPECT_NEAR(std::abs(mz->direction.z()), 1.0, 1e-8);
}

// Conicity: a 60 degree cone (apex at the origin, axis +z), the roundness configuration in two
// sections at z = 10 and 40: outer points t off the surface along its normal (t / cos 30 deg out
// from the axis), inner points on it. Within a section, no axis place gives a narrower spread of
// radii, and a change of the apex angle or of the apex along the axis moves a section's distances
// all alike (by an amount growing with z), so no other cone narrows the zone: it is t, about this
// cone. An inner cluster pulls least squares off.
TEST(MinimumZone, ConicityOfTwoAlternatingSectionsIsTheNormalZoneWidth) {
  const double half = 30 * pi / 180, t = 0.01;
  std::vector<Vec3> pts;
  for (double z : {10.0, 40.0}) {
    const double r = z * std::tan(half), out = r + t / std::cos(half);
    for (const auto& p : {polar(out, 0, z), polar(r, 90, z), polar(out, 180, z), polar(r, 270, z)}) pts.push_back(p);
    for (double a = 10; a <= 40; a += 5) pts.push_back(polar(r, a, z));
  }
  const auto mz = minimum_zone(Shape::Cone, pts);
  ASSERT_TRUE(mz);
  EXPECT_NEAR(mz->form_mm, t, 1e-8);
  EXPECT_GT(mz->least_squares_form_mm, t * 1.05);
  EXPECT_NEAR(std::abs(mz->direction.z()), 1.0, 1e-8);
  EXPECT_NEAR(mz->apex_angle_deg, 60.0, 1e-5);
  // The reference cone is the zone's middle: the surface t/2 out, so its apex t/2 / sin 30 deg
  // below the origin along the axis.
  EXPECT_NEAR(mz->position.x(), 0.0, 1e-6);
  EXPECT_NEAR(mz->position.y(), 0.0, 1e-6);
  EXPECT_NEAR(mz->position.z(), -(t / 2) / std::sin(half), 1e-6);
}

// Brute force against the fast path: for random planar data, no normal on a fine grid about the
// result gives a thinner slab, and the minimum zone is never wider than least squares.
TEST(MinimumZone, FlatnessIsNotBeatenByAGridOfNormals) {
  std::mt19937 rng(14);
  std::uniform_real_distribution<double> u(0, 50), e(-0.005, 0.005);
  std::vector<Vec3> pts;
  for (int i = 0; i < 40; ++i) {
    const double x = u(rng), y = u(rng);
    pts.push_back({x, y, 0.001 * x + e(rng) + 0.004 * std::sin(x / 7)});
  }
  const auto mz = minimum_zone(Shape::Plane, pts);
  ASSERT_TRUE(mz);
  EXPECT_LE(mz->form_mm, mz->least_squares_form_mm + 1e-12);
  const Vec3 n = mz->direction;
  const Vec3 e1 = n.cross(Vec3::UnitX()).normalized(), e2 = n.cross(e1);
  for (int i = -20; i <= 20; ++i)
    for (int j = -20; j <= 20; ++j) {
      const Vec3 m = (n + 2e-6 * i * e1 + 2e-6 * j * e2).normalized();
      double lo = 1e300, hi = -1e300;
      for (const auto& p : pts) lo = std::min(lo, m.dot(p)), hi = std::max(hi, m.dot(p));
      EXPECT_GE(hi - lo, mz->form_mm - 1e-10) << "normal offset " << i << ", " << j;
    }
}

// Maximum inscribed and minimum circumscribed circles (ISO 12181-1 MIC, MCC) against circles known
// exactly: three points on a circle of radius 10 about c, at 0, 100 and 230 degrees (an acute
// triangle, so that circle is the set's MCC when every other point lies inside it, and its MIC
// when every other point lies outside it). The other points cluster on one side, so least squares
// is pulled off c.
TEST(ExtremeCircle, InscribedAndCircumscribedCirclesOfThreeContacts) {
  const Vec3 c(3, -2, 5);
  std::vector<Vec3> inside, outside;
  for (double a : {0.0, 100.0, 230.0}) {
    inside.push_back(c + polar(10, a));
    outside.push_back(c + polar(10, a));
  }
  for (int i = 0; i < 30; ++i) {
    inside.push_back(c + polar(6 + 0.1 * i, 20 + 2 * i));     // within the circle, on one side
    outside.push_back(c + polar(14 + 0.1 * i, 15 + 11 * i));  // beyond it, all round
  }
  const auto mcc = metron::fitting::extreme_circle(inside, false, Vec3::UnitZ());
  ASSERT_TRUE(mcc);
  EXPECT_NEAR(mcc->diameter_mm, 20.0, 1e-6);
  EXPECT_NEAR((mcc->centre - c).norm(), 0.0, 1e-6);
  const auto mic = metron::fitting::extreme_circle(outside, true, Vec3::UnitZ());
  ASSERT_TRUE(mic);
  EXPECT_NEAR(mic->diameter_mm, 20.0, 1e-6);
  EXPECT_NEAR((mic->centre - c).norm(), 0.0, 1e-6);
  // Least squares gives neither (the baseline these replace).
  const auto ls = metron::fitting::fit(Shape::Circle, inside, {});
  ASSERT_TRUE(ls);
  EXPECT_GT(std::abs(ls->diameter_mm - 20.0), 0.5);
  // Points on a 90-degree arc do not enclose an inscribed circle, and their circumscribed circle
  // (the chord for a diameter, 14.1) is not the arc's either.
  std::vector<Vec3> arc;
  for (int i = 0; i <= 9; ++i) arc.push_back(c + polar(10, 10.0 * i));
  EXPECT_FALSE(metron::fitting::extreme_circle(arc, true, Vec3::UnitZ()));
  EXPECT_FALSE(metron::fitting::extreme_circle(arc, false, Vec3::UnitZ()));
}

// The sphere counterparts (ISO 14405-1 GX, GN sizes of a sphere): the four vertices of a regular
// tetrahedron on a sphere of radius 10 about c hold the centre inside their hull, so that sphere
// is the set's minimum circumscribed sphere when every other point lies inside it and its maximum
// inscribed sphere when every other point lies outside it.
TEST(ExtremeFeature, InscribedAndCircumscribedSpheresOfFourContacts) {
  const Vec3 c(3, -2, 5);
  const Vec3 vertices[] = {Vec3(1, 1, 1), Vec3(1, -1, -1), Vec3(-1, 1, -1), Vec3(-1, -1, 1)};
  std::vector<Vec3> inside, outside;
  for (const auto& v : vertices) {
    inside.push_back(c + 10 * v.normalized());
    outside.push_back(c + 10 * v.normalized());
  }
  for (int i = 0; i < 40; ++i) {
    const double a = 0.7 * i, e = std::asin(-0.95 + 0.0475 * i);  // a spiral over the whole sphere
    const Vec3 u(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
    inside.push_back(c + Vec3(2, 1, 0) + (5 + 0.05 * i) * u);  // within the sphere, off-centre
    outside.push_back(c + (10.5 + 0.05 * i) * u);              // beyond it, all round
  }
  const auto mcc = metron::fitting::extreme_feature(Shape::Sphere, inside, false);
  ASSERT_TRUE(mcc);
  EXPECT_NEAR(mcc->diameter_mm, 20.0, 1e-6);
  EXPECT_NEAR((mcc->position - c).norm(), 0.0, 1e-6);
  const auto mic = metron::fitting::extreme_feature(Shape::Sphere, outside, true);
  ASSERT_TRUE(mic);
  EXPECT_NEAR(mic->diameter_mm, 20.0, 1e-6);
  EXPECT_NEAR((mic->position - c).norm(), 0.0, 1e-6);
  const auto ls = metron::fitting::fit(Shape::Sphere, inside, {});
  ASSERT_TRUE(ls);
  EXPECT_GT(std::abs(ls->diameter_mm - 20.0), 0.5);  // least squares gives neither
  // A cap up to 60 degrees from the pole bounds no inscribed sphere: it grows without end below it.
  std::vector<Vec3> cap;
  for (int ring = 0; ring <= 3; ++ring)
    for (int k = 0; k < 8; ++k) {
      const double e = std::numbers::pi / 2 - ring * std::numbers::pi / 9, a = k * std::numbers::pi / 4;
      cap.push_back(c + 10 * Vec3(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)));
    }
  EXPECT_FALSE(metron::fitting::extreme_feature(Shape::Sphere, cap, true));
  // Nor the circumscribed one: the smallest sphere about a cap is smaller than the cap's sphere.
  EXPECT_FALSE(metron::fitting::extreme_feature(Shape::Sphere, cap, false));
  // A cylinder probed over half its circumference bounds no inscribed cylinder either.
  std::vector<Vec3> half;
  for (const double z : {0.0, 20.0})
    for (int k = 0; k <= 6; ++k)
      half.push_back(c + Vec3(10 * std::cos(k * std::numbers::pi / 6), 10 * std::sin(k * std::numbers::pi / 6), z));
  EXPECT_FALSE(metron::fitting::extreme_feature(Shape::Cylinder, half, true, Vec3::UnitZ()));
  EXPECT_FALSE(metron::fitting::extreme_feature(Shape::Cylinder, half, false, Vec3::UnitZ()));
}
