// SPDX-License-Identifier: GPL-3.0-or-later
// Torus (DMIS TORUS): geometric Levenberg-Marquardt on the distance from the centre circle.
#include <algorithm>
#include <cmath>

#include "levenberg_marquardt.hpp"
#include "metron/stdlib/fitting/torus_fit.hpp"

namespace metron::fitting {
namespace {

/// Two unit vectors that complete `axis` to a right-handed orthonormal frame.
std::pair<Vec3, Vec3> plane_basis(const Vec3& axis) {
  const Vec3 helper = std::abs(axis.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 u = axis.cross(helper).normalized();
  return {u, axis.cross(u)};
}

/// Where p lies relative to the torus: q = p - centre = rho e + h axis, and w = q - R e, the
/// vector from the centre circle's nearest point.
struct Relative {
  Vec3 e = Vec3::UnitX();  ///< unit, radial in the centre circle's plane
  double rho = 0, h = 0;
  Vec3 w = Vec3::Zero();
  double distance = 0;  ///< |w|
};

std::optional<Relative> relative(const Torus& t, const Vec3& p) {
  Relative r;
  const Vec3 q = p - t.centre;
  r.h = q.dot(t.axis);
  const Vec3 radial = q - r.h * t.axis;
  r.rho = radial.norm();
  if (!(r.rho > 1e-12)) return std::nullopt;  // on the axis: every point of the centre circle is nearest
  r.e = radial / r.rho;
  r.w = q - 0.5 * t.major_diameter_mm * r.e;
  r.distance = r.w.norm();
  return r;
}

/// Residual f_i = |w_i| - (r + offset). State steps: centre (3), the axis tilted by small angles
/// about the two axes normal to it (re-centred each step, as Forbes' re-linearisation), R, r.
/// Derivatives (q = rho e + h a, w = (rho - R) e + h a, n = w / |w|):
///   df/dcentre = -n (the centre circle moves rigidly; de/dq projects out e and a, which n is made of);
///   df/dtilt_u = h R (e . u) / |w|   (a' = a + t u: dh = q.u = rho e.u, drho = -h e.u);
///   df/dR = -(n . e);  df/dr = -1.
struct TorusModel {
  const std::vector<Vec3>& centres;
  double offset_mm;

  void evaluate(const Torus& t, Eigen::VectorXd& res, Eigen::MatrixXd& jac) const {
    const auto n = static_cast<Eigen::Index>(centres.size());
    res.resize(n);
    jac.resize(n, 7);
    const auto [u, v] = plane_basis(t.axis);
    const double big_r = 0.5 * t.major_diameter_mm;
    for (Eigen::Index i = 0; i < n; ++i) {
      const auto rel = relative(t, centres[static_cast<std::size_t>(i)]);
      if (!rel || !(rel->distance > 1e-12)) {
        res(i) = std::numeric_limits<double>::quiet_NaN();
        jac.row(i).setZero();
        continue;
      }
      const Vec3 normal = rel->w / rel->distance;
      res(i) = rel->distance - 0.5 * t.minor_diameter_mm - offset_mm;
      jac.row(i).head<3>() = -normal.transpose();
      jac(i, 3) = rel->h * big_r * rel->e.dot(u) / rel->distance;
      jac(i, 4) = rel->h * big_r * rel->e.dot(v) / rel->distance;
      jac(i, 5) = -0.5 * normal.dot(rel->e);  // per unit of the major diameter
      jac(i, 6) = -0.5;                       // per unit of the minor diameter
    }
  }
  Torus step(const Torus& t, const Eigen::VectorXd& delta) const {
    const auto [u, v] = plane_basis(t.axis);
    Torus s = t;
    s.centre += delta.head<3>();
    s.axis = (t.axis + delta(3) * u + delta(4) * v).normalized();
    s.major_diameter_mm += delta(5);
    s.minor_diameter_mm += delta(6);
    return s;
  }
};

}  // namespace

double distance_from_centre_circle(const Torus& torus, const Vec3& p) {
  const auto rel = relative(torus, p);
  return rel ? rel->distance : std::hypot(0.5 * torus.major_diameter_mm, (p - torus.centre).dot(torus.axis));
}

tl::expected<TorusFit, FitFailure> fit_torus(const std::vector<Vec3>& ball_centres, double ball_radius_mm, bool inner,
                                             const Torus& start) {
  if (ball_centres.size() < 7) return tl::unexpected(FitFailure::TooFewPoints);
  Torus t = start;
  t.axis = start.axis.normalized();
  for (const auto& c : ball_centres)
    if (!c.allFinite() || !relative(t, c)) return tl::unexpected(FitFailure::Degenerate);
  // The ball's centre rides r + b from the centre circle outside a ring, r - b inside a groove.
  const TorusModel model{ball_centres, inner ? -ball_radius_mm : ball_radius_mm};
  const detail::LmOutcome out = detail::levenberg_marquardt(model, t);
  if (!out.converged || !(t.major_diameter_mm > 0) || !(t.minor_diameter_mm > 0) || !t.centre.allFinite() ||
      !t.axis.allFinite())
    return tl::unexpected(FitFailure::NoConvergence);
  if (t.axis.dot(start.axis) < 0) t.axis = -t.axis;  // the same torus: keep the nominal's sense
  TorusFit fit;
  fit.torus = t;
  fit.iterations = out.iterations;
  detail::fill_residuals(fit, ball_centres, inner, [&](const Vec3& c) {
    return distance_from_centre_circle(t, c) - 0.5 * t.minor_diameter_mm - model.offset_mm;
  });
  return fit;
}

}  // namespace metron::fitting
