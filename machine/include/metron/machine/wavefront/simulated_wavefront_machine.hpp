// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <optional>

#include "metron/machine/rng.hpp"
#include "metron/machine/wavefront/wavefront_machine.hpp"
#include "metron/machine/wavefront/wavefront_world.hpp"

namespace metron::machine::wavefront {

/// The hidden quantities the calibration should recover, derived from the world at the machine's
/// current state (for tests and `--truth` only; the procedure never calls this).
struct WavefrontTruth {
  Vec3 step_mm;                ///< true dx, dy, dz
  double gauge_clocking_rad;   ///< gauge x axis from machine X, about Z
  Vec2 gauge_to_a_rad;         ///< angle between the gauge axis and the A axis (in the gauge frame: x, y)
  Vec2 a_to_z_rad;             ///< A axis direction's tilt from Z (x/z, y/z) at the current B, C commands
  Vec2 focus_to_a_mm;          ///< A axis from the focus, in the gauge frame, in the focus plane
  double focus_table_z_steps;  ///< Z command that puts the table surface (on A) at the focus height
  Vec2 part_to_a;  ///< mounted part: centre of curvature (mm) or face normal (rad) from the A axis, gauge frame, at A =
                   ///< current
  Vec2 part_wedge_rad;     ///< mounted flat: face tilt to its base, gauge frame at A = current
  Vec2 table_tilt_rad;     ///< table face tilt to the A axis, gauge frame at A = current
  Vec2 flat_centre_mm;     ///< mounted flat: centre of its clear disc from the A axis, gauge frame
  double xb_mm;            ///< X distance from the B axis to the A axis line at the B axis' height
  double zf_mm;            ///< Z distance from the B axis to the mounted sphere's centre of curvature
  double eccentricity_mm;  ///< X offset of the centre of curvature from the A axis (P of step 4)
  double b_axis_tilt_rad;  ///< B not perpendicular to X-Z
  double yc_mm;            ///< Y distance from the C axis to the A axis line at the C axis' height
  double zc_mm;            ///< Z distance from the B axis to the C axis
};

/// The simulated machine: the kinematic chain and the Fizeau gauge of docs/wavefront.md, with
/// seeded pixel noise (ARCHITECTURE.md rule 3).
class SimulatedWavefrontMachine final : public WavefrontMachine {
 public:
  SimulatedWavefrontMachine(WavefrontWorld world, std::uint64_t seed);

  void move(const AxisCommand& command) override { m_position = command; }
  [[nodiscard]] AxisCommand position() const override { return m_position; }
  tl::expected<GaugeMap, GaugeError> measure() override;
  bool mount(const std::string& part) override;
  [[nodiscard]] std::string mounted_part() const override { return m_mounted; }
  [[nodiscard]] Element element() const override { return m_element; }
  void turn_part_on_table(double deg) override { m_part_turn_deg += deg; }
  void fit_element(Element element) override { m_element = element; }
  void tilt_gauge_mount(double about_x_rad, double about_y_rad) override;
  void shift_rotary_zeros(double b_deg, double c_deg) override;
  [[nodiscard]] const GaugeSpec& gauge() const override { return m_world.gauge; }
  [[nodiscard]] const NominalGeometry& nominal() const override { return m_world.nominal; }
  [[nodiscard]] std::vector<PartSpec> parts() const override;
  [[nodiscard]] long maps_taken() const override { return m_maps; }

  /// A noiseless map (the surface as it sits and its form only), or the fault; does not count.
  [[nodiscard]] tl::expected<GaugeMap, GaugeError> ideal_map() const;
  /// The hidden truth at the current state (tests and --truth only).
  [[nodiscard]] WavefrontTruth truth() const;
  /// The world as loaded.
  [[nodiscard]] const WavefrontWorld& world() const { return m_world; }

 private:
  [[nodiscard]] Frame c_frame() const;        // after the C rotation, origin on the C axis
  [[nodiscard]] Frame spindle_frame() const;  // A axis frame (z along A) at the table's base
  [[nodiscard]] Frame part_frame() const;     // the mounted part's base frame
  [[nodiscard]] Frame gauge_frame() const;    // origin at the focus, z toward the gauge
  [[nodiscard]] const PartSpec* mounted() const;

  WavefrontWorld m_world;
  Rng m_rng;
  AxisCommand m_position;
  Element m_element;
  std::string m_mounted;
  double m_part_turn_deg = 0;
  Mat3 m_gauge_mount = Mat3::Identity();  // the operator's tip/tilt of the gauge mount
  double m_b_shift_rad = 0, m_c_shift_rad = 0;
  long m_maps = 0;
};

}  // namespace metron::machine::wavefront
