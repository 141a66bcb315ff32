// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cmath>
#include <string>
#include <vector>

#include "metron/machine/wavefront/wavefront_design.hpp"

namespace metron::machine::wavefront {

/// One gauge measurement: optical path difference (test minus reference, double pass) on a square
/// pixel grid over the pupil; NaN where there is no data (outside the pupil or the part).
struct GaugeMap {
  int pixels = 0;              ///< pixels across the grid (pixels x pixels values, row major, row = y)
  std::vector<double> opd_nm;  ///< optical path difference per pixel, NaN outside the aperture
  Element element = Element::Sphere;
  /// Millimetres (flat: lateral position in the gauge frame) or pupil units (sphere: sine of the
  /// ray angle / sin_max) per unit of normalised pupil coordinate; the grid spans [-1, 1]^2.
  double pupil_scale = 1;
  /// Normalised pupil coordinate of pixel index i along one axis (pixel centres).
  [[nodiscard]] double coordinate(int i) const { return (2.0 * i + 1.0) / pixels - 1.0; }
  [[nodiscard]] double at(int ix, int iy) const { return opd_nm[static_cast<std::size_t>(iy) * pixels + ix]; }
  /// Number of pixels with data.
  [[nodiscard]] int valid_count() const {
    int n = 0;
    for (double v : opd_nm) n += std::isfinite(v) ? 1 : 0;
    return n;
  }
};

/// Why a gauge measurement gave no map (a fault of the instrument, as a real one reports it).
enum class GaugeFault {
  TooManyFringes,  ///< local fringe density beyond the camera's Nyquist limit (0.5 fringe per pixel)
  NoReturn,        ///< no light comes back into the pupil (no part, or the part is far from null)
  NoPart,          ///< nothing mounted on the table
};

/// A failed measurement: the fault and a sentence a person can act on.
struct GaugeError {
  GaugeFault fault = GaugeFault::NoReturn;
  std::string message;
};

}  // namespace metron::machine::wavefront
