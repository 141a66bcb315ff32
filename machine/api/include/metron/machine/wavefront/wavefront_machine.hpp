// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>
#include <vector>

#include <tl/expected.hpp>

#include "metron/machine/wavefront/gauge_map.hpp"
#include "metron/machine/wavefront/wavefront_design.hpp"

namespace metron::machine::wavefront {

/// What the procedure may do with a wavefront-gauge machine (ARCHITECTURE.md rule 1): command
/// axes, take gauge maps, ask the operator to change the set-up, and read the design data. Nothing
/// here reveals the hidden geometry; a real machine would implement the same interface.
class WavefrontMachine {
 public:
  virtual ~WavefrontMachine() = default;

  /// Moves every axis to the command (translations in steps, rotations in degrees).
  virtual void move(const AxisCommand& command) = 0;
  /// The current commands (the controller's own positions).
  [[nodiscard]] virtual AxisCommand position() const = 0;
  /// One gauge map at the current position, or the instrument's fault.
  virtual tl::expected<GaugeMap, GaugeError> measure() = 0;

  /// Operator: mount the named part (design data in `parts()`); "" removes it.
  virtual bool mount(const std::string& part) = 0;
  /// The part on the table ("" = none), as the operator mounted it.
  [[nodiscard]] virtual std::string mounted_part() const = 0;
  /// The reference element fitted to the gauge.
  [[nodiscard]] virtual Element element() const = 0;
  /// Operator: turn the part on the table about its own axis (reversal), degrees.
  virtual void turn_part_on_table(double deg) = 0;
  /// Operator: change the gauge's reference element (transmission sphere or flat).
  virtual void fit_element(Element element) = 0;
  /// Operator: tip/tilt the gauge mount (radians about the gauge frame's x and y axes).
  virtual void tilt_gauge_mount(double about_x_rad, double about_y_rad) = 0;
  /// Controller: shift the B and C zeros (degrees added to every later command's meaning).
  virtual void shift_rotary_zeros(double b_deg, double c_deg) = 0;

  /// The gauge's specification (design data).
  [[nodiscard]] virtual const GaugeSpec& gauge() const = 0;
  /// The kinematic chain's design data.
  [[nodiscard]] virtual const NominalGeometry& nominal() const = 0;
  /// The parts the operator has, with their design data (hidden fields zeroed).
  [[nodiscard]] virtual std::vector<PartSpec> parts() const = 0;
  /// Number of gauge maps taken so far (for cost accounting).
  [[nodiscard]] virtual long maps_taken() const = 0;
};

}  // namespace metron::machine::wavefront
