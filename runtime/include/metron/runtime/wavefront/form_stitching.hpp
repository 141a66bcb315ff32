// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>
#include <vector>

#include <tl/expected.hpp>

#include "metron/machine/wavefront/gauge_map.hpp"
#include "metron/machine/wavefront/wavefront_design.hpp"
#include "metron/runtime/wavefront/gauge_reading.hpp"

namespace metron::runtime::wavefront {

/// One map of a rotation series (the B or C nulls): the map, and the rotation that takes a
/// direction in the gauge frame to the part's frame at that map (from the commanded B, C and A
/// and the gauge's clocking: design data and earlier steps, never the hidden truth).
struct SubApertureMap {
  machine::wavefront::GaugeMap map;
  Mat3 gauge_to_part = Mat3::Identity();
};

/// Result of the joint fit: per map, the reading of the part's placement with the part's own form
/// removed; the form itself in the part's coordinates.
struct FormStitch {
  std::vector<GaugeReading>
      readings;  ///< per map: tilt and focus of the placement alone (same conventions as read_gauge_map)
  /// The part's form as surface height (nm) in the part's frame, x and y over its clear radius, as
  /// coefficients of x^2 - y^2, 2xy, x^3 - 3xy^2, 3x^2y - y^3, x r^2, y r^2, r^4 (Noll's Z5..Z11
  /// less their piston, tilt and power, which cannot be told from placement, eccentricity and radius).
  std::vector<double> form_height_nm;
  std::vector<double> form_sigma_nm;  ///< standard error of each term in the fit with all seven
  std::vector<bool> form_used;        ///< the terms kept (|c| >= 3 sigma); the others are zero
  double residual_rms_nm = 0;         ///< rms of all maps minus the joint fit (the noise when the model holds)
};

/// Sub-aperture stitching of a rotation series on a sphere (docs/wavefront.md, "The part's form in
/// the rotation nulls"): every map is modelled as its own piston, tilt and focus (Noll Z1..Z4 on
/// the map's data disc, the normalisation of read_gauge_map) plus -2 h(part x, y), h one form
/// (the seven terms of `form_height_nm`) over the part's clear disc common to all maps. A pupil point's ray meets the
/// part at F - R d (sphere centred on the focus at null), which `gauge_to_part` carries into the part's frame. Least
/// squares over all pixels at once.
tl::expected<FormStitch, std::string> stitch_common_form(const std::vector<SubApertureMap>& maps,
                                                         const machine::wavefront::GaugeSpec& gauge, double radius_mm,
                                                         double clear_radius_mm);

}  // namespace metron::runtime::wavefront
