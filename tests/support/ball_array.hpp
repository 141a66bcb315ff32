// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>
#include <vector>

#include "metron/machine/compensation/error_map.hpp"
#include "metron/machine/error_space/calibration.hpp"
#include "metron/machine/machine.hpp"
#include "metron/machine/machine_errors/error_model.hpp"
#include "metron/stdlib/error_space/error_space_file.hpp"

// The artefact side of the compensation gain (issue 12, docs/error-space.md "The gain of
// compensation"): balls measured by touch on any machine::Machine, the length errors of their
// centres against the true ones, and the ideal maps taken from a world's hidden errors (for tests
// and benchmarks only: a controller never has them).
namespace metron::test_support {

/// The measured centres of a set of balls (ball-centre fits of 9 touches each).
struct BallMeasurement {
  std::vector<Vec3> centres_mm;  ///< one per ball, in order
  std::string error;             ///< empty when every touch succeeded
  double simulated_time_s = 0;   ///< the machine's clock at the end
};

/// Touches each ball (nominal centre, diameter) at its top, 4 points at 45 degrees and 4 on the
/// equator, with a tool T1 of 4 mm diameter on a 50 mm vertical stylus, travelling between balls
/// at `safe_z_mm`; the centre is the sphere fit of the 9 ball-centre points (free of the probe's
/// effective radius).
BallMeasurement measure_balls(machine::Machine& cmm, const std::vector<Vec3>& nominal_centres_mm, double diameter_mm,
                              double safe_z_mm);

/// Every pair's measured distance minus its true distance (ISO 10360-2 style length errors).
struct LengthErrors {
  double rms_mm = 0;      ///< RMS over the pairs
  double max_abs_mm = 0;  ///< largest |error|
  std::size_t pairs = 0;  ///< number of pairs
};
LengthErrors length_errors(const std::vector<Vec3>& measured_mm, const std::vector<Vec3>& truth_mm);

/// The ideal map: the world's hidden error at the tip, exactly (ram = q - stylus offset).
class TruthErrorMap final : public machine::ErrorMap {
 public:
  TruthErrorMap(machine::MachineErrorModel model, const Vec3& stylus_offset_mm)
      : m_model(std::move(model)), m_stylus_offset_mm(stylus_offset_mm) {}
  [[nodiscard]] Vec3 error_at_mm(const Vec3& q_mm) const override;

 private:
  machine::MachineErrorModel m_model;
  Vec3 m_stylus_offset_mm;
};

/// The ideal error-space file: the hidden error sampled at the grid (ram positions, the tip at
/// `stylus_offset_mm`), all three components, no reference removed.
error_space::ErrorSpaceFile truth_error_space(const machine::MachineErrorModel& model, const error_space::Grid& grid,
                                              const Vec3& stylus_offset_mm, const error_space::InterpolationSpec& spec);

}  // namespace metron::test_support
