// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/fitting/best_fit_frame.hpp"

#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "levenberg_marquardt.hpp"

namespace metron::fitting {

namespace {

constexpr const char* kFreedomNames[6] = {"position along X", "position along Y", "position along Z",
                                          "rotation about X", "rotation about Y", "rotation about Z"};

// start * T(t) * Rz(c) * Ry(b) * Rx(a), from (tx, ty, tz, a, b, c).
Frame frame_of(const Frame& start, const Eigen::Matrix<double, 6, 1>& p) {
  Frame motion = Frame::Identity();
  motion.translate(p.head<3>());
  motion.rotate(Eigen::AngleAxisd(p[5], Vec3::UnitZ()) * Eigen::AngleAxisd(p[4], Vec3::UnitY()) *
                Eigen::AngleAxisd(p[3], Vec3::UnitX()));
  return start * motion;
}

// The direction `d` turned to lie on the same side as `reference` (an axis has no sense).
Vec3 same_sense(const Vec3& d, const Vec3& reference) { return d.dot(reference) < 0 ? Vec3(-d) : d; }

// Appends one match's residuals for the frame `f` (machine mm).
void append_residuals(const FrameMatch& m, const Frame& f, std::vector<double>& out) {
  const Vec3 position = f * m.nominal_position;
  const Vec3 direction = (f.linear() * m.nominal_direction).normalized();
  const Vec3 gap = m.actual_position - position;
  auto push = [&](const Vec3& v) { out.insert(out.end(), {v.x(), v.y(), v.z()}); };
  switch (m.kind) {
    case FrameMatch::Kind::Point: push(gap); return;
    case FrameMatch::Kind::Plane: out.push_back(direction.dot(gap)); break;
    case FrameMatch::Kind::Axis: push(gap - gap.dot(direction) * direction); break;
  }
  if (m.extent_mm > 0) push(m.extent_mm * (direction - same_sense(m.actual_direction.normalized(), direction)));
}

struct FrameModel {
  const std::vector<FrameMatch>& matches;
  const Frame& start;
  std::vector<int> free;  // indices into (tx, ty, tz, a, b, c)

  [[nodiscard]] Eigen::Matrix<double, 6, 1> full(const Eigen::VectorXd& state) const {
    Eigen::Matrix<double, 6, 1> p = Eigen::Matrix<double, 6, 1>::Zero();
    for (std::size_t k = 0; k < free.size(); ++k) p[free[k]] = state[static_cast<Eigen::Index>(k)];
    return p;
  }
  [[nodiscard]] Eigen::VectorXd residuals(const Eigen::VectorXd& state) const {
    const Frame f = frame_of(start, full(state));
    std::vector<double> r;
    for (const auto& m : matches) append_residuals(m, f, r);
    return Eigen::Map<Eigen::VectorXd>(r.data(), static_cast<Eigen::Index>(r.size()));
  }
  // Central differences: six parameters, a few dozen residuals.
  void evaluate(const Eigen::VectorXd& state, Eigen::VectorXd& r, Eigen::MatrixXd& jacobian) const {
    r = residuals(state);
    jacobian.resize(r.size(), state.size());
    for (Eigen::Index k = 0; k < state.size(); ++k) {
      const double h = free[static_cast<std::size_t>(k)] < 3 ? 1e-5 : 1e-7;
      Eigen::VectorXd plus = state, minus = state;
      plus[k] += h;
      minus[k] -= h;
      jacobian.col(k) = (residuals(plus) - residuals(minus)) / (2 * h);
    }
  }
  [[nodiscard]] Eigen::VectorXd step(const Eigen::VectorXd& state, const Eigen::VectorXd& delta) const {
    return state + delta;
  }
};

}  // namespace

tl::expected<BestFitFrame, std::string> best_fit_frame(const std::vector<FrameMatch>& matches, const Frame& start,
                                                       const FrameFreedoms& freedoms) {
  if (matches.empty()) return tl::unexpected(std::string("a best fit needs at least one feature"));
  FrameModel model{matches, start, {}};
  for (int k = 0; k < 3; ++k)
    if (freedoms.along[static_cast<std::size_t>(k)]) model.free.push_back(k);
  for (int k = 0; k < 3; ++k)
    if (freedoms.about[static_cast<std::size_t>(k)]) model.free.push_back(3 + k);
  if (model.free.empty()) return tl::unexpected(std::string("a best fit needs at least one freedom"));

  Eigen::VectorXd state = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(model.free.size()));
  const detail::LmOutcome out = detail::levenberg_marquardt(model, state, 200, 1e-12);
  Eigen::VectorXd r;
  Eigen::MatrixXd jacobian;
  model.evaluate(state, r, jacobian);
  if (!r.allFinite())
    return tl::unexpected(std::string("the best fit did not converge (a feature's geometry is not finite)"));

  // A freedom no feature fixes leaves the Jacobian rank-deficient. The motions the features
  // cannot see span its null space; a freedom mostly in that span is named (zero rows pad a
  // Jacobian shorter than wide, so the SVD gives every right singular vector).
  const auto p_free = static_cast<Eigen::Index>(model.free.size());
  Eigen::MatrixXd padded = Eigen::MatrixXd::Zero(std::max(jacobian.rows(), p_free), p_free);
  padded.topRows(jacobian.rows()) = jacobian;
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(padded, Eigen::ComputeFullV);
  const auto& s = svd.singularValues();
  std::vector<Eigen::Index> null_columns;
  for (Eigen::Index i = 0; i < s.size(); ++i)
    if (s[i] <= 1e-6 * std::max(1.0, s[0])) null_columns.push_back(i);
  if (!null_columns.empty()) {
    std::vector<std::string> unseen;
    for (Eigen::Index k = 0; k < p_free; ++k) {
      double in_null_space = 0;
      for (const Eigen::Index c : null_columns) in_null_space += svd.matrixV()(k, c) * svd.matrixV()(k, c);
      if (in_null_space > 0.25) unseen.push_back(kFreedomNames[model.free[static_cast<std::size_t>(k)]]);
    }
    if (unseen.empty()) unseen.push_back("position and rotation together");
    std::string list = unseen.front();
    for (std::size_t i = 1; i < unseen.size(); ++i) list += (i + 1 == unseen.size() ? " and " : ", ") + unseen[i];
    return tl::unexpected(fmt::format(
        "the features do not fix the part's {}: leave that freedom out or add a feature that fixes it", list));
  }

  BestFitFrame fit;
  const Eigen::Matrix<double, 6, 1> p = model.full(state);
  fit.part_to_machine = frame_of(start, p);
  fit.translation_mm = p.head<3>();
  fit.rotation_deg = p.tail<3>() * 180.0 / std::numbers::pi;
  fit.rms_mm = std::sqrt(r.squaredNorm() / static_cast<double>(r.size()));
  fit.iterations = out.iterations;
  fit.residual_mm = frame_residuals_mm(matches, fit.part_to_machine);
  return fit;
}

std::vector<double> frame_residuals_mm(const std::vector<FrameMatch>& matches, const Frame& part_to_machine) {
  std::vector<double> lengths;
  for (const auto& m : matches) {
    std::vector<double> r;
    append_residuals(m, part_to_machine, r);
    double squares = 0;
    for (const double v : r) squares += v * v;
    lengths.push_back(std::sqrt(squares));
  }
  return lengths;
}

}  // namespace metron::fitting
