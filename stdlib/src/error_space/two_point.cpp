// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/error_space/two_point.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace metron::error_space {
namespace {

void check_line(const LineReadings& r, const char* what) {
  if (r.a_mm.size() != r.b_mm.size())
    throw std::invalid_argument(std::string(what) + ": sensors A and B have different numbers of readings");
  if (r.a_mm.size() < 2) throw std::invalid_argument(std::string(what) + ": a line needs at least 2 head positions");
  if (!r.angle_rad.empty() && r.angle_rad.size() != r.a_mm.size())
    throw std::invalid_argument(std::string(what) + ": the angle instrument has a different number of readings");
}

}  // namespace

double rotation_free_b(const LineReadings& r, std::size_t k) {
  return r.angle_rad.empty() ? r.b_mm[k] : r.b_mm[k] + r.angle_rad[k] * r.b_lever_mm;
}

std::vector<double> chain(const LineReadings& r) {
  check_line(r, "two-point line");
  std::vector<double> e(r.a_mm.size(), 0.0);
  // SEEDS.md 4: e_k = e_{k-1} - a_k + b_{k-1}
  for (std::size_t k = 1; k < e.size(); ++k) e[k] = e[k - 1] - r.a_mm[k] + rotation_free_b(r, k - 1);
  return e;
}

std::vector<double> chain_literal_start(const LineReadings& r) {
  check_line(r, "two-point line");
  std::vector<double> e(r.a_mm.size(), 0.0);
  for (std::size_t k = 2; k < e.size(); ++k) e[k] = e[k - 1] - r.a_mm[k] + rotation_free_b(r, k - 1);
  return e;
}

LineResult solve_line(const LineReadings& r, std::optional<double> known_delta_mm) {
  LineResult out;
  out.motion_mm = chain(r);
  const std::size_t n = out.motion_mm.size() - 1;
  // The chain carries k*Delta (SEEDS.md 4); without a known Delta it is removed by e_0 = e_n = 0.
  out.delta_mm = known_delta_mm ? *known_delta_mm : out.motion_mm[n] / static_cast<double>(n);
  for (std::size_t k = 0; k <= n; ++k) out.motion_mm[k] -= static_cast<double>(k) * out.delta_mm;
  out.profile_mm.resize(n + 1);
  // SEEDS.md 4: f_k = e_k + a_k - a_0
  for (std::size_t k = 0; k <= n; ++k) out.profile_mm[k] = out.motion_mm[k] + r.a_mm[k] - r.a_mm[0];
  return out;
}

double line_noise_sd_mm(int n, int k, double sigma, bool end_corrected) {
  if (n <= 0 || k < 0 || k > n) return 0;
  const double var = end_corrected ? 2.0 * k * (n - k) / n : 2.0 * k;
  return sigma * std::sqrt(var);
}

double line_noise_rms_mm(int n, double sigma) {
  if (n <= 1) return 0;
  return sigma * std::sqrt((n - 1) / 3.0);
}

SurfaceResult solve_surface(const SurfaceReadings& in, const SurfaceOptions& options) {
  if (in.x_lines.size() < 2) throw std::invalid_argument("error surface: needs at least 2 X lines (S1)");
  for (const auto& line : in.x_lines) check_line(line, "error surface X line");
  check_line(in.y_line_first, "error surface Y line at x_0");
  check_line(in.y_line_last, "error surface Y line at x_l");
  const std::size_t l = in.x_lines[0].a_mm.size() - 1;
  const std::size_t m = in.x_lines.size() - 1;
  for (const auto& line : in.x_lines)
    if (line.a_mm.size() != l + 1) throw std::invalid_argument("error surface: X lines of different lengths");
  if (in.y_line_first.a_mm.size() != m + 1 || in.y_line_last.a_mm.size() != m + 1)
    throw std::invalid_argument("error surface: a Y line needs one head position per X line");

  SurfaceResult out;
  // S1: the raw X chains. S2: Delta from the first line (its ends forced to zero).
  std::vector<std::vector<double>> x_curves;
  x_curves.reserve(m + 1);
  for (const auto& line : in.x_lines) x_curves.push_back(chain(line));
  out.delta_mm = options.known_delta_mm ? *options.known_delta_mm : x_curves[0][l] / static_cast<double>(l);
  // S3: every X curve corrected by the same Delta; their ends stay free (delta_z(y_j) != 0).
  for (auto& c : x_curves)
    for (std::size_t i = 0; i <= l; ++i) c[i] -= static_cast<double>(i) * out.delta_mm;
  // S4, S5: the Y boundary curves with the sensors turned 90 degrees: the same Delta.
  const LineResult y0 = solve_line(in.y_line_first, out.delta_mm);
  LineResult yl = solve_line(in.y_line_last, out.delta_mm);
  // The Y curve at x_l starts where the first X curve ends (0 when S2 forced that end to zero;
  // with a known Delta it keeps the slope).
  for (double& v : yl.motion_mm) v += x_curves[0][l];

  // S7: where the X curves meet the Y curve at x_l, the rise along X must equal the difference of
  // the two Y curves. Noise: X part 4 l sigma^2 (the chains of lines j and 0, through Delta or the
  // Y_l start), Y part 4 j sigma^2 (two chains of j steps; Delta cancels); D_0 = 0.
  const double sigma = options.sensor_sigma_mm;
  out.s7_disagreement_mm.resize(m + 1);
  out.s7_sd_mm.resize(m + 1);
  for (std::size_t j = 0; j <= m; ++j) {
    out.s7_disagreement_mm[j] = x_curves[j][l] - (yl.motion_mm[j] - y0.motion_mm[j]);
    const double var = j == 0 ? 0.0 : 4.0 * static_cast<double>(l + j);
    out.s7_sd_mm[j] = sigma * std::sqrt(var);
    // A 1 nm floor keeps rounding (and noise-free simulations) from asking for a re-measure;
    // with an estimated Delta, line 0 agrees by construction (D_0 = 0 up to rounding).
    const double limit = std::max(options.s7_factor * out.s7_sd_mm[j], 1e-6);
    if (std::abs(out.s7_disagreement_mm[j]) > limit) out.remeasure_lines.push_back(static_cast<int>(j));
  }
  out.remeasure = !out.remeasure_lines.empty();

  // S6: shift and tilt each X curve so its ends lie on the two Y boundary curves.
  out.error_mm.resize(static_cast<Eigen::Index>(l + 1), static_cast<Eigen::Index>(m + 1));
  out.profile_mm.resizeLike(out.error_mm);
  const double a00 = in.x_lines[0].a_mm[0];
  for (std::size_t j = 0; j <= m; ++j) {
    const double tilt = y0.motion_mm[j] - yl.motion_mm[j] + x_curves[j][l];
    for (std::size_t i = 0; i <= l; ++i) {
      const double e = x_curves[j][i] + y0.motion_mm[j] - static_cast<double>(i) / static_cast<double>(l) * tilt;
      out.error_mm(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = e;
      // f = e + a - a_00 (SEEDS.md 4's f_k = e_k + a_k - a_0 over the plane)
      out.profile_mm(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = e + in.x_lines[j].a_mm[i] - a00;
    }
  }
  return out;
}

Eigen::MatrixXd surface_reference(const Eigen::MatrixXd& e) {
  const Eigen::Index l = e.rows() - 1;
  const double e00 = e(0, 0);
  const double s = l > 0 ? (e(l, 0) - e00) / static_cast<double>(l) : 0.0;
  Eigen::MatrixXd out = e;
  for (Eigen::Index i = 0; i < e.rows(); ++i)
    for (Eigen::Index j = 0; j < e.cols(); ++j) out(i, j) -= e00 + s * static_cast<double>(i + j);
  return out;
}

double delta_by_reversal(const LineReadings& fwd, const LineReadings& rev) {
  check_line(fwd, "reversal, forward line");
  check_line(rev, "reversal, reversed line");
  if (fwd.a_mm.size() != rev.a_mm.size()) throw std::invalid_argument("reversal: the two lines differ in length");
  const std::size_t n = fwd.a_mm.size() - 1;
  double sum = 0;
  for (std::size_t k = 1; k <= n; ++k)
    sum += 0.5 * ((rotation_free_b(fwd, k - 1) - fwd.a_mm[k]) - (rev.a_mm[k - 1] - rotation_free_b(rev, k)));
  return sum / static_cast<double>(n);
}

Eigen::MatrixXd surface_noise_sd_mm(int l, int m, double sigma, double known_delta_sd, double sigma_b) {
  if (sigma_b < 0) sigma_b = sigma;
  // The method is linear in the readings: propagate each reading's unit impulse and add the squares.
  SurfaceReadings r;
  r.x_lines.assign(static_cast<std::size_t>(m + 1),
                   LineReadings{std::vector<double>(l + 1, 0.0), std::vector<double>(l + 1, 0.0), {}, 0});
  r.y_line_first = LineReadings{std::vector<double>(m + 1, 0.0), std::vector<double>(m + 1, 0.0), {}, 0};
  r.y_line_last = r.y_line_first;
  Eigen::MatrixXd var = Eigen::MatrixXd::Zero(l + 1, m + 1);
  // B's readings may be noisier (an angle instrument's noise times the lever adds to them).
  auto impulse = [&](double& reading, double sd) {
    reading = 1.0;
    SurfaceOptions o;
    if (known_delta_sd >= 0) o.known_delta_mm = 0.0;  // Delta from other readings: no impulse reaches it here
    var += sd * sd * solve_surface(r, o).error_mm.array().square().matrix();
    reading = 0.0;
  };
  for (auto& line : r.x_lines)
    for (int i = 0; i <= l; ++i)
      impulse(line.a_mm[static_cast<std::size_t>(i)], sigma), impulse(line.b_mm[static_cast<std::size_t>(i)], sigma_b);
  for (auto* line : {&r.y_line_first, &r.y_line_last})
    for (int j = 0; j <= m; ++j)
      impulse(line->a_mm[static_cast<std::size_t>(j)], sigma),
          impulse(line->b_mm[static_cast<std::size_t>(j)], sigma_b);
  if (known_delta_sd > 0)
    for (int i = 0; i <= l; ++i)
      for (int j = 0; j <= m; ++j) var(i, j) += std::pow(known_delta_sd * (i + j), 2);
  return var.array().sqrt().matrix();
}

}  // namespace metron::error_space
