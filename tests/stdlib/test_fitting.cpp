// SPDX-License-Identifier: GPL-3.0-or-later
// Oracle tests for metron::fitting: shapes generated from known parameters (exact, with seeded
// noise, partial arcs, probe compensation), failure values, and the NIST Algorithm Testing
// System reference pairs in shared/data/nist-fitting.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "metron/stdlib/fitting/fit.hpp"
#include "metron/stdlib/fitting/point_file.hpp"

namespace metron::fitting {
namespace {

constexpr double exact_tol = 1e-9;

/// Angle between two directions in rad, optionally ignoring the sign.
double angle_between(const Vec3& a, const Vec3& b, bool up_to_sign) {
  const double c = a.normalized().dot(b.normalized());
  const double s = a.normalized().cross(b.normalized()).norm();
  double angle = std::atan2(s, c);
  if (up_to_sign) angle = std::min(angle, std::numbers::pi - angle);
  return angle;
}

double distance_to_axis(const Vec3& p, const Vec3& point, const Vec3& axis) {
  return (p - point).cross(axis.normalized()).norm();
}

/// Seeded Gaussian noise along a direction; sigma 0 gives exact points.
class Noise {
 public:
  explicit Noise(double sigma_mm, unsigned seed = 12345) : m_engine(seed), m_sigma_mm(sigma_mm) {}
  double operator()() { return m_sigma_mm > 0 ? m_normal(m_engine) * m_sigma_mm : 0.0; }

 private:
  std::mt19937 m_engine;
  std::normal_distribution<double> m_normal{0.0, 1.0};
  double m_sigma_mm;
};

/// Orthonormal u, v completing `n`.
std::pair<Vec3, Vec3> basis(const Vec3& n) {
  const Vec3 u = any_perpendicular(n.normalized());
  return {u, n.normalized().cross(u)};
}

struct CircleTruth {
  Vec3 centre;
  Vec3 normal;
  double radius_mm;
};

/// `count` points over `span_deg` of the circle, each pushed `noise()` radially, optional
/// out-of-plane wobble.
std::vector<Vec3> circle_points(const CircleTruth& t, int count, double span_deg, Noise noise = Noise(0),
                                double wobble_mm = 0) {
  const auto [u, v] = basis(t.normal);
  std::vector<Vec3> pts;
  for (int k = 0; k < count; ++k) {
    const double a = (span_deg * std::numbers::pi / 180) * k / (span_deg >= 360 ? count : count - 1) + 0.3;
    const Vec3 radial = std::cos(a) * u + std::sin(a) * v;
    pts.push_back(t.centre + (t.radius_mm + noise()) * radial + wobble_mm * std::sin(3 * a) * t.normal.normalized());
  }
  return pts;
}

struct CylinderTruth {
  Vec3 point;
  Vec3 axis;
  double radius_mm;
};

std::vector<Vec3> cylinder_points(const CylinderTruth& t, int rings, int per_ring, double length_mm, double span_deg,
                                  Noise noise = Noise(0)) {
  const auto [u, v] = basis(t.axis);
  std::vector<Vec3> pts;
  for (int r = 0; r < rings; ++r) {
    const double w = length_mm * (r / double(rings - 1) - 0.5);
    for (int k = 0; k < per_ring; ++k) {
      const double a = (span_deg * std::numbers::pi / 180) * k / (span_deg >= 360 ? per_ring : per_ring - 1) + 0.2 * r;
      pts.push_back(t.point + w * t.axis.normalized() + (t.radius_mm + noise()) * (std::cos(a) * u + std::sin(a) * v));
    }
  }
  return pts;
}

struct ConeTruth {
  Vec3 point;  ///< on the axis
  Vec3 axis;   ///< apex toward opening
  double half_angle_rad;
  double distance_mm;  ///< orthogonal distance from point to surface
};

/// Points at axial offsets w in [w0, w1] from the truth point, pushed `noise()` along the normal.
std::vector<Vec3> cone_points(const ConeTruth& t, int rings, int per_ring, double w0, double w1, double span_deg,
                              Noise noise = Noise(0)) {
  const auto [u, v] = basis(t.axis);
  const Vec3 a = t.axis.normalized();
  const double c = std::cos(t.half_angle_rad);
  const double s = std::sin(t.half_angle_rad);
  std::vector<Vec3> pts;
  for (int r = 0; r < rings; ++r) {
    const double w = w0 + (w1 - w0) * r / double(rings - 1);
    const double radius = t.distance_mm / c + w * std::tan(t.half_angle_rad);
    for (int k = 0; k < per_ring; ++k) {
      const double ang =
          (span_deg * std::numbers::pi / 180) * k / (span_deg >= 360 ? per_ring : per_ring - 1) + 0.15 * r;
      const Vec3 radial = std::cos(ang) * u + std::sin(ang) * v;
      const Vec3 normal = c * radial - s * a;  // outward surface normal
      pts.push_back(t.point + w * a + radius * radial + noise() * normal);
    }
  }
  return pts;
}

/// Sum of squared orthogonal distances to a cylinder, the objective a fit must minimise.
double cylinder_ssq(const std::vector<Vec3>& pts, const Vec3& point, const Vec3& axis, double radius_mm) {
  double ssq = 0;
  for (const Vec3& p : pts) ssq += std::pow(distance_to_axis(p, point, axis) - radius_mm, 2);
  return ssq;
}

// ---------------------------------------------------------------------------------------------
// Names and failures

TEST(FitNames, ShapeNamesRoundTripCaseInsensitively) {
  for (Shape s :
       {Shape::Point, Shape::Line, Shape::Plane, Shape::Circle, Shape::Sphere, Shape::Cylinder, Shape::Cone}) {
    EXPECT_EQ(shape_from_name(to_string(s)), s);
  }
  EXPECT_EQ(shape_from_name("CyLinder"), Shape::Cylinder);
  EXPECT_EQ(shape_from_name("CONE"), Shape::Cone);
  EXPECT_FALSE(shape_from_name("torus").has_value());
  EXPECT_FALSE(shape_from_name("").has_value());
  EXPECT_FALSE(shape_from_name("cones").has_value());
  EXPECT_EQ(to_string(FitFailure::TooFewPoints), "too few points");
}

TEST(FitFailures, TooFewPoints) {
  EXPECT_EQ(fit_circle({Vec3(0, 0, 0), Vec3(1, 0, 0)}).error(), FitFailure::TooFewPoints);
  EXPECT_EQ(fit_point({}).error(), FitFailure::TooFewPoints);
  EXPECT_EQ(fit_line({Vec3(1, 2, 3)}).error(), FitFailure::TooFewPoints);
  EXPECT_EQ(fit_plane({Vec3(0, 0, 0), Vec3(1, 0, 0)}).error(), FitFailure::TooFewPoints);
  EXPECT_EQ(fit_sphere({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}).error(), FitFailure::TooFewPoints);
  const auto ring = circle_points({Vec3::Zero(), Vec3::UnitZ(), 5}, 4, 360);
  EXPECT_EQ(fit_cylinder(ring).error(), FitFailure::TooFewPoints);
  EXPECT_EQ(fit_cone({ring[0], ring[1], ring[2], ring[3], Vec3(0, 0, 1)}).error(), FitFailure::TooFewPoints);
}

TEST(FitFailures, DegeneratePointSets) {
  const std::vector<Vec3> collinear{Vec3(0, 0, 0), Vec3(1, 1, 1), Vec3(2, 2, 2), Vec3(3, 3, 3)};
  EXPECT_EQ(fit_plane(collinear).error(), FitFailure::Degenerate);
  EXPECT_EQ(fit_circle(collinear).error(), FitFailure::Degenerate);
  EXPECT_EQ(fit_cylinder({Vec3(0, 0, 0), Vec3(1, 1, 1), Vec3(2, 2, 2), Vec3(3, 3, 3), Vec3(4, 4, 4)}).error(),
            FitFailure::Degenerate);
  EXPECT_EQ(fit_line({Vec3(1, 2, 3), Vec3(1, 2, 3)}).error(), FitFailure::Degenerate);
  // Coplanar points leave a sphere undetermined.
  EXPECT_EQ(fit_sphere(circle_points({Vec3(1, 2, 3), Vec3(0, 1, 1), 10}, 12, 360)).error(), FitFailure::Degenerate);
  std::vector<Vec3> with_nan = circle_points({Vec3::Zero(), Vec3::UnitZ(), 5}, 8, 360);
  with_nan[3].y() = std::nan("");
  EXPECT_EQ(fit_circle(with_nan).error(), FitFailure::Degenerate);
}

TEST(FitFailures, StraightDataHasNoCircle) {
  // Coplanar but collinear-in-the-hint-plane points: the circle radius would be infinite.
  std::vector<Vec3> pts;
  for (int k = 0; k < 6; ++k) pts.emplace_back(k, 0, 0.1 * (k % 2));
  FitOptions options;
  options.direction_hint = Vec3::UnitZ();
  options.circle_in_plane_of_hint = true;
  EXPECT_FALSE(fit_circle(pts, options).has_value());
}

TEST(FitFailures, CompensationNeedsOneApproachPerPoint) {
  FitOptions options;
  options.compensation = Compensation{1.0, {Vec3::UnitZ()}};
  EXPECT_THROW((void)fit_plane({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}, options), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// Exact shapes

TEST(FitExact, PointIsTheMean) {
  const auto r = fit_point({Vec3(1, 2, 3), Vec3(3, 2, 1)});
  ASSERT_TRUE(r);
  EXPECT_LT((r->position - Vec3(2, 2, 2)).norm(), exact_tol);
  EXPECT_NEAR(r->form_mm, std::sqrt(2.0), exact_tol);
}

TEST(FitExact, LineAndStraightnessInTheHintPlane) {
  const Vec3 start(100, -50, 20);
  const Vec3 dir = Vec3(1, 2, 0.5).normalized();
  const Vec3 plane_normal = any_perpendicular(dir);
  const Vec3 across = dir.cross(plane_normal);
  std::vector<Vec3> pts;
  for (int k = 0; k < 11; ++k) pts.push_back(start + 3.0 * k * dir + (k == 4 ? 0.002 : k == 7 ? -0.001 : 0.0) * across);
  const auto plain = fit_line(pts);
  ASSERT_TRUE(plain);
  EXPECT_LT(angle_between(plain->direction, dir, false), 1e-3);  // first toward last point
  FitOptions options;
  options.direction_hint = plane_normal;
  const auto in_plane = fit_line(pts, options);
  ASSERT_TRUE(in_plane);
  // The least-squares line shifts and tilts, but a straight-edge check of two offsets of
  // +2 um and -1 um from an otherwise straight row spans at most 3 um.
  EXPECT_GT(in_plane->form_mm, 0.0025);
  EXPECT_LT(in_plane->form_mm, 0.0031);
  EXPECT_NEAR(plain->form_mm, 2 * *std::max_element(plain->residuals_mm.begin(), plain->residuals_mm.end()), 1e-15);
  // Exact line.
  std::vector<Vec3> exact;
  for (int k = 0; k < 5; ++k) exact.push_back(start + 7.0 * k * dir);
  const auto e = fit_line(exact);
  ASSERT_TRUE(e);
  EXPECT_LT(angle_between(e->direction, dir, false), exact_tol);
  EXPECT_LT(distance_to_axis(start, e->position, e->direction), exact_tol);
  EXPECT_LT(e->form_mm, exact_tol);
}

TEST(FitExact, PlaneOrientedByHint) {
  const Vec3 normal = Vec3(0.1, -0.2, 1).normalized();
  const auto [u, v] = basis(normal);
  const Vec3 origin(400, -300, 250);
  std::vector<Vec3> pts;
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 4; ++j) pts.push_back(origin + 10.0 * i * u + 7.0 * j * v);
  }
  FitOptions options;
  options.direction_hint = -normal;
  const auto r = fit_plane(pts, options);
  ASSERT_TRUE(r);
  EXPECT_LT(angle_between(r->direction, -normal, false), exact_tol);
  EXPECT_LT(std::abs((origin - r->position).dot(r->direction)), exact_tol);
  EXPECT_LT(r->form_mm, exact_tol);
  const auto unhinted = fit_plane(pts);
  ASSERT_TRUE(unhinted);
  EXPECT_GT(unhinted->direction.z(), 0);  // largest component positive
}

TEST(FitExact, FullAndPartialCircles) {
  const CircleTruth truth{Vec3(-250, 120, 80), Vec3(0.3, 0.4, 0.8).normalized(), 12.5};
  for (double span : {360.0, 90.0, 30.0}) {
    const auto r = fit_circle(circle_points(truth, 9, span));
    ASSERT_TRUE(r) << "span " << span;
    EXPECT_LT((r->position - truth.centre).norm(), exact_tol) << "span " << span;
    EXPECT_NEAR(r->diameter_mm, 2 * truth.radius_mm, exact_tol) << "span " << span;
    EXPECT_LT(angle_between(r->direction, truth.normal, true), exact_tol) << "span " << span;
    EXPECT_LT(r->form_mm, exact_tol);
  }
}

TEST(FitExact, CircleInThePlaneOfTheHint) {
  // Out-of-plane wobble must not change the in-plane circle.
  const CircleTruth truth{Vec3(10, 20, 30), Vec3::UnitZ(), 8};
  const auto pts = circle_points(truth, 24, 360, Noise(0), 0.05);
  FitOptions options;
  options.direction_hint = -Vec3::UnitZ();
  options.circle_in_plane_of_hint = true;
  const auto r = fit_circle(pts, options);
  ASSERT_TRUE(r);
  EXPECT_LT((r->position - truth.centre).head<2>().norm(), exact_tol);
  EXPECT_NEAR(r->diameter_mm, 16, exact_tol);
  EXPECT_LT(angle_between(r->direction, -Vec3::UnitZ(), false), exact_tol);
  EXPECT_LT(r->form_mm, exact_tol);
}

TEST(FitExact, SpheresFullAndCap) {
  const Vec3 centre(500, -700, 300);
  const double radius = 6.35;
  for (double cap_deg : {180.0, 45.0}) {
    std::vector<Vec3> pts;
    for (int i = 0; i < 6; ++i) {
      const double polar = (cap_deg * std::numbers::pi / 180) * (i + 1) / 6.0;
      for (int k = 0; k < 8; ++k) {
        const double az = 2 * std::numbers::pi * k / 8 + 0.1 * i;
        pts.push_back(centre +
                      radius * Vec3(std::sin(polar) * std::cos(az), std::sin(polar) * std::sin(az), std::cos(polar)));
      }
    }
    const auto r = fit_sphere(pts);
    ASSERT_TRUE(r) << "cap " << cap_deg;
    EXPECT_LT((r->position - centre).norm(), exact_tol) << "cap " << cap_deg;
    EXPECT_NEAR(r->diameter_mm, 2 * radius, exact_tol) << "cap " << cap_deg;
  }
}

TEST(FitExact, CylindersFullAndPartial) {
  const CylinderTruth truth{Vec3(120, 35, -60), Vec3(0.2, -0.5, 1).normalized(), 15};
  struct Case {
    int rings, per_ring;
    double length_mm, span_deg;
  };
  for (const Case c : {Case{4, 8, 40, 360}, Case{2, 6, 2, 360}, Case{3, 6, 30, 90}, Case{5, 3, 100, 60}}) {
    const auto r = fit_cylinder(cylinder_points(truth, c.rings, c.per_ring, c.length_mm, c.span_deg));
    const std::string what = fmt::format("rings {} length {} span {}", c.rings, c.length_mm, c.span_deg);
    ASSERT_TRUE(r) << what;
    EXPECT_LT(distance_to_axis(truth.point, r->position, r->direction), exact_tol) << what;
    EXPECT_LT(angle_between(r->direction, truth.axis, true), exact_tol) << what;
    EXPECT_NEAR(r->diameter_mm, 2 * truth.radius_mm, exact_tol) << what;
    EXPECT_LT(r->form_mm, exact_tol) << what;
  }
}

TEST(FitExact, ConesSteepFlatAndPartial) {
  struct Case {
    double half_angle_deg, w0, w1, span_deg;
  };
  for (const Case c : {Case{30, -5, 5, 360}, Case{1, -20, 20, 360}, Case{80, -1, 1, 360}, Case{20, 0, 10, 90}}) {
    const ConeTruth truth{Vec3(-40, 70, 210), Vec3(-0.3, 0.1, 1).normalized(),
                          c.half_angle_deg * std::numbers::pi / 180, 9};
    const auto pts = cone_points(truth, 5, 10, c.w0, c.w1, c.span_deg);
    const auto r = fit_cone(pts);
    const std::string what = fmt::format("half angle {} span {}", c.half_angle_deg, c.span_deg);
    ASSERT_TRUE(r) << what;
    EXPECT_LT(angle_between(r->direction, truth.axis, false), exact_tol) << what;
    EXPECT_LT(distance_to_axis(truth.point, r->position, r->direction), exact_tol) << what;
    EXPECT_NEAR(r->apex_angle_deg, 2 * c.half_angle_deg, exact_tol * 180 / std::numbers::pi) << what;
    // The truth's distance, carried along the axis to the fitted point.
    const double w = (r->position - truth.point).dot(truth.axis);
    EXPECT_NEAR(r->cone_distance_mm, truth.distance_mm + w * std::sin(truth.half_angle_rad), exact_tol) << what;
    EXPECT_LT(r->form_mm, exact_tol) << what;
  }
}

// ---------------------------------------------------------------------------------------------
// Noise: the fit must be the least-squares minimum, not just near the truth

TEST(FitNoisy, CylinderIsALocalMinimumOfTheSumOfSquares) {
  const CylinderTruth truth{Vec3(-300, 800, 20), Vec3(1, 1, 0.2).normalized(), 25};
  const auto pts = cylinder_points(truth, 5, 12, 60, 360, Noise(0.002, 7));
  const auto r = fit_cylinder(pts);
  ASSERT_TRUE(r);
  EXPECT_LT(angle_between(r->direction, truth.axis, true), 2e-4);
  EXPECT_NEAR(r->diameter_mm, 50, 2e-3);
  EXPECT_NEAR(r->rms_mm, 0.002, 0.0008);
  const double best = cylinder_ssq(pts, r->position, r->direction, r->diameter_mm / 2);
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> unit(-1, 1);
  for (int trial = 0; trial < 200; ++trial) {
    const Vec3 dp = 1e-4 * Vec3(unit(rng), unit(rng), unit(rng));
    const Vec3 da = 1e-5 * Vec3(unit(rng), unit(rng), unit(rng));
    const double dr = 1e-4 * unit(rng);
    EXPECT_GE(cylinder_ssq(pts, r->position + dp, r->direction + da, r->diameter_mm / 2 + dr), best)
        << "trial " << trial;
  }
}

TEST(FitNoisy, ResidualsAreOrthogonalDistances) {
  const ConeTruth truth{Vec3(10, 10, 10), Vec3::UnitZ(), 0.4, 5};
  const auto pts = cone_points(truth, 4, 12, -3, 3, 360, Noise(0.001, 3));
  const auto r = fit_cone(pts);
  ASSERT_TRUE(r);
  ASSERT_EQ(r->residuals_mm.size(), pts.size());
  double ssq = 0;
  for (double d : r->residuals_mm) ssq += d * d;
  EXPECT_NEAR(r->rms_mm, std::sqrt(ssq / pts.size()), 1e-15);
  const auto [lo, hi] = std::minmax_element(r->residuals_mm.begin(), r->residuals_mm.end());
  EXPECT_DOUBLE_EQ(r->form_mm, *hi - *lo);
  EXPECT_NEAR(r->apex_angle_deg, 2 * 0.4 * 180 / std::numbers::pi, 0.05);
}

// ---------------------------------------------------------------------------------------------
// Probe compensation: ball centres offset by r along the approach give the surface exactly

constexpr double ball_mm = 1.5;

/// Centres = surface + r * approach.
std::vector<Vec3> centres(const std::vector<Vec3>& surface, const std::vector<Vec3>& approach) {
  std::vector<Vec3> out;
  for (std::size_t i = 0; i < surface.size(); ++i) out.push_back(surface[i] + ball_mm * approach[i].normalized());
  return out;
}

TEST(FitCompensation, PlaneShiftsOntoTheSurface) {
  std::vector<Vec3> surface;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 3; ++j) surface.emplace_back(10.0 * i, 10.0 * j, 5);
  }
  const std::vector<Vec3> approach(surface.size(), Vec3(0, 0, -1));  // probing the underside
  FitOptions options;
  options.compensation = Compensation{ball_mm, approach};
  options.direction_hint = Vec3::UnitZ();  // outvoted by the approach
  const auto r = fit_plane(centres(surface, approach), options);
  ASSERT_TRUE(r);
  EXPECT_LT(angle_between(r->direction, -Vec3::UnitZ(), false), exact_tol);
  EXPECT_NEAR(r->position.z(), 5, exact_tol);
  for (double d : r->residuals_mm) EXPECT_NEAR(d, 0, exact_tol);
}

TEST(FitCompensation, InnerAndOuterCircleSphereCylinder) {
  const CylinderTruth truth{Vec3(30, -20, 10), Vec3(0.1, 0.2, 1).normalized(), 10};
  const auto surface = cylinder_points(truth, 3, 8, 20, 360);
  for (bool inner : {true, false}) {
    std::vector<Vec3> approach;
    for (const Vec3& p : surface) {
      const Vec3 d = p - truth.point;
      const Vec3 outward = (d - d.dot(truth.axis) * truth.axis).normalized();
      approach.push_back(inner ? Vec3(-outward) : outward);  // a hole is probed from the axis side
    }
    FitOptions options;
    options.compensation = Compensation{ball_mm, approach};
    options.inner = inner;
    const auto r = fit_cylinder(centres(surface, approach), options);
    ASSERT_TRUE(r) << "inner " << inner;
    EXPECT_NEAR(r->diameter_mm, 20, exact_tol) << "inner " << inner;
    EXPECT_LT(distance_to_axis(truth.point, r->position, r->direction), exact_tol);
    for (double d : r->residuals_mm) EXPECT_NEAR(d, 0, exact_tol);
  }
  const CircleTruth circle{Vec3(1, 2, 3), Vec3(0, 1, 1).normalized(), 4};
  const auto ring = circle_points(circle, 7, 360);
  for (bool inner : {true, false}) {
    std::vector<Vec3> approach;
    for (const Vec3& p : ring) approach.push_back(inner ? Vec3(circle.centre - p) : Vec3(p - circle.centre));
    FitOptions options;
    options.compensation = Compensation{ball_mm, approach};
    options.inner = inner;
    const auto c = fit_circle(centres(ring, approach), options);
    ASSERT_TRUE(c);
    EXPECT_NEAR(c->diameter_mm, 8, exact_tol) << "inner " << inner;
    EXPECT_LT((c->position - circle.centre).norm(), exact_tol);
    // Spheres through the same idea: points on a sphere of radius 4 about the circle centre.
    std::vector<Vec3> shell;
    std::vector<Vec3> shell_approach;
    for (int k = 0; k < 12; ++k) {
      const Vec3 dir = Vec3(std::cos(k), std::sin(1.7 * k), std::cos(2.3 * k) + 0.5).normalized();
      shell.push_back(circle.centre + 4 * dir);
      shell_approach.push_back(inner ? Vec3(-dir) : dir);
    }
    options.compensation = Compensation{ball_mm, shell_approach};
    const auto s = fit_sphere(centres(shell, shell_approach), options);
    ASSERT_TRUE(s);
    EXPECT_NEAR(s->diameter_mm, 8, exact_tol) << "inner " << inner;
    EXPECT_LT((s->position - circle.centre).norm(), exact_tol);
  }
}

TEST(FitCompensation, ResidualSignIsOutOfTheMaterial) {
  // A hole with one point 10 um proud into the hole (into the air): + for inner.
  const CylinderTruth truth{Vec3::Zero(), Vec3::UnitZ(), 10};
  auto surface = cylinder_points(truth, 3, 8, 20, 360);
  std::vector<Vec3> approach;
  for (const Vec3& p : surface) approach.push_back(Vec3(-p.x(), -p.y(), 0));
  surface[5] += 0.01 * approach[5].normalized();
  FitOptions options;
  options.compensation = Compensation{ball_mm, approach};
  const auto r = fit_cylinder(centres(surface, approach), options);
  ASSERT_TRUE(r);
  EXPECT_EQ(std::max_element(r->residuals_mm.begin(), r->residuals_mm.end()) - r->residuals_mm.begin(), 5);
}

TEST(FitCompensation, InnerAndOuterCones) {
  const ConeTruth truth{Vec3(5, 5, 5), Vec3(0, 1, 1).normalized(), 30 * std::numbers::pi / 180, 6};
  const auto surface = cone_points(truth, 4, 9, -2, 4, 360);
  for (bool inner : {true, false}) {
    std::vector<Vec3> approach;
    for (const Vec3& p : surface) {
      const Vec3 d = p - truth.point;
      const Vec3 radial = (d - d.dot(truth.axis) * truth.axis).normalized();
      const Vec3 normal = std::cos(truth.half_angle_rad) * radial - std::sin(truth.half_angle_rad) * truth.axis;
      approach.push_back(inner ? Vec3(-normal) : normal);
    }
    FitOptions options;
    options.compensation = Compensation{ball_mm, approach};
    options.inner = inner;
    const auto r = fit_cone(centres(surface, approach), options);
    ASSERT_TRUE(r);
    const double w = (r->position - truth.point).dot(truth.axis);
    EXPECT_NEAR(r->cone_distance_mm, truth.distance_mm + w * std::sin(truth.half_angle_rad), exact_tol)
        << "inner " << inner;
    EXPECT_NEAR(r->apex_angle_deg, 60, 1e-8);
    for (double d : r->residuals_mm) EXPECT_NEAR(d, 0, exact_tol);
  }
}

TEST(FitFailures, NearlyFlatDataHasNoCylinderConeOrSphere) {
  // The least-squares cylinder, cone or sphere of flat data lies at infinite radius.
  std::vector<Vec3> flat;
  for (int i = 0; i < 7; ++i) {
    for (int j = 0; j < 7; ++j) flat.emplace_back(3.0 * i, 2.0 * j + 0.3 * i, ((i * 7 + j) % 3 - 1) * 1e-4);
  }
  EXPECT_EQ(fit_cylinder(flat).error(), FitFailure::NoConvergence);
  EXPECT_EQ(fit_sphere(flat).error(), FitFailure::NoConvergence);
  for (Vec3& p : flat) p.z() = 0;
  EXPECT_EQ(fit_cone(flat).error(), FitFailure::NoConvergence);
}

TEST(FitExact, CylinderAxisFollowsTheHintAndLongScansStayFast) {
  const CylinderTruth truth{Vec3(5, 6, 7), Vec3(1, -1, 0.5).normalized(), 40};
  const auto pts = cylinder_points(truth, 50, 200, 80, 360, Noise(0.001, 21));  // a 10000-point scan
  FitOptions options;
  options.direction_hint = Vec3(-1, 1, -0.4);
  const auto r = fit_cylinder(pts, options);
  ASSERT_TRUE(r);
  EXPECT_LT(angle_between(r->direction, -truth.axis, false), 1e-4);
  EXPECT_NEAR(r->diameter_mm, 80, 1e-3);
  EXPECT_GT(r->iterations, 0);
}

// ---------------------------------------------------------------------------------------------
// NIST Algorithm Testing System reference pairs

const std::filesystem::path nist_dir = std::filesystem::path(METRON_SHARED_DATA) / "nist-fitting";

constexpr double nist_length_tol_mm = 1e-4;     // 0.1 um
constexpr double nist_angle_tol_rad = 0.48e-6;  // about 0.1 arc second

std::vector<double> read_numbers(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::vector<double> v;
  double x = 0;
  while (in >> x) v.push_back(x);
  return v;
}

/// Errors of one set against its reference.
struct NistErrors {
  std::string name;
  std::string failure;       ///< non-empty when the fit failed
  double location_mm = 0;    ///< centre distance, or reference point to fitted axis / plane
  double size_mm = 0;        ///< diameter, or cone distance at the reference point
  double direction_rad = 0;  ///< normal/axis angle (up to sign except cones)
  double apex_rad = 0;       ///< cone: full apex angle error
  [[nodiscard]] bool pass() const {
    return failure.empty() && location_mm <= nist_length_tol_mm && size_mm <= nist_length_tol_mm &&
           direction_rad <= nist_angle_tol_rad && apex_rad <= nist_angle_tol_rad;
  }
};

NistErrors compare_nist(Shape shape, const std::string& name, const FitResult& r, const std::vector<double>& ref) {
  NistErrors e{name, {}, 0, 0, 0, 0};
  const Vec3 point(ref.at(0), ref.at(1), ref.at(2));
  if (shape == Shape::Sphere) {
    e.location_mm = (r.position - point).norm();
    e.size_mm = std::abs(r.diameter_mm - ref.at(3));
    return e;
  }
  const Vec3 dir(ref.at(3), ref.at(4), ref.at(5));
  e.direction_rad = angle_between(r.direction, dir, shape != Shape::Cone);
  switch (shape) {
    case Shape::Plane: e.location_mm = std::abs((point - r.position).dot(r.direction)); break;
    case Shape::Cylinder:
      e.location_mm = distance_to_axis(point, r.position, r.direction);
      e.size_mm = std::abs(r.diameter_mm - ref.at(6));
      break;
    case Shape::Cone: {
      e.location_mm = distance_to_axis(point, r.position, r.direction);
      // Our distance carried along our axis to the foot of the reference point.
      const double half = r.apex_angle_deg * std::numbers::pi / 360;
      const double w = (point - r.position).dot(r.direction);
      e.size_mm = std::abs(r.cone_distance_mm + w * std::sin(half) - ref.at(6));
      e.apex_rad = std::abs(r.apex_angle_deg - ref.at(7)) * std::numbers::pi / 180;
      break;
    }
    default: break;
  }
  return e;
}

/// The reference moved by `motion`: point and direction (the sizes do not change).
std::vector<double> move_reference(Shape shape, std::vector<double> ref, const Frame& motion) {
  const Vec3 point = motion * Vec3(ref.at(0), ref.at(1), ref.at(2));
  for (int i = 0; i < 3; ++i) ref[static_cast<std::size_t>(i)] = point(i);
  if (shape != Shape::Sphere) {
    const Vec3 dir = motion.linear() * Vec3(ref.at(3), ref.at(4), ref.at(5));
    for (int i = 0; i < 3; ++i) ref[static_cast<std::size_t>(3 + i)] = dir(i);
  }
  return ref;
}

/// Fits every set of `folder` and compares with the references. With `seed`, each set is first
/// moved by a random rigid motion (up to 1 m away) and its points shuffled: the fit must not
/// depend on where the part is or in which order the points came.
void run_nist(Shape shape, const std::string& folder, const std::string& prefix, std::optional<unsigned> seed = {}) {
  if (!std::filesystem::is_directory(nist_dir / folder)) {
    GTEST_SKIP() << "NIST reference data not found at " << (nist_dir / folder).string()
                 << " (shared/data is not checked out next to the project)";
  }
  std::mt19937 rng(seed.value_or(0));
  std::uniform_real_distribution<double> unit(-1, 1);
  std::vector<NistErrors> all;
  for (int k = 1; k <= 30; ++k) {
    const std::string name = fmt::format("{}{}", prefix, k);
    auto pts = read_point_file((nist_dir / folder / (name + ".ds")).string());
    ASSERT_TRUE(pts) << name << ": " << pts.error().message;
    std::vector<double> ref = read_numbers(nist_dir / folder / (name + ".fit"));
    if (seed) {
      Frame motion = Frame::Identity();
      motion.linear() = Eigen::Quaterniond(Eigen::Vector4d(unit(rng), unit(rng), unit(rng), unit(rng)).normalized())
                            .toRotationMatrix();
      motion.translation() = 1000 * Vec3(unit(rng), unit(rng), unit(rng));
      for (Vec3& p : *pts) p = motion * p;
      std::shuffle(pts->begin(), pts->end(), rng);
      ref = move_reference(shape, ref, motion);
    }
    const auto r = fit(shape, *pts);
    if (!r) {
      all.push_back({name, to_string(r.error())});
      continue;
    }
    all.push_back(compare_nist(shape, name, *r, ref));
  }
  NistErrors worst{"worst", {}, 0, 0, 0, 0};
  std::ostringstream table;
  table << fmt::format("{:<8} {:>12} {:>12} {:>12} {:>12}\n", "set", "location um", "size um", "dir urad", "apex urad");
  for (const NistErrors& e : all) {
    worst.location_mm = std::max(worst.location_mm, e.location_mm);
    worst.size_mm = std::max(worst.size_mm, e.size_mm);
    worst.direction_rad = std::max(worst.direction_rad, e.direction_rad);
    worst.apex_rad = std::max(worst.apex_rad, e.apex_rad);
    if (!e.failure.empty()) {
      table << fmt::format("{:<8} failed: {}\n", e.name, e.failure);
      continue;
    }
    table << fmt::format("{:<8} {:>12.3e} {:>12.3e} {:>12.3e} {:>12.3e}{}\n", e.name, e.location_mm * 1e3,
                         e.size_mm * 1e3, e.direction_rad * 1e6, e.apex_rad * 1e6, e.pass() ? "" : "  <-- FAIL");
  }
  table << fmt::format("{:<8} {:>12.3e} {:>12.3e} {:>12.3e} {:>12.3e}\n", "worst", worst.location_mm * 1e3,
                       worst.size_mm * 1e3, worst.direction_rad * 1e6, worst.apex_rad * 1e6);
  const bool all_pass = std::all_of(all.begin(), all.end(), [](const NistErrors& e) { return e.pass(); });
  EXPECT_TRUE(all_pass) << folder << " sets outside 0.1 um / 0.48 urad:\n" << table.str();
  ::testing::Test::RecordProperty("worst_location_um", fmt::format("{:.3e}", worst.location_mm * 1e3));
  ::testing::Test::RecordProperty("worst_size_um", fmt::format("{:.3e}", worst.size_mm * 1e3));
  ::testing::Test::RecordProperty("worst_direction_urad", fmt::format("{:.3e}", worst.direction_rad * 1e6));
  if (std::getenv("METRON_FIT_VERBOSE") != nullptr) std::cout << folder << ":\n" << table.str();
}

TEST(FitNist, Planes) { run_nist(Shape::Plane, "Plane", "pla"); }
TEST(FitNist, Spheres) { run_nist(Shape::Sphere, "Sphere", "sph"); }
TEST(FitNist, Cylinders) { run_nist(Shape::Cylinder, "Cylinder", "cyl"); }
TEST(FitNist, Cones) { run_nist(Shape::Cone, "Cone", "con"); }
TEST(FitNistMoved, Planes) { run_nist(Shape::Plane, "Plane", "pla", 11); }
TEST(FitNistMoved, Spheres) { run_nist(Shape::Sphere, "Sphere", "sph", 12); }
TEST(FitNistMoved, Cylinders) { run_nist(Shape::Cylinder, "Cylinder", "cyl", 13); }
TEST(FitNistMoved, Cones) { run_nist(Shape::Cone, "Cone", "con", 14); }

}  // namespace
}  // namespace metron::fitting

// Two rings of four points at equal angles lie exactly on the nominal cylinder and on a diagonal
// one; fitted from the nominal axis (as a measured feature is), the nominal one is returned.
TEST(FitCylinder, StartFromHintKeepsADegeneratePatternOnTheNominal) {
  std::vector<metron::Vec3> centres;
  for (double z : {3.0, 11.0})
    for (int k = 0; k < 4; ++k) {
      const double a = k * 3.14159265358979323846 / 2;
      centres.emplace_back(4.25 * std::cos(a), 4.25 * std::sin(a), z);
    }
  metron::fitting::FitOptions options;
  options.direction_hint = metron::Vec3::UnitZ();
  options.start_from_hint = true;
  const auto r = metron::fitting::fit(metron::fitting::Shape::Cylinder, centres, options);
  ASSERT_TRUE(r.has_value());
  EXPECT_NEAR(std::abs(r->direction.z()), 1.0, 1e-12);
  EXPECT_NEAR(r->diameter_mm, 8.5, 1e-9);
}
