// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <tl/expected.hpp>

#include "metron/machine/wavefront/gauge_map.hpp"

namespace metron::runtime::wavefront {

/// What one gauge map says about the part's placement, from a Zernike fit (Noll Z1..Z11 on the
/// disc of the valid data: its centroid and equal-area radius; docs/wavefront.md "Fits").
struct GaugeReading {
  double tilt_x_nm = 0, tilt_y_nm = 0;  ///< Noll c2, c3 on the data disc
  double focus_nm = 0;                  ///< Noll c4 on the data disc
  /// Transmission sphere: the centre of curvature from the focus, across the beam (gauge x, y), mm:
  /// OPD = 2 d.Delta to first order, d = (u s, v s, -w), so c2 = s r Delta_x exactly (r: data radius in pupil units).
  Vec2 lateral_mm{0, 0};
  /// Transmission sphere: the centre of curvature from the focus along the gauge axis (+ toward
  /// the gauge), mm, from c4 and the focus response of the pupil (first order).
  double axial_mm = 0;
  /// Transmission flat: the surface normal's tilt to the gauge axis (x/z, y/z), radians.
  Vec2 angle_rad{0, 0};
  /// Centroid of the valid data in gauge coordinates (flat: mm; sphere: pupil units).
  Vec2 centroid{0, 0};
  int valid_pixels = 0;
  double residual_rms_nm = 0;  ///< rms of the map minus the 11-term fit
  double tilt_sigma_nm = 0;    ///< standard error of c2 from the fit's residual
};

/// Reads a map: the fit and its conversion to placement (sin_max of the transmission sphere from
/// the gauge's specification).
tl::expected<GaugeReading, const char*> read_gauge_map(const machine::wavefront::GaugeMap& map,
                                                       const machine::wavefront::GaugeSpec& gauge);

/// Focus coefficient c4 (nm) per mm of axial displacement of the centre of curvature, for a
/// spherical wave with the given sin_max, over the full pupil: c4 = <-2 w, Z4> / pi, w = sqrt(1 -
/// rho^2 s^2) (first order of the exact ray-sphere distance).
double focus_response_nm_per_mm(double sin_max);

}  // namespace metron::runtime::wavefront
