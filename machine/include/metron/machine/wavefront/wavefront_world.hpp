// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>
#include <tl/expected.hpp>

#include "metron/stdlib/geometry/vec.hpp"

/// The six-axis optical machine with an embedded wavefront gauge (SEEDS.md 5, docs/wavefront.md):
/// its design data (visible to the procedure) and its hidden geometry (the simulated truth).
namespace metron::machine::wavefront {

/// The gauge's reference element: a transmission sphere (spherical wave through a focus) or a
/// transmission flat (collimated wave).
enum class Element { Sphere, Flat };

/// Nominal gauge data, known to the procedure (the instrument's specification).
struct GaugeSpec {
  double wavelength_nm = 632.8;        ///< HeNe
  int pixels = 128;                    ///< camera pixels across the pupil (square grid)
  double sphere_sin_max = 0.25;        ///< transmission sphere: sine of the marginal ray angle (NA)
  double sphere_reference_radius_mm = 100;  ///< transmission sphere: reference surface to focus
  double flat_radius_mm = 25;          ///< transmission flat: radius of the collimated beam
  double noise_nm = 2;                 ///< rms noise of one pixel's optical path difference
  Element element = Element::Sphere;   ///< the element fitted at the start
};

/// What a part is (design data).
enum class PartKind { Sphere, Flat };

/// One part that the operator can mount on the spindle table. The nominal fields are design data;
/// `decentre_mm`, `wedge_rad` and the form are hidden (how the part was made and seated).
struct PartSpec {
  std::string name;                 ///< the operator's name for it ("ball_low", "flat")
  PartKind kind = PartKind::Sphere;
  double radius_mm = 12.5;          ///< sphere: radius of curvature, > 0 convex, < 0 concave
  double thickness_mm = 10;         ///< vertex (sphere) or top face (flat) above the part's base
  double mount_height_mm = 0;       ///< height of the mount the part stands on, above the table
  double clear_radius_mm = 10;      ///< radius of the usable surface around the part's axis
  Vec2 decentre_mm{0, 0};           ///< hidden: lateral offset of the part's axis (sphere: centre of curvature) on its mount
  Vec2 wedge_rad{0, 0};             ///< hidden, flat: tilt of the top face to the base (tangents about y, x)
  double astigmatism_nm = 0;        ///< hidden form: Noll Z6 coefficient of the surface height
  double trefoil_nm = 0;            ///< hidden form: Noll Z9 coefficient
  double spherical_nm = 0;          ///< hidden form: Noll Z11 coefficient
};

/// Design data of the kinematic chain (what the machine's drawing says). All zero offsets by
/// design except the heights.
struct NominalGeometry {
  Vec3 step_mm{1e-4, 1e-4, 1e-4};   ///< nominal step sizes dx, dy, dz (mm per step)
  double zc_mm = 40;                ///< C axis above the B axis
  double table_height_mm = 30;      ///< table surface above the C axis along A
  Vec3 focus_mm{0, 0, 180};         ///< nominal focus position in the machine frame at zero steps
};

/// The hidden truth of the machine: where every axis really is (docs/wavefront.md, "The machine").
struct HiddenGeometry {
  Vec3 step_mm{1e-4, 1e-4, 1e-4};   ///< true step sizes dx, dy, dz
  Vec3 focus_mm{0, 0, 180};         ///< the transmission sphere's focus at zero steps (machine frame)
  double gauge_tilt_x_rad = 0;      ///< gauge frame rotation about machine X
  double gauge_tilt_y_rad = 0;      ///< gauge frame rotation about machine Y
  double gauge_clocking_rad = 0;    ///< gauge frame rotation about its optical axis
  double b_zero_rad = 0;            ///< B encoder zero error (actual = command + error - correction)
  double c_zero_rad = 0;            ///< C encoder zero error
  Vec2 a_tilt_rad{0, 0};            ///< the spindle's own tilt in the C frame (toward x, toward y)
  double b_axis_tilt_rad = 0;       ///< B axis turned about Z toward X: B not perpendicular to X-Z
  double zc_mm = 40;                ///< C axis above the B axis
  double xb_mm = 0;                 ///< A axis from the B axis along X
  double yc_mm = 0;                 ///< A axis from the C axis along Y
  double table_height_mm = 30;      ///< table surface above the C axis along A
  Vec2 table_tilt_rad{0, 0};        ///< table face normal to the A axis (tangents about y, x)
};

/// Axis commands: translations in motor steps, rotations in degrees.
struct AxisCommand {
  Vec3 steps{0, 0, 0};  ///< X, Y, Z in steps
  double a_deg = 0;     ///< spindle
  double b_deg = 0;     ///< rotation about (nominally) Y
  double c_deg = 0;     ///< rotation about (nominally) X
};

/// A world of kind "wavefront" (docs/wavefront.md).
struct WavefrontWorld {
  std::string name;                 ///< free text
  std::uint64_t seed = 1;           ///< default noise seed
  GaugeSpec gauge;
  NominalGeometry nominal;
  HiddenGeometry hidden;
  std::vector<PartSpec> parts;      ///< the parts the operator can mount
  std::string mounted;              ///< the part on the table at the start ("" = none)
  AxisCommand start;                ///< axis commands at the start
};

/// Parses a world of kind "wavefront" strictly: unknown keys are errors naming their JSON
/// pointer. The message is "source: /pointer: what was expected".
tl::expected<WavefrontWorld, std::string> parse_wavefront_world(const nlohmann::json& json,
                                                                const std::string& source_name);
/// Reads and parses a file (see parse_wavefront_world).
tl::expected<WavefrontWorld, std::string> load_wavefront_world(const std::string& path);

}  // namespace metron::machine::wavefront
