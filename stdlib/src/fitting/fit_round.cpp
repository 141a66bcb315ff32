// SPDX-License-Identifier: GPL-3.0-or-later
// Circle (in a plane) and sphere: algebraic start, then geometric Levenberg-Marquardt.
#include <cmath>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include "geometry_fits.hpp"
#include "levenberg_marquardt.hpp"

namespace metron::fitting::detail {
namespace {

template <int Dim>
using Point = Eigen::Matrix<double, Dim, 1>;

/// Centre and radius of a circle (Dim 2) or sphere (Dim 3).
template <int Dim>
struct RoundState {
  Point<Dim> centre;
  double radius = 0;
};

/// Residual d_i = |p_i - c| - r (Shakarji 1998, circles and spheres).
template <int Dim>
struct RoundModel {
  const std::vector<Point<Dim>>& points;

  void evaluate(const RoundState<Dim>& s, Eigen::VectorXd& r, Eigen::MatrixXd& jac) const {
    const auto n = static_cast<Eigen::Index>(points.size());
    r.resize(n);
    jac.resize(n, Dim + 1);
    for (Eigen::Index i = 0; i < n; ++i) {
      const Point<Dim> diff = points[static_cast<std::size_t>(i)] - s.centre;
      const double dist = diff.norm();
      r(i) = dist - s.radius;
      jac.row(i).template head<Dim>() = dist > 0 ? Point<Dim>(-diff / dist) : Point<Dim>::Zero();
      jac(i, Dim) = -1;
    }
  }
  RoundState<Dim> step(const RoundState<Dim>& s, const Eigen::VectorXd& delta) const {
    return {s.centre + delta.template head<Dim>(), s.radius + delta(Dim)};
  }
};

/// Linear fit of |p|^2 = 2 c.p + (r^2 - |c|^2) (I. Kasa, IEEE Trans. Instrum. Meas. 25, 1976);
/// biased on partial arcs but a good start for the geometric fit.
template <int Dim>
std::optional<RoundState<Dim>> algebraic_round(const std::vector<Point<Dim>>& points) {
  const auto n = static_cast<Eigen::Index>(points.size());
  Eigen::MatrixXd a(n, Dim + 1);
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Point<Dim>& p = points[static_cast<std::size_t>(i)];
    a.row(i).template head<Dim>() = 2 * p.transpose();
    a(i, Dim) = 1;
    b(i) = p.squaredNorm();
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr = a.colPivHouseholderQr();
  if (qr.rank() < Dim + 1) return std::nullopt;
  const Eigen::VectorXd x = qr.solve(b);
  RoundState<Dim> s;
  s.centre = x.template head<Dim>();
  const double r2 = x(Dim) + s.centre.squaredNorm();
  if (!(r2 > 0) || !std::isfinite(r2)) return std::nullopt;
  s.radius = std::sqrt(r2);
  return s;
}

template <int Dim>
tl::expected<std::pair<RoundState<Dim>, int>, FitFailure> fit_round(const std::vector<Point<Dim>>& points) {
  std::optional<RoundState<Dim>> start = algebraic_round(points);
  if (!start) return tl::unexpected(FitFailure::Degenerate);
  RoundState<Dim> s = *start;
  const LmOutcome out = levenberg_marquardt(RoundModel<Dim>{points}, s);
  // A runaway radius means the data is (nearly) straight or flat: no finite circle or sphere.
  if (!out.converged || !std::isfinite(s.radius) || std::abs(s.radius) > 1e8) {
    return tl::unexpected(FitFailure::NoConvergence);
  }
  // The line (plane) through the centred points is the limit of ever larger circles (spheres),
  // so a best fit worse than it means the minimum lies at infinity.
  Eigen::Matrix<double, Dim, Dim> scatter = Eigen::Matrix<double, Dim, Dim>::Zero();
  for (const Point<Dim>& p : points) scatter += p * p.transpose();
  const double flat_cost = Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, Dim, Dim>>(scatter).eigenvalues()(0);
  if (out.cost > flat_cost * (1 + 1e-9) + 1e-28 * static_cast<double>(points.size())) {
    return tl::unexpected(FitFailure::NoConvergence);
  }
  s.radius = std::abs(s.radius);
  return std::pair{s, out.iterations};
}

}  // namespace

tl::expected<Geometry, FitFailure> fit_circle_geometry(const std::vector<Vec3>& points,
                                                       const std::optional<Vec3>& plane_normal) {
  const NormalizedPoints np = normalize(points);
  const PrincipalAxes pa = principal_axes(np.points);
  if (!(pa.rms_extent(1) > degenerate_extent * pa.rms_extent(0)) || !(pa.rms_extent(0) > 0)) {
    return tl::unexpected(FitFailure::Degenerate);
  }
  Vec3 normal = pa.axes.col(2).normalized();
  if (plane_normal && plane_normal->norm() > 0) normal = plane_normal->normalized();
  const Vec3 u = any_perpendicular(normal);
  const Vec3 v = normal.cross(u);
  std::vector<Vec2> flat;
  flat.reserve(np.points.size());
  for (const Vec3& q : np.points) flat.emplace_back(q.dot(u), q.dot(v));
  auto round = fit_round<2>(flat);
  if (!round) return tl::unexpected(round.error());
  const auto& [s, iterations] = *round;
  Geometry g;
  g.position = np.to_world(s.centre.x() * u + s.centre.y() * v);
  g.direction = normal;
  g.radius_mm = s.radius * np.scale;
  g.iterations = iterations;
  return g;
}

tl::expected<Geometry, FitFailure> fit_sphere_geometry(const std::vector<Vec3>& points) {
  const NormalizedPoints np = normalize(points);
  const PrincipalAxes pa = principal_axes(np.points);
  if (!(pa.rms_extent(2) > degenerate_extent * pa.rms_extent(0))) {
    return tl::unexpected(FitFailure::Degenerate);
  }
  auto round = fit_round<3>(np.points);
  if (!round) return tl::unexpected(round.error());
  const auto& [s, iterations] = *round;
  Geometry g;
  g.position = np.to_world(s.centre);
  g.radius_mm = s.radius * np.scale;
  g.iterations = iterations;
  return g;
}

}  // namespace metron::fitting::detail
