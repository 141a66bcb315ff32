// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <vector>

#include <Eigen/Core>

/// The sequential two-point method (SEEDS.md 4, seed 003; Tanaka & Sato, "Trend of straightness
/// measuring method and development of sequential two-point method", Seisan Kenkyu 34(6), 1982):
/// pure computation on the readings of two displacement sensors A and B at spacing d, moved in
/// steps of d over a commercially flat plate. Nothing here knows the machine or the plate.
///
/// Sign convention (docs/error-space.md): n is the plate normal pointing from the plate toward the
/// head; the motion error e is the head's displacement along n, the plate profile f the surface
/// height along n; a reading grows when the surface comes closer: a_k = f(x_k) - e_k + c_A,
/// b_k = f(x_{k+1}) - e_k + c_B (B one step ahead of A). So b_{k-1} - a_k = e_k - e_{k-1} + Delta
/// with Delta = c_B - c_A (tip height difference plus zero offsets).
namespace metron::error_space {

/// The readings of one line: index k = 0..n is the head position x_k = x_0 + k d.
struct LineReadings {
  std::vector<double> a_mm;  ///< sensor A, reading the plate under the head point x_k
  std::vector<double> b_mm;  ///< sensor B, one step ahead (x_{k+1})
  /// Optional: an angle instrument on the head (electronic level or autocollimator, its zero set by
  /// a reversal) read at every position: the head's rotation in the plane of the line and the
  /// plate normal, positive when it moves B away from the plate relative to A. Empty: none (the
  /// seed's case, which assumes the head does not rotate).
  std::vector<double> angle_rad;
  /// B's position relative to A along the step direction (+d; -d with the head reversed): the
  /// lever on which a rotation moves B against A.
  double b_lever_mm = 0;
};

/// B's reading at k with the head's rotation removed: b_k + angle_k * lever (the rotation moved B's
/// tip by angle_k * lever away from the plate, which the reading saw as the plate receding). A
/// carriage that pitches (a real CMM's EBX, ECX ...) otherwise puts angle * d into every increment
/// of the chain, which sums into e_k (docs/error-space.md, "The head's rotation").
double rotation_free_b(const LineReadings& readings, std::size_t k);

/// One line solved.
struct LineResult {
  std::vector<double> motion_mm;   ///< e_k, k = 0..n, relative to the reference line (ends zero unless Delta was given)
  std::vector<double> profile_mm;  ///< f_k = e_k + a_k - a_0, the plate profile under A, relative to the same line
  double delta_mm = 0;             ///< per-step constant removed: Delta (plus the end line's slope per step)
};

/// The raw chain (SEEDS.md 4): e_0 = 0, e_k = e_{k-1} - a_k + b_{k-1}. The seed also writes
/// e_1 = 0 as a start value; taken literally that drops the measured first increment b_0 - a_1
/// and leaves a kink (1 - k/n)(e_1 - e_0 + Delta) after the end correction (docs/error-space.md),
/// so the chain here starts from e_0 alone and the two free constants of the line (offset and the
/// slope that k*Delta cannot be told apart from) are fixed by the end correction.
std::vector<double> chain(const LineReadings& readings);

/// The seed's start values taken literally (e_0 = e_1 = 0, recursion from k = 2); kept only to show
/// the kink it leaves (tests/stdlib/test_error_space_method.cpp).
std::vector<double> chain_literal_start(const LineReadings& readings);

/// Solves a line: the chain, then the Delta correction by forcing the ends to zero
/// (e_k -= k e_n / n), then f_k = e_k + a_k - a_0. With `known_delta_mm` (S4/S5: the sensors
/// turned 90 degrees keep the Delta of S2) that Delta is removed instead and the end stays free.
/// Throws std::invalid_argument when a and b differ in length or have fewer than 2 readings.
LineResult solve_line(const LineReadings& readings, std::optional<double> known_delta_mm = {});

/// Noise propagation of one line with independent sensor noise of standard deviation sigma on every
/// reading. Each increment b_{k-1} - a_k uses two fresh readings, so the chain is a random walk:
/// var(e_k) = 2 k sigma^2. The end correction turns it into a Brownian bridge:
/// var(e_k) = 2 sigma^2 k (n - k) / n (zero at both ends, n sigma^2 / 2 in the middle).
double line_noise_sd_mm(int n_steps, int k, double sigma_mm, bool end_corrected = true);

/// RMS over k = 0..n of the bridge's standard deviation: sqrt(mean var) = sigma sqrt((n - 1) / 3)
/// (from sum_k k(n - k) = n (n^2 - 1) / 6).
double line_noise_rms_mm(int n_steps, double sigma_mm);

/// The readings of one plane (SEEDS.md 4, S1 and S4). Grid points (x_i, y_j), i = 0..l, j = 0..m,
/// with the X step equal to the sensor spacing and the Y step equal to it too (the same head).
struct SurfaceReadings {
  std::vector<LineReadings> x_lines;  ///< S1: one X-direction line per y_j (each l+1 head positions)
  LineReadings y_line_first;          ///< S4: Y-direction line at x_0 (sensors turned 90 degrees), m+1 positions
  LineReadings y_line_last;           ///< S4: Y-direction line at x_l
};

/// Choices of the surface method.
struct SurfaceOptions {
  double sensor_sigma_mm = 0;  ///< sensor noise standard deviation, for the S7 threshold and the noise floor
  double s7_factor = 4;        ///< S7: re-measure when |disagreement| > max(s7_factor * its standard deviation, 1 nm)
  std::optional<double> known_delta_mm;  ///< Delta known from elsewhere (e.g. a reversal): S2 is skipped
};

/// One error surface e(x_i, y_j) of the component normal to the plate (SEEDS.md 4, S1-S7).
struct SurfaceResult {
  Eigen::MatrixXd error_mm;    ///< (l+1) x (m+1): e(x_i, y_j) relative to the reference plane (docs/error-space.md)
  Eigen::MatrixXd profile_mm;  ///< (l+1) x (m+1): plate profile under A, relative to the same plane
  double delta_mm = 0;         ///< S2: Delta from the first X line (includes that line's end slope per step)
  std::vector<double> s7_disagreement_mm;  ///< S7, per j: X curve end rise minus the Y boundary curves' difference
  std::vector<double> s7_sd_mm;      ///< its standard deviation from sensor noise: 2 sigma sqrt(l + j), 0 for j = 0
  std::vector<int> remeasure_lines;  ///< S7: the j whose disagreement exceeds the threshold
  bool remeasure = false;            ///< S7 decision: any line to re-measure
};

/// S1-S7 of SEEDS.md 4. The result is relative to the reference plane P(i, j) = e(0,0) + s (i + j),
/// s = (e(l,0) - e(0,0)) / l: the one Delta cannot be told from one common slope per step in both
/// directions. With `known_delta_mm` the slope stays: the result is e - e(0,0). Throws std::invalid_argument on
/// inconsistent sizes (fewer than 2 points per line).
SurfaceResult solve_surface(const SurfaceReadings& readings, const SurfaceOptions& options = {});

/// The same reference applied to a known surface (for comparing with truth): e - P.
Eigen::MatrixXd surface_reference(const Eigen::MatrixXd& e_mm);

/// The method's noise floor on a plane: the standard deviation of every recovered e(x_i, y_j) for
/// sensor noise sigma, by exact linear propagation (the method is linear in the readings, so the
/// variance is sigma^2 times the sum of squared impulse responses). (l+1) x (m+1). With
/// `known_delta_sd_mm` >= 0 the plane was solved with a Delta measured elsewhere with that
/// standard deviation: its error adds delta (i + j), independent of the plane's readings.
/// `sigma_b_mm` >= 0: B's readings have this noise instead (with an angle instrument, sigma and
/// the instrument's noise times the lever in quadrature).
Eigen::MatrixXd surface_noise_sd_mm(int l_steps, int m_steps, double sigma_mm, double known_delta_sd_mm = -1,
                                    double sigma_b_mm = -1);

/// Delta by a reversal (beyond the seed): the same line measured a second time with the head
/// turned 180 degrees about the plate normal (B now one step behind A). Then
/// b_{k-1} - a_k = e_k - e_{k-1} + Delta and a'_{k-1} - b'_k = e_k - e_{k-1} - Delta, so
/// Delta = mean over k of ((b_{k-1} - a_k) - (a'_{k-1} - b'_k)) / 2, free of the machine's slope
/// (which the end correction cannot separate from Delta). Its standard deviation is sigma / sqrt(n).
/// Throws std::invalid_argument when the lines differ in length.
double delta_by_reversal(const LineReadings& forward, const LineReadings& reversed);

}  // namespace metron::error_space
