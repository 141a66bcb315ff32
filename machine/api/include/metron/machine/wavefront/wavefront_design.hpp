// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>

#include "metron/stdlib/geometry/vec.hpp"

/// What the calibration procedure may know of a wavefront-gauge machine (SEEDS.md 5,
/// docs/wavefront.md): the gauge's specification, the chain's design data, the parts' design data
/// and the axis commands. Part of the machine API: the hidden geometry stays in wavefront_world.hpp,
/// which only the simulation includes (ARCHITECTURE.md rule 1).
namespace metron::machine::wavefront {

/// The gauge's reference element: a transmission sphere (spherical wave through a focus) or a
/// transmission flat (collimated wave).
enum class Element { Sphere, Flat };

/// Nominal gauge data, known to the procedure (the instrument's specification).
struct GaugeSpec {
  double wavelength_nm = 632.8;             ///< HeNe
  int pixels = 128;                         ///< camera pixels across the pupil (square grid)
  double sphere_sin_max = 0.25;             ///< transmission sphere: sine of the marginal ray angle (NA)
  double sphere_reference_radius_mm = 100;  ///< transmission sphere: reference surface to focus
  double flat_radius_mm = 25;               ///< transmission flat: radius of the collimated beam
  double noise_nm = 2;                      ///< rms noise of one pixel's optical path difference
  Element element = Element::Sphere;        ///< the element fitted at the start
};

/// What a part is (design data).
enum class PartKind { Sphere, Flat };

/// One part that the operator can mount on the spindle table. The nominal fields are design data;
/// `decentre_mm`, `wedge_rad` and the form are hidden (how the part was made and seated).
struct PartSpec {
  std::string name;  ///< the operator's name for it ("ball_low", "flat")
  PartKind kind = PartKind::Sphere;
  double radius_mm = 12.5;      ///< sphere: radius of curvature, > 0 convex, < 0 concave
  double thickness_mm = 10;     ///< vertex (sphere) or top face (flat) above the part's base
  double mount_height_mm = 0;   ///< height of the mount the part stands on, above the table
  double clear_radius_mm = 10;  ///< radius of the usable surface around the part's axis
  Vec2 decentre_mm{0, 0};     ///< hidden: lateral offset of the part's axis (sphere: centre of curvature) on its mount
  Vec2 wedge_rad{0, 0};       ///< hidden, flat: tilt of the top face to the base (tangents about y, x)
  double astigmatism_nm = 0;  ///< hidden form: Noll Z6 coefficient of the surface height
  double trefoil_nm = 0;      ///< hidden form: Noll Z9 coefficient
  double spherical_nm = 0;    ///< hidden form: Noll Z11 coefficient
};

/// Design data of the kinematic chain (what the machine's drawing says). All zero offsets by
/// design except the heights.
struct NominalGeometry {
  Vec3 step_mm{1e-4, 1e-4, 1e-4};  ///< nominal step sizes dx, dy, dz (mm per step)
  double zc_mm = 40;               ///< C axis above the B axis
  double table_height_mm = 30;     ///< table surface above the C axis along A
  Vec3 focus_mm{0, 0, 180};        ///< nominal focus position in the machine frame at zero steps
};

/// Axis commands: translations in motor steps, rotations in degrees.
struct AxisCommand {
  Vec3 steps{0, 0, 0};  ///< X, Y, Z in steps
  double a_deg = 0;     ///< spindle
  double b_deg = 0;     ///< rotation about (nominally) Y
  double c_deg = 0;     ///< rotation about (nominally) X
};

}  // namespace metron::machine::wavefront
