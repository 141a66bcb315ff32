// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>
#include <vector>

#include <Eigen/Core>

#include "metron/stdlib/error_space/error_space.hpp"
#include "metron/stdlib/error_space/interpolation.hpp"

/// An error-space calibration report as one self-contained SVG page (no scripts, no fonts or
/// files fetched: it opens offline in any browser): heat maps of each error component on chosen
/// slices, the plate profile, and the every-second-point validation residuals.
namespace metron::error_space {

/// One heat map: values on a grid (rows = first axis), NaN = no data (drawn grey).
struct HeatMap {
  std::string title;               ///< above the map
  std::string x_label, y_label;    ///< axis names with units
  std::vector<double> x_mm, y_mm;  ///< coordinates of the columns of `values_mm` rows/cols
  Eigen::MatrixXd values_mm;       ///< (x_mm.size()) x (y_mm.size())
};

/// What the report shows.
struct ReportInput {
  std::string title;               ///< page title
  std::vector<std::string> notes;  ///< lines of text under the title (figures, settings)
  std::vector<HeatMap> maps;       ///< drawn in order, three per row
};

/// The slice k of component c of a space as a heat map over x and y (um colour scale).
HeatMap slice_map(const ErrorSpace& space, Component c, std::size_t k, const std::string& title);

/// Validation residuals (prediction minus grid value at the points not in the every-second subgrid)
/// on slice k, as a heat map (NaN at the fitted points); an error when the method does not suit.
tl::expected<HeatMap, std::string> validation_map(const ErrorSpace& space, Component c, std::size_t k,
                                                  const InterpolationSpec& spec, const std::string& title);

/// The page.
std::string report_svg(const ReportInput& input);

}  // namespace metron::error_space
