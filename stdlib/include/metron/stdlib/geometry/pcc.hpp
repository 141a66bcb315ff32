// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cmath>
#include <vector>

#include <Eigen/Core>

#include "metron/stdlib/geometry/vec.hpp"

// Parametric cubic curves (PCC), the scan-path representation of SEEDS.md 1 and 2.
namespace metron::geometry {

/// One PCC segment: X(S) = KX3*S^3 + KX2*S^2 + KX1*S + KX0 (likewise Y, Z), 0 <= S <= D,
/// with K0 the start point and D the straight-line distance from start to end (SEEDS.md 2).
struct PccSegment {
  Eigen::Matrix<double, 3, 4> k = Eigen::Matrix<double, 3, 4>::Zero();  ///< columns K0, K1, K2, K3
  double d_mm = 0.0;                                                    ///< parameter range D

  /// The cubic Hermite segment from p0 to p1 with unit tangents t0, t1 at its ends; S is then
  /// close to arc length for gently curved segments.
  static PccSegment hermite(const Vec3& p0, const Vec3& p1, const Vec3& t0, const Vec3& t1) {
    PccSegment seg;
    const double d = (p1 - p0).norm();
    seg.d_mm = d;
    seg.k.col(0) = p0;
    seg.k.col(1) = t0;
    if (d > 0.0) {
      seg.k.col(2) = 3.0 * (p1 - p0) / (d * d) - (2.0 * t0 + t1) / d;
      seg.k.col(3) = 2.0 * (p0 - p1) / (d * d * d) + (t0 + t1) / (d * d);
    }
    return seg;
  }

  [[nodiscard]] Vec3 point(double s) const { return ((k.col(3) * s + k.col(2)) * s + k.col(1)) * s + k.col(0); }
  /// dX/dS
  [[nodiscard]] Vec3 derivative(double s) const { return (3.0 * k.col(3) * s + 2.0 * k.col(2)) * s + k.col(1); }
  /// d2X/dS2
  [[nodiscard]] Vec3 second_derivative(double s) const { return 6.0 * k.col(3) * s + 2.0 * k.col(2); }
  [[nodiscard]] Vec3 start() const { return k.col(0); }
  [[nodiscard]] Vec3 end() const { return point(d_mm); }
  /// Unit tangent at S.
  [[nodiscard]] Vec3 tangent(double s) const { return derivative(s).normalized(); }
  /// Curvature |X' x X''| / |X'|^3 in 1/mm.
  [[nodiscard]] double curvature(double s) const {
    const Vec3 d1 = derivative(s);
    const double n = d1.norm();
    return n > 0.0 ? d1.cross(second_derivative(s)).norm() / (n * n * n) : 0.0;
  }
  /// Arc length from 0 to S by 8-point Gauss-Legendre quadrature (exact to ~1e-12 relative
  /// for the gently curved segments scan paths are made of).
  [[nodiscard]] double arc_length(double s) const {
    static constexpr double x[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267, 0.9602898564975363};
    static constexpr double w[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};
    double sum = 0.0;
    for (int i = 0; i < 4; ++i) {
      sum += w[i] * (derivative(0.5 * s * (1.0 + x[i])).norm() + derivative(0.5 * s * (1.0 - x[i])).norm());
    }
    return 0.5 * s * sum;
  }
  [[nodiscard]] double length() const { return arc_length(d_mm); }
};

/// A scan path: a chain of PCC segments (each end is the next start), with the surface normal
/// at each interpolation point (segment starts, plus the path end) and a speed per segment.
struct PccPath {
  std::vector<PccSegment> segments;
  std::vector<Vec3> normals;       ///< unit surface normals, segments.size() + 1 (may be empty)
  std::vector<double> speed_mm_s;  ///< per-segment speed limit (may be empty: no limit known)

  [[nodiscard]] double length() const {
    double sum = 0.0;
    for (const auto& s : segments) sum += s.length();
    return sum;
  }
};

}  // namespace metron::geometry
