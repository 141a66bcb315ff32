// SPDX-License-Identifier: GPL-3.0-or-later
// Ellipse (DMIS ELLIPS) in its plane: geometric Levenberg-Marquardt on the exact signed distance.
#include <cmath>
#include <numbers>

#include "levenberg_marquardt.hpp"
#include "metron/stdlib/fitting/ellipse_fit.hpp"
#include "metron/stdlib/geometry/ellipse.hpp"

namespace metron::fitting {
namespace {

/// p in the ellipse's own frame: x along the major axis.
Eigen::Vector2d to_local(const EllipseOutline& e, const Eigen::Vector2d& p) {
  const Eigen::Vector2d d = p - e.centre;
  const double c = std::cos(e.angle_rad), s = std::sin(e.angle_rad);
  return {c * d.x() + s * d.y(), -s * d.x() + c * d.y()};
}

geometry::EllipseFoot foot(const EllipseOutline& e, const Eigen::Vector2d& p) {
  return geometry::ellipse_foot(0.5 * e.major_diameter_mm, 0.5 * e.minor_diameter_mm, to_local(e, p));
}

/// Residual r_i = s(c_i) - offset. With the foot X = c + R(angle) (x, y) and n = R m its outward
/// normal (m in the local frame): ds/dc = -n, ds/dangle = -m . (-y, x), ds/da = -m_x x / a,
/// ds/db = -m_y y / b (a, b the semi-axes; half of that per unit of diameter).
struct EllipseModel {
  const std::vector<Eigen::Vector2d>& centres;
  double offset_mm;

  void evaluate(const EllipseOutline& e, Eigen::VectorXd& r, Eigen::MatrixXd& jac) const {
    const auto n = static_cast<Eigen::Index>(centres.size());
    r.resize(n);
    jac.resize(n, 5);
    const Eigen::Vector2d u(std::cos(e.angle_rad), std::sin(e.angle_rad)), v(-u.y(), u.x());
    const double a = 0.5 * e.major_diameter_mm, b = 0.5 * e.minor_diameter_mm;
    for (Eigen::Index i = 0; i < n; ++i) {
      const geometry::EllipseFoot f = foot(e, centres[static_cast<std::size_t>(i)]);
      const Eigen::Vector2d& m = f.normal;
      const double x = f.foot.x(), y = f.foot.y();
      r(i) = f.signed_distance - offset_mm;
      jac.row(i).head<2>() = -(m.x() * u + m.y() * v).transpose();
      jac(i, 2) = m.x() * y - m.y() * x;
      jac(i, 3) = -0.5 * m.x() * x / a;
      jac(i, 4) = -0.5 * m.y() * y / b;
    }
  }
  EllipseOutline step(const EllipseOutline& e, const Eigen::VectorXd& delta) const {
    EllipseOutline t = e;
    t.centre += delta.head<2>();
    t.angle_rad += delta(2);
    t.major_diameter_mm += delta(3);
    t.minor_diameter_mm += delta(4);
    return t;
  }
};

}  // namespace

double signed_distance(const EllipseOutline& ellipse, const Eigen::Vector2d& p) {
  return foot(ellipse, p).signed_distance;
}

tl::expected<EllipseFit, FitFailure> fit_ellipse(const std::vector<Eigen::Vector2d>& ball_centres,
                                                 double ball_radius_mm, bool inner, const EllipseOutline& start) {
  if (ball_centres.size() < 5) return tl::unexpected(FitFailure::TooFewPoints);
  for (const auto& c : ball_centres)
    if (!c.allFinite()) return tl::unexpected(FitFailure::Degenerate);
  if (!(start.major_diameter_mm > 0) || !(start.minor_diameter_mm > 0)) return tl::unexpected(FitFailure::Degenerate);
  const EllipseModel model{ball_centres, inner ? -ball_radius_mm : ball_radius_mm};
  EllipseOutline e = start;
  const detail::LmOutcome out = detail::levenberg_marquardt(model, e);
  if (!out.converged || !(e.major_diameter_mm > 0) || !(e.minor_diameter_mm > 0) || !e.centre.allFinite() ||
      !std::isfinite(e.angle_rad))
    return tl::unexpected(FitFailure::NoConvergence);
  if (e.minor_diameter_mm > e.major_diameter_mm) {
    std::swap(e.major_diameter_mm, e.minor_diameter_mm);
    e.angle_rad += 0.5 * std::numbers::pi;
  }
  // The same axis either way: keep the angle nearest the start's.
  e.angle_rad = start.angle_rad + std::remainder(e.angle_rad - start.angle_rad, std::numbers::pi);
  EllipseFit fit;
  fit.outline = e;
  fit.iterations = out.iterations;
  detail::fill_residuals(fit, ball_centres, inner,
                         [&](const Eigen::Vector2d& c) { return signed_distance(e, c) - model.offset_mm; });
  return fit;
}

}  // namespace metron::fitting
