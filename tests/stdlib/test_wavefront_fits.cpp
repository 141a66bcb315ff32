// SPDX-License-Identifier: GPL-3.0-or-later
// Fits on gauge maps (stdlib/wavefront) against analytic answers.
#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "metron/stdlib/wavefront/circle_fit.hpp"
#include "metron/stdlib/wavefront/zernike.hpp"

using metron::Vec2;
namespace wf = metron::wavefront;

namespace {

std::vector<Vec2> disc_grid(int n) {
  std::vector<Vec2> p;
  for (int iy = 0; iy < n; ++iy)
    for (int ix = 0; ix < n; ++ix) {
      const double x = (2.0 * ix + 1) / n - 1, y = (2.0 * iy + 1) / n - 1;
      if (x * x + y * y <= 1) p.emplace_back(x, y);
    }
  return p;
}

}  // namespace

// Noll's normalisation: unit rms over the disc and orthogonal terms (Noll 1976, eq. 4).
TEST(WavefrontZernike, NollTermsAreOrthonormalOnTheDisc) {
  const auto p = disc_grid(400);
  for (int j = 1; j <= 11; ++j)
    for (int k = j; k <= 11; ++k) {
      double s = 0;
      for (const auto& q : p) s += wf::zernike_noll(j, q.x(), q.y()) * wf::zernike_noll(k, q.x(), q.y());
      s /= static_cast<double>(p.size());
      EXPECT_NEAR(s, j == k ? 1.0 : 0.0, 0.01) << "Z" << j << " . Z" << k;
    }
  // The stated convention: Z2 = 2 x, Z3 = 2 y, Z4 = sqrt3 (2 rho^2 - 1).
  EXPECT_DOUBLE_EQ(wf::zernike_noll(2, 0.3, 0.4), 0.6);
  EXPECT_DOUBLE_EQ(wf::zernike_noll(3, 0.3, 0.4), 0.8);
  EXPECT_NEAR(wf::zernike_noll(4, 0.3, 0.4), std::sqrt(3.0) * (2 * 0.25 - 1), 1e-15);
}

TEST(WavefrontZernike, FitRecoversKnownCoefficientsAndTheirNoise) {
  const auto p = disc_grid(128);
  const std::vector<double> c{5, -3, 2, 7, 0.5, -1, 0.2, 0.3, -0.4, 0.6, 1.5};
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0, 2.0);
  std::vector<double> v, vn;
  for (const auto& q : p) {
    double s = 0;
    for (int j = 0; j < 11; ++j) s += c[j] * wf::zernike_noll(j + 1, q.x(), q.y());
    v.push_back(s);
    vn.push_back(s + noise(rng));
  }
  auto f = wf::fit_zernike(p, v, 11);
  ASSERT_TRUE(f);
  for (int j = 0; j < 11; ++j) EXPECT_NEAR(f->coefficients[j], c[j], 1e-9);
  auto fn = wf::fit_zernike(p, vn, 11);
  ASSERT_TRUE(fn);
  // sigma of a unit-rms term from M samples with noise sigma: sigma / sqrt(M).
  EXPECT_NEAR(fn->sigma[1], 2.0 / std::sqrt(static_cast<double>(p.size())),
              0.1 * 2.0 / std::sqrt(static_cast<double>(p.size())));
  EXPECT_NEAR(fn->residual_rms, 2.0, 0.05);
  EXPECT_FALSE(wf::fit_zernike(std::vector<Vec2>(3, Vec2(0, 0)), std::vector<double>(3, 0.0), 4));
}

TEST(WavefrontCircle, AlgebraicAndGeometricFitsOnAFullCircle) {
  std::vector<Vec2> p;
  for (int k = 0; k < 7; ++k) {
    const double a = 2 * std::numbers::pi * k / 7;
    p.emplace_back(1.5 + 2 * std::cos(a), -0.5 + 2 * std::sin(a));
  }
  for (auto fit : {wf::fit_circle_kasa, wf::fit_circle_pratt, wf::fit_circle_geometric}) {
    auto c = fit(p);
    ASSERT_TRUE(c);
    EXPECT_NEAR(c->centre.x(), 1.5, 1e-9);
    EXPECT_NEAR(c->centre.y(), -0.5, 1e-9);
    EXPECT_NEAR(c->radius, 2, 1e-9);
  }
  EXPECT_FALSE(wf::fit_circle_pratt(std::vector<Vec2>{{0, 0}, {1, 1}, {2, 2}}));
}

// On a short noisy arc Kasa's fit is biased toward a small radius (Chernov 2010, ch. 7); Pratt and
// the geometric fit are not (to first order).
TEST(WavefrontCircle, KasaIsBiasedOnAShortArcPrattAndGeometricAreNot) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0, 0.01);
  double kasa = 0, pratt = 0, geo = 0;
  const int trials = 400;
  for (int t = 0; t < trials; ++t) {
    std::vector<Vec2> p;
    for (int k = 0; k < 20; ++k) {
      const double a = -0.3 + 0.6 * k / 19;
      p.emplace_back(std::cos(a) + noise(rng), std::sin(a) + noise(rng));
    }
    kasa += wf::fit_circle_kasa(p)->radius - 1;
    pratt += wf::fit_circle_pratt(p)->radius - 1;
    geo += wf::fit_circle_geometric(p)->radius - 1;
  }
  kasa /= trials, pratt /= trials, geo /= trials;
  EXPECT_LT(kasa, -0.02);
  EXPECT_LT(std::abs(pratt), std::abs(kasa) / 3);
  EXPECT_LT(std::abs(geo), std::abs(kasa) / 3);
}

TEST(WavefrontCircle, PhasedCircleFromTwoAndSixAngles) {
  const Vec2 c(0.3, -0.2), r(0.05, 0.02);
  for (int sense : {1, -1}) {
    std::vector<Vec2> p;
    std::vector<double> a;
    for (double deg : {0.0, 60.0, 120.0, 180.0, 240.0, 300.0}) {
      const double t = sense * deg * std::numbers::pi / 180;
      a.push_back(deg * std::numbers::pi / 180);
      p.push_back(c + Eigen::Rotation2Dd(t) * r);
    }
    auto f = wf::fit_circle_phased(p, a);
    ASSERT_TRUE(f);
    EXPECT_EQ(f->sense, sense);
    EXPECT_NEAR((f->centre - c).norm(), 0, 1e-12);
    EXPECT_NEAR((f->radius_vector - r).norm(), 0, 1e-12);
  }
  // Two angles 180 degrees apart: the centre is the midpoint.
  std::vector<Vec2> two{c + r, c - r};
  std::vector<double> a2{0, std::numbers::pi};
  auto f2 = wf::fit_circle_phased(two, a2, 1);
  ASSERT_TRUE(f2);
  EXPECT_NEAR((f2->centre - c).norm(), 0, 1e-12);
  EXPECT_FALSE(wf::fit_circle_phased(std::vector<Vec2>{c, c}, std::vector<double>{0, 0}, 1));
}

TEST(WavefrontLine, LineFitSlopeAndItsError) {
  std::vector<double> x{0, 10, 20, 55}, y;
  for (double v : x) y.push_back(0.002 - 1.5e-4 * v);
  auto l = wf::fit_line(x, y);
  ASSERT_TRUE(l);
  EXPECT_NEAR(l->slope, -1.5e-4, 1e-15);
  EXPECT_NEAR(l->intercept, 0.002, 1e-15);
  EXPECT_FALSE(wf::fit_line(std::vector<double>{1, 1}, std::vector<double>{0, 1}));
}
