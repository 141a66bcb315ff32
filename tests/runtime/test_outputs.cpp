// SPDX-License-Identifier: GPL-3.0-or-later
// The human report, DMIS output lines and results.json (docs/results-json.md).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "metron/runtime/outputs.hpp"

namespace metron::runtime {
namespace {

Geometry geometry(FeatureType type, Side side, const Vec3& position, const Vec3& direction, double diameter_mm = 0,
                  double length_mm = 0) {
  Geometry g;
  g.type = type;
  g.side = side;
  g.position = position;
  g.direction = direction;
  g.diameter_mm = diameter_mm;
  g.length_mm = length_mm;
  return g;
}

FeatureReport measured(const std::string& label, const Geometry& nominal, const Geometry& actual) {
  FeatureReport r;
  r.label = label;
  r.nominal = nominal;
  r.actual = actual;
  return r;
}

/// Every physical line of a DMIS statement fits in 80 columns.
void expect_lines_fit(const std::string& statement) {
  std::istringstream in(statement);
  for (std::string line; std::getline(in, line);) EXPECT_LE(line.size(), 80u) << line;
}

// ------------------------------------------------------------------ DMIS output

TEST(DmisOutput, CircleMatchesTheNistReferenceOutput) {
  const Geometry c = geometry(FeatureType::Circle, Side::Inner, {50, 50, 40}, Vec3::UnitZ(), 50);
  const std::string line = dmis_feature_line(measured("A_CIRCLE", c, c));
  EXPECT_EQ(line,
            "FA(A_CIRCLE) = FEAT/CIRCLE, INNER, CART,  $\n"
            "  50.00000, 50.00000, 40.00000, 0.00000, 0.00000, 1.00000, 50.00000");
#ifdef METRON_SHARED_DATA
  std::ifstream file(std::string(METRON_SHARED_DATA) + "/nist-simple-part/output.dms");
  if (file) {
    std::stringstream text;
    text << file.rdbuf();
    EXPECT_NE(text.str().find(line + "\n"), std::string::npos);
  }
#endif
}

TEST(DmisOutput, EveryFeatureType) {
  const Geometry p = geometry(FeatureType::Point, Side::None, {1, 2, 3}, Vec3::UnitZ());
  EXPECT_EQ(dmis_feature_line(measured("P1", p, p)),
            "FA(P1) = FEAT/POINT, CART, 1.00000, 2.00000, 3.00000, 0.00000, 0.00000, 1.00000");

  // A tiny negative coordinate prints as 0.00000, not -0.00000; 82 columns break the line.
  const Geometry pl = geometry(FeatureType::Plane, Side::None, {10, -0.000001, 5}, -Vec3::UnitZ());
  EXPECT_EQ(dmis_feature_line(measured("PL1", pl, pl)),
            "FA(PL1) = FEAT/PLANE, CART,  $\n"
            "  10.00000, 0.00000, 5.00000, 0.00000, 0.00000, -1.00000");

  Geometry bounded = geometry(FeatureType::Line, Side::None, {0, 0, 0}, Vec3::UnitX(), 0, 50);
  bounded.bounded = true;
  bounded.normal2 = Vec3::UnitZ();
  const std::string bnd = dmis_feature_line(measured("L1", bounded, bounded));
  EXPECT_EQ(bnd,
            "FA(L1) = FEAT/LINE, BND, CART,  $\n"
            "  0.00000, 0.00000, 0.00000, 50.00000, 0.00000, 0.00000, 0.00000, 0.00000,  $\n"
            "  1.00000");
  expect_lines_fit(bnd);
  Geometry unbounded = bounded;
  unbounded.bounded = false;
  unbounded.direction = Vec3(0, 1, 0);
  EXPECT_EQ(dmis_feature_line(measured("L2", unbounded, unbounded)),
            "FA(L2) = FEAT/LINE, UNBND, CART,  $\n"
            "  0.00000, 0.00000, 0.00000, 0.00000, 1.00000, 0.00000, 0.00000, 0.00000,  $\n"
            "  1.00000");

  Geometry arc = geometry(FeatureType::Arc, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 20);
  arc.start_angle_deg = 0;
  arc.included_angle_deg = 90;
  EXPECT_EQ(dmis_feature_line(measured("ARC1", arc, arc)),
            "FA(ARC1) = FEAT/ARC, INNER, CART,  $\n"
            "  0.00000, 0.00000, 0.00000, 0.00000, 0.00000, 1.00000, 10.00000, 0.00000,  $\n"
            "  90.00000");

  const Geometry s = geometry(FeatureType::Sphere, Side::Outer, {10, 20, 30}, Vec3::UnitZ(), 25.4);
  EXPECT_EQ(dmis_feature_line(measured("S1", s, s)),
            "FA(S1) = FEAT/SPHERE, OUTER, CART, 10.00000, 20.00000, 30.00000, 25.40000");

  const Geometry cyl = geometry(FeatureType::Cylinder, Side::Inner, {10, 20, 0}, Vec3::UnitZ(), 12.012, 30);
  EXPECT_EQ(dmis_feature_line(measured("CYL1", cyl, cyl)),
            "FA(CYL1) = FEAT/CYLNDR, INNER, CART,  $\n"
            "  10.00000, 20.00000, 0.00000, 0.00000, 0.00000, 1.00000, 12.01200, 30.00000");

  Geometry cone = geometry(FeatureType::Cone, Side::Outer, {0, 0, 0}, Vec3::UnitZ());
  cone.apex_angle_deg = 60;
  EXPECT_EQ(dmis_feature_line(measured("CO1", cone, cone)),
            "FA(CO1) = FEAT/CONE, OUTER, CART,  $\n"
            "  0.00000, 0.00000, 0.00000, 0.00000, 0.00000, 1.00000, 60.00000");

  // Never measured: the nominal, as F().
  FeatureReport nominal_only;
  nominal_only.label = "P2";
  nominal_only.nominal = p;
  EXPECT_EQ(dmis_feature_line(nominal_only),
            "F(P2) = FEAT/POINT, CART, 1.00000, 2.00000, 3.00000, 0.00000, 0.00000, 1.00000");
}

TEST(DmisOutput, ToleranceLines) {
  ToleranceResult diam;
  diam.label = "TOL4";
  diam.kind = ToleranceKind::Diam;
  diam.value = 0.012;
  diam.in_tolerance = true;
  EXPECT_EQ(dmis_tolerance_line(diam), "TA(TOL4) = TOL/DIAM, 0.01200, INTOL");
  ToleranceResult pos;
  pos.label = "P1";
  pos.kind = ToleranceKind::Pos;
  pos.value = 0.06;
  EXPECT_EQ(dmis_tolerance_line(pos), "TA(P1) = TOL/POS, 2D, 0.06000, OUTOL");
  pos.three_d = true;
  EXPECT_EQ(dmis_tolerance_line(pos), "TA(P1) = TOL/POS, 3D, 0.06000, OUTOL");
  ToleranceResult distb;
  distb.label = "D1";
  distb.kind = ToleranceKind::DistB;
  distb.value = -0.003;
  distb.in_tolerance = true;
  EXPECT_EQ(dmis_tolerance_line(distb), "TA(D1) = TOL/DISTB, -0.00300, INTOL");
}

// ------------------------------------------------------------------ human report

TEST(HumanReport, FeatureBlock) {
  FeatureReport r =
      measured("CYL1", geometry(FeatureType::Cylinder, Side::Inner, {10, 20, 0}, Vec3::UnitZ(), 20, 30),
               geometry(FeatureType::Cylinder, Side::Inner, {10.003, 20, -1e-7}, Vec3(0, 0.0001, 1), 20.012, 29.8));
  r.frame = "PART";
  r.point_count = 12;
  r.fit = FitFigures{{}, 0.0021, 0.008};
  const std::string text = format_feature_report(r);
  EXPECT_EQ(text.substr(0, text.find('\n')), "FA(CYL1)  CYLNDR INNER  measured, 12 points  frame PART");
  EXPECT_NE(text.find("               NOMINAL        ACTUAL     DEVIATION\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  X            10.0000       10.0030       +0.0030\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  J           0.000000      0.000100     +0.000100\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  D            20.0000       20.0120       +0.0120\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  L            30.0000       29.8000       -0.2000\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  RMS                         0.0021\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  FORM                        0.0080\n"), std::string::npos) << text;
  // A deviation that rounds to zero carries no sign of its own.
  EXPECT_NE(text.find("  Z             0.0000        0.0000       +0.0000\n"), std::string::npos) << text;

  FeatureReport nominal_only;
  nominal_only.label = "S1";
  nominal_only.nominal = geometry(FeatureType::Sphere, Side::Outer, {1, 2, 3}, Vec3::UnitZ(), 25.4);
  const std::string n = format_feature_report(nominal_only);
  EXPECT_EQ(n,
            "F(S1)  SPHERE OUTER  not measured  frame MCS\n"
            "               NOMINAL\n"
            "  X             1.0000\n"
            "  Y             2.0000\n"
            "  Z             3.0000\n"
            "  D            25.4000\n");

  // An arc is sized by its radius, as FEAT/ARC writes it.
  FeatureReport arc;
  arc.label = "A1";
  arc.nominal = geometry(FeatureType::Arc, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 30);
  const std::string a = format_feature_report(arc);
  EXPECT_NE(a.find("  R            15.0000\n"), std::string::npos) << a;
  EXPECT_EQ(a.find("  D "), std::string::npos) << a;
}

TEST(HumanReport, ToleranceLine) {
  ToleranceResult r;
  r.label = "TOL4";
  r.kind = ToleranceKind::Diam;
  r.features = {"CYL1"};
  r.value = 0.012;
  r.actual = 20.012;
  r.nominal = 20;
  r.lower = -0.1;
  r.upper = 0.1;
  r.in_tolerance = true;
  EXPECT_EQ(format_tolerance_result(r),
            "T(TOL4)  DIAM  FA(CYL1)  nominal 20.0000  actual 20.0120  dev +0.0120  limits [-0.1000, "
            "+0.1000]  IN\n");
  ToleranceResult pos;
  pos.label = "P1";
  pos.kind = ToleranceKind::Pos;
  pos.features = {"CYL1"};
  pos.value = 0.06;
  pos.upper = 0.05;
  pos.note = "datum A: evaluated in the current alignment PART";
  EXPECT_EQ(format_tolerance_result(pos),
            "T(P1)  POS 2D  FA(CYL1)  value 0.0600  zone 0.0500  OUT\n"
            "  note: datum A: evaluated in the current alignment PART\n");
  ToleranceResult profs;
  profs.label = "PR";
  profs.kind = ToleranceKind::Profs;
  profs.features = {"PL1", "PL2"};
  profs.value = -0.02;
  profs.lower = -0.03;
  profs.upper = 0.03;
  profs.in_tolerance = true;
  EXPECT_EQ(format_tolerance_result(profs),
            "T(PR)  PROFS  FA(PL1),FA(PL2)  dev -0.0200  limits [-0.0300, +0.0300]  IN\n");
}

TEST(HumanReport, Fault) {
  FaultReport f;
  f.kind = "NoContact";
  f.message = "no contact within 5.000 mm of the nominal point";
  f.statement = {"prog.dmi", 42, 3};
  f.statement_text = "PTMEAS/CART,75,50,40,-1,0,0\n";
  f.position_mm = {1, 2, 3};
  f.time_s = 12.3456;
  EXPECT_EQ(format_fault(f),
            "FAULT NoContact at prog.dmi:42:3: no contact within 5.000 mm of the nominal point\n"
            "  PTMEAS/CART,75,50,40,-1,0,0\n"
            "  machine at 1.0000, 2.0000, 3.0000 mm, t = 12.346 s\n");
}

// ------------------------------------------------------------------ results.json

RunRecord sample_record() {
  RunRecord record;
  record.program = "programs/examples/01_first_circle.dmi";
  record.world = "nist-simple-part";
  record.seed = 42;
  record.status = RunStatus::Faulted;
  record.simulated_time_s = 12.5;
  record.diagnostics = {"prog.dmi:3:1: warning: unused feature F(X)"};

  Feature circle;
  circle.label = "A_CIRCLE";
  circle.nominal = geometry(FeatureType::Circle, Side::Inner, {50, 50, 40}, Vec3::UnitZ(), 50);
  circle.actual = geometry(FeatureType::Circle, Side::Inner, {50.001, 50, 40}, Vec3::UnitZ(), 50.004);
  for (int k = 0; k < 4; ++k) {
    MeasuredPoint p;
    const double a = k * 3.14159265358979323846 / 2;
    p.normal = -Vec3(std::cos(a), std::sin(a), 0);
    p.ball_radius_mm = 2;
    p.centre_mm = Vec3(50, 50, 40) + 23 * Vec3(std::cos(a), std::sin(a), 0);
    p.time_s = 1.0 + k;
    circle.points.push_back(p);
  }
  circle.fit = FitFigures{{0.001, -0.001, 0.002, -0.002}, 0.0016, 0.004};
  record.features.push_back(circle);
  Feature plane;
  plane.label = "PL1";
  plane.nominal = geometry(FeatureType::Plane, Side::None, {0, 0, 0}, Vec3::UnitZ());
  plane.source = ActualSource::Constructed;
  record.features.push_back(plane);

  FeatureReport report = measured("A_CIRCLE", circle.nominal, *circle.actual);
  report.frame = "START";
  report.fit = circle.fit;
  report.point_count = 4;
  record.events.emplace_back(report);
  ToleranceResult distb;
  distb.label = "D1";
  distb.kind = ToleranceKind::DistB;
  distb.features = {"A_CIRCLE", "PL1"};
  distb.value = 0.001;
  distb.actual = 40.001;
  distb.nominal = std::nan("");  // no nominal distance: must come out as null
  distb.lower = -0.01;
  distb.upper = 0.01;
  distb.in_tolerance = true;
  record.events.emplace_back(distb);
  record.events.emplace_back(TextReport{"operator: turn the part"});
  FaultReport fault;
  fault.kind = "NoContact";
  fault.message = "no contact within 5.000 mm of the nominal point";
  fault.statement = {"prog.dmi", 42, 3};
  fault.statement_text = "PTMEAS/CART,75,50,40,-1,0,0";
  fault.position_mm = {1, 2, 3};
  fault.time_s = 12.5;
  record.events.emplace_back(fault);
  return record;
}

TEST(ResultsJson, SchemaFieldsRoundTripWithoutNaN) {
  const nlohmann::json j = results_json(sample_record());
  const std::string text = j.dump(2);
  EXPECT_EQ(text.find("NaN"), std::string::npos);
  EXPECT_EQ(text.find("nan"), std::string::npos);
  const nlohmann::json back = nlohmann::json::parse(text);
  EXPECT_EQ(back, j);

  EXPECT_EQ(back["schema"], "metron.results/1");
  EXPECT_EQ(back["program"], "programs/examples/01_first_circle.dmi");
  EXPECT_EQ(back["world"], "nist-simple-part");
  EXPECT_EQ(back["seed"], 42);
  EXPECT_EQ(back["status"], "faulted");
  EXPECT_DOUBLE_EQ(back["simulated_time_s"].get<double>(), 12.5);
  EXPECT_EQ(back["diagnostics"].size(), 1u);

  const auto& c = back["features"][0];
  EXPECT_EQ(c["label"], "A_CIRCLE");
  EXPECT_EQ(c["type"], "CIRCLE");
  EXPECT_EQ(c["side"], "INNER");
  EXPECT_EQ(c["source"], "measured");
  EXPECT_EQ(c["nominal"]["position"], nlohmann::json::array({50.0, 50.0, 40.0}));
  EXPECT_DOUBLE_EQ(c["actual"]["diameter_mm"].get<double>(), 50.004);
  EXPECT_FALSE(c["nominal"].contains("length_mm"));
  EXPECT_DOUBLE_EQ(c["form_mm"].get<double>(), 0.004);
  ASSERT_EQ(c["points"].size(), 4u);
  const auto& p0 = c["points"][0];
  EXPECT_EQ(p0["centre_mm"], nlohmann::json::array({73.0, 50.0, 40.0}));
  EXPECT_EQ(p0["surface_mm"], nlohmann::json::array({75.0, 50.0, 40.0}));
  EXPECT_DOUBLE_EQ(p0["approach"][0].get<double>(), -1.0);
  EXPECT_DOUBLE_EQ(p0["ball_radius_mm"].get<double>(), 2.0);
  EXPECT_DOUBLE_EQ(p0["time_s"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(p0["residual_mm"].get<double>(), 0.001);

  const auto& pl = back["features"][1];
  EXPECT_EQ(pl["source"], "constructed");
  EXPECT_TRUE(pl["side"].is_null());
  EXPECT_TRUE(pl["actual"].is_null());
  EXPECT_TRUE(pl["form_mm"].is_null());
  EXPECT_FALSE(pl["nominal"].contains("diameter_mm"));
  EXPECT_FALSE(pl["nominal"].contains("side"));

  const auto& outputs = back["outputs"];
  ASSERT_EQ(outputs.size(), 4u);
  EXPECT_EQ(outputs[0]["kind"], "feature");
  EXPECT_EQ(outputs[0]["frame"], "START");
  EXPECT_NEAR(outputs[0]["deviation"]["position"][0].get<double>(), 0.001, 1e-12);
  EXPECT_NEAR(outputs[0]["deviation"]["diameter_mm"].get<double>(), 0.004, 1e-12);
  EXPECT_EQ(outputs[0]["point_count"], 4);
  EXPECT_EQ(outputs[1]["kind"], "tolerance");
  EXPECT_EQ(outputs[1]["type"], "DISTB");
  EXPECT_EQ(outputs[1]["status"], "IN");
  EXPECT_TRUE(outputs[1]["nominal"].is_null());
  EXPECT_EQ(outputs[1]["features"], nlohmann::json::array({"A_CIRCLE", "PL1"}));
  EXPECT_EQ(outputs[2], (nlohmann::json{{"kind", "text"}, {"text", "operator: turn the part"}}));
  EXPECT_EQ(outputs[3]["kind"], "fault");
  EXPECT_EQ(outputs[3]["fault"], "NoContact");
  EXPECT_EQ(outputs[3]["file"], "prog.dmi");
  EXPECT_EQ(outputs[3]["line"], 42);
  EXPECT_EQ(outputs[3]["column"], 3);
  EXPECT_EQ(outputs[3]["statement"], "PTMEAS/CART,75,50,40,-1,0,0");
  EXPECT_EQ(outputs[3]["position_mm"], nlohmann::json::array({1.0, 2.0, 3.0}));

  ASSERT_EQ(back["tolerances"].size(), 1u);
  EXPECT_EQ(back["tolerances"][0], outputs[1]);
}

TEST(ResultsJson, GeometryFieldsPerType) {
  RunRecord record;
  Feature s;
  s.label = "S";
  s.nominal = geometry(FeatureType::Sphere, Side::Outer, {0, 0, 0}, Vec3::UnitZ(), 10);
  Feature cyl;
  cyl.label = "C";
  cyl.nominal = geometry(FeatureType::Cylinder, Side::Inner, {0, 0, 0}, Vec3::UnitZ(), 10, 20);
  Feature cone;
  cone.label = "K";
  cone.nominal = geometry(FeatureType::Cone, Side::Outer, {0, 0, 0}, Vec3::UnitZ(), 0, 5);
  cone.nominal.apex_angle_deg = 60;
  Feature l;
  l.label = "L";
  l.nominal = geometry(FeatureType::Line, Side::None, {0, 0, 0}, Vec3::UnitX());
  record.features = {s, cyl, cone, l};
  const nlohmann::json j = results_json(record);
  EXPECT_EQ(j["status"], "completed");
  const auto& f = j["features"];
  EXPECT_FALSE(f[0]["nominal"].contains("direction"));
  EXPECT_EQ(f[0]["nominal"]["diameter_mm"], 10.0);
  EXPECT_EQ(f[1]["nominal"]["length_mm"], 20.0);
  EXPECT_EQ(f[1]["nominal"]["side"], "INNER");
  EXPECT_EQ(f[2]["nominal"]["apex_angle_deg"], 60.0);
  EXPECT_FALSE(f[2]["nominal"].contains("diameter_mm"));
  EXPECT_EQ(f[3]["nominal"]["bounded"], false);
  EXPECT_FALSE(f[3]["nominal"].contains("length_mm"));
  EXPECT_TRUE(f[3]["nominal"].contains("normal2"));
  EXPECT_EQ(j["outputs"], nlohmann::json::array());
}

}  // namespace
}  // namespace metron::runtime
