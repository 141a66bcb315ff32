// SPDX-License-Identifier: GPL-3.0-or-later
// Sub-aperture stitching of the rotation nulls' maps: the part's form, common to all maps in the
// part's frame, separated from each map's placement (docs/wavefront.md, "The part's form in the
// rotation nulls").
#include <cmath>
#include <numbers>

#include <fmt/format.h>
#include <Eigen/Dense>

#include "metron/runtime/wavefront/form_stitching.hpp"
#include "metron/stdlib/wavefront/zernike.hpp"

namespace metron::runtime::wavefront {
namespace {

constexpr int kPlacement = 4;  // Z1..Z4 per map
constexpr int kForm = 7;       // the form terms of form_term()
constexpr int kRow = kPlacement + kForm;

// The form's basis on the part (x, y over the clear radius): the homogeneous polynomials of degree
// 2 to 4 of Noll's Z5..Z11 without their piston, tilt and power parts, which no map can tell
// from the placement (1, x, y), the eccentricity and the radius (r^2) (docs/wavefront.md).
double form_term(int j, double x, double y) {
  const double r2 = x * x + y * y;
  switch (j) {
    case 0: return x * x - y * y;              // astigmatism 0/90 (Z6 = sqrt6 this)
    case 1: return 2 * x * y;                  // astigmatism 45 (Z5)
    case 2: return x * x * x - 3 * x * y * y;  // trefoil (Z10 = sqrt8 this)
    case 3: return 3 * x * x * y - y * y * y;  // trefoil (Z9)
    case 4: return x * r2;                     // coma's cubic part (Z8 = sqrt8 (3 this - 2 x))
    case 5: return y * r2;                     // (Z7)
    default: return r2 * r2;                   // spherical's quartic part (Z11 = sqrt5 (6 this - 6 r^2 + 1))
  }
}

// The data disc of one map as read_gauge_map normalises it: centroid and equal-area radius.
struct Disc {
  Vec2 centre{0, 0};
  double radius = 1;
};

Disc data_disc(const machine::wavefront::GaugeMap& map) {
  Vec2 sum{0, 0};
  int n = 0;
  for (int iy = 0; iy < map.pixels; ++iy)
    for (int ix = 0; ix < map.pixels; ++ix)
      if (std::isfinite(map.at(ix, iy))) sum += Vec2(map.coordinate(ix), map.coordinate(iy)), ++n;
  Disc d;
  if (n == 0) return d;
  d.centre = sum / n;
  d.radius = std::sqrt(static_cast<double>(n) * 4.0 / (map.pixels * map.pixels) / std::numbers::pi);
  return d;
}

// One pixel's row of the design matrix: Z1..Z4 on the map's disc, then Z5..Z11 at the point where
// the pixel's ray meets the part, in the part's frame over its clear disc.
Eigen::Matrix<double, kRow, 1> row(const SubApertureMap& sm, const Disc& disc, double s, double radius_mm,
                                   double clear_mm, double u, double v) {
  Eigen::Matrix<double, kRow, 1> r;
  const Vec2 p = (Vec2(u, v) - disc.centre) / disc.radius;
  for (int j = 0; j < kPlacement; ++j) r[j] = metron::wavefront::zernike_noll(j + 1, p.x(), p.y());
  // The ray through the focus (aplanatic pupil, as the gauge defines it) meets the sphere centred
  // on the focus at F - R d; at null the centre of curvature is on the focus.
  const Vec3 d(u * s, v * s, -std::sqrt(std::max(0.0, 1 - (u * u + v * v) * s * s)));
  const Vec3 hit = -radius_mm * (sm.gauge_to_part * d);
  for (int j = 0; j < kForm; ++j) r[kPlacement + j] = form_term(j, hit.x() / clear_mm, hit.y() / clear_mm);
  return r;
}

}  // namespace

tl::expected<FormStitch, std::string> stitch_common_form(const std::vector<SubApertureMap>& maps,
                                                         const machine::wavefront::GaugeSpec& gauge, double radius_mm,
                                                         double clear_radius_mm) {
  const auto k = static_cast<Eigen::Index>(maps.size());
  if (k < 2) return tl::unexpected(std::string("form stitching needs at least two maps"));
  if (!(clear_radius_mm > 0)) return tl::unexpected(std::string("form stitching needs the part's clear radius"));
  const double s = gauge.sphere_sin_max;
  const Eigen::Index n = kPlacement * k + kForm;
  // Normal equations, accumulated block by block (each pixel touches its map's four placement
  // terms and the common form terms only).
  Eigen::MatrixXd ata = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd atb = Eigen::VectorXd::Zero(n);
  std::vector<Disc> discs;
  long samples = 0;
  for (Eigen::Index i = 0; i < k; ++i) {
    const auto& sm = maps[static_cast<std::size_t>(i)];
    discs.push_back(data_disc(sm.map));
    Eigen::Matrix<double, kRow, kRow> a = Eigen::Matrix<double, kRow, kRow>::Zero();
    Eigen::Matrix<double, kRow, 1> b = Eigen::Matrix<double, kRow, 1>::Zero();
    for (int iy = 0; iy < sm.map.pixels; ++iy)
      for (int ix = 0; ix < sm.map.pixels; ++ix) {
        const double o = sm.map.at(ix, iy);
        if (!std::isfinite(o)) continue;
        const auto r =
            row(sm, discs.back(), s, radius_mm, clear_radius_mm, sm.map.coordinate(ix), sm.map.coordinate(iy));
        a.selfadjointView<Eigen::Lower>().rankUpdate(r);
        b += r * o;
        ++samples;
      }
    a = a.selfadjointView<Eigen::Lower>();
    const Eigen::Index p0 = kPlacement * i, f0 = kPlacement * k;
    ata.block(p0, p0, kPlacement, kPlacement) += a.topLeftCorner<kPlacement, kPlacement>();
    ata.block(p0, f0, kPlacement, kForm) += a.topRightCorner<kPlacement, kForm>();
    ata.block(f0, p0, kForm, kPlacement) += a.bottomLeftCorner<kForm, kPlacement>();
    ata.block(f0, f0, kForm, kForm) += a.bottomRightCorner<kForm, kForm>();
    atb.segment(p0, kPlacement) += b.head<kPlacement>();
    atb.segment(f0, kForm) += b.tail<kForm>();
  }
  if (samples <= n) return tl::unexpected(std::string("form stitching: too few pixels"));
  // Residual sum of squares of a solution over all pixels.
  const auto residual_ss = [&](const Eigen::VectorXd& x) {
    double ss = 0;
    for (Eigen::Index i = 0; i < k; ++i) {
      const auto& sm = maps[static_cast<std::size_t>(i)];
      Eigen::Matrix<double, kRow, 1> c;
      c << x.segment(kPlacement * i, kPlacement), x.tail<kForm>();
      for (int iy = 0; iy < sm.map.pixels; ++iy)
        for (int ix = 0; ix < sm.map.pixels; ++ix) {
          const double o = sm.map.at(ix, iy);
          if (!std::isfinite(o)) continue;
          const double f = c.dot(row(sm, discs[static_cast<std::size_t>(i)], s, radius_mm, clear_radius_mm,
                                     sm.map.coordinate(ix), sm.map.coordinate(iy)));
          ss += (o - f) * (o - f);
        }
    }
    return ss;
  };
  // Least squares on the placement terms and the form terms in `used` (the others held at zero).
  const auto solve = [&](const std::vector<bool>& used) -> tl::expected<Eigen::VectorXd, std::string> {
    std::vector<Eigen::Index> idx;
    for (Eigen::Index j = 0; j < n; ++j)
      if (j < kPlacement * k || used[static_cast<std::size_t>(j - kPlacement * k)]) idx.push_back(j);
    const Eigen::MatrixXd a = ata(idx, idx);
    const Eigen::VectorXd b = atb(idx);
    Eigen::LDLT<Eigen::MatrixXd> ldlt(a);
    if (ldlt.info() != Eigen::Success || ldlt.rcond() < 1e-13)
      return tl::unexpected(
          std::string("form stitching: the maps do not separate the form from the placement "
                      "(the sub-apertures must move across the part)"));
    const Eigen::VectorXd y = ldlt.solve(b);
    Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
    for (std::size_t j = 0; j < idx.size(); ++j) x[idx[j]] = y[static_cast<Eigen::Index>(j)];
    return x;
  };
  // Every form term first; then only those the data show (|c| >= 3 standard errors): a term the
  // noise cannot resolve would add its noise to every null's tilt through its leak and remove no
  // bias worth the name (docs/wavefront.md).
  std::vector<bool> used(kForm, true);
  auto full = solve(used);
  if (!full) return tl::unexpected(full.error());
  const double var = residual_ss(*full) / static_cast<double>(samples - n);
  const Eigen::MatrixXd cov = ata.ldlt().solve(Eigen::MatrixXd::Identity(n, n)) * var;
  FormStitch out;
  for (int j = 0; j < kForm; ++j) {
    const Eigen::Index q = kPlacement * k + j;
    out.form_sigma_nm.push_back(std::sqrt(cov(q, q)) / 2);
    used[static_cast<std::size_t>(j)] = std::abs((*full)[q]) >= 3 * std::sqrt(cov(q, q));
  }
  auto x = solve(used);
  if (!x) return tl::unexpected(x.error());
  out.form_used = used;
  for (Eigen::Index i = 0; i < k; ++i) {
    const auto& sm = maps[static_cast<std::size_t>(i)];
    const Disc& disc = discs[static_cast<std::size_t>(i)];
    Eigen::Matrix<double, kRow, 1> c;
    c << x->segment(kPlacement * i, kPlacement), x->tail<kForm>();
    // The same conversions as read_gauge_map (gauge_reading.cpp): exact lateral, first-order axial.
    GaugeReading g;
    g.tilt_x_nm = c[1];
    g.tilt_y_nm = c[2];
    g.focus_nm = c[3];
    g.centroid = disc.centre * sm.map.pupil_scale;
    g.valid_pixels = sm.map.valid_count();
    const double scale = sm.map.pupil_scale * disc.radius;
    g.lateral_mm = Vec2(g.tilt_x_nm, g.tilt_y_nm) / (s * scale) * 1e-6;
    g.axial_mm = g.focus_nm / (focus_response_nm_per_mm(s) * disc.radius * disc.radius);
    out.readings.push_back(g);
  }
  out.residual_rms_nm = std::sqrt(residual_ss(*x) / static_cast<double>(samples));
  for (int j = 0; j < kForm; ++j) out.form_height_nm.push_back(-(*x)[kPlacement * k + j] / 2);  // OPD = -2 h
  for (auto& g : out.readings) g.residual_rms_nm = out.residual_rms_nm;
  return out;
}

}  // namespace metron::runtime::wavefront
