// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "metron/stdlib/discrepancy/measured_data.hpp"

/// The model-discrepancy analysis (docs/discrepancy.md): residuals of measured data against a base
/// model's prediction, structure searches, the catalogue of physical effects fitted by forward
/// selection with an extra-sum-of-squares F test, cross-validation that respects cycles and time.
namespace metron::discrepancy {

/// Residuals to explain: one observation per (row, measured axis).
struct Problem {
  const MeasuredData* data = nullptr;
  std::vector<std::size_t> row;      ///< the row of each observation
  std::vector<int> axis;             ///< its component: 0 x, 1 y, 2 z, 3 n (along the approach)
  std::vector<double> measured_mm;   ///< measured deviation
  std::vector<double> predicted_mm;  ///< the base model's prediction of it
  std::vector<double> residual_mm;   ///< measured - predicted
};

/// Builds the problem from the data and the base model's predicted deviation per (row, axis).
Problem make_problem(const MeasuredData& data, const std::function<double(std::size_t row, int axis)>& predicted_mm);

/// A fitted parameter with its standard uncertainty.
struct Parameter {
  std::string name;  ///< e.g. "amplitude"
  double value = 0;
  double sd = 0;     ///< standard uncertainty (linearised, from the residual variance)
  std::string unit;  ///< e.g. "um", "mm", "s", "ppm"
};

/// One catalogue effect found in the data.
struct Effect {
  std::string
      kind;  ///< catalogue entry: scale, squareness, cross-axis, reversal, cyclic, drift, thermal, acceleration, lobing
  std::string what;         ///< e.g. "cyclic error of x along x"
  std::string explanation;  ///< the physical cause
  std::string condition;    ///< the condition it follows (a column name or "x position")
  int component = 0;        ///< observations it acts on
  std::vector<Parameter> parameters;
  double f_statistic = 0;               ///< extra-sum-of-squares F against the model without it
  double p_value = 1;                   ///< of F, before the multiple-test correction
  double tests = 1;                     ///< Bonferroni factor: candidates and independent search points
  double delta_bic = 0;                 ///< BIC with it minus without (negative: better)
  double cv_rms_mm = 0;                 ///< cross-validated residual RMS once it is added
  nlohmann::json world_term;            ///< the machine.errors term that simulates it (null: not expressible)
  std::vector<double> contribution_mm;  ///< its fitted value per observation
};

/// Structure left in residuals that the catalogue does not explain.
struct Structure {
  std::string condition;  ///< what it follows
  int component = 0;
  std::string test;      ///< "binned means" or "periodogram"
  double statistic = 0;  ///< F
  double p_value = 1;    ///< Bonferroni-corrected
  double size_mm = 0;    ///< range of the binned means, or the amplitude
  double period = 0;     ///< periodogram: the period (in the condition's unit)
};

/// A periodogram (generalised Lomb-Scargle: the F of a sine and cosine at each period).
struct Spectrum {
  std::string against;  ///< "x position", "time", ...
  int component = 0;
  std::vector<double> period;  ///< in the condition's unit
  std::vector<double> power;   ///< fraction of the residual sum of squares explained
};

/// The whole result.
struct Analysis {
  std::size_t observations = 0;
  double rms_base_mm = 0;       ///< RMS of measured - predicted (no fit at all)
  double cv_rms_before_mm = 0;  ///< cross-validated RMS of the base model with its nuisance terms
  double cv_rms_after_mm = 0;   ///< ... with the claimed effects
  double fit_rms_after_mm = 0;  ///< in-sample RMS with the effects
  double noise_mm = 0;          ///< stated or estimated noise of one reading
  bool noise_stated = false;
  std::string noise_source;  ///< how the noise was obtained
  std::string folds;         ///< how the folds were made
  int fold_count = 0;
  std::vector<std::string> nuisance;  ///< terms always fitted (zero offsets, placement)
  std::vector<Effect> effects;        ///< claimed, in the order found
  /// The best remaining candidate when the selection stopped: why it was not claimed.
  std::string stopped_at;
  std::vector<Structure> structure_before;  ///< structure searches on the base residual
  std::vector<Structure> unexplained;       ///< structure left after the effects
  std::vector<Spectrum> spectra_before, spectra_after;
  std::vector<double> residual_after_mm;   ///< per observation, after nuisance and effects
  std::vector<double> residual_before_mm;  ///< per observation, after the nuisance terms only
};

/// Tuning of the analysis.
struct Options {
  int max_effects = 4;
  double alpha = 1e-3;                ///< family-wise level of the significance test
  bool significance = true;           ///< false: claim the best candidate by CV alone (for the mutation check)
  std::vector<std::string> disabled;  ///< catalogue entries left out
  std::function<void(const std::string&)> progress;  ///< called with a line per step
};

/// Runs the analysis.
Analysis analyse(const Problem& problem, const Options& options = {});

/// The catalogue: entry, model, parameters and physical explanation (for docs and reports).
struct CatalogueEntry {
  std::string kind, model, explanation;
};
const std::vector<CatalogueEntry>& catalogue();

/// Upper tail of the F distribution, P(F(d1, d2) > f) (regularised incomplete beta).
double f_upper_tail(double f, double d1, double d2);

/// The body temperature following `temperature_c` (piecewise linear in `time_s`, increasing)
/// through a first-order lag tau (exact per segment; tau 0: the input), starting at the first value.
std::vector<double> first_order_lag(const std::vector<double>& time_s, const std::vector<double>& temperature_c,
                                    double tau_s);

/// The analysis as JSON (results file).
nlohmann::json to_json(const Analysis& analysis);
/// A plain-text summary.
std::string summary(const Analysis& analysis, const MeasuredData& data);

}  // namespace metron::discrepancy
