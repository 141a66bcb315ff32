// SPDX-License-Identifier: GPL-3.0-or-later
#include <cmath>

#include <Eigen/Dense>

#include "metron/stdlib/wavefront/zernike.hpp"

namespace metron::wavefront {

double zernike_noll(int j, double x, double y) {
  // Noll 1976 table 1; rho, theta from the disc's centre, theta from +x toward +y.
  const double r2 = x * x + y * y, r = std::sqrt(r2), t = std::atan2(y, x);
  switch (j) {
    case 1: return 1;
    case 2: return 2 * x;
    case 3: return 2 * y;
    case 4: return std::sqrt(3.0) * (2 * r2 - 1);
    case 5: return std::sqrt(6.0) * r2 * std::sin(2 * t);
    case 6: return std::sqrt(6.0) * r2 * std::cos(2 * t);
    case 7: return std::sqrt(8.0) * (3 * r2 - 2) * r * std::sin(t);
    case 8: return std::sqrt(8.0) * (3 * r2 - 2) * r * std::cos(t);
    case 9: return std::sqrt(8.0) * r2 * r * std::sin(3 * t);
    case 10: return std::sqrt(8.0) * r2 * r * std::cos(3 * t);
    case 11: return std::sqrt(5.0) * (6 * r2 * r2 - 6 * r2 + 1);
    default: return 0;
  }
}

tl::expected<ZernikeFit, const char*> fit_zernike(std::span<const Vec2> xy, std::span<const double> values, int terms) {
  if (terms < 1 || terms > 11) return tl::make_unexpected("zernike terms must be 1..11");
  if (xy.size() != values.size()) return tl::make_unexpected("points and values differ in number");
  const auto n = static_cast<Eigen::Index>(xy.size());
  if (n < terms + 1) return tl::make_unexpected("too few points for the zernike terms");
  // Normal equations: the basis is orthonormal on the disc, so they are well conditioned.
  Eigen::MatrixXd ata = Eigen::MatrixXd::Zero(terms, terms);
  Eigen::VectorXd atb = Eigen::VectorXd::Zero(terms);
  Eigen::VectorXd row(terms);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (int j = 0; j < terms; ++j) row[j] = zernike_noll(j + 1, xy[i].x(), xy[i].y());
    ata.selfadjointView<Eigen::Lower>().rankUpdate(row);
    atb += row * values[i];
  }
  ata = ata.selfadjointView<Eigen::Lower>();
  Eigen::LDLT<Eigen::MatrixXd> ldlt(ata);
  if (ldlt.info() != Eigen::Success || ldlt.rcond() < 1e-12)
    return tl::make_unexpected("the points do not determine the zernike terms");
  const Eigen::VectorXd c = ldlt.solve(atb);
  double ss = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    double f = 0;
    for (int j = 0; j < terms; ++j) f += c[j] * zernike_noll(j + 1, xy[i].x(), xy[i].y());
    ss += (values[i] - f) * (values[i] - f);
  }
  ZernikeFit fit;
  fit.samples = static_cast<int>(n);
  fit.coefficients.assign(c.data(), c.data() + terms);
  fit.residual_rms = std::sqrt(ss / static_cast<double>(n));
  const double var = ss / static_cast<double>(n - terms);
  const Eigen::MatrixXd cov = ldlt.solve(Eigen::MatrixXd::Identity(terms, terms)) * var;
  for (int j = 0; j < terms; ++j) fit.sigma.push_back(std::sqrt(cov(j, j)));
  return fit;
}

Vec2 centroid(std::span<const Vec2> xy) {
  Vec2 s = Vec2::Zero();
  for (const auto& p : xy) s += p;
  return xy.empty() ? s : Vec2(s / static_cast<double>(xy.size()));
}

}  // namespace metron::wavefront
