// SPDX-License-Identifier: GPL-3.0-or-later
// DATSET with a closed slot (CPARLN): after a plane set the primary axis, the slot orients the
// secondary axis by its long axis (not by its plane's normal, which the plane already gave);
// as the primary datum it gives its plane's normal. Expected frames are built by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "metron/runtime/alignment_ops.hpp"

using namespace metron;
using namespace metron::runtime;

namespace {

Geometry plane(const Vec3& point, const Vec3& normal) {
  Geometry g;
  g.type = FeatureType::Plane;
  g.position = point;
  g.direction = normal;
  return g;
}

Geometry slot(const Vec3& centre, const Vec3& normal, const Vec3& axis) {
  Geometry g;
  g.type = FeatureType::ClosedSlot;
  g.position = centre;
  g.direction = normal;
  g.slot_axis = axis;
  g.length_mm = 30;
  g.width_mm = 10;
  return g;
}

}  // namespace

TEST(Datset, AClosedSlotOrientsTheSecondaryAxisByItsLongAxis) {
  const double a = 30.0 * std::numbers::pi / 180;
  const Vec3 axis(std::cos(a), std::sin(a), 0);
  const Vec3 centre(340, 250, 40);
  const auto f = datset(Frame::Identity(), {{plane({300, 200, 40}, Vec3::UnitZ()), Axis::Z, false, {Axis::Z}},
                                            {slot(centre, Vec3::UnitZ(), axis), Axis::X, false, {Axis::X, Axis::Y}}});
  ASSERT_TRUE(f) << f.error();
  EXPECT_LT((f->linear().col(0) - axis).norm(), 1e-12);
  EXPECT_LT((f->linear().col(2) - Vec3::UnitZ()).norm(), 1e-12);
  EXPECT_LT((f->linear().col(1) - Vec3::UnitZ().cross(axis)).norm(), 1e-12);
  // The slot's centre is the origin (x, y) on the plane (z).
  EXPECT_LT((f->translation() - centre).norm(), 1e-9);

  // As the primary datum: its plane's normal.
  const auto g = datset(Frame::Identity(), {{slot(centre, Vec3::UnitZ(), axis), Axis::Z, false, {}}});
  ASSERT_TRUE(g) << g.error();
  EXPECT_LT((g->linear().col(2) - Vec3::UnitZ()).norm(), 1e-12);
}
