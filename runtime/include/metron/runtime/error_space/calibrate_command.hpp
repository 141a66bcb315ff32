// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <functional>
#include <string>

#include <tl/expected.hpp>

#include "metron/stdlib/error_space/error_space.hpp"

namespace metron::runtime {

/// CALL/EXTERN,SYS,'CALIBRATE ERROR-SPACE [KEY=VALUE | REVERSAL]...' (docs/error-space.md, "From a
/// DMIS program"): the grid and the instruments of the sequential two-point calibration, with the
/// defaults of `metron calibrate error-space`.
struct ErrorSpaceRequest {
  std::array<int, 3> size{11, 11, 3};                  ///< SIZE=nx,ny,nz grid points
  std::array<double, 3> origin_mm{100, 100, 0};        ///< ORIGIN=x,y,z ram position of the first point
  double step_mm = 50;                                 ///< STEP=d grid step, the head's sensor spacing
  std::array<bool, 3> components{false, false, true};  ///< COMPONENTS=xyz plates facing these axes
  double sensor_noise_um = 0.1;                        ///< NOISE=um each reading's white noise
  bool reversal = false;                               ///< REVERSAL: Delta by turning the head 180 degrees
  bool angle_instrument = false;                       ///< ANGLE[=urad]: the head's rotation read and removed
  double angle_noise_urad = 0.25;                      ///<   with this noise
  std::array<double, 3> sensor_offset_mm{0, 0, -120};  ///< OFFSET=x,y,z sensor A's tip from the ram reference
  int runs = 1;                                        ///< RUNS=n every plane n times, averaged
  int laser_cycles = 2;                                ///< LASER=n bidirectional ISO 230-2 runs tying the planes
};

/// Reads the words after CALIBRATE ERROR-SPACE (keys case-insensitive); the error quotes the word.
/// Grids are bounded (at most 250 000 points, each count 1..1000) so a program cannot hang a run.
tl::expected<ErrorSpaceRequest, std::string> parse_error_space_request(const std::string& words);

/// What the rig and the method produced: the recovered space (its sd_mm the noise floor), and the
/// S7 verdicts.
struct ErrorSpaceOutcome {
  error_space::ErrorSpace space;
  int planes = 0;
  int planes_to_remeasure = 0;
};

/// Runs the calibration on the run's machine. The composition root provides it: the rig is
/// simulation, not the runtime's to build (ARCHITECTURE.md); the error says why it failed.
using ErrorSpaceRig = std::function<tl::expected<ErrorSpaceOutcome, std::string>(const ErrorSpaceRequest&)>;

/// The files CALIBRATE ERROR-SPACE writes into the run's output directory.
inline constexpr const char* kErrorSpaceFileName = "error-space.json";
inline constexpr const char* kErrorSpaceReportName = "error-space.svg";

}  // namespace metron::runtime
