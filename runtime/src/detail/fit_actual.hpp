// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>
#include <utility>
#include <vector>

#include <tl/expected.hpp>

#include "metron/runtime/feature.hpp"

namespace metron::runtime {

/// Fits the actual of a feature of the nominal's type from its ball centres, compensating the
/// probe radius; oriented like the nominal.
tl::expected<std::pair<Geometry, FitFigures>, std::string> fit_actual(const Geometry& nominal,
                                                                      const std::vector<MeasuredPoint>& points);

}  // namespace metron::runtime
