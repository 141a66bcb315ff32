// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <utility>

#include "metron/machine/error_space/plate.hpp"
#include "metron/machine/machine_errors/axis_function.hpp"
#include "metron/machine/machine_errors/error_model.hpp"
#include "metron/machine/rng.hpp"
#include "metron/stdlib/error_space/two_point.hpp"

namespace metron::machine {

/// The two-sensor head of SEEDS.md 4 (hidden truth except `spacing_mm`, `noise_sd_mm` as a
/// datasheet value, and the sensor offset, which the user sets up).
struct TwoPointHead {
  double spacing_mm = 20;       ///< d: B sits d ahead of A along the step direction
  double delta_mm = 0.0023;     ///< hidden: B's tip is this much nearer the plate than A's
  double zero_a_mm = 0.0011;    ///< hidden zero offset of A
  double zero_b_mm = -0.0007;   ///< hidden zero offset of B
  double noise_sd_mm = 0.0001;  ///< white noise of every reading (0.1 um)
  double linearity_per_mm = 0;  ///< hidden nonlinearity: r -> r + k r^2 (r from the nominal standoff)
  double standoff_mm = 1;       ///< nominal gap at which the sensors read zero
  /// Hidden pitch of the head itself during the move (rad, as a function of the travel along the
  /// line, mm), about its centre: A's gap changes by +theta d/2, B's by -theta d/2. The seed
  /// assumes none.
  AxisFunction pitch_rad;
  /// Hidden error of the spacing: B actually sits d + this ahead of A (the steps stay d), so A
  /// and B no longer read the same plate point; matters on a plate far from flat.
  double spacing_error_mm = 0;
  /// Hidden change of Delta when the sensors are turned 90 degrees (S4 assumes none).
  double delta_change_turned_mm = 0;
  Vec3 sensor_offset_mm{0, 0, -120};  ///< A's tip from the ram reference point (an Abbe lever for the angular errors)
  /// An angle instrument on the head (electronic level or autocollimator, zero set by reversal):
  /// reads the head's true rotation in the plane of the line and the plate normal (the machine's
  /// angular errors and the head's own pitch) with white noise, at every position.
  bool angle_instrument = false;
  double angle_noise_sd_rad = 0.25e-6;  ///< its noise (0.05 arcsec, a good autocollimator's repeatability)
};

/// The head on the (hidden-error) machine facing a plate: produces readings only. Every reading
/// advances simulated time by `dwell_s`.
class TwoPointRig {
 public:
  /// `errors` must outlive the rig.
  TwoPointRig(const MachineErrorModel& errors, FlatPlate plate, TwoPointHead head, std::uint64_t seed,
              double start_time_s = 0);

  /// Moves the plate (SEEDS.md 4: the plate for each plane; the same plate, so the same profile).
  void place_plate(int normal_axis, int normal_sign, const Vec3& origin_mm) {
    m_plate.place(normal_axis, normal_sign, origin_mm);
  }
  /// The readings (a, b) with the ram at `axes_mm`, the sensors lined up along machine axis
  /// `step_axis` (turned 90 degrees when that changes), `travel_mm` along the line for the head pitch.
  /// `reversed`: the head turned 180 degrees, B one step behind A.
  std::pair<double, double> read(const Vec3& axes_mm, int step_axis, double travel_mm, bool turned = false,
                                 bool reversed = false);
  /// A line: steps+1 head positions from `start_axes_mm` in steps of d along `step_axis`
  /// (`turned`: the sensors turned 90 degrees from their first orientation).
  error_space::LineReadings measure_line(const Vec3& start_axes_mm, int step_axis, int steps, bool turned = false,
                                         bool reversed = false);
  /// S1 and S4 of SEEDS.md 4 on the plate as placed: lines along u at v_0..v_m, then along v at
  /// u_0 and u_l; grid origin `origin_axes_mm` (ram positions), steps of d.
  error_space::SurfaceReadings measure_surface(const Vec3& origin_axes_mm, int u_axis, int v_axis, int l_steps,
                                               int m_steps);

  /// The angle instrument's reading at the last `read` (rad; see LineReadings::angle_rad).
  [[nodiscard]] double last_angle_rad() const { return m_last_angle_rad; }
  [[nodiscard]] double time_s() const { return m_time_s; }           ///< simulated time now
  [[nodiscard]] const TwoPointHead& head() const { return m_head; }  ///< the head
  [[nodiscard]] const FlatPlate& plate() const { return m_plate; }   ///< the plate (hidden profile)
  double dwell_s = 0.5;                                              ///< simulated time per reading (move and settle)

 private:
  const MachineErrorModel& m_errors;
  FlatPlate m_plate;
  TwoPointHead m_head;
  Rng m_rng;
  double m_time_s = 0;
  double m_last_angle_rad = 0;
};

}  // namespace metron::machine
