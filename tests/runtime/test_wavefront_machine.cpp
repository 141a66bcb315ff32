// SPDX-License-Identifier: GPL-3.0-or-later
// The wavefront machine and its gauge against the geometry written out independently here.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "metron/machine/wavefront/simulated_wavefront_machine.hpp"
#include "metron/runtime/wavefront/gauge_reading.hpp"

namespace mw = metron::machine::wavefront;
using metron::Vec2;
using metron::Vec3;

namespace {

// A perfect machine: focus at the origin of the table chain's reach, one convex ball centred on
// the A axis, the gauge aligned, no noise.
mw::WavefrontWorld perfect_world() {
  mw::WavefrontWorld w;
  w.gauge.noise_nm = 0;
  w.gauge.pixels = 128;
  w.hidden = mw::HiddenGeometry{};
  mw::PartSpec ball;
  ball.name = "ball";
  ball.radius_mm = 12.7;
  ball.thickness_mm = 25.4;
  ball.clear_radius_mm = 12;
  w.parts.push_back(ball);
  w.mounted = "ball";
  // The ball's centre sits at zc + table + (25.4 - 12.7) = 82.7 at zero steps; the focus at 180.
  w.start.steps = Vec3(0, 0, (180 - 82.7) / 1e-4);
  return w;
}

// The double-pass path change for a ray through the focus along d when the centre of curvature
// of a convex sphere of radius R sits at delta from the focus (exact ray-sphere distance).
double exact_opd_nm(const Vec3& d, const Vec3& delta, double r) {
  const double b = d.dot(delta);
  return 2 * (b + r - std::sqrt(r * r - delta.squaredNorm() + b * b)) * 1e6;
}

}  // namespace

TEST(WavefrontWorld, LoadsTheShippedWorldsAndRejectsUnknownKeys) {
  for (const char* name : {"wavefront_sphere_machine.json", "wavefront_coarse.json", "wavefront_concave.json"}) {
    auto w = mw::load_wavefront_world(std::string(METRON_SOURCE_DIR) + "/programs/worlds/" + name);
    ASSERT_TRUE(w) << w.error();
    EXPECT_FALSE(w->parts.empty());
  }
  auto bad =
      mw::parse_wavefront_world(nlohmann::json::parse(R"({"kind": "wavefront", "hidden": {"xb_mn": 1}})"), "w.json");
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error(), "w.json: /hidden/xb_mn: unknown key 'xb_mn'");
  auto kind = mw::parse_wavefront_world(nlohmann::json::parse(R"({"kind": "cmm"})"), "w.json");
  ASSERT_FALSE(kind);
  EXPECT_NE(kind.error().find("/kind: expected \"wavefront\""), std::string::npos);
  auto part = mw::parse_wavefront_world(
      nlohmann::json::parse(R"({"kind": "wavefront", "parts": [{"name": "a", "kind": "torus"}]})"), "w.json");
  ASSERT_FALSE(part);
  EXPECT_NE(part.error().find("/parts/0/kind"), std::string::npos);
  auto mounted = mw::parse_wavefront_world(nlohmann::json::parse(R"({"kind": "wavefront", "mounted": "x"})"), "w.json");
  ASSERT_FALSE(mounted);
  EXPECT_NE(mounted.error().find("/mounted"), std::string::npos);
}

TEST(WavefrontGauge, ConfocalBallReadsZeroAndADisplacedOneReadsTheExactPath) {
  mw::SimulatedWavefrontMachine m(perfect_world(), 1);
  auto map = m.ideal_map();
  ASSERT_TRUE(map) << map.error().message;
  double worst = 0;
  for (double v : map->opd_nm)
    if (std::isfinite(v)) worst = std::max(worst, std::abs(v));
  EXPECT_LT(worst, 1e-6);
  // Move the ball by steps: the centre goes (dx, dy, dz) from the focus.
  const Vec3 delta(0.004, -0.003, 0.02);
  mw::AxisCommand c = m.position();
  c.steps += Vec3(delta.x() / 1e-4, delta.y() / 1e-4, delta.z() / 1e-4);
  m.move(c);
  map = m.ideal_map();
  ASSERT_TRUE(map) << map.error().message;
  const double s = 0.25;
  for (int iy = 0; iy < map->pixels; iy += 9)
    for (int ix = 0; ix < map->pixels; ix += 7) {
      const double u = map->coordinate(ix), v = map->coordinate(iy);
      if (u * u + v * v > 1) continue;
      const Vec3 d = Vec3(u * s, v * s, -std::sqrt(1 - (u * u + v * v) * s * s));
      EXPECT_NEAR(map->at(ix, iy), exact_opd_nm(d, delta, 12.7), 1e-5) << ix << "," << iy;
    }
  // Off axial null the exact path has a cross term Delta_lat Delta_z / R that looks like tilt
  // (second order): the lateral reading is off by about that much, and the axial one is first order.
  auto r = metron::runtime::wavefront::read_gauge_map(*map, m.gauge());
  ASSERT_TRUE(r);
  const double cross = 0.005 * delta.z() / 12.7;
  EXPECT_NEAR(r->lateral_mm.x(), delta.x(), 1.5 * cross);
  EXPECT_GT(std::abs(r->lateral_mm.x() - delta.x()), 0.5 * 0.004 * delta.z() / 12.7);
  EXPECT_NEAR(r->axial_mm, delta.z(), 0.01 * delta.z());
  // At the axial null the tilt is exact to third order: c2 = s Delta_x.
  c.steps.z() -= delta.z() / 1e-4;
  m.move(c);
  map = m.ideal_map();
  ASSERT_TRUE(map);
  r = metron::runtime::wavefront::read_gauge_map(*map, m.gauge());
  ASSERT_TRUE(r);
  EXPECT_NEAR(r->lateral_mm.x(), delta.x(), 1e-9);
  EXPECT_NEAR(r->lateral_mm.y(), delta.y(), 1e-9);
}

// The Nyquist rule: a lateral displacement Delta gives an OPD slope of 2 s Delta per pupil unit,
// 4 s Delta / N per pixel; the camera resolves lambda / 2 per pixel: Delta_max = lambda N / (8 s).
TEST(WavefrontGauge, TooManyFringesBeyondNyquistFailsClearly) {
  mw::SimulatedWavefrontMachine m(perfect_world(), 1);
  const double max_mm = 632.8e-6 * 128 / (8 * 0.25);
  const mw::AxisCommand start = m.position();
  for (double f : {0.9, 1.1}) {
    mw::AxisCommand c = start;
    c.steps.x() += f * max_mm / 1e-4;
    m.move(c);
    auto map = m.measure();
    if (f < 1) {
      EXPECT_TRUE(map) << map.error().message;
    } else {
      ASSERT_FALSE(map);
      EXPECT_EQ(map.error().fault, mw::GaugeFault::TooManyFringes);
      EXPECT_NE(map.error().message.find("Nyquist"), std::string::npos);
      EXPECT_NE(map.error().message.find("null the part"), std::string::npos);
    }
  }
  EXPECT_TRUE(m.mount(""));
  auto none = m.measure();
  ASSERT_FALSE(none);
  EXPECT_EQ(none.error().fault, mw::GaugeFault::NoPart);
}

TEST(WavefrontGauge, NoiseIsSeededAndHasTheStatedRms) {
  auto w = perfect_world();
  w.gauge.noise_nm = 3;
  mw::SimulatedWavefrontMachine a(w, 5), b(w, 5), c(w, 6);
  auto ma = a.measure(), mb = b.measure(), mc = c.measure();
  ASSERT_TRUE(ma && mb && mc);
  double ss = 0, diff = 0;
  int n = 0;
  for (std::size_t i = 0; i < ma->opd_nm.size(); ++i) {
    if (!std::isfinite(ma->opd_nm[i])) continue;
    EXPECT_EQ(ma->opd_nm[i], mb->opd_nm[i]);
    ss += ma->opd_nm[i] * ma->opd_nm[i];
    diff += std::abs(ma->opd_nm[i] - mc->opd_nm[i]);
    ++n;
  }
  EXPECT_NEAR(std::sqrt(ss / n), 3, 0.1);
  EXPECT_GT(diff, 0);
}

// A flat under the transmission flat: the map's slope is twice the face's tilt, and the centroid
// of the data is the flat's centre.
TEST(WavefrontGauge, FlatUnderTheTransmissionFlat) {
  auto w = perfect_world();
  mw::PartSpec flat;
  flat.name = "flat";
  flat.kind = mw::PartKind::Flat;
  flat.thickness_mm = 10;
  flat.clear_radius_mm = 10;
  flat.decentre_mm = Vec2(1.0, -0.5);
  flat.wedge_rad = Vec2(1e-4, -5e-5);
  w.parts.push_back(flat);
  w.gauge.element = mw::Element::Flat;
  w.gauge.pixels = 256;
  mw::SimulatedWavefrontMachine m(w, 1);
  m.mount("flat");
  auto map = m.ideal_map();
  ASSERT_TRUE(map) << map.error().message;
  auto r = metron::runtime::wavefront::read_gauge_map(*map, m.gauge());
  ASSERT_TRUE(r);
  EXPECT_NEAR(r->angle_rad.x(), 1e-4, 1e-9);
  EXPECT_NEAR(r->angle_rad.y(), -5e-5, 1e-9);
  EXPECT_NEAR(r->centroid.x(), 1.0, 0.02);
  EXPECT_NEAR(r->centroid.y(), -0.5, 0.02);
  const auto t = m.truth();
  EXPECT_NEAR(t.part_wedge_rad.x(), 1e-4, 1e-12);
  EXPECT_NEAR(t.flat_centre_mm.x(), 1.0, 1e-9);
}
