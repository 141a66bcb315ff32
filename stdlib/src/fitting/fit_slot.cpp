// SPDX-License-Identifier: GPL-3.0-or-later
// Closed slot (DMIS CPARLN) in its plane: geometric Levenberg-Marquardt on the signed distance.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "levenberg_marquardt.hpp"
#include "metron/stdlib/fitting/slot_fit.hpp"

namespace metron::fitting {
namespace {

/// A point in the slot's own frame: x along the long axis, y across it.
struct Local {
  double x = 0;
  double y = 0;
};

Local to_local(const SlotOutline& s, const Eigen::Vector2d& p) {
  const Eigen::Vector2d d = p - s.centre;
  const double c = std::cos(s.angle_rad), n = std::sin(s.angle_rad);
  return {c * d.x() + n * d.y(), -n * d.x() + c * d.y()};
}

/// The signed distance and its derivatives with respect to the local x, y, the length and the width.
struct Distance {
  double value = 0;
  double dx = 0, dy = 0, dlength = 0, dwidth = 0;
};

double sign(double v) { return v < 0 ? -1.0 : 1.0; }

Distance stadium(const SlotOutline& s, const Local& q) {
  // Distance from the centre segment (half length h = L/2 - W/2 along x) minus the radius W/2.
  const double h = std::max(0.0, 0.5 * (s.length_mm - s.width_mm));
  const double qx = std::abs(q.x) > h ? q.x - sign(q.x) * h : 0.0;
  const double norm = std::hypot(qx, q.y);
  Distance d;
  d.value = norm - 0.5 * s.width_mm;
  const double ux = norm > 0 ? qx / norm : 0.0, uy = norm > 0 ? q.y / norm : 1.0;
  d.dx = ux;
  d.dy = uy;
  d.dlength = -0.5 * std::abs(ux);      // dh/dL = 1/2, d|q|/dh = -|ux|
  d.dwidth = 0.5 * std::abs(ux) - 0.5;  // dh/dW = -1/2, and the radius
  return d;
}

Distance rectangle(const SlotOutline& s, const Local& q) {
  const double ex = std::abs(q.x) - 0.5 * s.length_mm, ey = std::abs(q.y) - 0.5 * s.width_mm;
  Distance d;
  if (ex > 0 || ey > 0) {
    const double mx = std::max(ex, 0.0), my = std::max(ey, 0.0), norm = std::hypot(mx, my);
    d.value = norm;
    d.dx = sign(q.x) * mx / norm;
    d.dy = sign(q.y) * my / norm;
    d.dlength = -0.5 * mx / norm;
    d.dwidth = -0.5 * my / norm;
  } else if (ex > ey) {
    d.value = ex;
    d.dx = sign(q.x);
    d.dlength = -0.5;
  } else {
    d.value = ey;
    d.dy = sign(q.y);
    d.dwidth = -0.5;
  }
  return d;
}

Distance distance(const SlotOutline& s, const Eigen::Vector2d& p) {
  const Local q = to_local(s, p);
  return s.round_ends ? stadium(s, q) : rectangle(s, q);
}

/// Residual r_i = s(c_i) - offset; state: the outline, stepped in centre, angle, length, width.
struct SlotModel {
  const std::vector<Eigen::Vector2d>& centres;
  double offset_mm;

  void evaluate(const SlotOutline& s, Eigen::VectorXd& r, Eigen::MatrixXd& jac) const {
    const auto n = static_cast<Eigen::Index>(centres.size());
    r.resize(n);
    jac.resize(n, 5);
    const Eigen::Vector2d a(std::cos(s.angle_rad), std::sin(s.angle_rad)), b(-a.y(), a.x());
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::Vector2d& p = centres[static_cast<std::size_t>(i)];
      const Local q = to_local(s, p);
      const Distance d = s.round_ends ? stadium(s, q) : rectangle(s, q);
      r(i) = d.value - offset_mm;
      // x = (p - c).a, y = (p - c).b: dx/dc = -a, dy/dc = -b, dx/dangle = y, dy/dangle = -x.
      jac.row(i).head<2>() = -(d.dx * a + d.dy * b).transpose();
      jac(i, 2) = d.dx * q.y - d.dy * q.x;
      jac(i, 3) = d.dlength;
      jac(i, 4) = d.dwidth;
    }
  }
  SlotOutline step(const SlotOutline& s, const Eigen::VectorXd& delta) const {
    SlotOutline t = s;
    t.centre += delta.head<2>();
    t.angle_rad += delta(2);
    t.length_mm += delta(3);
    t.width_mm += delta(4);
    return t;
  }
};

}  // namespace

double signed_distance(const SlotOutline& slot, const Eigen::Vector2d& p) { return distance(slot, p).value; }

SlotPart nearest_part(const SlotOutline& slot, const Eigen::Vector2d& p) {
  const Local q = to_local(slot, p);
  // Round ends: beyond the straight part; flat ends: nearer the end line than the side line.
  const bool end = slot.round_ends
                       ? std::abs(q.x) > 0.5 * std::max(0.0, slot.length_mm - slot.width_mm)
                       : std::abs(std::abs(q.x) - 0.5 * slot.length_mm) < std::abs(std::abs(q.y) - 0.5 * slot.width_mm);
  if (end) return q.x >= 0 ? SlotPart::PlusEnd : SlotPart::MinusEnd;
  return q.y >= 0 ? SlotPart::PlusSide : SlotPart::MinusSide;
}

tl::expected<SlotFit, FitFailure> fit_slot(const std::vector<Eigen::Vector2d>& ball_centres, double ball_radius_mm,
                                           bool inner, const SlotOutline& start) {
  if (ball_centres.size() < 5) return tl::unexpected(FitFailure::TooFewPoints);
  int on_part[4] = {0, 0, 0, 0};
  for (const auto& c : ball_centres) {
    if (!c.allFinite()) return tl::unexpected(FitFailure::Degenerate);
    ++on_part[static_cast<int>(nearest_part(start, c))];
  }
  if (std::any_of(std::begin(on_part), std::end(on_part), [](int k) { return k == 0; }))
    return tl::unexpected(FitFailure::TooFewPoints);
  const SlotModel model{ball_centres, inner ? -ball_radius_mm : ball_radius_mm};
  SlotOutline s = start;
  const detail::LmOutcome out = detail::levenberg_marquardt(model, s);
  const bool slot_shaped = s.width_mm > 0 && s.length_mm > 0 && (!s.round_ends || s.length_mm >= s.width_mm);
  if (!out.converged || !slot_shaped || !std::isfinite(s.angle_rad)) return tl::unexpected(FitFailure::NoConvergence);
  // The same line either way: keep the angle nearest the start's.
  s.angle_rad = start.angle_rad + std::remainder(s.angle_rad - start.angle_rad, std::numbers::pi);
  SlotFit fit;
  fit.outline = s;
  fit.iterations = out.iterations;
  detail::fill_residuals(fit, ball_centres, inner,
                         [&](const Eigen::Vector2d& c) { return distance(s, c).value - model.offset_mm; });
  return fit;
}

}  // namespace metron::fitting
