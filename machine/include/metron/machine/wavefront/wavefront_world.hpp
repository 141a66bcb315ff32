// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>
#include <tl/expected.hpp>

#include "metron/machine/wavefront/wavefront_design.hpp"
#include "metron/stdlib/geometry/vec.hpp"

/// The six-axis optical machine with an embedded wavefront gauge (SEEDS.md 5, docs/wavefront.md):
/// its hidden geometry (the simulated truth) and the world file; the design data the procedure may
/// know is in wavefront_design.hpp (the machine API).
namespace metron::machine::wavefront {

/// The hidden truth of the machine: where every axis really is (docs/wavefront.md, "The machine").
struct HiddenGeometry {
  Vec3 step_mm{1e-4, 1e-4, 1e-4};  ///< true step sizes dx, dy, dz
  Vec3 focus_mm{0, 0, 180};        ///< the transmission sphere's focus at zero steps (machine frame)
  double gauge_tilt_x_rad = 0;     ///< gauge frame rotation about machine X
  double gauge_tilt_y_rad = 0;     ///< gauge frame rotation about machine Y
  double gauge_clocking_rad = 0;   ///< gauge frame rotation about its optical axis
  double b_zero_rad = 0;           ///< B encoder zero error (actual = command + error - correction)
  double c_zero_rad = 0;           ///< C encoder zero error
  Vec2 a_tilt_rad{0, 0};           ///< the spindle's own tilt in the C frame (toward x, toward y)
  double b_axis_tilt_rad = 0;      ///< B axis turned about Z toward X: B not perpendicular to X-Z
  double zc_mm = 40;               ///< C axis above the B axis
  double xb_mm = 0;                ///< A axis from the B axis along X
  double yc_mm = 0;                ///< A axis from the C axis along Y
  double table_height_mm = 30;     ///< table surface above the C axis along A
  Vec2 table_tilt_rad{0, 0};       ///< table face normal to the A axis (tangents about y, x)
};

/// A world of kind "wavefront" (docs/wavefront.md).
struct WavefrontWorld {
  std::string name;        ///< free text
  std::uint64_t seed = 1;  ///< default noise seed
  GaugeSpec gauge;
  NominalGeometry nominal;
  HiddenGeometry hidden;
  std::vector<PartSpec> parts;  ///< the parts the operator can mount
  std::string mounted;          ///< the part on the table at the start ("" = none)
  AxisCommand start;            ///< axis commands at the start
};

/// Parses a world of kind "wavefront" strictly: unknown keys are errors naming their JSON
/// pointer. The message is "source: /pointer: what was expected".
tl::expected<WavefrontWorld, std::string> parse_wavefront_world(const nlohmann::json& json,
                                                                const std::string& source_name);
/// Reads and parses a file (see parse_wavefront_world).
tl::expected<WavefrontWorld, std::string> load_wavefront_world(const std::string& path);

}  // namespace metron::machine::wavefront
