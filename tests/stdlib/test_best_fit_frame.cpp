// SPDX-License-Identifier: GPL-3.0-or-later
// The best-fit frame (LOCATE) against frames known by construction: actuals made by moving
// nominals with a chosen rigid motion must give that motion back; the closed-form least-squares
// rigid fit of point sets (Umeyama, IEEE PAMI 13(4) 1991, Eigen::umeyama) is the reference
// where every feature is a point.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include <Eigen/Geometry>

#include "metron/stdlib/fitting/best_fit_frame.hpp"

using metron::Frame;
using metron::Vec3;
using metron::fitting::best_fit_frame;
using metron::fitting::FrameFreedoms;
using metron::fitting::FrameMatch;

namespace {

constexpr double deg = std::numbers::pi / 180;

Frame motion(const Vec3& t, double ax, double ay, double az) {
  Frame f = Frame::Identity();
  f.translate(t);
  f.rotate(Eigen::AngleAxisd(az * deg, Vec3::UnitZ()) * Eigen::AngleAxisd(ay * deg, Vec3::UnitY()) *
           Eigen::AngleAxisd(ax * deg, Vec3::UnitX()));
  return f;
}

FrameMatch match(FrameMatch::Kind kind, const Vec3& p, const Vec3& d, const Frame& truth, double extent = 0) {
  FrameMatch m;
  m.kind = kind;
  m.nominal_position = p;
  m.nominal_direction = d.normalized();
  m.actual_position = truth * p;
  m.actual_direction = truth.linear() * d.normalized();
  m.extent_mm = extent;
  return m;
}

// A block's three datum faces, a bore and a sphere, as a part program probes them.
std::vector<FrameMatch> block_features(const Frame& truth) {
  using K = FrameMatch::Kind;
  return {match(K::Plane, {80, 50, 40}, {0, 0, 1}, truth, 40),   // top face
          match(K::Plane, {0, 50, 20}, {-1, 0, 0}, truth, 30),   // left face
          match(K::Plane, {80, 0, 20}, {0, -1, 0}, truth, 30),   // front face
          match(K::Axis, {40, 50, 30}, {0, 0, 1}, truth),        // a bore's circle
          match(K::Point, {75, 75, 48}, {0, 0, 1}, truth),       // a sphere's centre
          match(K::Plane, {150, 90, 40}, {0, 0, 1}, truth, 0)};  // a surface point
}

}  // namespace

// Six freedoms: a part turned 3 degrees about Z, tilted 0.2 and 0.1 degrees and 2 mm away is
// found to 1e-9 from the identity.
TEST(BestFitFrame, FindsTheMotionThatMadeTheActuals) {
  const Frame start = motion({300, 200, 0}, 0, 0, 0);
  const Frame moved = motion({2, -1.5, 0.3}, 0.2, -0.1, 3);
  const Frame truth = start * moved;
  const auto fit = best_fit_frame(block_features(truth), start, {});
  ASSERT_TRUE(fit) << fit.error();
  EXPECT_LT((fit->part_to_machine.matrix() - truth.matrix()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_NEAR(fit->translation_mm.x(), 2, 1e-9);
  EXPECT_NEAR(fit->rotation_deg.z(), 3, 1e-8);
  EXPECT_LT(fit->rms_mm, 1e-9);
}

// Three freedoms (XDIR, YDIR, ZAXIS): the part moved in the table's plane only is found; a
// height and a tilt in the actuals stay in the residuals, not in the frame.
TEST(BestFitFrame, KeepsTheFreedomsItIsNotGiven) {
  const Frame start = Frame::Identity();
  FrameFreedoms planar;
  planar.along = {true, true, false};
  planar.about = {false, false, true};
  const auto in_plane = best_fit_frame(block_features(motion({1, 2, 0}, 0, 0, -4)), start, planar);
  ASSERT_TRUE(in_plane) << in_plane.error();
  EXPECT_NEAR(in_plane->translation_mm.y(), 2, 1e-9);
  EXPECT_NEAR(in_plane->rotation_deg.z(), -4, 1e-8);

  const auto lifted = best_fit_frame(block_features(motion({1, 2, 0.5}, 0, 0, -4)), start, planar);
  ASSERT_TRUE(lifted) << lifted.error();
  EXPECT_EQ(lifted->translation_mm.z(), 0);
  EXPECT_EQ(lifted->rotation_deg.x(), 0);
  EXPECT_GT(lifted->rms_mm, 0.1);
  // The top face's residual is the 0.5 mm lift.
  EXPECT_NEAR(lifted->residual_mm[0], 0.5, 1e-6);
}

// Point features with noise: the least-squares frame is Umeyama's closed form.
TEST(BestFitFrame, PointsFitAsTheClosedFormRigidFit) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, 0.01);
  std::uniform_real_distribution<double> where(-100, 100);
  const Frame truth = motion({5, -3, 1}, 1, 2, 10);
  std::vector<FrameMatch> matches;
  Eigen::Matrix3Xd nominal(3, 12), actual(3, 12);
  for (int i = 0; i < 12; ++i) {
    const Vec3 p(where(rng), where(rng), where(rng));
    FrameMatch m = match(FrameMatch::Kind::Point, p, Vec3::UnitZ(), truth);
    m.actual_position += Vec3(noise(rng), noise(rng), noise(rng));
    nominal.col(i) = p;
    actual.col(i) = m.actual_position;
    matches.push_back(m);
  }
  const auto fit = best_fit_frame(matches, Frame::Identity(), {});
  ASSERT_TRUE(fit) << fit.error();
  const Eigen::Matrix4d closed_form = Eigen::umeyama(nominal, actual, false);
  EXPECT_LT((fit->part_to_machine.matrix() - closed_form).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_GT(fit->rms_mm, 0.003);
}

// Features that cannot fix a freedom: the error names it.
TEST(BestFitFrame, NamesTheFreedomNoFeatureFixes) {
  using K = FrameMatch::Kind;
  const Frame truth = motion({0, 0, 0.2}, 0, 0, 0);
  const std::vector<FrameMatch> top_only = {match(K::Plane, {80, 50, 40}, {0, 0, 1}, truth, 40)};
  FrameFreedoms flat;
  flat.along = {false, false, true};
  flat.about = {true, true, false};
  const auto fixed = best_fit_frame(top_only, Frame::Identity(), flat);
  ASSERT_TRUE(fixed) << fixed.error();
  EXPECT_NEAR(fixed->translation_mm.z(), 0.2, 1e-9);

  FrameFreedoms slide = flat;
  slide.along = {true, false, true};
  const auto loose = best_fit_frame(top_only, Frame::Identity(), slide);
  ASSERT_FALSE(loose);
  EXPECT_NE(loose.error().find("do not fix the part's position along X:"), std::string::npos) << loose.error();
  FrameFreedoms all;
  const auto unseen = best_fit_frame(top_only, Frame::Identity(), all);
  ASSERT_FALSE(unseen);
  EXPECT_NE(unseen.error().find("position along X, position along Y and rotation about Z:"), std::string::npos)
      << unseen.error();
  EXPECT_FALSE(best_fit_frame({}, Frame::Identity(), {}));
}
