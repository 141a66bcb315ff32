// SPDX-License-Identifier: GPL-3.0-or-later
#include <cmath>
#include <numeric>

#include <Eigen/Dense>

#include "metron/stdlib/wavefront/circle_fit.hpp"

namespace metron::wavefront {
namespace {

double radial_rms(std::span<const Vec2> p, const Vec2& c, double r) {
  double ss = 0;
  for (const auto& q : p) ss += std::pow((q - c).norm() - r, 2);
  return std::sqrt(ss / static_cast<double>(p.size()));
}

Vec2 mean(std::span<const Vec2> p) {
  Vec2 m = Vec2::Zero();
  for (const auto& q : p) m += q;
  return m / static_cast<double>(p.size());
}

}  // namespace

tl::expected<Circle2, const char*> fit_circle_kasa(std::span<const Vec2> points) {
  if (points.size() < 3) return tl::make_unexpected("a circle needs 3 points");
  const Vec2 m = mean(points);  // centred for conditioning
  Eigen::MatrixXd a(points.size(), 3);
  Eigen::VectorXd b(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec2 q = points[i] - m;
    a.row(static_cast<Eigen::Index>(i)) << 2 * q.x(), 2 * q.y(), 1;
    b[static_cast<Eigen::Index>(i)] = q.squaredNorm();
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
  if (qr.rank() < 3) return tl::make_unexpected("the points lie on a line");
  const Eigen::Vector3d s = qr.solve(b);
  Circle2 c;
  c.centre = m + Vec2(s[0], s[1]);
  c.radius = std::sqrt(s[2] + s[0] * s[0] + s[1] * s[1]);
  c.residual_rms = radial_rms(points, c.centre, c.radius);
  return c;
}

tl::expected<Circle2, const char*> fit_circle_pratt(std::span<const Vec2> points) {
  if (points.size() < 3) return tl::make_unexpected("a circle needs 3 points");
  const Vec2 m = mean(points);
  // Chernov (2010) sec. 5.5: A z^2 + B x + C y + D = 0 under the constraint B^2 + C^2 - 4AD = 1,
  // the generalised eigenproblem M v = eta N v with the smallest non-negative eta.
  Eigen::Matrix4d mm = Eigen::Matrix4d::Zero();
  for (const auto& p : points) {
    const Vec2 q = p - m;
    const Eigen::Vector4d row(q.squaredNorm(), q.x(), q.y(), 1);
    mm += row * row.transpose();
  }
  Eigen::Matrix4d nn = Eigen::Matrix4d::Zero();
  nn(1, 1) = nn(2, 2) = 1;
  nn(0, 3) = nn(3, 0) = -2;
  Eigen::GeneralizedEigenSolver<Eigen::Matrix4d> ges(mm, nn);
  int best = -1;
  double best_eta = 0;
  for (int i = 0; i < 4; ++i) {
    const auto ev = ges.alphas()[i];
    const double beta = ges.betas()[i];
    if (std::abs(beta) < 1e-300 || std::abs(ev.imag()) > 1e-9 * std::abs(ev.real()) + 1e-300) continue;
    const double eta = ev.real() / beta;
    if (eta < -1e-9 * mm.norm()) continue;
    if (best < 0 || eta < best_eta) best = i, best_eta = eta;
  }
  if (best < 0) return tl::make_unexpected("no circle (pratt eigenproblem)");
  const Eigen::Vector4d v = ges.eigenvectors().col(best).real();
  if (std::abs(v[0]) < 1e-14 * v.norm()) return tl::make_unexpected("the points lie on a line");
  Circle2 c;
  c.centre = m + Vec2(-v[1] / (2 * v[0]), -v[2] / (2 * v[0]));
  c.radius = std::sqrt(v[1] * v[1] + v[2] * v[2] - 4 * v[0] * v[3]) / (2 * std::abs(v[0]));
  c.residual_rms = radial_rms(points, c.centre, c.radius);
  return c;
}

tl::expected<Circle2, const char*> fit_circle_geometric(std::span<const Vec2> points) {
  auto start = fit_circle_pratt(points);
  if (!start) return start;
  Eigen::Vector3d p(start->centre.x(), start->centre.y(), start->radius);
  const auto cost = [&](const Eigen::Vector3d& q) {
    double s = 0;
    for (const auto& pt : points) s += std::pow((pt - q.head<2>()).norm() - q[2], 2);
    return s;
  };
  double lambda = 1e-3, f = cost(p);
  for (int it = 0; it < 100; ++it) {
    Eigen::Matrix3d jtj = Eigen::Matrix3d::Zero();
    Eigen::Vector3d jtr = Eigen::Vector3d::Zero();
    for (const auto& pt : points) {
      const Vec2 d = pt - p.head<2>();
      const double dist = d.norm();
      if (dist == 0) continue;
      const Eigen::Vector3d j(-d.x() / dist, -d.y() / dist, -1);
      jtj += j * j.transpose();
      jtr += j * (dist - p[2]);
    }
    Eigen::Matrix3d a = jtj;
    a.diagonal() *= 1 + lambda;
    const Eigen::Vector3d step = a.ldlt().solve(-jtr);
    const double fn = cost(p + step);
    if (fn < f) {
      p += step;
      const bool done = f - fn <= 1e-15 * f + 1e-300;
      f = fn;
      lambda *= 0.3;
      if (done || step.norm() < 1e-15 * (1 + p.norm())) break;
    } else {
      lambda *= 10;
      if (lambda > 1e12) break;
    }
  }
  Circle2 c;
  c.centre = p.head<2>();
  c.radius = std::abs(p[2]);
  c.residual_rms = std::sqrt(f / static_cast<double>(points.size()));
  return c;
}

tl::expected<PhasedCircle, const char*> fit_circle_phased(std::span<const Vec2> points,
                                                          std::span<const double> angles_rad, int sense) {
  if (points.size() != angles_rad.size()) return tl::make_unexpected("points and angles differ in number");
  if (points.size() < 2) return tl::make_unexpected("a phased circle needs 2 angles");
  if (sense == 0) {
    if (points.size() < 3) return fit_circle_phased(points, angles_rad, 1);
    auto a = fit_circle_phased(points, angles_rad, 1);
    auto b = fit_circle_phased(points, angles_rad, -1);
    if (!a) return b;
    if (!b) return a;
    return a->residual_rms <= b->residual_rms ? a : b;
  }
  // p_k = c + R(s a_k) r: [1 0 cos -s sin; 0 1 s sin cos] (cx cy rx ry)^T
  const auto n = static_cast<Eigen::Index>(points.size());
  Eigen::MatrixXd m(2 * n, 4);
  Eigen::VectorXd y(2 * n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double c = std::cos(angles_rad[k]), s = sense * std::sin(angles_rad[k]);
    m.row(2 * k) << 1, 0, c, -s;
    m.row(2 * k + 1) << 0, 1, s, c;
    y[2 * k] = points[k].x();
    y[2 * k + 1] = points[k].y();
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(m);
  if (qr.rank() < 4) return tl::make_unexpected("the angles do not separate centre and radius (all equal?)");
  const Eigen::Vector4d x = qr.solve(y);
  PhasedCircle out;
  out.centre = x.head<2>();
  out.radius_vector = x.tail<2>();
  out.sense = sense;
  const double ss = (m * x - y).squaredNorm();
  out.residual_rms = std::sqrt(ss / static_cast<double>(n));
  if (2 * n > 4) {
    const Eigen::Matrix4d cov = (m.transpose() * m).inverse() * (ss / static_cast<double>(2 * n - 4));
    out.centre_sigma = std::sqrt(0.5 * (cov(0, 0) + cov(1, 1)));
  }
  return out;
}

tl::expected<Line2, const char*> fit_line(std::span<const double> x, std::span<const double> y) {
  if (x.size() != y.size() || x.size() < 2) return tl::make_unexpected("a line needs 2 points");
  const double n = static_cast<double>(x.size());
  const double mx = std::accumulate(x.begin(), x.end(), 0.0) / n, my = std::accumulate(y.begin(), y.end(), 0.0) / n;
  double sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) sxx += (x[i] - mx) * (x[i] - mx), sxy += (x[i] - mx) * (y[i] - my);
  if (sxx <= 0) return tl::make_unexpected("a line needs 2 distinct x");
  Line2 l;
  l.slope = sxy / sxx;
  l.intercept = my - l.slope * mx;
  double ss = 0;
  for (std::size_t i = 0; i < x.size(); ++i) ss += std::pow(y[i] - l.intercept - l.slope * x[i], 2);
  l.residual_rms = std::sqrt(ss / n);
  if (x.size() > 2) l.slope_sigma = std::sqrt(ss / (n - 2) / sxx);
  return l;
}

}  // namespace metron::wavefront
