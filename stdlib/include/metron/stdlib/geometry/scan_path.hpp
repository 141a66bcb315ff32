// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>
#include <vector>

#include <tl/expected.hpp>

#include "metron/stdlib/geometry/contour.hpp"
#include "metron/stdlib/geometry/pcc.hpp"

// Scan paths from design data (SEEDS.md 1): offset contour points fitted by a chain of PCC
// segments within a chord tolerance, with the curvature at each interpolation point and a
// speed per segment.
namespace metron::geometry {

/// Why no scan path could be made.
struct ScanPathError {
  std::string message;
};

/// How a scan path is built from a contour.
struct ScanPathOptions {
  double ball_radius_mm = 2.0;           ///< r, the stylus ball radius
  double reference_deflection_mm = 0.3;  ///< E0, the reference deflection
  double chord_tolerance_mm = 0.001;     ///< max distance between the PCC chain and the offset contour
  double max_segment_mm = 0;             ///< longest segment chord D (0: no limit)
  double feed_mm_s = 10;                 ///< scan feed: the speed cap on every segment
  double centripetal_accel_mm_s2 = 200;  ///< a: a segment of curvature kappa runs at most sqrt(a/kappa)
  double corner_angle_deg = 20;          ///< a turn sharper than this between samples ends a smooth piece
};

/// A chain of PCC segments and how well it fits.
struct PccFit {
  std::vector<PccSegment> segments;
  std::vector<std::size_t> knots;  ///< contour index of each interpolation point (segments.size() + 1)
  double max_deviation_mm = 0;     ///< largest distance found between the chain and the contour
};

/// Fits an ordered polyline (dense samples of a smooth curve) by cubic Hermite PCC segments
/// through a subset of its points, splitting a segment at its middle sample until every sample
/// lies within `tolerance_mm` of it and the segment between samples stays within `tolerance_mm`
/// of the polyline. `closed`: the last point repeats the first (tangents wrap around).
/// Points closer than 1e-9 mm to their predecessor are dropped first.
PccFit fit_pcc(const std::vector<Vec3>& points, bool closed, double tolerance_mm, double max_segment_mm = 0);

/// A scan path with what it was made from.
struct ScanPathPlan {
  PccPath path;                                  ///< ball-centre path; normals and speeds filled
  std::vector<double> curvature_per_mm;          ///< path curvature at each interpolation point (segments + 1)
  std::vector<double> segment_curvature_per_mm;  ///< the largest curvature on each segment (sets its speed)
  double max_deviation_mm = 0;                   ///< fit deviation from the offset contour
  std::size_t corner_count = 0;                  ///< sharp corners where smooth pieces meet
};

/// SEEDS.md 1: contour -> offset by (r - E0) along the normals -> PCC chain within the chord
/// tolerance -> curvature at the interpolation points -> a speed per segment:
/// v = min(feed, sqrt(a / kappa_max)) with kappa_max the segment's largest curvature.
tl::expected<ScanPathPlan, ScanPathError> make_scan_path(const Contour& contour, const ScanPathOptions& options);

/// Speed for a curvature: min(feed, sqrt(a / kappa)) (centripetal acceleration v^2 kappa <= a).
double curvature_speed_mm_s(double curvature_per_mm, double feed_mm_s, double centripetal_accel_mm_s2);

/// The point of a path at arc length `s_mm` from its start (clamped to the path), and the
/// unit normal interpolated linearly between the interpolation points.
struct PathPoint {
  Vec3 position = Vec3::Zero();
  Vec3 tangent = Vec3::UnitX();
  Vec3 normal = Vec3::UnitZ();
};
PathPoint point_at_length(const PccPath& path, double s_mm);

}  // namespace metron::geometry
