// SPDX-License-Identifier: GPL-3.0-or-later
// Datum reference frames for POS and PROFS. The truth is the simulated part: its features are
// made with known errors in the part frame, then the whole part is misplaced on the machine by a
// known rigid motion that no alignment removes. The frame the DAT labels build must recover the
// part-frame errors exactly; without datums, the misplacement shows in the result.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "feature_geometry.hpp"
#include "metron/runtime/alignment_ops.hpp"
#include "metron/runtime/datum_frame.hpp"
#include "metron/runtime/tolerance.hpp"

namespace metron::runtime {
namespace {

constexpr double k_tight = 1e-9;

/// The misplacement of the part on the table: 0.4 deg about a skew axis and a shift.
Frame misplacement() {
  Frame m = Frame::Identity();
  m.linear() =
      Eigen::AngleAxisd(0.4 * 3.14159265358979323846 / 180.0, Vec3(0.2, -0.3, 1.0).normalized()).toRotationMatrix();
  m.translation() = Vec3(0.35, -0.22, 0.13);
  return m;
}

using test_support::plane;

Geometry bore(FeatureType type, const Vec3& position, const Vec3& axis, double diameter_mm) {
  Geometry g;
  g.type = type;
  g.side = Side::Inner;
  g.position = position;
  g.direction = axis.normalized();
  g.diameter_mm = diameter_mm;
  g.length_mm = type == FeatureType::Cylinder ? 20 : 0;
  return g;
}

/// A datum whose nominal is `nominal` and whose actual is the true part geometry (`truth`, part
/// frame) misplaced on the machine.
Datum datum(const std::string& label, const Geometry& nominal, const Geometry& truth) {
  return Datum{label, "F_" + label, to_machine(truth, misplacement()), nominal, Frame::Identity()};
}

Feature feature(const Geometry& nominal, const Geometry& truth) {
  Feature f;
  f.label = "HOLE";
  f.nominal = nominal;
  f.actual = to_machine(truth, misplacement());
  return f;
}

ToleranceSpec position(std::vector<std::string> datums) {
  ToleranceSpec s;
  s.label = "T1";
  s.kind = ToleranceKind::Pos;
  s.zone = 0.05;
  s.datums = std::move(datums);
  return s;
}

// The three planes of a block (3-2-1), each made slightly off in the part frame, as a real
// block's faces are: the datum frame is built from the faces as made, not as drawn.
struct Block {
  Datum a = datum("A", plane({50, 30, 0}, -Vec3::UnitZ()), plane({50, 30, 0.004}, Vec3(0.0001, 0, -1)));
  Datum b = datum("B", plane({0, 30, 10}, -Vec3::UnitX()), plane({-0.006, 30, 10}, Vec3(-1, 0.0002, 0)));
  Datum c = datum("C", plane({50, 0, 10}, -Vec3::UnitY()), plane({50, 0.003, 10}, Vec3(0, -1, 0)));
};

/// The hole's true coordinates in the frame of the block's faces as made, built independently of
/// the fitted motion from the datum rules (ASME Y14.5 4.11, least-squares association constrained
/// by precedence): z along A's normal, its origin on A; x along B's normal made perpendicular to z,
/// the plane x = 0 through B's centroid; y = z x x, the plane y = 0 through C's centroid.
Vec3 coordinates_in_faces_frame(const Block& block, const Vec3& hole_truth) {
  const Geometry a = to_machine(block.a.geometry, misplacement().inverse());
  const Geometry b = to_machine(block.b.geometry, misplacement().inverse());
  const Geometry c = to_machine(block.c.geometry, misplacement().inverse());
  const Vec3 z = -a.direction.normalized();
  const Vec3 x = (-b.direction - (-b.direction).dot(z) * z).normalized();
  const Vec3 y = z.cross(x);
  return {x.dot(hole_truth - b.position), y.dot(hole_truth - c.position), z.dot(hole_truth - a.position)};
}

TEST(DatumFrame, PositionToThreePlanesIgnoresThePartsMisplacement) {
  const Block block;
  const Geometry nominal = bore(FeatureType::Cylinder, {40, 25, 10}, Vec3::UnitZ(), 8);
  const Geometry truth = bore(FeatureType::Cylinder, {40.012, 24.991, 10}, Vec3::UnitZ(), 8.01);
  const Feature hole = feature(nominal, truth);
  ToleranceContext context;
  context.datums = {&block.a, &block.b, &block.c};

  const auto r = evaluate_tolerance(position({"A", "B", "C"}), {&hole}, context);
  ASSERT_TRUE(r) << r.error();
  // Truth: the hole's offset from where the drawing puts it, in the frame of the faces as made.
  const Vec3 in_faces = coordinates_in_faces_frame(block, truth.position);
  const double expected = 2.0 * std::hypot(in_faces.x() - 40.0, in_faces.y() - 25.0);
  EXPECT_NEAR(r->value, expected, 1e-6);
  EXPECT_NE(r->note.find("datum reference frame A|B|C: 3 of 3 rotations and 3 of 3 translations fixed"),
            std::string::npos)
      << r->note;

  // Without datums the part's misplacement (0.18 mm across the hole) is what POS sees.
  const auto bare = evaluate_tolerance(position({}), {&hole}, {});
  ASSERT_TRUE(bare);
  EXPECT_GT(bare->value, 0.3);
}

TEST(DatumFrame, PlaneThenTwoHolesFixesTheRotationByTheThirdHole) {
  // Primary plane A (the top), secondary bore B (located in the plane), tertiary bore C (its
  // direction from B fixes the rotation about A): the usual plane-hole-hole frame.
  const Datum a = datum("A", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0}, Vec3::UnitZ()));
  const Datum b = datum("B", bore(FeatureType::Circle, {0, 0, -5}, Vec3::UnitZ(), 10),
                        bore(FeatureType::Circle, {0, 0, -5}, Vec3::UnitZ(), 10));
  const Datum c = datum("C", bore(FeatureType::Circle, {80, 0, -5}, Vec3::UnitZ(), 6),
                        bore(FeatureType::Circle, {80, 0, -5}, Vec3::UnitZ(), 6));
  const Geometry nominal = bore(FeatureType::Circle, {40, 30, -5}, Vec3::UnitZ(), 8);
  // The part as made: the hole 0.015 off along x and 0.02 along y, in the part frame.
  const Geometry truth = bore(FeatureType::Circle, {40.015, 30.02, -5}, Vec3::UnitZ(), 8);
  const Feature hole = feature(nominal, truth);
  ToleranceContext context;
  context.datums = {&a, &b, &c};
  const auto r = evaluate_tolerance(position({"A", "B", "C"}), {&hole}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 2.0 * std::hypot(0.015, 0.02), k_tight);
  EXPECT_NE(r->note.find("3 of 3 rotations and 3 of 3 translations fixed"), std::string::npos) << r->note;
}

// Plane A primary, closed slot B secondary (CPARLN): the slot fixes its centre in A and, by its
// long axis, the rotation about A's normal, so the frame is complete with two datums, and the
// hole's position error in the part frame is recovered exactly (the misplacement turns the part
// about a skew axis, so about A's normal too).
TEST(DatumFrame, PlaneThenClosedSlotFixesTheRotationByTheSlotsAxis) {
  const Datum a = datum("A", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0}, Vec3::UnitZ()));
  Geometry slot;
  slot.type = FeatureType::ClosedSlot;
  slot.side = Side::Inner;
  slot.position = {0, 0, -5};
  slot.direction = Vec3::UnitZ();
  slot.slot_axis = Vec3::UnitX();
  slot.length_mm = 40;
  slot.width_mm = 10;
  const Datum b = datum("B", slot, slot);
  const Geometry nominal = bore(FeatureType::Circle, {40, 30, -5}, Vec3::UnitZ(), 8);
  const Geometry truth = bore(FeatureType::Circle, {40.015, 30.02, -5}, Vec3::UnitZ(), 8);
  const Feature hole = feature(nominal, truth);
  ToleranceContext context;
  context.datums = {&a, &b};
  const auto r = evaluate_tolerance(position({"A", "B"}), {&hole}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 2.0 * std::hypot(0.015, 0.02), k_tight);
  EXPECT_NE(r->note.find("3 of 3 rotations and 3 of 3 translations fixed"), std::string::npos) << r->note;
}

TEST(DatumFrame, PrimaryAxisThenFaceThenHole) {
  // A shaft-like part: primary cylinder A along z, secondary face B (fixes z), tertiary hole C.
  const Datum a = datum("A", bore(FeatureType::Cylinder, {0, 0, 10}, Vec3::UnitZ(), 30),
                        bore(FeatureType::Cylinder, {0, 0, 10}, Vec3::UnitZ(), 30));
  const Datum b = datum("B", plane({0, 0, 0}, -Vec3::UnitZ()), plane({0, 0, 0}, -Vec3::UnitZ()));
  const Datum c = datum("C", bore(FeatureType::Cylinder, {25, 0, 10}, Vec3::UnitZ(), 5),
                        bore(FeatureType::Cylinder, {25, 0, 10}, Vec3::UnitZ(), 5));
  const Geometry nominal = bore(FeatureType::Sphere, {0, 25, 18}, Vec3::UnitZ(), 4);
  const Geometry truth = bore(FeatureType::Sphere, {0.01, 25, 18.02}, Vec3::UnitZ(), 4);
  const Feature ball = feature(nominal, truth);
  ToleranceContext context;
  context.datums = {&a, &b, &c};
  ToleranceSpec s = position({"A", "B", "C"});
  s.three_d = true;
  const auto r = evaluate_tolerance(s, {&ball}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 2.0 * std::hypot(0.01, 0.02), k_tight);
}

TEST(DatumFrame, ADatumLeavesFreeWhatItDoesNotConstrain) {
  // Only A (the top plane): the zone may slide in the plane and turn about its normal, so the
  // hole's in-plane offset is measured as it stands, the tilt of the part is removed.
  const Datum a = datum("A", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0}, Vec3::UnitZ()));
  Frame shift_only = Frame::Identity();
  shift_only.translation() = Vec3(0.02, -0.01, 0.3);  // no turn: what A leaves free is a pure shift
  Datum shifted_a = a;
  shifted_a.geometry = to_machine(plane({0, 0, 0}, Vec3::UnitZ()), shift_only);
  const Geometry nominal = bore(FeatureType::Circle, {40, 30, -5}, Vec3::UnitZ(), 8);
  Feature hole;
  hole.label = "HOLE";
  hole.nominal = nominal;
  hole.actual = to_machine(nominal, shift_only);
  ToleranceContext context;
  context.datums = {&shifted_a};
  ToleranceSpec s = position({"A"});
  s.three_d = true;
  const auto r = evaluate_tolerance(s, {&hole}, context);
  ASSERT_TRUE(r) << r.error();
  // The 0.3 mm along A's normal is A's to remove; the in-plane 0.02, -0.01 is not.
  EXPECT_NEAR(r->value, 2.0 * std::hypot(0.02, 0.01), k_tight);
  EXPECT_NE(r->note.find("2 of 3 rotations and 1 of 3 translations fixed"), std::string::npos) << r->note;
}

TEST(DatumFrame, DatumNominalsWrittenBeforeTheAlignmentCompareInTheFeaturesFrame) {
  // A program defines its datum features under the machine system, aligns to them (DATSET), and
  // then defines the hole in the part frame. The datum nominals (part numbers written in the MCS)
  // are re-placed in the hole's frame, so the frame does not count the part's misplacement twice.
  const Block block;
  Datum a = block.a, b = block.b, c = block.c;
  // The part alignment the program's DATSET made: exactly the misplacement (faces as drawn).
  const Frame part = misplacement();
  a.geometry = to_machine(a.nominal, part);
  b.geometry = to_machine(b.nominal, part);
  c.geometry = to_machine(c.nominal, part);
  const Geometry nominal_part = bore(FeatureType::Cylinder, {40, 25, 10}, Vec3::UnitZ(), 8);
  Feature hole;
  hole.label = "HOLE";
  hole.nominal = to_machine(nominal_part, part);  // FEAT under the part alignment
  hole.nominal_frame = part;
  hole.actual = to_machine(bore(FeatureType::Cylinder, {40.01, 25, 10}, Vec3::UnitZ(), 8), part);
  ToleranceContext context;
  context.datums = {&a, &b, &c};
  const auto r = evaluate_tolerance(position({"A", "B", "C"}), {&hole}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.02, k_tight);
  EXPECT_NE(r->note.find("turned 0.0000 deg"), std::string::npos) << r->note;
  EXPECT_NE(r->note.find("(datum nominals read in the feature's alignment)"), std::string::npos) << r->note;
}

TEST(DatumFrame, DatumNominalsInAFrameOfTheirOwnAreTakenWhereTheyWereDefined) {
  // The NIST DCX program's way: the datum planes are written in a frame of their own (shifted and
  // turned 180 deg from the part frame the hole is written in), and their numbers mean where
  // that frame puts them. Re-reading them in the hole's frame would put the datums 200 mm away.
  Frame own = Frame::Identity();
  own.linear() = Eigen::AngleAxisd(3.14159265358979323846, Vec3::UnitZ()).toRotationMatrix();
  own.translation() = Vec3(355, 91, -80);
  auto defined_in_own = [&](const std::string& label, const Geometry& numbers) {
    const Geometry placed = to_machine(numbers, own);
    return Datum{label, "F_" + label, placed, placed, own};
  };
  const Datum a = defined_in_own("A", plane({0, 0, 30}, Vec3::UnitZ()));
  const Datum b = defined_in_own("B", plane({0, -52, 15}, -Vec3::UnitY()));
  const Datum c = defined_in_own("C", plane({-86, -20, 15}, -Vec3::UnitX()));
  Feature hole;
  hole.label = "HOLE";
  hole.nominal_frame = Frame::Identity();  // the fine alignment, here the machine's own frame
  hole.nominal = bore(FeatureType::Cylinder, {300, 80, -60}, Vec3::UnitZ(), 12);
  hole.actual = bore(FeatureType::Cylinder, {300.01, 80, -60}, Vec3::UnitZ(), 12);
  ToleranceContext context;
  context.datums = {&a, &b, &c};
  const auto r = evaluate_tolerance(position({"A", "B", "C"}), {&hole}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.02, k_tight);
  EXPECT_EQ(r->note.find("read in the feature's alignment"), std::string::npos) << r->note;
}

TEST(DatumFrame, SurfaceProfileToDatumsIgnoresTheMisplacement) {
  const Block block;
  // A sphere whose surface is made 0.03 mm oversize in radius (+0.03 everywhere, outside).
  Geometry nominal;
  nominal.type = FeatureType::Sphere;
  nominal.side = Side::Outer;
  nominal.position = {30, 20, 15};
  nominal.diameter_mm = 10;
  Feature ball;
  ball.label = "BALL";
  ball.nominal = nominal;
  Geometry truth = nominal;
  truth.diameter_mm = 10.06;
  ball.actual = to_machine(truth, misplacement());
  for (const Vec3& d : {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1), Vec3(-1, 0, 0), Vec3(0, -1, 0)}) {
    MeasuredPoint p;
    p.ball_radius_mm = 1;
    p.normal = misplacement().linear() * d;
    p.centre_mm = misplacement() * (nominal.position + (5.03 + 1.0) * d);
    ball.points.push_back(p);
  }
  ToleranceSpec s;
  s.label = "T2";
  s.kind = ToleranceKind::Profs;
  s.lower = -0.05;
  s.upper = 0.05;
  s.datums = {"A", "B", "C"};
  // The faces as drawn, so the truth is exactly +0.03 at every point.
  Datum a = block.a, b = block.b, c = block.c;
  a.geometry = to_machine(a.nominal, misplacement());
  b.geometry = to_machine(b.nominal, misplacement());
  c.geometry = to_machine(c.nominal, misplacement());
  ToleranceContext context;
  context.datums = {&a, &b, &c};
  const auto r = evaluate_tolerance(s, {&ball}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.03, k_tight);
  EXPECT_TRUE(r->in_tolerance);
  s.datums.clear();
  const auto bare = evaluate_tolerance(s, {&ball}, {});
  ASSERT_TRUE(bare);
  EXPECT_FALSE(bare->in_tolerance);  // the 0.4 mm misplacement
}

TEST(DatumFrame, ASecondaryDatumOrientsThePerpendicularityZoneOfAPlane) {
  // A front face square to the top (A) but yawed 0.1 deg about z against the left face (B), its
  // points spread 100 mm along x. Perpendicular to A alone the yaw is free (the value is the
  // face's form, 0); to A|B the zone's normal is the drawn one, and the yaw shows as
  // 100 sin(0.1 deg) = 0.17453 mm.
  const Datum a = datum("A", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0}, Vec3::UnitZ()));
  const Datum b = datum("B", plane({-50, 0, -10}, -Vec3::UnitX()), plane({-50, 0, -10}, -Vec3::UnitX()));
  const double yaw = 0.1 * 3.14159265358979323846 / 180.0;
  const Vec3 normal(std::sin(yaw), -std::cos(yaw), 0);  // the yawed face's normal (part frame)
  const Vec3 along(std::cos(yaw), std::sin(yaw), 0);
  Feature face;
  face.label = "FRONT";
  face.nominal = plane({0, -20, -10}, -Vec3::UnitY());
  face.actual = to_machine(plane({0, -20, -10}, normal), misplacement());
  for (const double x : {-50.0, 50.0})
    for (const double z : {-5.0, -15.0}) {
      MeasuredPoint p;
      p.ball_radius_mm = 1;
      p.normal = misplacement().linear() * normal;
      p.centre_mm = misplacement() * (Vec3(0, -20, 0) + x * along + Vec3(0, 0, z) + 1.0 * normal);
      face.points.push_back(p);
    }
  ToleranceSpec s;
  s.label = "T3";
  s.kind = ToleranceKind::Perp;
  s.zone = 0.05;
  s.datums = {"A"};
  ToleranceContext context;
  context.datums = {&a};
  auto r = evaluate_tolerance(s, {&face}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.0, 1e-9);
  s.datums = {"A", "B"};
  context.datums = {&a, &b};
  r = evaluate_tolerance(s, {&face}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 100 * std::sin(yaw), 1e-9);
  EXPECT_FALSE(r->in_tolerance);
  EXPECT_NE(r->note.find("zone oriented by datums A|B"), std::string::npos) << r->note;
}

TEST(DatumFrame, ASecondaryDatumOrientsTheAngularityZoneOfAnAxis) {
  // A 20 mm pin drawn at 45 deg to the top (A), leaning toward +x square to the left face (B),
  // made at the right angle but yawed 10 deg about z. To A alone the yaw is free: 0. To A|B the
  // zone's planes hold the drawn axis and y: the yawed axis leaves them by
  // sin 45 cos 45 (1 - cos 10 deg) over each mm of its length, 20 x 0.5 (1 - cos 10 deg) = 0.15192.
  const double deg = 3.14159265358979323846 / 180.0;
  const Datum a = datum("A", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0}, Vec3::UnitZ()));
  const Datum b = datum("B", plane({-50, 0, -10}, -Vec3::UnitX()), plane({-50, 0, -10}, -Vec3::UnitX()));
  const Vec3 drawn(std::sin(45 * deg), 0, std::cos(45 * deg));
  const Vec3 yawed(std::cos(10 * deg) * std::sin(45 * deg), std::sin(10 * deg) * std::sin(45 * deg),
                   std::cos(45 * deg));
  const Feature pin =
      feature(bore(FeatureType::Cylinder, {0, 20, -10}, drawn, 8), bore(FeatureType::Cylinder, {0, 20, -10}, yawed, 8));
  ToleranceSpec s;
  s.label = "T4";
  s.kind = ToleranceKind::Anglr;
  s.zone = 0.1;
  s.nominal = 45;
  s.datums = {"A"};
  ToleranceContext context;
  context.datums = {&a};
  auto r = evaluate_tolerance(s, {&pin}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.0, k_tight);
  s.datums = {"A", "B"};
  context.datums = {&a, &b};
  r = evaluate_tolerance(s, {&pin}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 20 * 0.5 * (1 - std::cos(10 * deg)), k_tight);
  EXPECT_FALSE(r->in_tolerance);
  EXPECT_NE(r->note.find("zone oriented by datums A|B"), std::string::npos) << r->note;
}

TEST(DatumFrame, AnUndefinedOrMismatchedDatumIsAnError) {
  const Geometry nominal = bore(FeatureType::Circle, {40, 30, -5}, Vec3::UnitZ(), 8);
  const Feature hole = feature(nominal, nominal);
  EXPECT_EQ(evaluate_tolerance(position({"A"}), {&hole}, {}).error(),
            "datum A is not defined: DATDEF/FA(feature),DAT(A) first");
  Datum odd = datum("A", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0}, Vec3::UnitZ()));
  odd.geometry.type = FeatureType::Point;
  ToleranceContext context;
  context.datums = {&odd};
  EXPECT_EQ(evaluate_tolerance(position({"A"}), {&hole}, context).error(),
            "datum A: its actual is POINT and its nominal PLANE: they cannot be matched");
}

}  // namespace
}  // namespace metron::runtime
