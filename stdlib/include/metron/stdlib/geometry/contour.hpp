// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <functional>
#include <optional>
#include <vector>

#include "metron/stdlib/geometry/mesh.hpp"
#include "metron/stdlib/geometry/vec.hpp"

// Contour points (x,y,z,P,Q,R) from design data, the first step of SEEDS.md 1:
// CAD surface -> contour points -> offset contour points -> PCC path.
namespace metron::geometry {

/// One contour point: a point on the design surface and the unit surface normal there, pointing
/// out of the material towards the probe (DMIS x,y,z,i,j,k; the seed's x,y,z,P,Q,R).
struct ContourPoint {
  Vec3 position = Vec3::Zero();  ///< on the surface, mm
  Vec3 normal = Vec3::UnitZ();   ///< unit, out of the material
};

/// An ordered, densely sampled contour on a surface, in the direction of scanning.
struct Contour {
  std::vector<ContourPoint> points;  ///< consecutive points no farther apart than the sampling step
  bool closed = false;               ///< the last point repeats the first
};

/// A circle or circular arc on a cylinder (or in a plane): centre, unit axis, radius; angles in
/// degrees counterclockwise about `axis` from `reference` (projected perpendicular to the axis).
/// INNER (a bore, `inner` = true) has normals toward the axis, OUTER away from it. A sweep of
/// +-360 gives a closed contour. Sampled at most `step_mm` apart.
struct ArcSpec {
  Vec3 centre = Vec3::Zero();
  Vec3 axis = Vec3::UnitZ();
  double radius_mm = 10;
  Vec3 reference = Vec3::UnitX();  ///< direction of angle 0
  double start_deg = 0;
  double sweep_deg = 360;  ///< signed: negative runs clockwise about `axis`
  bool inner = true;
  double pitch_mm = 0;  ///< helix: advance along `axis` per turn (0: a circle)
};
Contour arc_contour(const ArcSpec& arc, double step_mm = 0.05);

/// A straight line on a plane from `start` to `end`, with the plane's unit normal (out of the
/// material). The normal is made perpendicular to the line.
Contour line_contour(const Vec3& start, const Vec3& end, const Vec3& normal, double step_mm = 0.05);

/// A free-form surface z = f(x, y) (material below), for analytic test shapes and design data
/// given as a formula.
using HeightField = std::function<double(double x, double y)>;
/// The curve of the height field above the straight line from (x0,y0) to (x1,y1): the section
/// of the surface by the vertical plane through that line. Normals from the analytic gradient
/// (central differences of f with step 1e-4 mm). Sampled at most `step_mm` apart in x,y.
Contour height_field_contour(const HeightField& f, const Vec2& from_xy, const Vec2& to_xy, double step_mm = 0.05);

/// Plane sections of a mesh (the Mesh facade's slicer): every polyline the plane cuts, resampled
/// to at most `step_mm` between points; normals from the faces the polyline crosses. At a convex
/// edge the vertex repeats with normals turning from one face's to the next (every 2 degrees), so
/// the offset rolls around it on an arc; a concave edge gets the mean normal. Closed polylines
/// give closed contours. Direction as
/// `Mesh::section` (counterclockwise about the plane normal for outer boundaries).
std::vector<Contour> mesh_section_contours(const Mesh& mesh, const Vec3& plane_point, const Vec3& plane_normal,
                                           double step_mm = 0.05);

/// The contour among `contours` that passes nearest to `near` (nullopt if there are none). A
/// closed contour is rotated to start at its point nearest to `near`; an open one is reversed
/// when its last point is nearer to `near` than its first.
std::optional<Contour> nearest_contour(const std::vector<Contour>& contours, const Vec3& near);

/// The contour run backwards (scan in the opposite direction).
Contour reversed(const Contour& contour);

/// Every point moved along its normal by `offset_mm` (SEEDS.md 1: offset by r - E0 gives the
/// ball-centre path at the reference deflection).
Contour offset_contour(const Contour& contour, double offset_mm);

}  // namespace metron::geometry
