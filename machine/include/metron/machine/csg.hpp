// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "metron/stdlib/geometry/vec.hpp"

/// The design of a workpiece as a CSG tree of analytic primitives, in PART coordinates, and the
/// deviations of the part as machined (docs/world.md). A primitive's solid is its material.
namespace metron::machine::csg {

/// Material on the side opposite to `normal`: { p : (p - point) . normal <= 0 }.
struct HalfSpace {
  Vec3 point = Vec3::Zero();    ///< on the boundary plane
  Vec3 normal = Vec3::UnitZ();  ///< unit, outward (away from the material)
};

/// Material within diameter/2 of the axis; infinite, or capped from `point` to
/// point + length * axis.
struct Cylinder {
  Vec3 point = Vec3::Zero();        ///< on the axis (the start of the capped cylinder)
  Vec3 axis = Vec3::UnitZ();        ///< unit
  double diameter_mm = 10;          ///< of the cylinder
  std::optional<double> length_mm;  ///< capped when set
};

/// Material within diameter/2 of the centre.
struct Sphere {
  Vec3 centre = Vec3::Zero();  ///< of the sphere
  double diameter_mm = 10;     ///< of the sphere
};

/// Infinite convex cone, material inside the nappe that opens along +axis from the apex.
struct Cone {
  Vec3 apex = Vec3::Zero();    ///< the cone's tip
  Vec3 axis = Vec3::UnitZ();   ///< unit, from the apex into the cone
  double half_angle_deg = 45;  ///< in (0, 90)
};

/// A ring: material within minor_diameter/2 of the circle of major_diameter about `axis`
/// through `centre` (the solid torus).
struct Torus {
  Vec3 centre = Vec3::Zero();     ///< of the centre circle
  Vec3 axis = Vec3::UnitZ();      ///< unit, normal to the centre circle's plane
  double major_diameter_mm = 40;  ///< of the centre circle
  double minor_diameter_mm = 10;  ///< of the tube, < major_diameter_mm
};

/// Material within the ellipse of major_diameter along `major_axis` and minor_diameter across
/// it, swept along `axis` through `point`; infinite, or capped from `point` to
/// point + length * axis (an elliptic hole or boss).
struct EllipticCylinder {
  Vec3 point = Vec3::Zero();        ///< on the axis (the start of the capped cylinder)
  Vec3 axis = Vec3::UnitZ();        ///< unit
  Vec3 major_axis = Vec3::UnitX();  ///< unit, normal to `axis`
  double major_diameter_mm = 20;    ///< along `major_axis`
  double minor_diameter_mm = 10;    ///< across it, <= major_diameter_mm
  std::optional<double> length_mm;  ///< capped when set
};

/// A primitive with the name of the feature it belongs to (empty: unnamed).
struct Primitive {
  std::string name;  ///< feature name for deviations and messages (may be empty)
  std::variant<HalfSpace, Cylinder, Sphere, Cone, Torus, EllipticCylinder> shape;  ///< the geometry, part coordinates
};

/// A node of the tree: a primitive or a boolean operation on the children.
struct Node {
  enum class Op {
    Primitive,     ///< a leaf: `primitive`
    Union,         ///< material of any child
    Intersection,  ///< material of every child
    Difference,    ///< the first child minus all the others
  };
  Op op = Op::Primitive;       ///< leaf or operation
  Primitive primitive;         ///< when op == Primitive
  std::vector<Node> children;  ///< when op != Primitive (at least one)
};

/// Lobed form of a round primitive: amplitude * cos(lobes * (theta - phase)) along the normal,
/// theta the azimuth about the primitive's local z axis (roundness = 2 * amplitude).
struct Lobing {
  int lobes = 3;            ///< undulations per turn
  double amplitude_mm = 0;  ///< half the peak-to-valley
  double phase_deg = 0;     ///< azimuth of a maximum
};

/// Waviness of a plane: amplitude * cos(2 pi u / wavelength - phase) along the normal,
/// u the coordinate along the primitive's local x axis (flatness = 2 * amplitude).
struct Waviness {
  double amplitude_mm = 0;    ///< half the peak-to-valley
  double wavelength_mm = 10;  ///< along the local x axis
  double phase_deg = 0;       ///< phase at u = 0
};

/// How the machined primitive differs from its design (all zero: as designed).
struct Deviation {
  Vec3 offset_mm = Vec3::Zero();  ///< translation, in PART coordinates
  Vec2 tilt_deg = Vec2::Zero();   ///< rotations about the local x then the local y axis, about the local origin
  /// Size: diameter change for cylinders, spheres and cones, the tube's diameter change for a
  /// torus, the change of both diameters of an elliptic cylinder; material added along the
  /// outward normal for half-spaces.
  double size_mm = 0;
  std::optional<Lobing> lobing;      ///< cylinders, spheres, cones, tori (about the axis)
  std::optional<Waviness> waviness;  ///< half-spaces
};

/// Local frame of a primitive (part coordinates): origin at point/centre/apex, z along the
/// axis or normal (the part's z for spheres), x = the part's x projected onto the plane normal
/// to z (the part's y when z is within 25.8 degrees of x), y = z cross x.
Frame local_frame(const Primitive& primitive);

}  // namespace metron::machine::csg
