// SPDX-License-Identifier: GPL-3.0-or-later
// Tolerance evaluation against hand-computed answers (docs/tolerances.md gives the formulas).
#include <gtest/gtest.h>

#include <cmath>
#include <tuple>

#include "feature_geometry.hpp"
#include "metron/runtime/tolerance.hpp"
#include "runtime/src/detail/fit_actual.hpp"

namespace metron::runtime {
namespace {

constexpr double k_pi = 3.14159265358979323846;
constexpr double k_tight = 1e-9;

using test_support::plane;

Geometry round(FeatureType type, Side side, const Vec3& position, const Vec3& axis, double diameter_mm,
               double length_mm = 0) {
  Geometry g;
  g.type = type;
  g.side = side;
  g.position = position;
  g.direction = axis.normalized();
  g.diameter_mm = diameter_mm;
  g.length_mm = length_mm;
  return g;
}

Geometry point(const Vec3& position, const Vec3& normal = Vec3::UnitZ()) {
  Geometry g;
  g.type = FeatureType::Point;
  g.position = position;
  g.direction = normal;
  return g;
}

Geometry line(const Vec3& position, const Vec3& direction, double length_mm = 0) {
  Geometry g;
  g.type = FeatureType::Line;
  g.position = position;
  g.direction = direction.normalized();
  g.length_mm = length_mm;
  g.bounded = length_mm > 0;
  return g;
}

Feature feature(const std::string& label, const Geometry& nominal, std::optional<Geometry> actual) {
  Feature f;
  f.label = label;
  f.nominal = nominal;
  f.actual = std::move(actual);
  return f;
}

/// A probed point whose compensated surface point is exactly `surface` (ball radius 1 mm).
MeasuredPoint probed(const Vec3& surface, const Vec3& approach) {
  MeasuredPoint p;
  p.ball_radius_mm = 1.0;
  p.normal = approach.normalized();
  p.centre_mm = surface + p.ball_radius_mm * p.normal;
  return p;
}

ToleranceSpec spec(ToleranceKind kind) {
  ToleranceSpec s;
  s.label = "T1";
  s.kind = kind;
  return s;
}

Datum datum(const std::string& label, const Geometry& g) { return Datum{label, "D_" + label, g, g, Frame::Identity()}; }

tl::expected<ToleranceResult, std::string> evaluate(const ToleranceSpec& s, std::vector<const Feature*> fs,
                                                    const ToleranceContext& context = {}) {
  return evaluate_tolerance(s, fs, context);
}

// ------------------------------------------------------------------ size

TEST(ToleranceSize, BoreOversizeIsInOrOutByItsLimits) {
  const Feature bore = feature("CYL1", round(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 20.0, 30),
                               round(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 20.012, 30));
  ToleranceSpec s = spec(ToleranceKind::Diam);
  s.lower = -0.01;
  s.upper = 0.02;
  auto r = evaluate(s, {&bore});
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.012, k_tight);
  EXPECT_NEAR(r->actual, 20.012, k_tight);
  EXPECT_NEAR(r->nominal, 20.0, k_tight);
  EXPECT_TRUE(r->in_tolerance);
  EXPECT_EQ(r->features, std::vector<std::string>{"CYL1"});

  s.upper = 0.01;
  r = evaluate(s, {&bore});
  ASSERT_TRUE(r);
  EXPECT_FALSE(r->in_tolerance);
  EXPECT_DOUBLE_EQ(r->lower, -0.01);
  EXPECT_DOUBLE_EQ(r->upper, 0.01);
}

TEST(ToleranceSize, RadiusIsHalfTheDiameterDeviation) {
  const Feature circle = feature("C1", round(FeatureType::Circle, Side::Outer, {0, 0, 0}, Vec3::UnitZ(), 10.0),
                                 round(FeatureType::Circle, Side::Outer, {0, 0, 0}, Vec3::UnitZ(), 9.99));
  ToleranceSpec s = spec(ToleranceKind::Rad);
  s.lower = -0.004;
  s.upper = 0.004;
  const auto r = evaluate(s, {&circle});
  ASSERT_TRUE(r);
  EXPECT_NEAR(r->value, -0.005, k_tight);
  EXPECT_NEAR(r->actual, 4.995, k_tight);
  EXPECT_FALSE(r->in_tolerance);
}

TEST(ToleranceSize, ValueOnTheLimitIsIn) {
  // 50.01 - 50.0 is not exactly 0.01 in binary; the limit still holds.
  const Feature c = feature("C", round(FeatureType::Circle, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 50.0),
                            round(FeatureType::Circle, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 50.01));
  ToleranceSpec s = spec(ToleranceKind::Diam);
  s.lower = -0.01;
  s.upper = 0.01;
  EXPECT_TRUE(evaluate(s, {&c})->in_tolerance);
}

TEST(ToleranceSize, WrongTypesAndMissingActual) {
  const Feature pl = feature("PL1", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0}, Vec3::UnitZ()));
  Geometry cone = round(FeatureType::Cone, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 0);
  cone.apex_angle_deg = 60;
  const Feature co = feature("CO1", cone, cone);
  EXPECT_EQ(evaluate(spec(ToleranceKind::Diam), {&pl}).error(),
            "DIAM applies to a circle, arc, sphere or cylinder, not to a PLANE");
  EXPECT_EQ(evaluate(spec(ToleranceKind::Diam), {&co}).error(),
            "DIAM applies to a circle, arc, sphere or cylinder, not to a CONE");
  EXPECT_EQ(evaluate(spec(ToleranceKind::Rad), {&pl}).error(),
            "RAD applies to a circle, arc, sphere or cylinder, not to a PLANE");
  const Feature unmeasured = feature("F1", round(FeatureType::Circle, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 5), {});
  EXPECT_EQ(evaluate(spec(ToleranceKind::Diam), {&unmeasured}).error(),
            "feature F1 has no actual: measure or construct it first");
  EXPECT_EQ(evaluate(spec(ToleranceKind::Diam), {&pl, &pl}).error(), "DIAM applies to one feature, got 2");
}

// ------------------------------------------------------------------ form

TEST(ToleranceForm, FormValueAgainstTheZone) {
  Feature pl = feature("PL1", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0.001}, Vec3::UnitZ()));
  pl.fit = FitFigures{{}, 0.001, 0.004};
  ToleranceSpec s = spec(ToleranceKind::Flat);
  s.zone = 0.01;
  auto r = evaluate(s, {&pl});
  ASSERT_TRUE(r);
  EXPECT_DOUBLE_EQ(r->value, 0.004);
  EXPECT_DOUBLE_EQ(r->lower, 0.0);
  EXPECT_DOUBLE_EQ(r->upper, 0.01);
  EXPECT_TRUE(r->in_tolerance);
  s.zone = 0.003;
  EXPECT_FALSE(evaluate(s, {&pl})->in_tolerance);
}

// STRGHT of a CYLNDR: its axis, the centres of its sections. A pin of diameter 10 touched at 8
// points in each of three sections (z 0, 10, 20) whose centres are (0, 0), (d, 0), (0, 0): the
// narrowest cylinder about a line holding the three centres is the narrowest strip of their
// triangle in its plane, its least altitude, d (the other two are near 2d). Two sections: their
// centres lie on a line, 0. MMC adds the pin's departure from its MMC size (the nominal 10).
TEST(ToleranceForm, StraightnessOfACylindersAxisIsItsSectionCentres) {
  const double d = 0.01;
  const auto pin = [&](const std::vector<std::pair<double, Vec3>>& sections, double diameter) {
    const Geometry nominal = round(FeatureType::Cylinder, Side::Outer, {0, 0, 10}, Vec3::UnitZ(), 10, 20);
    Geometry actual = round(FeatureType::Cylinder, Side::Outer, {0, 0, 10}, Vec3::UnitZ(), diameter, 20);
    Feature f = feature("PIN", nominal, actual);
    f.fit = FitFigures{{}, 0.0, 0.0};
    for (const auto& [z, centre] : sections)
      for (int k = 0; k < 8; ++k) {
        const Vec3 out(std::cos(k * k_pi / 4), std::sin(k * k_pi / 4), 0);
        f.points.push_back(probed(centre + Vec3(0, 0, z) + diameter / 2 * out, out));
      }
    return f;
  };
  const Feature bent = pin({{0, {0, 0, 0}}, {10, {d, 0, 0}}, {20, {0, 0, 0}}}, 10);
  ToleranceSpec s = spec(ToleranceKind::Strght);
  s.zone = 0.012;
  const auto r = evaluate(s, {&bent});
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, d, 1e-6) << r->note;
  EXPECT_TRUE(r->in_tolerance);
  EXPECT_NE(r->note.find("the centres of 3 sections"), std::string::npos) << r->note;
  s.zone = 0.008;
  EXPECT_FALSE(evaluate(s, {&bent})->in_tolerance);
  // At MMC a pin 0.004 under its MMC size (taken as the nominal 10) gets 0.004 more.
  const Feature thin = pin({{0, {0, 0, 0}}, {10, {d, 0, 0}}, {20, {0, 0, 0}}}, 9.996);
  s.condition = MaterialCondition::Mmc;
  const auto bonus = evaluate(s, {&thin});
  ASSERT_TRUE(bonus) << bonus.error();
  EXPECT_NEAR(bonus->upper, 0.012, 1e-9);
  EXPECT_TRUE(bonus->in_tolerance) << bonus->note;
  const Feature two = pin({{0, {0, 0, 0}}, {20, {d, 0, 0}}}, 10);
  s.condition = MaterialCondition::Rfs;
  EXPECT_NEAR(evaluate(s, {&two})->value, 0.0, 1e-12);
  // Per unit length 20 (STRGHT,t,tu,20): an axis bowed d over 40 mm, its centres 0, d/2, d, d/2, 0
  // at z 0..40: the whole is d, a stretch of 20 at most d/2 (z 10..30: the middle centre d/2 off
  // the line of the other two; z 0..20 and 20..40 lie on lines).
  const Feature bow =
      pin({{0, {0, 0, 0}}, {10, {d / 2, 0, 0}}, {20, {d, 0, 0}}, {30, {d / 2, 0, 0}}, {40, {0, 0, 0}}}, 10);
  s.zone = 1.2 * d;
  s.unit_length = 20;
  s.unit_zone = 0.6 * d;
  auto unit = evaluate(s, {&bow});
  ASSERT_TRUE(unit) << unit.error();
  EXPECT_NEAR(unit->value, d, 1e-6) << unit->note;
  EXPECT_TRUE(unit->in_tolerance) << unit->note;
  EXPECT_NE(unit->note.find("per unit length 20.0000: the largest minimum zone of the centres 0.005000 (zone 0.006000, "
                            "IN)"),
            std::string::npos)
      << unit->note;
  s.unit_zone = 0.4 * d;
  unit = evaluate(s, {&bow});
  ASSERT_TRUE(unit) << unit.error();
  EXPECT_FALSE(unit->in_tolerance) << unit->note;
  EXPECT_TRUE(tolerance_applies(ToleranceKind::Strght, FeatureType::Cylinder));
}

// CIRLTY of a SPHERE (ASME Y14.5: every section through a common centre) is its minimum-zone
// sphericity. Six points on the axes of a 20 mm ball, the +X one 0.01 out: a centre e along X
// puts the X radii at 10.01 - e and 10 + e, the other four at sqrt(100 + e^2) (a shift across X
// shortens one of them), so the range is least at e = 0.005: 0.005 - (sqrt(100 + 0.005^2) - 10).
TEST(ToleranceForm, CircularityOfASphereIsItsSphericity) {
  Feature ball = feature("BALL", round(FeatureType::Sphere, Side::Outer, {0, 0, 0}, Vec3::UnitZ(), 20), std::nullopt);
  for (const Vec3& u : {Vec3(1, 0, 0), Vec3(-1, 0, 0), Vec3(0, 1, 0), Vec3(0, -1, 0), Vec3(0, 0, 1), Vec3(0, 0, -1)})
    ball.points.push_back(probed((u.x() > 0 ? 10.01 : 10.0) * u, -u));
  auto fitted = fit_actual(ball.nominal, ball.points);
  ASSERT_TRUE(fitted) << fitted.error();
  ball.actual = fitted->first;
  ball.fit = fitted->second;
  ToleranceSpec s = spec(ToleranceKind::Cirlty);
  s.zone = 0.006;
  const auto r = evaluate(s, {&ball});
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.005 - (std::sqrt(100 + 0.005 * 0.005) - 10), 1e-9) << r->note;
  EXPECT_TRUE(r->in_tolerance);
  EXPECT_NE(r->note.find("a sphere's circularity"), std::string::npos) << r->note;
  EXPECT_NEAR(evaluate(spec(ToleranceKind::Sphcty), {&ball})->value, r->value, 1e-12);
}

TEST(ToleranceForm, EachFormAppliesToItsShape) {
  const Geometry cyl = round(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10, 20);
  Feature c = feature("CYL1", cyl, cyl);
  c.fit = FitFigures{{}, 0.001, 0.005};
  EXPECT_EQ(evaluate(spec(ToleranceKind::Flat), {&c}).error(), "FLAT applies to a plane, not to a CYLNDR");
  EXPECT_EQ(evaluate(spec(ToleranceKind::Cirlty), {&c}).error(),
            "feature CYL1 has no section of four points or more (points at one height along its axis): CIRLTY of a "
            "CYLNDR is the roundness of its sections");
  EXPECT_EQ(evaluate(spec(ToleranceKind::Sphcty), {&c}).error(), "SPHCTY applies to a sphere, not to a CYLNDR");
  EXPECT_EQ(evaluate(spec(ToleranceKind::Strght), {&c}).error(),
            "feature CYL1 has no measured points: the straightness of its axis needs the centres of its sections");
  ToleranceSpec s = spec(ToleranceKind::Cylcty);
  s.zone = 0.004;
  const auto r = evaluate(s, {&c});
  ASSERT_TRUE(r);
  EXPECT_DOUBLE_EQ(r->value, 0.005);
  EXPECT_FALSE(r->in_tolerance);

  const Geometry arc = round(FeatureType::Arc, Side::Outer, {0, 0, 0}, Vec3::UnitZ(), 10);
  Feature a = feature("ARC1", arc, arc);
  a.fit = FitFigures{{}, 0.0, 0.002};
  EXPECT_DOUBLE_EQ(evaluate(spec(ToleranceKind::Cirlty), {&a})->value, 0.002);
  Feature l = feature("L1", line({0, 0, 0}, Vec3::UnitX(), 50), line({0, 0, 0}, Vec3::UnitX(), 50));
  l.fit = FitFigures{{}, 0.0, 0.003};
  EXPECT_DOUBLE_EQ(evaluate(spec(ToleranceKind::Strght), {&l})->value, 0.003);
}

TEST(ToleranceForm, ConstructedFeatureHasNoForm) {
  const Feature pl = feature("PL1", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0}, Vec3::UnitZ()));
  EXPECT_EQ(evaluate(spec(ToleranceKind::Flat), {&pl}).error(),
            "feature PL1 has no fit: FLAT needs the form of measured points, and it was constructed without any");
}

// ------------------------------------------------------------------ POS

TEST(TolerancePosition, AxisOffsetGivesTwiceTheOffset) {
  // The actual axis is offset 0.03 in X; its position lies at another height on the axis.
  const Feature bore = feature("CYL1", round(FeatureType::Cylinder, Side::Inner, {10, 20, 0}, Vec3::UnitZ(), 12, 30),
                               round(FeatureType::Cylinder, Side::Inner, {10.03, 20, 15}, Vec3::UnitZ(), 12, 30));
  ToleranceSpec s = spec(ToleranceKind::Pos);
  s.zone = 0.1;
  auto r = evaluate(s, {&bore});
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.06, k_tight);
  EXPECT_DOUBLE_EQ(r->upper, 0.1);
  EXPECT_TRUE(r->in_tolerance);
  EXPECT_FALSE(r->three_d);
  s.zone = 0.05;
  EXPECT_FALSE(evaluate(s, {&bore})->in_tolerance);
  // 3D counts the 15 mm along the axis too.
  s.three_d = true;
  r = evaluate(s, {&bore});
  EXPECT_NEAR(r->value, 2 * std::hypot(0.03, 15.0), 1e-9);
  EXPECT_TRUE(r->three_d);
}

TEST(TolerancePosition, TiltedAxisIsComparedAtTheNominalHeight) {
  // Through (10, 20, 10), tilted 0.001 in X per mm of Z: at z = 0 it passes x = 9.99.
  const Feature bore = feature("CYL1", round(FeatureType::Cylinder, Side::Inner, {10, 20, 0}, Vec3::UnitZ(), 12, 30),
                               round(FeatureType::Cylinder, Side::Inner, {10, 20, 10}, {0.001, 0, 1}, 12, 30));
  ToleranceSpec s = spec(ToleranceKind::Pos);
  s.zone = 0.1;
  EXPECT_NEAR(evaluate(s, {&bore})->value, 0.02, 1e-9);
}

TEST(TolerancePosition, PointsAndSpheres) {
  const Feature p = feature("P1", point({1, 2, 3}), point({1.003, 2.004, 3.5}));
  ToleranceSpec s = spec(ToleranceKind::Pos);
  s.zone = 0.02;
  // 2D drops the offset along the nominal direction (Z).
  EXPECT_NEAR(evaluate(s, {&p})->value, 0.01, k_tight);
  s.three_d = true;
  EXPECT_NEAR(evaluate(s, {&p})->value, 2 * std::sqrt(0.003 * 0.003 + 0.004 * 0.004 + 0.25), k_tight);

  const Feature sph = feature("S1", round(FeatureType::Sphere, Side::Outer, {0, 0, 0}, Vec3::UnitZ(), 20),
                              round(FeatureType::Sphere, Side::Outer, {0.03, 0, 0.5}, Vec3::UnitZ(), 20));
  s.three_d = false;
  EXPECT_NEAR(evaluate(s, {&sph})->value, 0.06, k_tight);
}

TEST(TolerancePosition, MaterialConditionBonus) {
  const Geometry nominal = round(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10, 20);
  Geometry actual = round(FeatureType::Cylinder, Side::Inner, {0.03, 0, 0}, Vec3::UnitZ(), 10.02, 20);
  Feature hole = feature("H1", nominal, actual);
  ToleranceSpec s = spec(ToleranceKind::Pos);
  s.zone = 0.05;
  EXPECT_FALSE(evaluate(s, {&hole})->in_tolerance);  // RFS: 0.06 > 0.05
  s.condition = MaterialCondition::Mmc;
  auto r = evaluate(s, {&hole});
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->upper, 0.07, k_tight);  // 0.05 + (10.02 - 10)
  EXPECT_TRUE(r->in_tolerance);
  EXPECT_NE(r->note.find("MMC bonus 0.0200"), std::string::npos) << r->note;
  // LMC: the hole grew toward LMC (the nominal), no bonus.
  s.condition = MaterialCondition::Lmc;
  EXPECT_NEAR(evaluate(s, {&hole})->upper, 0.05, k_tight);
  // An undersize hole is beyond MMC: no bonus under MMC, 0.01 under LMC.
  hole.actual->diameter_mm = 9.99;
  EXPECT_NEAR(evaluate(s, {&hole})->upper, 0.06, k_tight);
  s.condition = MaterialCondition::Mmc;
  EXPECT_NEAR(evaluate(s, {&hole})->upper, 0.05, k_tight);
  // A boss gains under MMC as it shrinks.
  Geometry boss_nominal = nominal;
  boss_nominal.side = Side::Outer;
  Geometry boss_actual = actual;
  boss_actual.side = Side::Outer;
  boss_actual.diameter_mm = 9.98;
  const Feature boss = feature("B1", boss_nominal, boss_actual);
  EXPECT_NEAR(evaluate(s, {&boss})->upper, 0.07, k_tight);

  const Feature p = feature("P1", point({0, 0, 0}), point({0, 0, 0}));
  EXPECT_EQ(evaluate(s, {&p}).error(),
            "MMC applies to a circle, arc, sphere, cylinder, pair of parallel planes or closed slot (CPARLN), not to a "
            "POINT");
}

// Datum shift: plane A, then hole B at MMC, 10 mm nominal, 10.04 as made (0.04 from its MMC
// size): the frame may move 0.02, taken off the feature's 0.05 deviation. Expected values by hand.
TEST(TolerancePosition, ADatumHoleAtMmcLetsTheFrameShift) {
  const Feature c = feature("C1", round(FeatureType::Circle, Side::Inner, {30, 0, 0}, Vec3::UnitZ(), 6),
                            round(FeatureType::Circle, Side::Inner, {30.05, 0, 0}, Vec3::UnitZ(), 6));
  const Datum a = datum("A", plane({0, 0, 0}, Vec3::UnitZ()));
  Datum b = datum("B", round(FeatureType::Circle, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10));
  b.geometry.diameter_mm = 10.04;
  ToleranceContext context;
  context.datums = {&a, &b};
  ToleranceSpec s = spec(ToleranceKind::Pos);
  s.zone = 0.08;
  s.datums = {"A", "B"};
  s.datum_conditions = {MaterialCondition::Rfs, MaterialCondition::Rfs};
  const auto rfs = evaluate(s, {&c}, context);
  ASSERT_TRUE(rfs) << rfs.error();
  EXPECT_NEAR(rfs->value, 0.10, k_tight);
  EXPECT_FALSE(rfs->in_tolerance);
  s.datum_conditions[1] = MaterialCondition::Mmc;
  const auto mmc = evaluate(s, {&c}, context);
  ASSERT_TRUE(mmc) << mmc.error();
  EXPECT_NEAR(mmc->value, 2 * (0.05 - 0.02), k_tight);
  EXPECT_TRUE(mmc->in_tolerance);
  EXPECT_NE(mmc->note.find("datum shift: DAT(B) at MMC departs 0.0400 from that size, the frame may move 0.0200; "
                           "without the shift 0.1000"),
            std::string::npos)
      << mmc->note;
  // LMC: a hole larger than nominal is nearer its LMC, no departure, no shift.
  s.datum_conditions[1] = MaterialCondition::Lmc;
  EXPECT_NEAR(evaluate(s, {&c}, context)->value, 0.10, k_tight);
  // A deviation smaller than the shift is taken up whole.
  const Feature near = feature("C2", round(FeatureType::Circle, Side::Inner, {30, 0, 0}, Vec3::UnitZ(), 6),
                               round(FeatureType::Circle, Side::Inner, {30.012, 0.009, 0}, Vec3::UnitZ(), 6));
  s.datum_conditions[1] = MaterialCondition::Mmc;
  EXPECT_NEAR(evaluate(s, {&near}, context)->value, 0, k_tight);
  // A plane at MMC has no size: a note, no shift.
  s.datum_conditions = {MaterialCondition::Mmc, MaterialCondition::Rfs};
  const auto plane_mmc = evaluate(s, {&c}, context);
  EXPECT_NEAR(plane_mmc->value, 0.10, k_tight);
  EXPECT_NE(plane_mmc->note.find("DAT(A) at MMC: a PLANE datum does not shift here"), std::string::npos);
}

TEST(TolerancePosition, DatumsMustBeDefinedAndPlanesAreRejected) {
  const Feature c = feature("C1", round(FeatureType::Circle, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10),
                            round(FeatureType::Circle, Side::Inner, {0.01, 0, 0}, Vec3::UnitZ(), 10));
  ToleranceSpec s = spec(ToleranceKind::Pos);
  s.zone = 0.1;
  s.datums = {"A", "B"};
  EXPECT_EQ(evaluate(s, {&c}).error(), "datum A is not defined: DATDEF/FA(feature),DAT(A) first");
  // Datums whose actuals are their nominals leave the evaluation as it stands (the frame is
  // tested against misplaced parts in test_datum_frame.cpp).
  const Datum a = datum("A", plane({0, 0, 0}, Vec3::UnitZ()));
  const Datum b = datum("B", plane({-20, 0, 0}, -Vec3::UnitX()));
  ToleranceContext context;
  context.datums = {&a, &b};
  const auto r = evaluate(s, {&c}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.02, k_tight);
  EXPECT_NE(r->note.find("datum reference frame A|B: 3 of 3 rotations and 2 of 3 translations fixed"),
            std::string::npos)
      << r->note;
  const Feature pl = feature("PL1", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0}, Vec3::UnitZ()));
  EXPECT_EQ(
      evaluate(s, {&pl}).error(),
      "POS applies to a point, circle, arc, sphere, cylinder, cone, line, closed slot (CPARLN), torus, ellipse or "
      "pair of parallel planes, not to a PLANE");
}

// ------------------------------------------------------------------ DISTB

/// A part frame rotated 30 deg about machine X and shifted: part Z is not machine Z.
Alignment rotated_part() {
  Alignment a;
  a.label = "PART";
  a.part_to_machine = Frame::Identity();
  a.part_to_machine.translate(Vec3(100, 50, -20));
  a.part_to_machine.rotate(Eigen::AngleAxisd(30.0 * k_pi / 180.0, Vec3::UnitX()));
  return a;
}

TEST(ToleranceDistance, TwoPlanesAlongZOfARotatedAlignment) {
  const Alignment part = rotated_part();
  const auto pl = [&](const Vec3& p) { return plane(part.to_machine_point(p), part.to_machine_vector(Vec3::UnitZ())); };
  // Positions (centroids) at different part XY: only the Z difference counts.
  const Feature bottom = feature("PL1", pl({0, 0, 0}), pl({5, 3, 0}));
  const Feature top = feature("PL2", pl({10, 10, 40}), pl({-7, 12, 40.015}));
  ToleranceSpec s = spec(ToleranceKind::DistB);
  s.axis = DistanceAxis::ZAxis;
  s.nominal = 40;
  s.lower = -0.01;
  s.upper = 0.01;
  ToleranceContext context;
  context.alignment = &part;
  auto r = evaluate(s, {&bottom, &top}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->actual, 40.015, 1e-9);
  EXPECT_NEAR(r->nominal, 40.0, 1e-9);
  EXPECT_NEAR(r->value, 0.015, 1e-9);
  EXPECT_FALSE(r->in_tolerance);
  EXPECT_EQ(r->note, "along ZAXIS of PART");

  // Point to point between planes: along the first plane's normal, the same here.
  s.axis = DistanceAxis::PointToPoint;
  EXPECT_NEAR(evaluate(s, {&bottom, &top}, context)->actual, 40.015, 1e-9);
  // Along machine Z (no alignment) the vertical line crosses the tilted planes 40.015 / cos 30 apart.
  s.axis = DistanceAxis::ZAxis;
  EXPECT_NEAR(evaluate(s, {&bottom, &top})->actual, 40.015 / std::cos(30.0 * k_pi / 180.0), 1e-9);
  // Part X lies in both planes.
  s.axis = DistanceAxis::XAxis;
  EXPECT_EQ(evaluate(s, {&bottom, &top}, context).error(), "DISTB along XAXIS: plane PL1 is parallel to that axis");
}

TEST(ToleranceDistance, PointsAxesAndCounts) {
  const Alignment part = rotated_part();
  ToleranceContext context;
  context.alignment = &part;
  const Feature a = feature("A", point(part.to_machine_point({0, 0, 0})), point(part.to_machine_point({0, 0, 0})));
  const Feature b = feature("B", point(part.to_machine_point({3, 4, 0})), point(part.to_machine_point({3, 4.01, 0})));
  ToleranceSpec s = spec(ToleranceKind::DistB);
  s.nominal = 5;
  s.lower = -0.1;
  s.upper = 0.1;
  auto r = evaluate(s, {&a, &b}, context);
  EXPECT_NEAR(r->actual, std::hypot(3.0, 4.01), 1e-9);
  EXPECT_NEAR(r->nominal, 5.0, 1e-9);
  s.axis = DistanceAxis::YAxis;
  s.nominal = 4;
  r = evaluate(s, {&a, &b}, context);
  EXPECT_NEAR(r->actual, 4.01, 1e-9);
  EXPECT_NEAR(r->value, 0.01, 1e-9);

  // A point and a cylinder: from the point to the axis.
  const Feature cyl = feature("CYL", round(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 5, 10),
                              round(FeatureType::Cylinder, Side::Inner, {0, 0, 7}, Vec3::UnitZ(), 5, 10));
  const Feature p = feature("P", point({6, 8, 3}), point({6, 8, 3}));
  s.axis = DistanceAxis::PointToPoint;
  s.nominal = 10;
  EXPECT_NEAR(evaluate(s, {&cyl, &p})->actual, 10.0, 1e-12);
  EXPECT_NEAR(evaluate(s, {&p, &cyl})->actual, 10.0, 1e-12);

  EXPECT_EQ(evaluate(s, {&a}).error(), "DISTB needs two features, got 1");
  // A nominal that disagrees with the features' nominals is noted.
  s.nominal = 9.5;
  EXPECT_EQ(evaluate(s, {&cyl, &p})->note, "the feature nominals give 10.0000, the tolerance nominal is 9.5000");
}

TEST(ToleranceDistance, MinimAndMaximTakeTheSizesOffOrAddThem) {
  // Two holes of 10 and 6 mm, centres 50 mm apart along X (actual 50.02): the wall between
  // them (MINIM) is 50.02 - 5 - 3 and the span over them (MAXIM) 50.02 + 5 + 3.
  const Feature big = feature("C1", round(FeatureType::Circle, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10),
                              round(FeatureType::Circle, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10));
  const Feature small = feature("C2", round(FeatureType::Circle, Side::Inner, {50, 0, 0}, Vec3::UnitZ(), 6),
                                round(FeatureType::Circle, Side::Inner, {50.02, 0, 0}, Vec3::UnitZ(), 6));
  ToleranceSpec s = spec(ToleranceKind::DistB);
  s.nominal = 42;
  s.lower = -0.1;
  s.upper = 0.1;
  s.extent = DistanceExtent::Minimum;
  auto r = evaluate(s, {&big, &small});
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->actual, 42.02, 1e-9);
  EXPECT_NEAR(r->nominal, 42.0, 1e-9);
  EXPECT_EQ(r->note, "MINIM: between the near sides");
  s.extent = DistanceExtent::Maximum;
  s.nominal = 58;
  EXPECT_NEAR(evaluate(s, {&big, &small})->actual, 58.02, 1e-9);
  // Along Z the circles (in XY planes) have no extent: MAXIM is the centre distance along Z.
  s.axis = DistanceAxis::ZAxis;
  EXPECT_NEAR(evaluate(s, {&big, &small})->actual, 0.0, 1e-9);
  // Along X each circle reaches its radius.
  s.axis = DistanceAxis::XAxis;
  EXPECT_NEAR(evaluate(s, {&big, &small})->actual, 58.02, 1e-9);
  // A sphere of 20 mm 30 mm above a plane: its lowest point is 20 mm above it, its top 40 mm.
  const Feature floor = feature("PL", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0}, Vec3::UnitZ()));
  const Feature ball = feature("SPH", round(FeatureType::Sphere, Side::Outer, {3, 4, 30}, Vec3::UnitZ(), 20),
                               round(FeatureType::Sphere, Side::Outer, {3, 4, 30}, Vec3::UnitZ(), 20));
  s.axis = DistanceAxis::PointToPoint;
  s.extent = DistanceExtent::Minimum;
  EXPECT_NEAR(evaluate(s, {&floor, &ball})->actual, 20.0, 1e-9);
  s.extent = DistanceExtent::Maximum;
  EXPECT_NEAR(evaluate(s, {&floor, &ball})->actual, 40.0, 1e-9);
  // Two points have no size: MINIM is their distance, and the note says so.
  const Feature a = feature("A", point({0, 0, 0}), point({0, 0, 0}));
  const Feature b = feature("B", point({3, 4, 0}), point({3, 4, 0}));
  s.extent = DistanceExtent::Minimum;
  r = evaluate(s, {&a, &b});
  EXPECT_NEAR(r->actual, 5.0, 1e-9);
  EXPECT_NE(r->note.find("neither feature has a size"), std::string::npos);
}

// ------------------------------------------------------------------ PERP / PARLEL

constexpr double k_tilt = 0.001;  // tan of the tilt of the measured surfaces

/// A wall x = 50 (normal +X) whose points lean by k_tilt: x = 50 + k_tilt z, for z in [0, 20].
Feature leaning_wall() {
  const double theta = std::atan(k_tilt);
  Feature f = feature("WALL", plane({50, 15, 10}, Vec3::UnitX()),
                      plane({50 + 10 * k_tilt, 15, 10}, {std::cos(theta), 0, -std::sin(theta)}));
  for (double y : {0.0, 30.0})
    for (double z : {0.0, 10.0, 20.0}) f.points.push_back(probed({50 + k_tilt * z, y, z}, Vec3::UnitX()));
  return f;
}

/// A top face z = 10 (normal +Z) rising by 0.0002 per mm of X over x in [0, 100].
Feature rising_top() {
  const double slope = 0.0002;
  Feature f = feature("TOP", plane({50, 15, 10}, Vec3::UnitZ()), plane({50, 15, 10.01}, Vec3(-slope, 0, 1)));
  for (double x : {0.0, 50.0, 100.0})
    for (double y : {0.0, 30.0}) f.points.push_back(probed({x, y, 10 + slope * x}, Vec3::UnitZ()));
  return f;
}

TEST(ToleranceOrientation, PlaneToDatumPlane) {
  const Datum a = datum("A", plane({0, 0, 0}, Vec3::UnitZ()));
  ToleranceContext context;
  context.datums = {&a};
  ToleranceSpec s = spec(ToleranceKind::Perp);
  s.zone = 0.03;
  s.datums = {"A"};
  const Feature wall = leaning_wall();
  auto r = evaluate(s, {&wall}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 20 * k_tilt, 1e-12);  // the points span x in [50, 50.02]
  EXPECT_TRUE(r->in_tolerance);

  s.kind = ToleranceKind::Parlel;
  s.zone = 0.01;
  const Feature top = rising_top();
  r = evaluate(s, {&top}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.02, 1e-12);  // z spans [10, 10.02]
  EXPECT_FALSE(r->in_tolerance);
}

TEST(ToleranceOrientation, PlaneToDatumAxis) {
  const Datum b = datum("B", round(FeatureType::Cylinder, Side::Outer, {0, 0, 0}, Vec3::UnitZ(), 10, 50));
  ToleranceContext context;
  context.datums = {&b};
  ToleranceSpec s = spec(ToleranceKind::Perp);
  s.zone = 0.05;
  const Feature top = rising_top();
  EXPECT_NEAR(evaluate(s, {&top}, context)->value, 0.02, 1e-12);
  s.kind = ToleranceKind::Parlel;
  const Feature wall = leaning_wall();
  EXPECT_NEAR(evaluate(s, {&wall}, context)->value, 20 * k_tilt, 1e-12);
}

TEST(ToleranceOrientation, AxisToDatumPlaneAndAxis) {
  const Datum a = datum("A", plane({0, 0, 0}, Vec3::UnitZ()));
  ToleranceContext context;
  context.datums = {&a};
  ToleranceSpec s = spec(ToleranceKind::Perp);
  s.zone = 0.05;
  // A 50 mm bore tilted by atan(0.001) from Z: diametral zone 50 sin(theta).
  const Vec3 tilted = Vec3(0.001, 0, 1).normalized();
  const Feature bore = feature("CYL1", round(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10, 50),
                               round(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, tilted, 10, 50));
  auto r = evaluate(s, {&bore}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 50 * 0.001 / std::sqrt(1 + 1e-6), 1e-12);
  EXPECT_TRUE(r->in_tolerance);
  EXPECT_EQ(r->note, "axis of CYL1 at 0.0573 deg to datum A (normal), over 50.0000 mm (diametral zone)");
  // An axis has no sense: pointing down gives the same value and angle.
  Feature down = bore;
  down.actual->direction = -tilted;
  const auto r_down = evaluate(s, {&down}, context);
  EXPECT_NEAR(r_down->value, r->value, 1e-15);
  EXPECT_EQ(r_down->note, r->note);
  // PARLEL of a horizontal line to the datum plane: its rise over its length.
  const Vec3 rising = Vec3(1, 0, 0.0004).normalized();
  const Feature l = feature("L1", line({0, 0, 5}, Vec3::UnitX(), 100), line({0, 0, 5}, rising, 100));
  s.kind = ToleranceKind::Parlel;
  EXPECT_NEAR(evaluate(s, {&l}, context)->value, 100 * 0.0004 / std::sqrt(1 + 1.6e-7), 1e-12);

  // Against a datum axis: PARLEL is diametral, PERP is two planes normal to the datum axis.
  const Datum b = datum("B", round(FeatureType::Cylinder, Side::Outer, {0, 0, 0}, Vec3::UnitZ(), 10, 50));
  context.datums = {&b};
  EXPECT_NEAR(evaluate(s, {&bore}, context)->value, 50 * 0.001 / std::sqrt(1 + 1e-6), 1e-12);
  s.kind = ToleranceKind::Perp;
  EXPECT_NEAR(evaluate(s, {&l}, context)->value, 100 * 0.0004 / std::sqrt(1 + 1.6e-7), 1e-12);
}

// PERP at MMC of a bore (ASME Y14.5 bonus): a 10 mm bore made 10.03 departs 0.03 from its MMC
// size (the nominal: the tolerance has no size limits), so a 0.03 zone grows to 0.06 and holds
// the axis's 50 x 0.001 = 0.05 excursion that RFS rejects.
TEST(ToleranceOrientation, MaterialConditionGrowsTheZoneOfAFeatureOfSize) {
  const Datum a = datum("A", plane({0, 0, 0}, Vec3::UnitZ()));
  ToleranceContext context;
  context.datums = {&a};
  ToleranceSpec s = spec(ToleranceKind::Perp);
  s.zone = 0.03;
  s.datums = {"A"};
  const Vec3 tilted = Vec3(0.001, 0, 1).normalized();
  const Feature bore = feature("CYL1", round(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10, 50),
                               round(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, tilted, 10.03, 50));
  auto r = evaluate(s, {&bore}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 50 * 0.001 / std::sqrt(1 + 1e-6), 1e-12);
  EXPECT_FALSE(r->in_tolerance);
  s.condition = MaterialCondition::Mmc;
  r = evaluate(s, {&bore}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->upper, 0.06, 1e-12);
  EXPECT_TRUE(r->in_tolerance);
  EXPECT_NE(r->note.find("MMC bonus"), std::string::npos) << r->note;
  // A plane has no size: the modifier is noted and the zone stays.
  const Feature wall = leaning_wall();
  r = evaluate(s, {&wall}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->upper, 0.03, 1e-12);
  EXPECT_NE(r->note.find("WALL has no size: MMC does not apply"), std::string::npos) << r->note;
}

TEST(ToleranceOrientation, AxisLengthFromThePointsWhenUnknown) {
  const Datum a = datum("A", plane({0, 0, 0}, Vec3::UnitZ()));
  ToleranceContext context;
  context.datums = {&a};
  Feature bore = feature("CYL1", round(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10, 0),
                         round(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, Vec3(0.001, 0, 1), 10, 0));
  for (double z : {2.0, 12.0, 32.0}) bore.points.push_back(probed({5, 0, z}, -Vec3::UnitX()));
  ToleranceSpec s = spec(ToleranceKind::Perp);
  s.zone = 0.05;
  const Vec3 axis = Vec3(0.001, 0, 1).normalized();
  const double extent = (Vec3(5, 0, 32) - Vec3(5, 0, 2)).dot(axis);
  EXPECT_NEAR(evaluate(s, {&bore}, context)->value, extent * axis.cross(Vec3::UnitZ()).norm(), 1e-12);
  bore.points.clear();
  EXPECT_EQ(evaluate(s, {&bore}, context).error(),
            "PERP of CYL1: the axis has no length and no points to take it from");
}

TEST(ToleranceOrientation, DatumErrors) {
  const Feature wall = leaning_wall();
  ToleranceSpec s = spec(ToleranceKind::Perp);
  EXPECT_EQ(evaluate(s, {&wall}).error(), "PERP needs a datum: TOL/PERP,...,DAT(A)");
  s.datums = {"A"};
  EXPECT_EQ(evaluate(s, {&wall}).error(), "datum A is not defined: DATDEF/FA(feature),DAT(A) first");
  ToleranceContext context;
  context.datums = {nullptr};
  EXPECT_EQ(evaluate(s, {&wall}, context).error(), "datum A is not defined: DATDEF/FA(feature),DAT(A) first");
  const Datum p = datum("A", point({0, 0, 0}));
  context.datums = {&p};
  EXPECT_EQ(evaluate(s, {&wall}, context).error(), "datum A is a POINT: it has no direction to measure PERP against");
  const Feature c = feature("C1", round(FeatureType::Circle, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10),
                            round(FeatureType::Circle, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10));
  EXPECT_EQ(evaluate(s, {&c}, context).error(),
            "PERP applies to a plane, line, cylinder, cone, closed slot (CPARLN) or pair of parallel planes, not to a "
            "CIRCLE");
}

// ------------------------------------------------------------------ ANGLR

/// A face through the origin whose normal is `tilt_deg` from +Z toward +X (a chamfer), touched
/// at slant distances 2 and 8 mm down its slope and y 0 and 30.
Feature chamfer(double tilt_deg) {
  const double t = tilt_deg * k_pi / 180.0;
  const Vec3 normal(std::sin(t), 0, std::cos(t));
  const Vec3 slope(std::cos(t), 0, -std::sin(t));  // in the face, down from the origin
  const double nominal = 30 * k_pi / 180.0;
  Feature f =
      feature("CHAMFER", plane({0, 0, 0}, Vec3(std::sin(nominal), 0, std::cos(nominal))), plane({0, 0, 0}, normal));
  for (double s : {2.0, 8.0})
    for (double y : {0.0, 30.0}) f.points.push_back(probed(s * slope + Vec3(0, y, 0), normal));
  return f;
}

// Angularity (ASME Y14.5M-1994 6.6.2): the zone is two planes (for an axis: its excursion) at the basic
// angle to the datum. Expected values from the geometry: a face 0.1 deg past its basic 30 deg,
// touched 6 mm apart down its slope, spreads 6 sin(0.1 deg) across the zone; an axis 0.2 deg off
// over 40 mm, 40 sin(0.2 deg).
TEST(ToleranceOrientation, AngularityAtTheBasicAngle) {
  const Datum a = datum("A", plane({0, 0, 0}, Vec3::UnitZ()));
  ToleranceContext context;
  context.datums = {&a};
  ToleranceSpec s = spec(ToleranceKind::Anglr);
  s.zone = 0.01;
  s.nominal = 30;
  s.datums = {"A"};
  const double deg = k_pi / 180.0;
  const Feature off = chamfer(30.1);
  auto r = evaluate(s, {&off}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 6 * std::sin(0.1 * deg), 1e-12);
  EXPECT_FALSE(r->in_tolerance);
  EXPECT_NE(r->note.find("the plane at 30.1000 deg to datum A, basic 30 deg"), std::string::npos) << r->note;
  const Feature exact = chamfer(30);
  EXPECT_NEAR(evaluate(s, {&exact}, context)->value, 0, 1e-12);
  // The same lines at the obtuse angle; and at 90 and 0 deg, angularity is PERP and PARLEL.
  s.nominal = 150;
  EXPECT_NEAR(evaluate(s, {&off}, context)->value, 6 * std::sin(0.1 * deg), 1e-12);
  const Feature wall = leaning_wall();
  const Feature top = rising_top();
  for (const auto& [basic, kind, f] :
       {std::tuple{90.0, ToleranceKind::Perp, &wall}, std::tuple{0.0, ToleranceKind::Parlel, &top}}) {
    s.kind = ToleranceKind::Anglr;
    s.nominal = basic;
    const double angularity = evaluate(s, {f}, context)->value;
    s.kind = kind;
    EXPECT_NEAR(angularity, evaluate(s, {f}, context)->value, 1e-12) << basic;
  }

  // An axis at 45.2 deg to the datum plane (its direction 44.8 deg from the plane's normal),
  // basic 45 deg: 40 sin(0.2 deg); the same axis against a datum axis along Z (the angle between
  // the axes is 44.8 deg) is 0.2 deg off a basic 45 too, on the other side.
  s.kind = ToleranceKind::Anglr;
  s.nominal = 45;
  const Vec3 axis(std::sin(44.8 * deg), 0, std::cos(44.8 * deg));
  const Feature pin = feature("PIN", round(FeatureType::Cylinder, Side::Outer, {0, 0, 0}, Vec3(1, 0, 1), 10, 40),
                              round(FeatureType::Cylinder, Side::Outer, {0, 0, 0}, axis, 10, 40));
  r = evaluate(s, {&pin}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 40 * std::sin(0.2 * deg), 1e-12);
  EXPECT_NE(r->note.find("the axis at 45.2000 deg to datum A, basic 45 deg"), std::string::npos) << r->note;
  const Datum b = datum("B", round(FeatureType::Cylinder, Side::Outer, {0, 0, 0}, Vec3::UnitZ(), 10, 50));
  context.datums = {&b};
  r = evaluate(s, {&pin}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 40 * std::sin(0.2 * deg), 1e-12);
  EXPECT_NE(r->note.find("the axis at 44.8000 deg to datum B, basic 45 deg"), std::string::npos) << r->note;
  // A plane at a basic 20 deg to a datum axis: its normal 70 deg from the axis. The chamfer's
  // normal is 30.1 deg from it, the plane 59.9 deg to the axis: 0.1 deg off a basic 60.
  s.nominal = 60;
  r = evaluate(s, {&off}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 6 * std::sin(0.1 * deg), 1e-12);
  EXPECT_NE(r->note.find("the plane at 59.9000 deg to datum B"), std::string::npos) << r->note;
  // An axis along the datum's normal has no rotation toward the basic angle but its nominal's.
  context.datums = {&a};
  const Feature upright = feature("UP", round(FeatureType::Cylinder, Side::Outer, {0, 0, 0}, Vec3(1, 0, 1), 10, 40),
                                  round(FeatureType::Cylinder, Side::Outer, {0, 0, 0}, Vec3::UnitZ(), 10, 40));
  EXPECT_NEAR(evaluate(s, {&upright}, context)->value, 40 * std::sin(30 * deg), 1e-12);
}

// ------------------------------------------------------------------ ANGLB

TEST(ToleranceAngle, AngleToADatumAndToAFeature) {
  const double rad = 30.01 * k_pi / 180.0;
  const Datum a = datum("A", plane({0, 0, 0}, Vec3::UnitZ()));
  ToleranceContext context;
  context.datums = {&a};
  // A face whose normal is 30.01 deg from the datum normal (its sense does not matter).
  const Feature face = feature("F1", plane({0, 0, 0}, Vec3(std::sin(30 * k_pi / 180), 0, std::cos(30 * k_pi / 180))),
                               plane({0, 0, 0}, Vec3(-std::sin(rad), 0, -std::cos(rad))));
  ToleranceSpec s = spec(ToleranceKind::Anglb);
  s.nominal = 30;
  s.lower = -0.02;
  s.upper = 0.02;
  s.datums = {"A"};
  auto r = evaluate(s, {&face}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->actual, 30.01, 1e-9);
  EXPECT_NEAR(r->nominal, 30.0, 1e-12);
  EXPECT_NEAR(r->value, 0.01, 1e-9);
  EXPECT_TRUE(r->in_tolerance);
  // An obtuse nominal reads the supplement.
  s.nominal = 150;
  r = evaluate(s, {&face}, context);
  EXPECT_NEAR(r->actual, 149.99, 1e-9);
  EXPECT_NEAR(r->value, -0.01, 1e-9);

  // Two lines 60 deg apart, the second given as the reference.
  const Feature l1 = feature("L1", line({0, 0, 0}, Vec3::UnitX()), line({0, 0, 0}, Vec3::UnitX()));
  const Feature l2 =
      feature("L2", line({0, 0, 0}, Vec3(0.5, std::sqrt(3) / 2, 0)), line({0, 0, 0}, Vec3(0.5, std::sqrt(3) / 2, 0)));
  s.nominal = 60;
  s.datums.clear();
  r = evaluate(s, {&l1, &l2});
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->actual, 60, 1e-9);
  EXPECT_EQ(r->features, (std::vector<std::string>{"L1", "L2"}));
  EXPECT_EQ(r->note, "angle between the axis of L1 and the axis of L2");
  const Feature p = feature("P1", point({0, 0, 0}), point({0, 0, 0}));
  EXPECT_EQ(evaluate(s, {&p}, context).error(),
            "ANGLB applies to a plane, line, cylinder, cone, circle, arc, closed slot (CPARLN) or pair of parallel "
            "planes, not to a POINT");
  // A width (PARPLN) by its median plane's normal, as a plane.
  Geometry width = plane({0, 0, 0}, Vec3(std::sin(30 * k_pi / 180), 0, std::cos(30 * k_pi / 180)));
  width.type = FeatureType::ParallelPlanes;
  width.width_mm = 10;
  Geometry tilted_width = width;
  tilted_width.direction = Vec3(std::sin(rad), 0, std::cos(rad));
  const Feature slot = feature("W1", width, tilted_width);
  s.nominal = 30;
  s.datums = {"A"};
  r = evaluate(s, {&slot}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->actual, 30.01, 1e-9);
  EXPECT_EQ(r->note, "angle between the normal of W1 and the normal of datum A");
}

// ------------------------------------------------------------------ PROFL, PROFP

TEST(ToleranceProfile, PointProfileIsTheDeviationAlongTheNominalNormal) {
  // A point 0.03 above its nominal along the normal (and 0.5 aside, which does not count).
  Feature p = feature("P1", point({10, 0, 5}, Vec3::UnitZ()), point({10.5, 0, 5.03}, Vec3::UnitZ()));
  p.points.push_back(probed({10.5, 0, 5.03}, Vec3::UnitZ()));
  ToleranceSpec s = spec(ToleranceKind::Profp);
  s.lower = -0.02;
  s.upper = 0.02;
  auto r = evaluate(s, {&p});
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.03, k_tight);
  EXPECT_FALSE(r->in_tolerance);
  // A constructed point (no probed point) is judged by its own position.
  const Feature c = feature("P2", point({10, 0, 5}, Vec3::UnitZ()), point({10, 0, 4.99}, Vec3::UnitZ()));
  r = evaluate(s, {&c});
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, -0.01, k_tight);
  EXPECT_TRUE(r->in_tolerance);
}

TEST(ToleranceProfile, LineProfileOfACircleAndOfALine) {
  // A bore of radius 5 whose points lie at radius 5.01 and 4.995: deviations -0.01 and +0.005
  // (for a bore the material is outward: oversize is negative, as for PROFS).
  Feature c = feature("C1", round(FeatureType::Circle, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10),
                      round(FeatureType::Circle, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10));
  c.points.push_back(probed({5.01, 0, 0}, -Vec3::UnitX()));
  c.points.push_back(probed({0, 4.995, 0}, -Vec3::UnitY()));
  ToleranceSpec s = spec(ToleranceKind::Profl);
  s.lower = -0.02;
  s.upper = 0.02;
  auto r = evaluate(s, {&c});
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, -0.01, k_tight);
  // A line along x in the x-y plane (normal2 = z): deviations across it, along z x x = y.
  Geometry nominal = line({0, 0, 0}, Vec3::UnitX(), 50);
  nominal.normal2 = Vec3::UnitZ();
  Feature l = feature("L1", nominal, nominal);
  l.points.push_back(probed({10, 0.004, 0}, Vec3::UnitY()));
  l.points.push_back(probed({40, -0.012, 0}, Vec3::UnitY()));
  r = evaluate(s, {&l});
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, -0.012, k_tight);
  EXPECT_EQ(r->note.find("side unknown"), std::string::npos) << r->note;
  const Feature pl = feature("PL", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0}, Vec3::UnitZ()));
  EXPECT_EQ(evaluate(s, {&pl}).error(), "PROFL applies to a line, circle, arc, GCURVE or ellipse, not to a PLANE");
}

// ------------------------------------------------------------------ CONCEN, COAXIAL, runout

/// Surface points of a circle of radius r about centre c in the plane normal to z (probed from
/// inside a bore: approach toward the centre), every `step_deg`.
void add_ring(Feature& f, const Vec3& centre, double r, double step_deg = 45) {
  for (double a = 0; a < 360; a += step_deg) {
    const Vec3 radial(std::cos(a * k_pi / 180), std::sin(a * k_pi / 180), 0);
    f.points.push_back(probed(centre + r * radial, -radial));
  }
}

TEST(ToleranceCoaxiality, ConcentricityIsTwiceTheCentresDistanceFromTheDatumAxis) {
  const Datum a = datum("A", round(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 20, 30));
  const Feature c = feature("C1", round(FeatureType::Circle, Side::Inner, {0, 0, 40}, Vec3::UnitZ(), 10),
                            round(FeatureType::Circle, Side::Inner, {0.01, 0.02, 40}, Vec3::UnitZ(), 10));
  ToleranceSpec s = spec(ToleranceKind::Concen);
  s.zone = 0.05;
  s.datums = {"A"};
  ToleranceContext context;
  context.datums = {&a};
  const auto r = evaluate(s, {&c}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 2 * std::hypot(0.01, 0.02), k_tight);
  EXPECT_TRUE(r->in_tolerance);
  // A plane cannot be a datum axis; no datum at all is an error too.
  const Datum plane_a = datum("A", plane({0, 0, 0}, Vec3::UnitZ()));
  context.datums = {&plane_a};
  EXPECT_EQ(evaluate(s, {&c}, context).error(),
            "datum A is a PLANE: CONCEN needs a datum axis (a cylinder, circle, cone or line)");
  s.datums.clear();
  EXPECT_EQ(evaluate(s, {&c}).error(), "CONCEN needs a datum axis: TOL/CONCEN,zone,DAT(A)");
}

TEST(ToleranceCoaxiality, CoaxialityTakesTheFartherEndOfTheAxis) {
  // The actual axis runs from (0.01, 0, 0) to (0.03, 0, 20); its points span z = 0..20.
  const Datum a = datum("A", round(FeatureType::Cylinder, Side::Inner, {0, 0, -50}, Vec3::UnitZ(), 20, 30));
  const Vec3 axis = Vec3(0.02, 0, 20).normalized();
  Feature cyl = feature("CYL1", round(FeatureType::Cylinder, Side::Inner, {0, 0, 10}, Vec3::UnitZ(), 10, 20),
                        round(FeatureType::Cylinder, Side::Inner, {0.02, 0, 10}, axis, 10, 20));
  add_ring(cyl, {0.01, 0, 0}, 5);
  add_ring(cyl, {0.03, 0, 20}, 5);
  ToleranceSpec s = spec(ToleranceKind::Coaxial);
  s.zone = 0.05;
  s.datums = {"A"};
  ToleranceContext context;
  context.datums = {&a};
  auto r = evaluate(s, {&cyl}, context);
  ASSERT_TRUE(r) << r.error();
  // The rings are level, so their points reach 0.005 mm past the axis ends (5 mm x 0.001 slope):
  // the ends found from the points lie 5e-6 mm farther out.
  EXPECT_NEAR(r->value, 0.06, 2e-5);
  EXPECT_FALSE(r->in_tolerance);
  // At MMC (ISO 2692) the bore made 10.02 gains its 0.02 departure from its MMC size (the
  // nominal 10): a zone of 0.07 holds the 0.06.
  cyl.actual->diameter_mm = 10.02;
  s.condition = MaterialCondition::Mmc;
  r = evaluate(s, {&cyl}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->upper, 0.07, 1e-12);
  EXPECT_TRUE(r->in_tolerance) << r->note;
}

TEST(ToleranceCoaxiality, TwoAxisDatumsMakeACommonAxis) {
  // Datum circles A at z = 0 and B at z = 100, B 0.1 mm off along x: the common axis A-B passes
  // (0.05, 0, 50), where the feature's centre is.
  const Datum a = datum("A", round(FeatureType::Circle, Side::Outer, {0, 0, 0}, Vec3::UnitZ(), 20));
  const Datum b = datum("B", round(FeatureType::Circle, Side::Outer, {0.1, 0, 100}, Vec3::UnitZ(), 20));
  const Feature c = feature("C1", round(FeatureType::Circle, Side::Outer, {0, 0, 50}, Vec3::UnitZ(), 30),
                            round(FeatureType::Circle, Side::Outer, {0.05, 0, 50}, Vec3::UnitZ(), 30));
  ToleranceSpec s = spec(ToleranceKind::Concen);
  s.zone = 0.01;
  s.datums = {"A", "B"};
  ToleranceContext context;
  context.datums = {&a, &b};
  auto r = evaluate(s, {&c}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.0, 1e-9);
  EXPECT_NE(r->note.find("common datum axis A-B"), std::string::npos) << r->note;
  s.datums = {"A"};
  context.datums = {&a};
  r = evaluate(s, {&c}, context);
  ASSERT_TRUE(r);
  EXPECT_NEAR(r->value, 0.1, 1e-9);
}

TEST(ToleranceRunout, RadialRunoutIsTheLargestSectionsSpreadTotalRunoutTheWholeSpread) {
  // Section z = 0: a circle of radius 5 centred 0.01 off the datum axis (spread 0.02); section
  // z = 10: radius 5.02 on the axis (spread 0). Circular runout 0.02; total 5.02 - 4.99 = 0.03.
  const Datum a = datum("A", round(FeatureType::Cylinder, Side::Outer, {0, 0, -40}, Vec3::UnitZ(), 20, 30));
  Feature cyl = feature("CYL1", round(FeatureType::Cylinder, Side::Outer, {0, 0, 5}, Vec3::UnitZ(), 10, 10),
                        round(FeatureType::Cylinder, Side::Outer, {0, 0, 5}, Vec3::UnitZ(), 10, 10));
  add_ring(cyl, {0.01, 0, 0}, 5);
  add_ring(cyl, {0, 0, 10}, 5.02);
  ToleranceContext context;
  context.datums = {&a};
  ToleranceSpec s = spec(ToleranceKind::Crnout);
  s.zone = 0.025;
  s.datums = {"A"};
  auto r = evaluate(s, {&cyl}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.02, 1e-9);
  EXPECT_TRUE(r->in_tolerance);
  EXPECT_NE(r->note.find("radial runout about datum A over 16 points in 2 sections"), std::string::npos) << r->note;
  s.kind = ToleranceKind::Totrun;
  r = evaluate(s, {&cyl}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.03, 1e-9);
  EXPECT_FALSE(r->in_tolerance);
}

TEST(ToleranceRunout, AxialRunoutOfAFaceSquareToTheAxis) {
  // A face tilted 0.001 rad about y (h = 0.001 x): on the circle r = 10 it spreads 0.02; the
  // circle r = 5 is also stepped up 0.02 (spread 0.01, from 0.015 to 0.025). Circular runout 0.02,
  // total runout 0.025 - (-0.01) = 0.035.
  const Datum a = datum("A", round(FeatureType::Cylinder, Side::Outer, {0, 0, -40}, Vec3::UnitZ(), 20, 30));
  Feature face = feature("FACE", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0}, Vec3::UnitZ()));
  for (const double r : {10.0, 5.0})
    for (double deg = 0; deg < 360; deg += 30) {
      const double x = r * std::cos(deg * k_pi / 180), y = r * std::sin(deg * k_pi / 180);
      face.points.push_back(probed({x, y, 0.001 * x + (r == 5.0 ? 0.02 : 0.0)}, Vec3::UnitZ()));
    }
  ToleranceContext context;
  context.datums = {&a};
  ToleranceSpec s = spec(ToleranceKind::Crnout);
  s.zone = 0.03;
  s.datums = {"A"};
  auto r = evaluate(s, {&face}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.02, 1e-9);
  EXPECT_NE(r->note.find("axial runout"), std::string::npos);
  s.kind = ToleranceKind::Totrun;
  r = evaluate(s, {&face}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 0.035, 1e-9);
  // Without points there is nothing to take a runout from.
  const Feature bare = feature("BARE", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0}, Vec3::UnitZ()));
  EXPECT_EQ(evaluate(s, {&bare}, context).error(), "TOTRUN of BARE needs measured points: it has 0");
}

// ------------------------------------------------------------------ PROFS

TEST(ToleranceProfile, PlanePointsAgainstTheNominal) {
  Feature f = feature("PL1", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0}, Vec3::UnitZ()));
  for (const double z : {0.01, -0.02, 0.005}) f.points.push_back(probed({z * 100, 3, z}, Vec3::UnitZ()));
  ToleranceSpec s = spec(ToleranceKind::Profs);
  s.lower = -0.03;
  s.upper = 0.03;
  auto r = evaluate(s, {&f});
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, -0.02, 1e-12);
  EXPECT_TRUE(r->in_tolerance);
  EXPECT_EQ(r->note, "deviations from the nominal surface: min -0.0200, max +0.0100 over 3 points");
  s.lower = -0.01;
  EXPECT_FALSE(evaluate(s, {&f})->in_tolerance);
}

TEST(ToleranceProfile, SignIsPositiveOutsideTheMaterial) {
  ToleranceSpec s = spec(ToleranceKind::Profs);
  s.lower = -0.05;
  s.upper = 0.05;
  // Surface points at radius 10.01 around the Z axis.
  std::vector<MeasuredPoint> ring;
  for (int k = 0; k < 8; ++k) {
    const double a = k * k_pi / 4;
    const Vec3 radial(std::cos(a), std::sin(a), 0);
    ring.push_back(probed(10.01 * radial + Vec3(0, 0, 2.0 * k), -radial));
  }
  // A bore 0.01 oversize: its wall lies inside the nominal material.
  Feature bore = feature("B", round(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 20, 20),
                         round(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 20.02, 20));
  bore.points = ring;
  EXPECT_NEAR(evaluate(s, {&bore})->value, -0.01, 1e-12);
  // The same surface on a boss is 0.01 too big: outside the material.
  Feature boss = bore;
  boss.nominal.side = Side::Outer;
  EXPECT_NEAR(evaluate(s, {&boss})->value, 0.01, 1e-12);
  // A circle ignores the axial offsets.
  Feature circle = bore;
  circle.nominal.type = FeatureType::Circle;
  EXPECT_NEAR(evaluate(s, {&circle})->value, -0.01, 1e-12);

  // A sphere of radius 5, points 0.02 inside its surface.
  Feature sphere = feature("S", round(FeatureType::Sphere, Side::Outer, {1, 2, 3}, Vec3::UnitZ(), 10),
                           round(FeatureType::Sphere, Side::Outer, {1, 2, 3}, Vec3::UnitZ(), 9.96));
  sphere.points.push_back(probed(Vec3(1, 2, 3) + 4.98 * Vec3(1, 1, 1).normalized(), Vec3(1, 1, 1)));
  EXPECT_NEAR(evaluate(s, {&sphere})->value, -0.02, 1e-12);

  // A 90 deg cone (half angle 45) with its apex at the origin: a point 0.01 outside its nappe.
  Geometry cone = round(FeatureType::Cone, Side::Outer, {0, 0, 0}, Vec3::UnitZ(), 0);
  cone.apex_angle_deg = 90;
  Feature c = feature("CO", cone, cone);
  c.points.push_back(probed({10 + 0.01 * std::sqrt(2.0), 0, 10}, Vec3(1, 0, -1)));
  EXPECT_NEAR(evaluate(s, {&c})->value, 0.01, 1e-12);
  c.nominal.side = Side::Inner;
  EXPECT_NEAR(evaluate(s, {&c})->value, -0.01, 1e-12);
}

TEST(ToleranceProfile, Errors) {
  const Feature l = feature("L1", line({0, 0, 0}, Vec3::UnitX()), line({0, 0, 0}, Vec3::UnitX()));
  EXPECT_EQ(evaluate(spec(ToleranceKind::Profs), {&l}).error(),
            "PROFS applies to a plane, circle, arc, sphere, cylinder, cone, GSURF, torus or ellipse, not to a LINE");
  const Feature pl = feature("PL1", plane({0, 0, 0}, Vec3::UnitZ()), plane({0, 0, 0}, Vec3::UnitZ()));
  EXPECT_EQ(evaluate(spec(ToleranceKind::Profs), {&pl}).error(), "PROFS of PL1 needs measured points: it has none");
}

// ------------------------------------------------------------------ PARPLN, WIDTH, SYMMTY

/// A slot (INNER) or tab (OUTER) of the given median point, unit normal and width, probed at the
/// in-plane offsets (v along the faces, z) on each face; `bump_mm` moves points of the + face out
/// of the material (all of them, or only the first when `one_point`).
Feature parallel_planes(Side side, const Vec3& median, const Vec3& normal, double width_mm, double bump_mm = 0,
                        bool one_point = false) {
  Geometry nominal;
  nominal.type = FeatureType::ParallelPlanes;
  nominal.side = side;
  nominal.position = {0, 0, 0};
  nominal.direction = Vec3::UnitX();
  nominal.width_mm = 10;
  Feature f = feature("SLOT", nominal, std::nullopt);
  const Vec3 n = normal.normalized();
  const Vec3 v = Vec3::UnitZ().cross(n).normalized();
  const double offsets[][2] = {{-10, -3}, {10, -3}, {0, 4}};
  for (double face : {1.0, -1.0})
    for (const auto& o : offsets) {
      const Vec3 outward = (side == Side::Inner ? -face : face) * n;  // out of the material
      const double bump = face > 0 && (!one_point || &o == &offsets[0]) ? bump_mm : 0;
      const Vec3 surface = median + face * 0.5 * width_mm * n + o[0] * v + o[1] * Vec3::UnitZ() + bump * outward;
      f.points.push_back(probed(surface, outward));
    }
  auto fitted = fit_actual(f.nominal, f.points);
  EXPECT_TRUE(fitted) << (fitted ? "" : fitted.error());
  if (fitted) {
    f.actual = fitted->first;
    f.fit = fitted->second;
  }
  return f;
}

// The fit recovers a slot's width, normal and median plane (truth: the faces the points were
// put on, 0.3 deg from nominal, the median 0.02 mm off).
TEST(ToleranceWidth, ParallelPlanesFitAndWidthDeviation) {
  const double a = 0.3 * k_pi / 180;
  const Vec3 n(std::cos(a), std::sin(a), 0);
  for (Side side : {Side::Inner, Side::Outer}) {
    const Feature slot = parallel_planes(side, {0.02, 0, 0}, n, 10.012);
    ASSERT_TRUE(slot.actual);
    EXPECT_NEAR(slot.actual->width_mm, 10.012, 1e-9);
    EXPECT_NEAR(slot.actual->direction.dot(n), 1.0, 1e-12);
    EXPECT_NEAR((slot.actual->position - Vec3(0.02, 0, 0)).dot(n), 0.0, 1e-9);
    EXPECT_NEAR(slot.fit->form_mm, 0.0, 1e-9);
    ToleranceSpec w = spec(ToleranceKind::Width);
    w.lower = -0.01;
    w.upper = 0.01;
    const auto r = evaluate(w, {&slot});
    ASSERT_TRUE(r) << r.error();
    EXPECT_NEAR(r->value, 0.012, 1e-9);
    EXPECT_FALSE(r->in_tolerance);
  }
  // A face 5 um out of the material: a slot narrows by it, a tab widens, the median plane moves
  // half of it; no form. One point out: some form, at most the 5 um.
  const Feature narrower = parallel_planes(Side::Inner, {0, 0, 0}, Vec3::UnitX(), 10, 0.005);
  EXPECT_NEAR(narrower.actual->width_mm, 10 - 0.005, 1e-9);
  EXPECT_NEAR(narrower.actual->position.x(), -0.0025, 1e-9);
  EXPECT_NEAR(narrower.fit->form_mm, 0.0, 1e-9);
  const Feature wider = parallel_planes(Side::Outer, {0, 0, 0}, Vec3::UnitX(), 10, 0.005);
  EXPECT_NEAR(wider.actual->width_mm, 10 + 0.005, 1e-9);
  EXPECT_NEAR(wider.actual->position.x(), 0.0025, 1e-9);
  const Feature bumped = parallel_planes(Side::Inner, {0, 0, 0}, Vec3::UnitX(), 10, 0.005, true);
  EXPECT_GT(bumped.fit->form_mm, 0.001);
  EXPECT_LE(bumped.fit->form_mm, 0.005 + 1e-12);
  // WIDTH needs a PARPLN.
  const Feature bore = feature("B", round(FeatureType::Circle, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10),
                               round(FeatureType::Circle, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10));
  EXPECT_FALSE(evaluate(spec(ToleranceKind::Width), {&bore}));
}

// SYMMTY: twice the largest distance of the median points from the datum's median plane. The
// slot's median plane is 0.02 mm off the datum's and turned 0.1 deg about z; its points reach
// 10 mm either way along the faces, so the farthest median point is 0.02 + 10 sin(0.1 deg) off.
TEST(ToleranceSymmetry, TwiceTheFarthestMedianPointFromTheDatumMedianPlane) {
  const double a = 0.1 * k_pi / 180;
  const Feature slot = parallel_planes(Side::Inner, {0.02, 0, 0}, {std::cos(a), std::sin(a), 0}, 10);
  Geometry datum_slot;
  datum_slot.type = FeatureType::ParallelPlanes;
  datum_slot.position = {0, 50, 0};
  datum_slot.direction = Vec3::UnitX();
  datum_slot.width_mm = 30;
  const Datum d = datum("A", datum_slot);
  ToleranceSpec s = spec(ToleranceKind::Symmty);
  s.zone = 0.05;
  s.datums = {"A"};
  ToleranceContext context;
  context.datums = {&d};
  const auto r = evaluate(s, {&slot}, context);
  ASSERT_TRUE(r) << r.error();
  EXPECT_NEAR(r->value, 2 * (0.02 * std::cos(a) + 10 * std::sin(a)), 1e-6);
  EXPECT_FALSE(r->in_tolerance);
  // Centred and square to the datum: zero, within the zone.
  const Feature centred = parallel_planes(Side::Inner, {0, 7, 0}, Vec3::UnitX(), 10);
  const auto c = evaluate(s, {&centred}, context);
  ASSERT_TRUE(c) << c.error();
  EXPECT_NEAR(c->value, 0.0, 1e-9);
  EXPECT_TRUE(c->in_tolerance);
  // The datum must be a plane; without one it is an error.
  const Datum axis = datum("A", round(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 20, 30));
  context.datums = {&axis};
  EXPECT_EQ(evaluate(s, {&slot}, context).error(),
            "datum A is not a plane: SYMMTY needs a datum median plane (a PARPLN) or a PLANE");
  s.datums.clear();
  EXPECT_FALSE(evaluate(s, {&slot}));
}

// ------------------------------------------------------------------ CPARLN

/// A closed slot along `axis` in the plane normal to z, 30 x 10, centre `centre`.
Geometry closed_slot(const Vec3& centre, const Vec3& axis, double length_mm = 30, double width_mm = 10) {
  Geometry g;
  g.type = FeatureType::ClosedSlot;
  g.side = Side::Inner;
  g.position = centre;
  g.direction = Vec3::UnitZ();
  g.slot_axis = axis.normalized();
  g.length_mm = length_mm;
  g.width_mm = width_mm;
  return g;
}

// WIDTH (SHORT) is the width, WIDTH,LONG the length; POS its centre; PARLEL and ANGLB its long
// axis (analytic answers: the axis turned 0.1 deg in its plane over a 30.05 mm slot).
TEST(ToleranceWidth, ClosedSlotWidthLengthCentreAndAxis) {
  const double a = 0.1 * k_pi / 180;
  const Feature slot = feature("SLOT", closed_slot({0, 0, 0}, Vec3::UnitX()),
                               closed_slot({0.02, 0.01, 0}, {std::cos(a), std::sin(a), 0}, 30.05, 10.03));
  ToleranceSpec w = spec(ToleranceKind::Width);
  w.lower = -0.01;
  w.upper = 0.01;
  const auto width = evaluate(w, {&slot});
  ASSERT_TRUE(width) << width.error();
  EXPECT_NEAR(width->value, 0.03, k_tight);
  EXPECT_FALSE(width->in_tolerance);
  w.long_side = true;
  const auto length = evaluate(w, {&slot});
  ASSERT_TRUE(length) << length.error();
  EXPECT_NEAR(length->value, 0.05, k_tight);
  ToleranceSpec pos = spec(ToleranceKind::Pos);
  pos.zone = 0.05;
  const auto p = evaluate(pos, {&slot});
  ASSERT_TRUE(p) << p.error();
  EXPECT_NEAR(p->value, 2 * std::hypot(0.02, 0.01), k_tight);
  const Datum x_axis = datum("A", line({0, 0, 0}, Vec3::UnitX(), 100));
  ToleranceContext context;
  context.datums = {&x_axis};
  ToleranceSpec parallel = spec(ToleranceKind::Parlel);
  parallel.zone = 0.1;
  parallel.datums = {"A"};
  const auto par = evaluate(parallel, {&slot}, context);
  ASSERT_TRUE(par) << par.error();
  EXPECT_NEAR(par->value, 30.05 * std::sin(a), 1e-9);
  ToleranceSpec angle = spec(ToleranceKind::Anglb);
  angle.datums = {"A"};
  angle.upper = 1;
  const auto ang = evaluate(angle, {&slot}, context);
  ASSERT_TRUE(ang) << ang.error();
  EXPECT_NEAR(ang->actual, 0.1, 1e-9);
  // LONG has no meaning on a PARPLN (no length): an error that says what it applies to.
  Geometry pair;
  pair.type = FeatureType::ParallelPlanes;
  pair.width_mm = 10;
  const Feature planes = feature("PAIR", pair, pair);
  EXPECT_EQ(evaluate(w, {&planes}).error(), "WIDTH applies to a closed slot (CPARLN), not to a PARPLN");
}

TEST(ToleranceWords, DmisWords) {
  EXPECT_STREQ(dmis_word(ToleranceKind::Cylcty), "CYLCTY");
  EXPECT_STREQ(dmis_word(ToleranceKind::Parlel), "PARLEL");
  EXPECT_STREQ(dmis_word(FeatureType::Cylinder), "CYLNDR");
  EXPECT_STREQ(dmis_word(Side::None), "");
}

}  // namespace
}  // namespace metron::runtime

namespace metron::runtime {
namespace {

// The compiler's check (tolerance_applies) and the evaluators must agree: for every one-feature
// kind and every type, the evaluator refuses the type ("... applies to ...") exactly when the
// table says it does not apply.
TEST(ToleranceTypes, TheTableIsTheEvaluators) {
  const FeatureType types[] = {FeatureType::Point,          FeatureType::Plane,        FeatureType::Line,
                               FeatureType::Circle,         FeatureType::Arc,          FeatureType::Sphere,
                               FeatureType::Cylinder,       FeatureType::Cone,         FeatureType::ParallelPlanes,
                               FeatureType::GenericSurface, FeatureType::GenericCurve, FeatureType::ClosedSlot};
  const ToleranceKind kinds[] = {ToleranceKind::Diam,   ToleranceKind::Rad,    ToleranceKind::Flat,
                                 ToleranceKind::Cirlty, ToleranceKind::Cylcty, ToleranceKind::Sphcty,
                                 ToleranceKind::Strght, ToleranceKind::Pos,    ToleranceKind::Perp,
                                 ToleranceKind::Parlel, ToleranceKind::Concen, ToleranceKind::Coaxial,
                                 ToleranceKind::Crnout, ToleranceKind::Totrun, ToleranceKind::Profs,
                                 ToleranceKind::Profl,  ToleranceKind::Width,  ToleranceKind::Symmty,
                                 ToleranceKind::Profp,  ToleranceKind::Angl,   ToleranceKind::Anglr};
  const Datum a = datum("A", plane({0, 0, 0}, Vec3::UnitX()));
  ToleranceContext context;
  context.datums = {&a};
  for (const ToleranceKind kind : kinds)
    for (const FeatureType type : types) {
      Geometry g = round(type, Side::Inner, {1, 2, 3}, Vec3(0, 0.6, 0.8), 10, 20);
      g.slot_axis = Vec3::UnitX();
      g.width_mm = 5;
      g.apex_angle_deg = 60;
      const Feature f = feature("F", g, g);
      ToleranceSpec s = spec(kind);
      s.zone = 0.1;
      s.upper = 0.1;
      s.datums = {"A"};
      const auto r = evaluate(s, {&f}, context);
      const bool refused = !r && r.error().find(" applies to ") != std::string::npos;
      EXPECT_EQ(refused, !tolerance_applies(kind, type))
          << dmis_word(kind) << " of a " << dmis_word(type) << ": " << (r ? "evaluated" : r.error());
    }
}

}  // namespace
}  // namespace metron::runtime
