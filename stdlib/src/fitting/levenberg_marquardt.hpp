// SPDX-License-Identifier: GPL-3.0-or-later
// Private: the Levenberg-Marquardt driver shared by the nonlinear fits.
#pragma once
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Dense>

namespace metron::fitting::detail {

/// The root mean square and the range (max - min: the form) of a fit's residuals.
struct ResidualFigures {
  double rms_mm = 0;
  double form_mm = 0;
};
inline ResidualFigures residual_figures(const std::vector<double>& residuals_mm) {
  if (residuals_mm.empty()) return {};
  double lo = residuals_mm.front(), hi = lo, squares = 0;
  for (const double r : residuals_mm) {
    lo = std::min(lo, r);
    hi = std::max(hi, r);
    squares += r * r;
  }
  return {std::sqrt(squares / static_cast<double>(residuals_mm.size())), hi - lo};
}

/// Fills a fit's residuals (+ outside the material: `offset_distance(c)` is the ball centre's
/// distance beyond its offset surface, negated for an inner feature) and its RMS and form.
template <class Fit, class Point, class OffsetDistance>
void fill_residuals(Fit& fit, const std::vector<Point>& ball_centres, bool inner, OffsetDistance offset_distance) {
  for (const Point& c : ball_centres) {
    const double e = offset_distance(c);
    fit.residuals_mm.push_back(inner ? -e : e);
  }
  const ResidualFigures figures = residual_figures(fit.residuals_mm);
  fit.rms_mm = figures.rms_mm;
  fit.form_mm = figures.form_mm;
}

/// Result of one Levenberg-Marquardt run.
struct LmOutcome {
  bool converged = false;  ///< reached a minimum to the step tolerance (or to machine precision)
  int iterations = 0;      ///< trial steps taken, accepted or not
  double cost = std::numeric_limits<double>::infinity();  ///< sum of squared residuals at `state`
};

/// Minimises the sum of squared residuals of `model` starting from `state` (updated in place).
///
/// `Model` provides
///   void evaluate(const State&, Eigen::VectorXd& residuals, Eigen::MatrixXd& jacobian) const;
///   State step(const State&, const Eigen::VectorXd& delta) const;
/// The Jacobian may be taken with respect to a local parametrisation that `step` applies and
/// re-centres (Forbes' re-linearisation about the current estimate, A. B. Forbes, NPL Report DITC 140/89), so
/// the state never nears a parametrisation singularity.
///
/// Each step solves min |J d + r|^2 + lambda |D d|^2. J = QR is factored once per accepted
/// step; every trial lambda then solves the small stacked system [R; sqrt(lambda) D] d = [-Q'r; 0]
/// by a pivoted QR, which avoids squaring the condition number as the normal equations would.
/// D holds the largest column norms of J seen so far (J. J. More, "The Levenberg-Marquardt
/// algorithm: implementation and theory", Lecture Notes in Mathematics 630, 1978).
template <class Model, class State>
LmOutcome levenberg_marquardt(const Model& model, State& state, int max_iterations = 500,
                              double step_tolerance = 1e-13) {
  Eigen::VectorXd r;
  Eigen::MatrixXd jac;
  model.evaluate(state, r, jac);
  LmOutcome out;
  if (!r.allFinite() || !jac.allFinite()) return out;
  out.cost = r.squaredNorm();
  const Eigen::Index n = jac.rows();
  const Eigen::Index p = jac.cols();
  const Eigen::Index k = std::min(n, p);
  Eigen::VectorXd col_scale = Eigen::VectorXd::Constant(p, std::numeric_limits<double>::min());
  Eigen::MatrixXd r_factor(k, p);
  Eigen::VectorXd qt_r(k);
  Eigen::MatrixXd stacked(k + p, p);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(k + p);
  Eigen::VectorXd r_trial;
  Eigen::MatrixXd jac_trial;
  auto factor = [&] {
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(jac);
    r_factor = qr.matrixQR().topRows(k).template triangularView<Eigen::Upper>();
    qt_r = (qr.householderQ().adjoint() * r).head(k);
    col_scale = col_scale.cwiseMax(jac.colwise().norm().transpose());
  };
  factor();
  double lambda = 1e-3;
  for (out.iterations = 1; out.iterations <= max_iterations; ++out.iterations) {
    stacked.topRows(k) = r_factor;
    stacked.bottomRows(p) = (std::sqrt(lambda) * col_scale).asDiagonal();
    rhs.head(k) = -qt_r;
    const Eigen::VectorXd delta = stacked.colPivHouseholderQr().solve(rhs);
    State trial = model.step(state, delta);
    model.evaluate(trial, r_trial, jac_trial);
    const bool finite = r_trial.allFinite() && jac_trial.allFinite();
    const double trial_cost = finite ? r_trial.squaredNorm() : std::numeric_limits<double>::infinity();
    if (trial_cost < out.cost) {
      state = std::move(trial);
      out.cost = trial_cost;
      r.swap(r_trial);
      jac.swap(jac_trial);
      lambda = std::max(lambda * 0.1, 1e-15);
      if (delta.norm() <= step_tolerance) {
        out.converged = true;
        return out;
      }
      factor();
    } else {
      lambda *= 10;
      if (lambda > 1e12) {
        // No damping finds a descent. A minimum as far as floating point can tell when even the
        // undamped Gauss-Newton step predicts a decrease below the rounding noise of the cost
        // (each residual carries an absolute error of order eps on points of order one).
        const Eigen::VectorXd gauss_newton = r_factor.colPivHouseholderQr().solve(-qt_r);
        const double predicted = (r_factor * gauss_newton).squaredNorm();
        out.converged = predicted <= 1e-13 * r.lpNorm<1>() + 1e-30 * static_cast<double>(n);
        return out;
      }
    }
  }
  return out;
}

}  // namespace metron::fitting::detail
