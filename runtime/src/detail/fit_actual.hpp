// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>
#include <utility>
#include <vector>

#include <tl/expected.hpp>

#include "metron/runtime/feature.hpp"
#include "metron/stdlib/fitting/fit.hpp"

namespace metron::runtime {

/// The fitting shape of a feature type (an ARC fits as a circle; the types fitted on their own,
/// PARPLN, CPARLN, TORUS, ELLIPS, GSURF, GCURVE, have a placeholder).
fitting::Shape fit_shape(FeatureType type);

/// Fits the actual of a feature of the nominal's type from its ball centres, compensating the
/// probe radius; oriented like the nominal.
tl::expected<std::pair<Geometry, FitFigures>, std::string> fit_actual(const Geometry& nominal,
                                                                      const std::vector<MeasuredPoint>& points);

}  // namespace metron::runtime
