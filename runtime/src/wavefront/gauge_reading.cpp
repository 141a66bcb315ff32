// SPDX-License-Identifier: GPL-3.0-or-later
#include <cmath>
#include <numbers>
#include <vector>

#include "metron/runtime/wavefront/gauge_reading.hpp"
#include "metron/stdlib/wavefront/zernike.hpp"

namespace metron::runtime::wavefront {

using machine::wavefront::Element;

double focus_response_nm_per_mm(double sin_max) {
  // Simpson's rule on rho in [0, 1]: c4 = (1/pi) * 2 pi * int_0^1 (-2 w) sqrt3 (2 rho^2 - 1) rho drho.
  const int n = 2000;
  double sum = 0;
  for (int i = 0; i <= n; ++i) {
    const double r = static_cast<double>(i) / n;
    const double f = -2 * std::sqrt(1 - r * r * sin_max * sin_max) * std::sqrt(3.0) * (2 * r * r - 1) * r;
    sum += f * (i == 0 || i == n ? 1 : (i % 2 ? 4 : 2));
  }
  return 2 * sum / (3.0 * n) * 1e6;
}

tl::expected<GaugeReading, const char*> read_gauge_map(const machine::wavefront::GaugeMap& map,
                                                       const machine::wavefront::GaugeSpec& gauge) {
  std::vector<Vec2> xy;
  std::vector<double> v;
  xy.reserve(map.opd_nm.size());
  v.reserve(map.opd_nm.size());
  for (int iy = 0; iy < map.pixels; ++iy)
    for (int ix = 0; ix < map.pixels; ++ix) {
      const double o = map.at(ix, iy);
      if (!std::isfinite(o)) continue;
      xy.emplace_back(map.coordinate(ix), map.coordinate(iy));
      v.push_back(o);
    }
  if (xy.size() < 20) return tl::make_unexpected("too few valid pixels for a fit");
  GaugeReading r;
  r.valid_pixels = static_cast<int>(xy.size());
  const Vec2 c = metron::wavefront::centroid(xy);
  // Equal-area radius of the data disc (normalised units): a pixel is (2/N)^2.
  const double radius = std::sqrt(static_cast<double>(xy.size()) * 4.0 / (map.pixels * map.pixels) / std::numbers::pi);
  for (auto& p : xy) p = (p - c) / radius;
  auto fit = metron::wavefront::fit_zernike(xy, v, 11);
  if (!fit) return tl::unexpected(fit.error());
  r.tilt_x_nm = fit->coefficients[1];
  r.tilt_y_nm = fit->coefficients[2];
  r.focus_nm = fit->coefficients[3];
  r.residual_rms_nm = fit->residual_rms;
  r.tilt_sigma_nm = fit->sigma[1];
  r.centroid = c * map.pupil_scale;
  // Z2 = 2 rho cos t with rho = x / radius: the OPD's slope is 2 c2 / radius per normalised unit,
  // whatever radius was chosen (the fit is exact for a plane).
  const double scale = map.pupil_scale * radius;  // mm (flat) or pupil units (sphere) per rho
  if (map.element == Element::Sphere) {
    // OPD = 2 s u Delta_x: slope 2 s Delta_x per pupil unit.
    r.lateral_mm = Vec2(r.tilt_x_nm, r.tilt_y_nm) / (gauge.sphere_sin_max * scale) * 1e-6;
    // c4 on the data disc: rescale the full-pupil response by radius^2 (rho^2 term ~ (radius rho)^2).
    r.axial_mm = r.focus_nm / (focus_response_nm_per_mm(gauge.sphere_sin_max) * radius * radius);
  } else {
    // OPD = 2 (n_x / n_z) x: slope 2 angle per mm.
    r.angle_rad = Vec2(r.tilt_x_nm, r.tilt_y_nm) / scale * 1e-6;
  }
  return r;
}

}  // namespace metron::runtime::wavefront
