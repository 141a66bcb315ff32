// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <span>
#include <vector>

#include <tl/expected.hpp>

#include "metron/stdlib/geometry/vec.hpp"

/// Fits on gauge maps (docs/wavefront.md, "Fits").
namespace metron::wavefront {

/// Noll's Zernike polynomial Z_j (j = 1..11) on the unit disc, normalised to unit rms over the
/// disc (R. J. Noll, "Zernike polynomials and atmospheric turbulence", JOSA 66(3), 1976; the same
/// normalisation as ISO 14999-2/-4's "standard" Zernikes): Z1 = 1, Z2 = 2 rho cos t (x tilt),
/// Z3 = 2 rho sin t (y tilt), Z4 = sqrt3 (2 rho^2 - 1) (focus), ... Z11 = sqrt5 (6 rho^4 - 6 rho^2 + 1).
double zernike_noll(int j, double x, double y);

/// Coefficients of a least-squares Zernike fit (index 0 is Z1) and what the data said about them.
struct ZernikeFit {
  std::vector<double> coefficients;  ///< c_j for j = 1..terms, in the data's unit
  std::vector<double> sigma;         ///< standard error of each coefficient from the residual
  double residual_rms = 0;           ///< rms of data minus fit
  int samples = 0;                   ///< points used
};

/// Least-squares fit of Z1..Z_terms to values at points of the unit disc (terms 1..11).
/// Returns an error message when the points do not determine the terms.
tl::expected<ZernikeFit, const char*> fit_zernike(std::span<const Vec2> xy, std::span<const double> values, int terms);

/// Centroid of points (the aperture's centre of mass when the points are pixel centres).
Vec2 centroid(std::span<const Vec2> xy);

}  // namespace metron::wavefront
