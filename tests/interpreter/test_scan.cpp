// SPDX-License-Identifier: GPL-3.0-or-later
// Scanning statements end to end (PATH, SCNMOD, SCNSET, FEDRAT/SCNVEL, PAMEAS) on a small fake
// machine that answers ScanPath with samples on a known actual surface (nominal + form + offset),
// so fitted actuals and form can be checked against that truth. The virtual CMM's scanning probe
// is tested in tests/machine.
#include <gtest/gtest.h>

#include "scratch.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>

#include <nlohmann/json.hpp>

#include "metron/interpreter/compiler.hpp"
#include "metron/interpreter/interpreter.hpp"
#include "metron/runtime/measurement_runtime.hpp"
#include "metron/runtime/outputs.hpp"
#include "metron/stdlib/geometry/mesh.hpp"
#include "metron/stdlib/geometry/scan_path.hpp"

namespace {

namespace fs = std::filesystem;
using namespace metron;
using metron::interpreter::ExecStatus;
// The ball centre touching the actual surface when the probe rests at `q` on the commanded path
// (the truth of the fake world).
using Truth = std::function<Vec3(const Vec3& q)>;

class FakeScanMachine : public machine::Machine {
 public:
  explicit FakeScanMachine(Truth truth) : m_truth(std::move(truth)) {}
  void submit(machine::Command c) override { m_queue.push_back(std::move(c)); }
  std::vector<machine::Response> execute() override {
    std::vector<machine::Response> out;
    for (auto& c : m_queue) {
      machine::Response r;
      r.tag = c.tag;
      std::visit([&](auto& body) { answer(body, r); }, c.body);
      out.push_back(std::move(r));
    }
    m_queue.clear();
    return out;
  }
  [[nodiscard]] machine::MachineState state() const override {
    machine::MachineState s;
    s.position_mm = m_position;
    s.time_s = m_time;
    s.tool = m_tool;
    s.measuring_feed_mm_s = 5;
    s.positioning_feed_mm_s = 50;
    return s;
  }
  [[nodiscard]] std::vector<machine::Command> queued() const override { return m_queue; }
  std::vector<machine::ScanPath> scans;  ///< every ScanPath received

 private:
  void answer(const machine::DefineTool& d, machine::Response& r) {
    m_tool = machine::ToolInfo{d.name, d.ball_diameter_mm / 2, d.ball_diameter_mm / 2, false, 0};
    r.tool = m_tool;
  }
  void answer(const machine::SelectTool&, machine::Response& r) { r.tool = m_tool; }
  void answer(const machine::QualifyTool&, machine::Response& r) {
    m_tool->qualified = true;
    r.tool = m_tool;
  }
  void answer(const machine::GoTo& g, machine::Response&) { m_position = g.target_mm; }
  void answer(const machine::SetFeeds&, machine::Response&) {}
  void answer(const machine::PtMeas& p, machine::Response& r) {
    r.hit = machine::Hit{p.nominal_mm + m_tool->effective_radius_mm * p.normal, p.normal, m_tool->effective_radius_mm,
                         m_time};
  }
  // Its state() reports no buffer limit (0), so the runtime never splits a scan for it.
  void answer(const machine::ScanBufferWrite&, machine::Response& r) {
    r.status = machine::Response::Status::Fault;
    r.fault =
        machine::Fault{machine::FaultKind::BadCommand, "the fake machine has no command buffers", m_position, m_time};
  }
  void answer(const machine::ContourScan&, machine::Response& r) {
    r.status = machine::Response::Status::Fault;
    r.fault = machine::Fault{machine::FaultKind::BadCommand, "the fake machine follows no unknown contour", m_position,
                             m_time};
  }
  void answer(const machine::ScanPath& s, machine::Response& r) {
    scans.push_back(s);
    const double length = s.path.length();
    const double speed = s.speed_mm_s.value_or(5);
    for (double at = 0; at <= length + 1e-9; at += s.sample_spacing_mm) {
      const auto p = geometry::point_at_length(s.path, at);
      machine::ScanSample sample;
      sample.centre_mm = m_truth(p.position);
      sample.deflection_mm = sample.centre_mm - p.position;
      sample.path_s_mm = at;
      sample.time_s = m_time + at / speed;
      r.scan.push_back(sample);
    }
    m_time += length / speed;
    m_position = s.path.segments.back().end();
  }

  Truth m_truth;
  std::vector<machine::Command> m_queue;
  Vec3 m_position = Vec3(0, 0, 100);
  double m_time = 0;
  std::optional<machine::ToolInfo> m_tool;
};

struct Run {
  ExecStatus status = ExecStatus::Error;
  std::string diagnostics;
  SourceManager sources;
  DiagnosticSink sink;
  runtime::RunRecord record;
  std::unique_ptr<FakeScanMachine> machine;
  std::unique_ptr<runtime::MeasurementRuntime> runtime;
};

std::unique_ptr<Run> run(const std::string& body, Truth truth) {
  const fs::path dir = metron::test_support::scratch_root("metron_scan");
  fs::create_directories(dir);
  const fs::path file = dir / "scan.dmi";
  std::ofstream(file) << "DMISMN/'scan test', 5.0\nUNITS/MM, ANGDEC\n"
                         "S(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\nSNSLCT/S(P4)\n"
                      << body << "ENDFIL\n";
  auto r = std::make_unique<Run>();
  interpreter::Compiler compiler(r->sources, r->sink);
  r->machine = std::make_unique<FakeScanMachine>(std::move(truth));
  r->runtime = std::make_unique<runtime::MeasurementRuntime>(*r->machine, r->sources, r->record);
  auto unit = compiler.compile_file(file.string());
  if (unit && !r->sink.has_errors()) {
    interpreter::Interpreter vm(compiler.module(), *r->runtime, r->sources, r->sink);
    vm.start(*unit);
    r->status = vm.run();
  }
  r->runtime->finish();
  for (const auto& d : r->sink.items()) r->diagnostics += format_diagnostic(d, r->sources);
  return r;
}

// Bore at c, nominal radius 10, actually shifted by o, with a 3-lobe form of amplitude A (radius
// R + A cos 3 theta about the shifted centre, to first order).
Truth lobed_bore(const Vec3& c, const Vec3& o, double amplitude_mm, double ball_radius_mm) {
  return [=](const Vec3& q) {
    Vec3 d = q - c;
    d.z() = 0;
    const Vec3 u = d.normalized();
    const double theta = std::atan2(u.y(), u.x());
    const double r_true = 10 + amplitude_mm * std::cos(3 * theta) + o.dot(u);
    return Vec3(c + (r_true - ball_radius_mm) * u + Vec3(0, 0, q.z() - c.z()));
  };
}

TEST(Scanning, ScnmodScansACircleByItsNominalAndFitsTheHiddenForm) {
  const Vec3 c(340, 250, 30), o(0.02, -0.015, 0);
  auto r =
      run("FEDRAT/SCNVEL, MMPS, 8\nSCNSET/DIST, 0.05, DEFLEC, 0.25, LAW, VC1P, CHORD, 0.0005\n"
          "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
          "F(B1) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\n"
          "GOTO/40, 50, 35\nSCNMOD/ON\nMEAS/CIRCLE, F(B1), 0\nENDMES\nSCNMOD/OFF\n",
          lobed_bore(c, o, 0.005, 2.0));
  ASSERT_EQ(r->status, ExecStatus::Finished) << r->diagnostics;
  ASSERT_EQ(r->machine->scans.size(), 1u);
  const auto& scan = r->machine->scans[0];
  EXPECT_EQ(scan.law, machine::ScanLaw::Vc1Prime);
  EXPECT_EQ(scan.speed_mm_s, 8.0);
  EXPECT_EQ(scan.reference_deflection_mm, 0.25);
  EXPECT_EQ(scan.sample_spacing_mm, 0.05);
  // The path is the nominal bore offset by r - E0 = 1.75 toward the axis, within the chord tolerance.
  for (const auto& seg : scan.path.segments)
    for (int k = 0; k <= 10; ++k) {
      Vec3 d = seg.point(seg.d_mm * k / 10) - c;
      EXPECT_NEAR(d.z(), 0, 1e-9);
      d.z() = 0;
      EXPECT_NEAR(d.norm(), 10 - 1.75, 0.0005);
    }
  // Starts where the probe was nearest (it came down at the centre: any start is fine), approaches
  // from the inside.
  EXPECT_NEAR(scan.approach_normal.z(), 0, 1e-12);
  const auto& f = r->runtime->features().at("B1");
  ASSERT_TRUE(f.actual);
  ASSERT_TRUE(f.fit);
  EXPECT_GT(f.points.size(), 900u);  // 2 std::numbers::pi 8.25 / 0.05
  EXPECT_TRUE(f.points.front().scanned);
  EXPECT_NEAR(f.actual->position.x(), c.x() + o.x(), 1e-4);
  EXPECT_NEAR(f.actual->position.y(), c.y() + o.y(), 1e-4);
  EXPECT_NEAR(f.actual->diameter_mm, 20, 1e-4);
  EXPECT_NEAR(f.fit->form_mm, 0.010, 1e-4);  // roundness of a 3-lobe form: 2 A
}

// Independent expectations: peak-to-valley of least-squares residuals on a dense uniform grid.
// Circle: algebraic (Kasa) fit in the plane, x^2 + y^2 + D x + E y + F = 0.
struct Kasa {
  Vec2 centre;
  double radius_mm, form_mm;
};
Kasa kasa(const std::vector<Vec2>& p) {
  Eigen::MatrixXd a(static_cast<Eigen::Index>(p.size()), 3);
  Eigen::VectorXd b(static_cast<Eigen::Index>(p.size()));
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto k = static_cast<Eigen::Index>(i);
    a(k, 0) = p[i].x(), a(k, 1) = p[i].y(), a(k, 2) = 1;
    b(k) = -p[i].squaredNorm();
  }
  const Eigen::Vector3d x = a.colPivHouseholderQr().solve(b);
  const Vec2 centre(-x(0) / 2, -x(1) / 2);
  const double radius = std::sqrt(centre.squaredNorm() - x(2));
  double lo = 1e9, hi = -1e9;
  for (const auto& q : p) {
    lo = std::min(lo, (q - centre).norm() - radius);
    hi = std::max(hi, (q - centre).norm() - radius);
  }
  return {centre, radius, hi - lo};
}
double circle_form(const std::vector<Vec2>& p) { return kasa(p).form_mm; }
// Line z(x): linear regression.
double line_form(const std::vector<Vec2>& p) {
  double sx = 0, sz = 0, sxx = 0, sxz = 0;
  const double n = static_cast<double>(p.size());
  for (const auto& q : p) sx += q.x(), sz += q.y(), sxx += q.x() * q.x(), sxz += q.x() * q.y();
  const double slope = (n * sxz - sx * sz) / (n * sxx - sx * sx), icpt = (sz - slope * sx) / n;
  double lo = 1e9, hi = -1e9;
  for (const auto& q : p) {
    lo = std::min(lo, q.y() - slope * q.x() - icpt);
    hi = std::max(hi, q.y() - slope * q.x() - icpt);
  }
  return (hi - lo) / std::sqrt(1 + slope * slope);
}

// GEOALG/CIRCLE,MAXINS|MINCIR: a bore of radius 10 with 3 lobes of 5 um, scanned, is 20 mm by
// least squares, 2 (10 - 0.005) by its maximum inscribed circle (a pin gauge's size: the three
// troughs, 120 degrees apart) and 2 (10 + 0.005) by its minimum circumscribed circle (the peaks).
TEST(Scanning, GeoalgSizesACircleByItsInscribedOrCircumscribedCircle) {
  const Vec3 c(340, 250, 30);
  // B2, a circle constructed from B1's points, is sized by the same algorithm.
  const std::string scan =
      "GOTO/40, 50, 35\nSCNMOD/ON\nMEAS/CIRCLE, F(B1), 0\nENDMES\nSCNMOD/OFF\n"
      "F(B2) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\nCONST/CIRCLE, F(B2), BF, FA(B1)\n";
  const auto diameter = [&](const std::string& geoalg) {
    auto r =
        run("SCNSET/DIST, 0.05, CHORD, 0.0005\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
            "F(B1) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\n" +
                geoalg + scan,
            lobed_bore(c, Vec3::Zero(), 0.005, 2.0));
    EXPECT_EQ(r->status, ExecStatus::Finished) << r->diagnostics;
    const auto& b1 = r->runtime->features().at("B1");
    EXPECT_TRUE(b1.actual.has_value());
    if (b1.actual) {
      EXPECT_LT((b1.actual->position - c).norm(), 2e-4) << geoalg;
      const auto& b2 = r->runtime->features().at("B2");
      EXPECT_TRUE(b2.actual && std::abs(b2.actual->diameter_mm - b1.actual->diameter_mm) < 1e-9) << geoalg;
    }
    return b1.actual ? b1.actual->diameter_mm : 0.0;
  };
  EXPECT_NEAR(diameter(""), 20.0, 2e-4);
  EXPECT_NEAR(diameter("GEOALG/CIRCLE, MAXINS\n"), 19.99, 2e-4);
  EXPECT_NEAR(diameter("GEOALG/CIRCLE, MINCIR\n"), 20.01, 2e-4);
  EXPECT_NEAR(diameter("GEOALG/CIRCLE, MAXINS\nGEOALG/CIRCLE, LSTSQR\n"), 20.0, 2e-4);
}

// GEOALG/CIRCLE,MINMAX: the minimum zone circle of a bore whose hidden profile has 3 and 2 lobes
// of 5 um, r = 10 + 0.005 cos 3t + 0.005 cos 2t. Its least-squares centre is the axis (no first
// harmonic); the narrowest annulus is not centred there. The expected centre and diameter come
// from a brute-force search of the hidden profile itself (a 0.1 um grid of centres, 3600 profile
// points), independent of metron's minimum-zone search: the centre 3.7 um along +x, the diameter
// r_max + r_min = 19.99669, where least squares gives 20.0000.
TEST(Scanning, GeoalgMinmaxCentresACircleInItsNarrowestAnnulus) {
  const Vec3 c(340, 250, 30);
  const auto profile = [](double t) { return 10 + 0.005 * std::cos(3 * t) + 0.005 * std::cos(2 * t); };
  const Truth truth = [=](const Vec3& q) {
    Vec3 d = q - c;
    d.z() = 0;
    const Vec3 u = d.normalized();
    return Vec3(c + (profile(std::atan2(u.y(), u.x())) - 2.0) * u + Vec3(0, 0, q.z() - c.z()));
  };
  // The independent reference: the centre on a grid that makes r_max - r_min least.
  double best_width = 1e9, best_x = 0, best_y = 0, best_diameter = 0;
  for (int i = -60; i <= 60; ++i)
    for (int j = -20; j <= 20; ++j) {
      double lo = 1e9, hi = 0;
      for (int k = 0; k < 3600; ++k) {
        const double t = 2 * std::numbers::pi * k / 3600;
        const double r = profile(t);
        const double x = r * std::cos(t) - i * 1e-4, y = r * std::sin(t) - j * 1e-4;
        const double rr = std::hypot(x, y);
        lo = std::min(lo, rr);
        hi = std::max(hi, rr);
      }
      if (hi - lo < best_width) best_width = hi - lo, best_x = i * 1e-4, best_y = j * 1e-4, best_diameter = hi + lo;
    }
  ASSERT_NEAR(best_x, 0.0037, 1e-4);  // the reference itself, before metron is asked
  const auto fitted = [&](const std::string& geoalg) {
    auto r =
        run("SCNSET/DIST, 0.05, CHORD, 0.0005\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
            "F(B1) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\n" +
                geoalg + "GOTO/40, 50, 35\nSCNMOD/ON\nMEAS/CIRCLE, F(B1), 0\nENDMES\nSCNMOD/OFF\n",
            truth);
    EXPECT_EQ(r->status, ExecStatus::Finished) << r->diagnostics;
    const auto& b1 = r->runtime->features().at("B1");
    EXPECT_TRUE(b1.actual.has_value());
    return b1.actual ? *b1.actual : metron::runtime::Geometry{};
  };
  const auto mz = fitted("GEOALG/CIRCLE, MINMAX\n");
  EXPECT_NEAR(mz.position.x() - c.x(), best_x, 5e-4);
  EXPECT_NEAR(mz.position.y() - c.y(), best_y, 5e-4);
  EXPECT_NEAR(mz.position.z(), c.z(), 1e-6);
  EXPECT_NEAR(mz.diameter_mm, best_diameter, 5e-4);
  const auto ls = fitted("");
  EXPECT_NEAR(ls.diameter_mm, 20.0, 2e-4);
  EXPECT_GT(std::abs(ls.diameter_mm - mz.diameter_mm), 2e-3);  // the two algorithms differ here
}

// PTMEAS/CART at `p` with normal `n`: the fake machine's touch lands exactly on the commanded
// surface point, so a feature's points are the ones written here.
std::string ptmeas(const Vec3& p, const Vec3& n) {
  char line[160];
  std::snprintf(line, sizeof line, "PTMEAS/CART, %.9f, %.9f, %.9f, %.9f, %.9f, %.9f\n", p.x(), p.y(), p.z(), n.x(),
                n.y(), n.z());
  return line;
}

// GEOALG/CYLNDR and GEOALG/SPHERE: every algorithm on point sets whose reference features follow
// by hand. A boss of radius 10 probed on two rings of 8 points (z 20 and 40), the point at 0
// degrees of each ring 10 um proud. With the axis shifted by s along x (s small), the radii are
// 10.01 - s at 0 degrees, 10 + s at 180, 10 -+ 0.7071 s at 45 and 135, 10 at 90 and 270:
//   least squares: s = (2/8) 0.01 = 2.5 um, d = 2 (10 + 0.01/8)        = 20.0025
//   minimum zone:  width 0.01 - 0.29 s for s < 5 um, 1.71 s beyond:  s = 5 um, d = 10.005 + 10 - 0.7071 0.005
//   = 20.001464 circumscribed: max(10.01 - s, 10 + s) least at s = 5 um,          d = 20.01 inscribed:     min radius
//   10 at s = 0 and less anywhere else,     d = 20.00
// (first order in s; the neglected terms are s^2 / 2R = 1.25e-6). Tilting the axis moves the two
// rings' centres apart, which only widens each. A sphere of radius 10 probed at its 6 axis points
// and 8 cube-diagonal points, the +x point 10 um proud: the same reasoning with 0.5774 s at the
// diagonals gives LS s = (3/14) 0.01, MZ s = 5 um, d = 10.005 + 10 - 0.5774 0.005 = 20.002113,
// MCC s = 5 um, d = 20.01, MIC s = 0, d = 20.00.
TEST(Geoalg, CylindersAndSpheresAreSizedByEachAlgorithm) {
  const Vec3 c(40, 50, 30);
  std::string cylinder_points;
  for (const double z : {20.0, 40.0})
    for (int k = 0; k < 8; ++k) {
      const double t = k * std::numbers::pi / 4;
      const Vec3 u(std::cos(t), std::sin(t), 0);
      cylinder_points += ptmeas(Vec3(c.x(), c.y(), z) + (k == 0 ? 10.01 : 10.0) * u, u);
    }
  std::string sphere_points;
  std::vector<Vec3> directions = {Vec3::UnitX(),  -Vec3::UnitX(), Vec3::UnitY(),
                                  -Vec3::UnitY(), Vec3::UnitZ(),  -Vec3::UnitZ()};
  for (const double x : {-1.0, 1.0})
    for (const double y : {-1.0, 1.0})
      for (const double z : {-1.0, 1.0}) directions.push_back(Vec3(x, y, z).normalized());
  for (std::size_t i = 0; i < directions.size(); ++i)
    sphere_points += ptmeas(c + (i == 0 ? 10.01 : 10.0) * directions[i], directions[i]);
  const auto measured = [&](const std::string& geoalg) {
    auto r = run(geoalg +
                     "F(BOSS) = FEAT/CYLNDR, OUTER, CART, 40, 50, 20, 0, 0, 1, 20, 20\n"
                     "MEAS/CYLNDR, F(BOSS), 16\n" +
                     cylinder_points +
                     "ENDMES\n"
                     "F(BALL) = FEAT/SPHERE, OUTER, CART, 40, 50, 30, 20\n"
                     "MEAS/SPHERE, F(BALL), 14\n" +
                     sphere_points + "ENDMES\n",
                 [](const Vec3& q) { return q; });
    EXPECT_EQ(r->status, ExecStatus::Finished) << r->diagnostics;
    const auto& features = r->runtime->features();
    EXPECT_TRUE(features.at("BOSS").actual && features.at("BALL").actual) << geoalg;
    return std::pair(features.at("BOSS").actual.value_or(runtime::Geometry{}),
                     features.at("BALL").actual.value_or(runtime::Geometry{}));
  };
  struct Expected {
    const char* geoalg;
    double cylinder_shift_mm, cylinder_diameter_mm, sphere_shift_mm, sphere_diameter_mm;
  };
  const Expected cases[] = {
      {"", 0.0025, 20.0025, 3.0 / 14 * 0.01, 2 * (10 + 0.01 / 14)},
      {"GEOALG/CYLNDR, MINMAX\nGEOALG/SPHERE, MINMAX\n", 0.005, 20.005 - std::sqrt(0.5) * 0.005, 0.005,
       20.005 - std::sqrt(1.0 / 3) * 0.005},
      {"GEOALG/CYLNDR, MINCIR\nGEOALG/SPHERE, MINCIR\n", 0.005, 20.01, 0.005, 20.01},
      {"GEOALG/CYLNDR, MAXINS\nGEOALG/SPHERE, MAXINS\n", 0.0, 20.0, 0.0, 20.0},
      // Back to least squares.
      {"GEOALG/CYLNDR, MAXINS\nGEOALG/SPHERE, MINCIR\nGEOALG/CYLNDR, DEFALT\nGEOALG/SPHERE, LSTSQR\n", 0.0025, 20.0025,
       3.0 / 14 * 0.01, 2 * (10 + 0.01 / 14)},
  };
  for (const auto& e : cases) {
    const auto [boss, ball] = measured(e.geoalg);
    EXPECT_NEAR(boss.diameter_mm, e.cylinder_diameter_mm, 1e-5) << e.geoalg;
    EXPECT_NEAR(boss.position.x() - c.x(), e.cylinder_shift_mm, 1e-5) << e.geoalg;
    EXPECT_NEAR(boss.position.y() - c.y(), 0, 2e-4) << e.geoalg;  // MCC: flat in y to second order
    EXPECT_NEAR(boss.position.z(), 20, 1e-3) << e.geoalg;         // at the nominal's height
    EXPECT_GT(boss.direction.z(), 1 - 1e-8) << e.geoalg;
    EXPECT_NEAR(ball.diameter_mm, e.sphere_diameter_mm, 1e-5) << e.geoalg;
    EXPECT_NEAR(ball.position.x() - c.x(), e.sphere_shift_mm, 1e-5) << e.geoalg;
    EXPECT_NEAR((ball.position - c).tail<2>().norm(), 0, 2e-4) << e.geoalg;
  }
}

// GEOALG/ARC shares CIRCLE's setting, and an arc of 120 degrees does not surround its centre:
// its circumscribed circle would have the chord for a diameter (17.32, not 20), so the
// least-squares arc is kept with a warning.
TEST(Geoalg, AShortArcKeepsItsLeastSquaresSize) {
  std::string points;
  for (int k = 0; k <= 4; ++k) {
    const double t = k * std::numbers::pi / 6;  // 0 to 120 degrees
    const Vec3 u(std::cos(t), std::sin(t), 0);
    points += ptmeas(Vec3(40, 50, 30) + 10 * u, -u);
  }
  const auto measured = [&](const std::string& geoalg) {
    auto r = run(geoalg + "F(A1) = FEAT/ARC, INNER, CART, 40, 50, 30, 0, 0, 1, 10, 0, 120\nMEAS/ARC, F(A1), 5\n" +
                     points + "ENDMES\n",
                 [](const Vec3& q) { return q; });
    EXPECT_EQ(r->status, ExecStatus::Finished) << r->diagnostics;
    const auto& a = r->runtime->features().at("A1");
    EXPECT_TRUE(a.actual.has_value()) << r->diagnostics;
    std::string said = r->diagnostics;  // compile diagnostics, then the run's warnings
    for (const auto& line : r->record.diagnostics) said += line + "\n";
    return std::pair(a.actual ? a.actual->diameter_mm : 0.0, said);
  };
  EXPECT_NEAR(measured("").first, 20.0, 1e-6);
  const auto [mcc, said] = measured("GEOALG/ARC, MINCIR\n");
  EXPECT_NEAR(mcc, 20.0, 1e-6);
  EXPECT_NE(said.find("GEOALG MINCIR: the points of F(A1) do not surround their centre; its least-squares fit is kept"),
            std::string::npos)
      << said;
}

// GEOALG/PLANE,MINMAX and GEOALG/LINE,MINMAX: four points of a face at z = 0 and one 10 um high
// in their middle. Least squares puts the plane at their mean height, 2 um; the minimum zone is
// 10 um wide between z = 0 and z = 0.01 whatever the tilt (the middle point is the corners' mean),
// so its middle plane is at 5 um. The same for a line probed at x = 0, 10, 15 (high), 20, 30.
TEST(Geoalg, PlanesAndLinesAreTheMiddleOfTheirMinimumZone) {
  std::string plane_points, line_points;
  for (const Vec3& p : {Vec3(0, 0, 0), Vec3(10, 0, 0), Vec3(0, 10, 0), Vec3(10, 10, 0), Vec3(5, 5, 0.01)})
    plane_points += ptmeas(p + Vec3(30, 40, 25), Vec3::UnitZ());
  for (const double x : {0.0, 10.0, 15.0, 20.0, 30.0})
    line_points += ptmeas(Vec3(30 + x, 60, x == 15 ? 25.01 : 25), Vec3::UnitZ());
  const auto measured = [&](const std::string& geoalg) {
    auto r =
        run(geoalg + "F(TOP) = FEAT/PLANE, CART, 35, 45, 25, 0, 0, 1\nMEAS/PLANE, F(TOP), 5\n" + plane_points +
                "ENDMES\nF(EDGE) = FEAT/LINE, BND, CART, 30, 60, 25, 60, 60, 25, 0, 1, 0\nMEAS/LINE, F(EDGE), 5\n" +
                line_points + "ENDMES\n",
            [](const Vec3& q) { return q; });
    EXPECT_EQ(r->status, ExecStatus::Finished) << r->diagnostics;
    const auto& features = r->runtime->features();
    return std::pair(features.at("TOP").actual.value_or(runtime::Geometry{}),
                     features.at("EDGE").actual.value_or(runtime::Geometry{}));
  };
  const auto [ls_plane, ls_line] = measured("");
  EXPECT_NEAR(ls_plane.position.z(), 25.002, 1e-9);
  EXPECT_NEAR(ls_line.position.z(), 25.002, 1e-9);
  const auto [mz_plane, mz_line] = measured("GEOALG/PLANE, MINMAX\nGEOALG/LINE, MINMAX\n");
  EXPECT_NEAR(mz_plane.position.z(), 25.005, 1e-7);
  EXPECT_GT(mz_plane.direction.z(), 1 - 1e-10);
  EXPECT_NEAR((mz_plane.position - ls_plane.position).head<2>().norm(), 0, 1e-9);  // slid along the normal only
  EXPECT_NEAR(mz_line.position.z(), 25.005, 1e-7);
  EXPECT_NEAR(mz_line.position.x(), 30, 1e-6);  // still at the nominal start
  EXPECT_GT(mz_line.direction.x(), 1 - 1e-10);
}

// GEOALG/CONE,MINMAX: a 60 degree boss cone (apex at (40, 50, 0), axis +z) probed in two sections
// (z 10 and 40) with the alternating contacts of MinimumZone.ConicityOfTwoAlternatingSectionsIs-
// TheNormalZoneWidth: outer points t = 10 um off the surface at 0 and 180 degrees, inner ones on
// it at 90 and 270, and in the lower section a cluster of inner ones from 10 to 40 degrees. The
// alternation in each section keeps the minimum-zone cone the zone's middle, t/2 out: its apex
// t/2 / sin 30 deg = 10 um below the true apex, its angle 60 degrees; least squares, pulled in at
// the lower section by the cluster, has another apex and another angle.
TEST(Geoalg, AConeIsTheMiddleOfItsMinimumZone) {
  const Vec3 apex(40, 50, 0);
  const double half = std::numbers::pi / 6, t = 0.01;
  std::string points;
  for (const double z : {10.0, 40.0}) {
    std::vector<std::pair<double, double>> at = {{0, t}, {90, 0}, {180, t}, {270, 0}};
    if (z == 10.0)
      for (double a = 10; a <= 40; a += 5) at.push_back({a, 0});
    for (const auto& [deg, off] : at) {
      const double a = deg * std::numbers::pi / 180;
      const Vec3 u(std::cos(a), std::sin(a), 0);
      const Vec3 normal = (std::cos(half) * u - std::sin(half) * Vec3::UnitZ()).normalized();
      points += ptmeas(apex + Vec3(0, 0, z) + (z * std::tan(half) + off / std::cos(half)) * u, normal);
    }
  }
  const auto measured = [&](const std::string& geoalg) {
    auto r = run(
        geoalg + "F(CN) = FEAT/CONE, OUTER, CART, 40, 50, 0, 0, 0, 1, 60\nMEAS/CONE, F(CN), 15\n" + points + "ENDMES\n",
        [](const Vec3& q) { return q; });
    EXPECT_EQ(r->status, ExecStatus::Finished) << r->diagnostics;
    return r->runtime->features().at("CN").actual.value_or(runtime::Geometry{});
  };
  const auto ls = measured("");
  const auto mz = measured("GEOALG/CONE, MINMAX\n");
  EXPECT_NEAR((mz.position - (apex - Vec3(0, 0, (t / 2) / std::sin(half)))).norm(), 0, 1e-5);
  EXPECT_NEAR(mz.apex_angle_deg, 60.0, 1e-4);
  EXPECT_GT(mz.direction.z(), 1 - 1e-9);
  EXPECT_GT((ls.position - mz.position).norm(), 1e-3);  // the two algorithms differ here
  EXPECT_GT(std::abs(ls.apex_angle_deg - 60.0), 1e-3) << ls.apex_angle_deg;
  const auto back = measured("GEOALG/CONE, MINMAX\nGEOALG/CONE, LSTSQR\n");
  EXPECT_NEAR((back.position - ls.position).norm(), 0, 1e-12);
}

// CONST/POINT,EXTREM,...,RADIAL: the measured point farthest from (MIN: nearest to) the feature's
// own axis. Six points of a bore at 60 degree steps, radii 10, 10.02, 10, 9.99, 10, 10: the
// expected points are chosen by distance from an independent algebraic (Kasa) circle through the
// same points, not from metron's fit. A plane has no axis: an error at run.
TEST(Constructions, ExtremeRadialPointsAreFarthestFromAndNearestToTheAxis) {
  const double radii[] = {10, 10.02, 10, 9.99, 10, 10};
  std::string points;
  std::vector<Vec2> plane_points;
  for (int k = 0; k < 6; ++k) {
    const double t = k * std::numbers::pi / 3;
    const Vec3 u(std::cos(t), std::sin(t), 0);
    points += ptmeas(Vec3(40, 50, 30) + radii[k] * u, -u);
    plane_points.push_back(radii[k] * Vec2(u.x(), u.y()));
  }
  const Kasa reference = kasa(plane_points);
  std::size_t far = 0, near = 0;
  for (std::size_t k = 0; k < 6; ++k) {
    const double r = (plane_points[k] - reference.centre).norm();
    if (r > (plane_points[far] - reference.centre).norm()) far = k;
    if (r < (plane_points[near] - reference.centre).norm()) near = k;
  }
  ASSERT_EQ(far, 1u);   // the reference itself: 60 degrees, 10.02
  ASSERT_EQ(near, 0u);  // 0 degrees: the fitted centre moved toward it
  auto r =
      run("F(B1) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\nMEAS/CIRCLE, F(B1), 6\n" + points +
              "ENDMES\nCONST/POINT, F(OUT), EXTREM, FA(B1), RADIAL\nCONST/POINT, F(IN), EXTREM, MIN, FA(B1), RADIAL\n"
              "F(TOP) = FEAT/PLANE, CART, 40, 50, 40, 0, 0, 1\nMEAS/PLANE, F(TOP), 3\n" +
              ptmeas(Vec3(30, 40, 40), Vec3::UnitZ()) + ptmeas(Vec3(50, 40, 40), Vec3::UnitZ()) +
              ptmeas(Vec3(40, 60, 40), Vec3::UnitZ()) + "ENDMES\nCONST/POINT, F(BAD), EXTREM, FA(TOP), RADIAL\n",
          [](const Vec3& q) { return q; });
  EXPECT_EQ(r->status, ExecStatus::Error);
  EXPECT_NE(r->diagnostics.find("RADIAL measures from an axis or a centre: FA(TOP) is a PLANE"), std::string::npos)
      << r->diagnostics;
  const auto& features = r->runtime->features();
  ASSERT_TRUE(features.at("OUT").actual && features.at("IN").actual) << r->diagnostics;
  const Vec2 out(features.at("OUT").actual->position.x() - 40, features.at("OUT").actual->position.y() - 50);
  const Vec2 in(features.at("IN").actual->position.x() - 40, features.at("IN").actual->position.y() - 50);
  EXPECT_LT((out - plane_points[far]).norm(), 1e-9);
  EXPECT_LT((in - plane_points[near]).norm(), 1e-9);
}

TEST(Scanning, PameasScansAnArcPathAndALinePath) {
  const Vec3 c(40, 50, 25);
  // A line on the top face z = 40 whose actual surface is 3 um high with a 2 um sine on it.
  const auto truth = [&](const Vec3& q) {
    if (std::abs(q.z() - 25) < 1e-6) return lobed_bore(c, Vec3::Zero(), 0.003, 2.0)(q);
    const double z = 40.003 + 0.002 * std::sin(2 * std::numbers::pi * q.x() / 7.5);
    return Vec3(q.x(), q.y(), z + 2.0);
  };
  auto r =
      run("P(A1) = PATH/ARC, CART, 40, 50, 25, 0, 0, 1, 10, 0, 270, INNER\n"
          "F(B2) = FEAT/CIRCLE, INNER, CART, 40, 50, 25, 0, 0, 1, 20\n"
          "MEAS/CIRCLE, F(B2), 0\n  PAMEAS/P(A1)\nENDMES\n"
          "P(L1) = PATH/LINE, CART, 5, 20, 40, 35, 20, 40, 0, 0, 1\n"
          "F(E1) = FEAT/LINE, BND, CART, 5, 20, 40, 35, 20, 40, 0, 1, 0\n"
          "MEAS/LINE, F(E1), 0\n  PAMEAS/P(L1)\nENDMES\n",
          truth);
  ASSERT_EQ(r->status, ExecStatus::Finished) << r->diagnostics;
  ASSERT_EQ(r->machine->scans.size(), 2u);
  // The arc runs counterclockwise from angle 0 (+X) to 270 degrees, at the default E0 0.3 and law Vc2.
  const auto& arc = r->machine->scans[0];
  EXPECT_EQ(arc.law, machine::ScanLaw::Vc2);
  EXPECT_LT((arc.path.segments.front().start() - Vec3(40 + 8.3, 50, 25)).norm(), 1e-9);
  EXPECT_LT((arc.path.segments.back().end() - Vec3(40, 50 - 8.3, 25)).norm(), 1e-9);
  EXPECT_GT(arc.approach_normal.dot(-Vec3::UnitX()), 1 - 1e-12);
  const auto& b2 = r->runtime->features().at("B2");
  ASSERT_TRUE(b2.actual && b2.fit);
  EXPECT_NEAR(b2.actual->diameter_mm, 20, 1e-3);
  std::vector<Vec2> arc_truth;
  for (int i = 0; i <= 20000; ++i) {
    const double t = 1.5 * std::numbers::pi * i / 20000;
    arc_truth.push_back((10 + 0.003 * std::cos(3 * t)) * Vec2(std::cos(t), std::sin(t)));
  }
  EXPECT_NEAR(b2.fit->form_mm, circle_form(arc_truth), 1e-4);
  // The line: one straight segment 1.7 above the face; fitted 3 um up; straightness of the sine
  // about its least-squares line.
  const auto& line = r->machine->scans[1];
  ASSERT_EQ(line.path.segments.size(), 1u);
  EXPECT_LT((line.path.segments[0].start() - Vec3(5, 20, 41.7)).norm(), 1e-9);
  const auto& e1 = r->runtime->features().at("E1");
  ASSERT_TRUE(e1.actual && e1.fit);
  std::vector<Vec2> line_truth;
  for (int i = 0; i <= 20000; ++i) {
    const double x = 5 + 30.0 * i / 20000;
    line_truth.push_back(Vec2(x, 0.002 * std::sin(2 * std::numbers::pi * x / 7.5)));
  }
  // The line is reported at its nominal start x = 5: the height there of the least-squares line
  // of the true surface (the sine tilts it), not the mean height 40.003.
  double mx = 0, mz = 0, sxz = 0, sxx = 0;
  for (const Vec2& q : line_truth) mx += q.x(), mz += q.y();
  mx /= static_cast<double>(line_truth.size());
  mz /= static_cast<double>(line_truth.size());
  for (const Vec2& q : line_truth) sxz += (q.x() - mx) * (q.y() - mz), sxx += (q.x() - mx) * (q.x() - mx);
  EXPECT_NEAR(e1.actual->position.x(), 5.0, 1e-6);
  EXPECT_NEAR(e1.actual->position.z(), 40.003 + mz + sxz / sxx * (5 - mx), 1e-4);
  EXPECT_NEAR(e1.fit->form_mm, line_form(line_truth), 1e-4);
  std::printf("270-degree arc form %.5f mm (expected %.5f), line straightness %.5f mm (expected %.5f)\n",
              b2.fit->form_mm, circle_form(arc_truth), e1.fit->form_mm, line_form(line_truth));
  // Scanned points are in results.json, marked as scanned.
  const auto j = runtime::results_json(r->record);
  bool found = false;
  for (const auto& f : j["features"])
    if (f["label"] == "E1") {
      found = true;
      EXPECT_GT(f["points"].size(), 250u);
      EXPECT_EQ(f["points"][0]["scanned"], true);
    }
  EXPECT_TRUE(found);
}

// The truth of a round boss about the vertical axis through c: the ball centre stands
// `centre_radius_mm` from the axis, at the probe's height.
Truth ball_centres_around(const Vec3& c, double centre_radius_mm) {
  return [c, centre_radius_mm](const Vec3& q) {
    Vec3 d = q - c;
    d.z() = 0;
    return Vec3(c + centre_radius_mm * d.normalized() + Vec3(0, 0, q.z() - c.z()));
  };
}

// A boss of radius 10 about part (40, 50), 30 high, as a 256-facet STL in part coordinates.
constexpr int boss_facets = 256;
fs::path boss_stl() {
  std::vector<Vec3> v;
  std::vector<geometry::Mesh::Face> faces;
  const int n = boss_facets;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    v.emplace_back(40 + 10 * std::cos(a), 50 + 10 * std::sin(a), 0);
    v.emplace_back(40 + 10 * std::cos(a), 50 + 10 * std::sin(a), 30);
  }
  v.emplace_back(40, 50, 0);
  v.emplace_back(40, 50, 30);
  const auto bottom = static_cast<std::uint32_t>(2 * n);
  for (int i = 0; i < n; ++i) {
    const auto a0 = static_cast<std::uint32_t>(2 * i), a1 = a0 + 1;
    const auto b0 = static_cast<std::uint32_t>(2 * ((i + 1) % n)), b1 = b0 + 1;
    faces.push_back({a0, b0, b1});
    faces.push_back({a0, b1, a1});
    faces.push_back({bottom, b0, a0});
    faces.push_back({bottom + 1, a1, b1});
  }
  auto mesh = geometry::Mesh::from_triangles(v, faces);
  EXPECT_TRUE(mesh);
  const fs::path stl = metron::test_support::scratch_root("metron_scan") / "boss.stl";
  fs::create_directories(stl.parent_path());
  EXPECT_TRUE(mesh && geometry::save_mesh(*mesh, stl.string()));
  return stl;
}

TEST(Scanning, PathSectionCutsACadModelInThePartFrame) {
  // The boss of boss_stl(); the part frame is shifted to machine (300, 200, 0). Truth: radius
  // 10 + 4 um cos 3 theta.
  const double rb = 2.0;
  const Vec3 c(340, 250, 15);
  const int n = boss_facets;
  const fs::path stl = boss_stl();
  const auto truth = [&](const Vec3& q) {
    Vec3 d = q - c;
    d.z() = 0;
    const Vec3 u = d.normalized();
    const double r_true = 10 + 0.004 * std::cos(3 * std::atan2(u.y(), u.x()));
    return Vec3(c + (r_true + rb) * u + Vec3(0, 0, q.z() - c.z()));
  };
  auto r =
      run("D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
          "P(S1) = PATH/SECTION, '" +
              stl.string() +
              "', 0, 0, 15, 0, 0, 1, 40, 70, 15\n"
              "F(BOSS) = FEAT/CIRCLE, OUTER, CART, 40, 50, 15, 0, 0, 1, 20\n"
              "MEAS/CIRCLE, F(BOSS), 0\n  PAMEAS/P(S1)\nENDMES\n",
          truth);
  ASSERT_EQ(r->status, ExecStatus::Finished) << r->diagnostics;
  ASSERT_EQ(r->machine->scans.size(), 1u);
  const auto& scan = r->machine->scans[0];
  // Starts nearest the hint (part (40, 70) = machine (340, 270)), runs counterclockwise, 1.7 outside.
  EXPECT_LT((scan.path.segments.front().start() - Vec3(340, 261.7, 15)).norm(), 0.05);
  EXPECT_LT(scan.path.segments.front().tangent(0).x(), -0.99);
  const double sagitta = 10 * (1 - std::cos(std::numbers::pi / n));
  for (const auto& seg : scan.path.segments) {
    Vec3 d = seg.point(seg.d_mm / 2) - c;
    d.z() = 0;
    EXPECT_NEAR(d.norm(), 11.7, 0.001 + sagitta);
  }
  const auto& f = r->runtime->features().at("BOSS");
  ASSERT_TRUE(f.actual && f.fit);
  EXPECT_NEAR(f.actual->diameter_mm, 20, 1e-4);
  EXPECT_NEAR(f.actual->position.x(), 340, 1e-4);
  EXPECT_NEAR(f.fit->form_mm, 0.008, 1e-4);
}

// A sub-range of a section (issue 11 item 11): from the point nearest part (40, 70) to the point
// nearest part (30, 50), in the section's direction (counterclockwise about the plane normal for
// an outer boundary): a quarter of the boss, from its top to its left side.
TEST(Scanning, PathSectionScansASubRangeBetweenTwoPoints) {
  const fs::path stl = boss_stl();
  const Vec3 c(340, 250, 15);
  auto r =
      run("D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
          "P(Q) = PATH/SECTION, '" +
              stl.string() +
              "', 0, 0, 15, 0, 0, 1, 40, 70, 15, 30, 50, 15\n"
              "F(BOSS) = FEAT/ARC, OUTER, CART, 40, 50, 15, 0, 0, 1, 10, 90, 180\n"
              "MEAS/ARC, F(BOSS), 0\n  PAMEAS/P(Q)\nENDMES\n",
          ball_centres_around(c, 12.0));
  ASSERT_EQ(r->status, ExecStatus::Finished) << r->diagnostics;
  ASSERT_EQ(r->machine->scans.size(), 1u);
  const auto& path = r->machine->scans[0].path;
  EXPECT_LT((path.segments.front().start() - Vec3(340, 261.7, 15)).norm(), 0.05);
  EXPECT_LT((path.segments.back().end() - Vec3(328.3, 250, 15)).norm(), 0.05);
  double length = 0;
  for (const auto& seg : path.segments) length += seg.d_mm;
  EXPECT_NEAR(length, 11.7 * std::numbers::pi / 2, 0.05);  // a quarter turn at the ball centre's radius
  // Three end numbers or none: anything else names the statement.
  EXPECT_NE(run("P(Q) = PATH/SECTION, '" + stl.string() + "', 0, 0, 15, 0, 0, 1, 40, 70, 15, 30, 50\n", nullptr)
                ->diagnostics.find("PATH/SECTION expects the file and 9 numbers"),
            std::string::npos);
}

TEST(Scanning, ScnmodScansAnArcFromItsStartAngleInThePartFrame) {
  // Part frame rotated 90 degrees about Z: part +X is machine +Y, so angle 90 is machine -X.
  const Vec3 c(100, 100, 10);
  auto r =
      run("D(T) = TRANS/XORIG, 100, YORIG, 100, ZORIG, 10\nD(R) = ROTATE/ZAXIS, 90\n"
          "F(A1) = FEAT/ARC, OUTER, CART, 0, 0, 0, 0, 0, 1, 10, 90, 180\n"
          "SCNMOD/ON\nMEAS/ARC, F(A1), 0\nENDMES\n",
          ball_centres_around(c, 12.0));
  ASSERT_EQ(r->status, ExecStatus::Finished) << r->diagnostics;
  ASSERT_EQ(r->machine->scans.size(), 1u);
  ASSERT_LT((r->runtime->features().at("A1").nominal.position - c).norm(), 1e-9);
  const auto& path = r->machine->scans[0].path;
  const Vec3 start = path.segments.front().start(), end = path.segments.back().end();
  ASSERT_LT(std::abs(start.z() - 10), 1e-9) << start.transpose();
  EXPECT_LT((start - (c + Vec3(-11.7, 0, 0))).norm(), 1e-6) << start.transpose();
  EXPECT_LT((end - (c + Vec3(11.7, 0, 0))).norm(), 1e-6) << end.transpose();
  EXPECT_LT((path.segments.front().point(1.0) - c).y(), 0);  // counterclockwise: from -X through -Y
  const auto& f = r->runtime->features().at("A1");
  ASSERT_TRUE(f.actual);
  EXPECT_NEAR(f.actual->diameter_mm, 20, 1e-6);
}

TEST(Scanning, HelicalPathIntoACylinder) {
  // Two turns of pitch 5 down a bore whose actual is a 3-lobe (A = 4 um) cylinder shifted by o.
  const Vec3 c(40, 50, 0), o(-0.01, 0.02, 0);
  auto r =
      run("P(H) = PATH/HELICAL, CART, 40, 50, 20, 0, 0, -1, 10, 0, 720, 5, INNER\n"
          "F(C) = FEAT/CYLNDR, INNER, CART, 40, 50, 0, 0, 0, 1, 20, 25\n"
          "MEAS/CYLNDR, F(C), 0\n  PAMEAS/P(H)\nENDMES\n",
          lobed_bore(c, o, 0.004, 2.0));
  ASSERT_EQ(r->status, ExecStatus::Finished) << r->diagnostics;
  const auto& path = r->machine->scans.at(0).path;
  EXPECT_NEAR(path.segments.front().start().z(), 20, 1e-9);
  EXPECT_NEAR(path.segments.back().end().z(), 10, 1e-9);  // the axis points down: it advances down
  const auto& f = r->runtime->features().at("C");
  ASSERT_TRUE(f.actual && f.fit);
  // On a helix the lobes correlate with an axis tilt (z and the angle advance together), so the
  // least-squares cylinder tilts a little. Independent expectation: the linearised cylinder fit
  // r - 10 = p0 + p1 cos + p2 sin + z (p3 cos + p4 sin) of the truth along the same helix.
  const int n = 20000;
  Eigen::MatrixXd a(n, 5);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    const double t = 4 * std::numbers::pi * i / (n - 1), th = -t, z = 20 - 5 * t / (2 * std::numbers::pi);
    const Vec3 u(std::cos(th), std::sin(th), 0);
    a.row(i) << 1, u.x(), u.y(), z * u.x(), z * u.y();
    b(i) = 0.004 * std::cos(3 * th) + o.dot(u);
  }
  const Eigen::VectorXd q = a.colPivHouseholderQr().solve(b);
  const Eigen::VectorXd e = b - a * q;
  EXPECT_NEAR(f.actual->diameter_mm, 20 + 2 * q(0), 1e-4);
  EXPECT_NEAR(f.actual->position.x(), 40 + q(1), 1e-4);  // the axis at the nominal's z = 0
  EXPECT_NEAR(f.actual->position.y(), 50 + q(2), 1e-4);
  EXPECT_NEAR(f.actual->direction.y() / f.actual->direction.z(), q(4), 1e-5);
  EXPECT_NEAR(f.fit->form_mm, e.maxCoeff() - e.minCoeff(), 1e-4);
  std::printf("helix into cylinder: form %.5f mm (linearised %.5f), tilt %.2e (linearised %.2e)\n", f.fit->form_mm,
              e.maxCoeff() - e.minCoeff(), f.actual->direction.y() / f.actual->direction.z(), q(4));
}

TEST(Scanning, ScnmodWithPtmeasPairsScansFromStartToEnd) {
  // The RationalDMIS form: in scan mode two PTMEAS are the start and end of a scan (MEAS's count
  // is the number of PTMEAS); here 0 -> 180 degrees, then 90 -> 270, around a 20 mm bore.
  const Vec3 c(-20.5, 35.5, 107.5);
  auto r =
      run("SCNMOD/ON\nSCNSET/DRAG, .1\n"
          "F(CIR_11) = FEAT/CIRCLE, INNER, CART, -20.5, 35.5, 107.5, 0.0, 0.0, 1.0, 20\n"
          "MEAS/CIRCLE, F(CIR_11), 4\n"
          "PTMEAS/CART, -10.5, 35.5, 107.5, -1, 0, 0\nPTMEAS/CART, -30.5, 35.5, 107.5, 1, 0, 0\n"
          "GOTO/-20.5, 35.5, 107.5\n"
          "PTMEAS/CART, -20.5, 45.5, 107.5, 0, -1, 0\nPTMEAS/CART, -20.5, 25.5, 107.5, 0, 1, 0\nENDMES\n",
          lobed_bore(c, Vec3(0.01, 0.005, 0), 0.002, 2.0));
  ASSERT_EQ(r->status, ExecStatus::Finished) << r->diagnostics;
  ASSERT_EQ(r->machine->scans.size(), 2u);
  const auto angle = [&](const Vec3& p) { return std::atan2(p.y() - c.y(), p.x() - c.x()) * 180 / std::numbers::pi; };
  const auto& first = r->machine->scans[0].path;
  const auto& second = r->machine->scans[1].path;
  EXPECT_NEAR(angle(first.segments.front().start()), 0, 1e-9);
  EXPECT_NEAR(std::abs(angle(first.segments.back().end())), 180, 1e-9);
  EXPECT_GT(angle(first.segments.front().point(1.0)), 0);  // counterclockwise
  EXPECT_NEAR(angle(second.segments.front().start()), 90, 1e-9);
  EXPECT_NEAR(angle(second.segments.back().end()), -90, 1e-9);
  EXPECT_EQ(r->machine->scans[0].sample_spacing_mm, 0.1);
  const auto& f = r->runtime->features().at("CIR_11");
  ASSERT_TRUE(f.actual && f.fit);
  // Independent expectation: the truth sampled like the two scans (90..180 degrees twice), fitted.
  std::vector<Vec2> truth;
  for (double from : {0.0, 90.0})
    for (int i = 0; i <= 5000; ++i) {
      const double t = (from + 180.0 * i / 5000) * std::numbers::pi / 180;
      const Vec2 u(std::cos(t), std::sin(t));
      truth.push_back((10 + 0.002 * std::cos(3 * t) + 0.01 * u.x() + 0.005 * u.y()) * u);
    }
  const Kasa want = kasa(truth);
  EXPECT_NEAR(f.actual->diameter_mm, 2 * want.radius_mm, 1e-4);
  EXPECT_NEAR(f.actual->position.x(), c.x() + want.centre.x(), 1e-4);
  EXPECT_NEAR(f.actual->position.y(), c.y() + want.centre.y(), 1e-4);
  EXPECT_NEAR(f.fit->form_mm, want.form_mm, 1e-4);
  // An odd PTMEAS in scan mode has no end: a positioned error.
  auto odd =
      run("SCNMOD/ON\nF(B) = FEAT/CIRCLE, INNER, CART, 0, 0, 0, 0, 0, 1, 20\nMEAS/CIRCLE, F(B), 3\n"
          "PTMEAS/CART, 10, 0, 0\nPTMEAS/CART, -10, 0, 0\nPTMEAS/CART, 0, 10, 0\nENDMES\n",
          [](const Vec3& q) { return q; });
  EXPECT_EQ(odd->status, ExecStatus::Error);
  EXPECT_NE(odd->diagnostics.find("scan.dmi:10:1: error: in scan mode (SCNMOD/ON) PTMEAS come in pairs"),
            std::string::npos)
      << odd->diagnostics;
}

TEST(Scanning, CompileErrorsAndWarningsArePositioned) {
  const auto identity = [](const Vec3& q) { return q; };
  const auto diag = [&](const std::string& body) { return run(body, identity)->diagnostics; };
  // Lines 1-4 are the prologue of run(): the statement under test is on line 5.
  EXPECT_NE(diag("PAMEAS/P(X)\n").find("scan.dmi:5:1: error: PAMEAS outside a MEAS block"), std::string::npos);
  EXPECT_NE(diag("SCNMOD/MAYBE\n").find("scan.dmi:5:8: error: expected ON or OFF after SCNMOD/"), std::string::npos);
  EXPECT_NE(diag("SCNSET/CHORD, 0\n").find("scan.dmi:5:15: error: the SCNSET/CHORD value must be positive"),
            std::string::npos);
  EXPECT_NE(diag("P(Q) = PATH/LINE, CART, 1, 2, 3, 1, 2, 3, 0, 0, 1\n")
                .find("scan.dmi:5:34: error: the line's end points are the same"),
            std::string::npos);
  EXPECT_NE(diag("P(Q) = PATH/ARC, CART, 0, 0, 0, 0, 0, 0, 5, 0, 90\n")
                .find("scan.dmi:5:33: error: the path vector i,j,k is zero"),
            std::string::npos);
  EXPECT_NE(diag("P(Q) = PATH/SECTION, 'nowhere.stl', 0, 0, 0, 0, 0, 1, 0, 0, 0\n")
                .find("scan.dmi:5:22: error: CAD file 'nowhere.stl' not found"),
            std::string::npos);
  // An unsupported PATH type is skipped with a warning; using it is an error naming the skip.
  const auto d = diag(
      "P(C) = PATH/CURVE, PTDATA\nF(B) = FEAT/CIRCLE, INNER, CART, 0, 0, 0, 0, 0, 1, 20\n"
      "MEAS/CIRCLE, F(B), 0\n  PAMEAS/P(C)\nENDMES\n");
  EXPECT_NE(d.find("scan.dmi:5:13: warning: PATH/CURVE is not supported; P(C) is skipped"), std::string::npos) << d;
  EXPECT_NE(d.find("scan.dmi:8:10: error: path P(C) was defined by a skipped statement"), std::string::npos) << d;
}

TEST(Scanning, RunTimeErrorsArePositioned) {
  // A bore smaller than the ball: the offset path folds over.
  auto r = run("F(S1) = FEAT/CIRCLE, INNER, CART, 0, 0, 0, 0, 0, 1, 3\nSCNMOD/ON\nMEAS/CIRCLE, F(S1), 0\nENDMES\n",
               [](const Vec3& q) { return q; });
  EXPECT_EQ(r->status, ExecStatus::Error);
  EXPECT_NE(r->diagnostics.find("scan.dmi:7:1: error: cannot make a scan path: the offset path folds over"),
            std::string::npos)
      << r->diagnostics;
  // A sphere is scanned along a path, not by its nominal.
  auto s = run("F(S2) = FEAT/SPHERE, OUTER, CART, 0, 0, 0, 20\nSCNMOD/ON\nMEAS/SPHERE, F(S2), 0\nENDMES\n",
               [](const Vec3& q) { return q; });
  EXPECT_EQ(s->status, ExecStatus::Error);
  EXPECT_NE(s->diagnostics.find("scan a SPHERE along a PATH with PAMEAS"), std::string::npos) << s->diagnostics;
}

}  // namespace
