// SPDX-License-Identifier: GPL-3.0-or-later
// Normalisation, principal axes, and the closed-form fits: line and plane.
#include <cmath>

#include <Eigen/SVD>

#include "geometry_fits.hpp"

namespace metron::fitting::detail {

NormalizedPoints normalize(const std::vector<Vec3>& points) {
  NormalizedPoints out;
  if (points.empty()) return out;
  for (const Vec3& p : points) out.centroid += p;
  out.centroid /= static_cast<double>(points.size());
  double sum_sq = 0;
  for (const Vec3& p : points) sum_sq += (p - out.centroid).squaredNorm();
  const double scale = std::sqrt(sum_sq / static_cast<double>(points.size()));
  out.scale = scale > 0 && std::isfinite(scale) ? scale : 1.0;
  out.points.reserve(points.size());
  for (const Vec3& p : points) out.points.push_back((p - out.centroid) / out.scale);
  return out;
}

PrincipalAxes principal_axes(const std::vector<Vec3>& centred) {
  Eigen::MatrixX3d m(static_cast<Eigen::Index>(centred.size()), 3);
  for (std::size_t i = 0; i < centred.size(); ++i) m.row(static_cast<Eigen::Index>(i)) = centred[i].transpose();
  // Total least squares: the right singular vectors of the centred points are the directions
  // of largest to smallest spread (Shakarji 1998, lines and planes).
  const Eigen::JacobiSVD<Eigen::MatrixX3d> svd(m, Eigen::ComputeFullV);
  PrincipalAxes out;
  out.axes = svd.matrixV();
  // Fewer than 3 points give fewer singular values; the missing extents are zero.
  const Eigen::VectorXd sv = svd.singularValues();
  out.rms_extent.head(sv.size()) = sv / std::sqrt(static_cast<double>(centred.size()));
  return out;
}

tl::expected<Geometry, FitFailure> fit_line_geometry(const std::vector<Vec3>& points) {
  const NormalizedPoints np = normalize(points);
  const PrincipalAxes pa = principal_axes(np.points);
  if (!(pa.rms_extent(0) > degenerate_extent)) return tl::unexpected(FitFailure::Degenerate);
  Geometry g;
  g.position = np.centroid;
  g.direction = pa.axes.col(0).normalized();
  return g;
}

tl::expected<Geometry, FitFailure> fit_plane_geometry(const std::vector<Vec3>& points) {
  const NormalizedPoints np = normalize(points);
  const PrincipalAxes pa = principal_axes(np.points);
  if (!(pa.rms_extent(1) > degenerate_extent * pa.rms_extent(0)) || !(pa.rms_extent(0) > 0)) {
    return tl::unexpected(FitFailure::Degenerate);
  }
  Geometry g;
  g.position = np.centroid;
  g.direction = pa.axes.col(2).normalized();
  return g;
}

}  // namespace metron::fitting::detail
