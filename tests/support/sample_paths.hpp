// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstddef>

#include "metron/stdlib/geometry/pcc.hpp"

// Long synthetic scan paths for the segmented-scanning tests and benchmark.
namespace metron::test_support {

/// A free-form contour: `segments` Hermite segments of about `segment_mm` on a spiral around a
/// lobed surface of revolution, r(theta) = 40 (1 + 0.3 sin 3 theta + 0.12 sin(7 theta + 1)) mm
/// rising 1.5 mm per turn; its curvature varies smoothly between about 1/150 and 1/7 mm^-1.
geometry::PccPath freeform_contour(std::size_t segments, double segment_mm = 1.0);

/// A meander with many tight curvature changes: y = A(x) sin(phi(x)) in the XY plane with a
/// wavelength swept between 4 and 30 mm and an amplitude between 1 and 6 mm (radii down to
/// about 1 mm, curvature changing sign every half wave).
geometry::PccPath tight_meander(std::size_t segments, double segment_mm = 0.5);

}  // namespace metron::test_support
