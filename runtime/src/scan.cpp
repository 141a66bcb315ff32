// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/runtime/scan.hpp"

#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "metron/runtime/measurement_plan.hpp"
#include "metron/runtime/measurement_runtime.hpp"

namespace metron::runtime {

geometry::Contour path_contour(const PathDefinition& path, double step_mm) {
  if (path.section) return *path.section;
  if (path.kind == PathDefinition::Kind::Line)
    return geometry::line_contour(path.point, path.point2, path.direction, step_mm);
  geometry::ArcSpec arc;
  arc.centre = path.point;
  arc.axis = path.direction.normalized();
  arc.radius_mm = path.radius_mm;
  arc.reference = path.reference;
  arc.start_deg = path.start_deg;
  arc.sweep_deg = path.end_deg - path.start_deg;
  arc.inner = path.inner;
  arc.pitch_mm = path.kind == PathDefinition::Kind::Helical ? path.pitch_mm : 0.0;
  return geometry::arc_contour(arc, step_mm);
}

tl::expected<geometry::Contour, std::string> nominal_contour(const Geometry& g, const Vec3& start_near, double depth_mm,
                                                             const Vec3& up, const Vec3& arc_reference,
                                                             double step_mm) {
  const Vec3 axis = g.direction.normalized();
  switch (g.type) {
    case FeatureType::Circle:
    case FeatureType::Arc: {
      geometry::ArcSpec arc;
      // Like the touch planner: the circle lies DEPTH below its nominal centre.
      arc.centre = g.position - depth_mm * (axis.dot(up) >= 0 ? up : Vec3(-up));
      arc.axis = axis;
      arc.radius_mm = g.diameter_mm / 2;
      arc.inner = g.side != Side::Outer;
      if (g.type == FeatureType::Arc) {
        arc.reference = arc_reference;
        arc.start_deg = g.start_angle_deg;
        arc.sweep_deg = g.included_angle_deg;
      } else {
        // Start where the probe is nearest, to keep the approach short.
        const Vec3 d = start_near - arc.centre;
        const Vec3 radial = d - d.dot(axis) * axis;
        arc.reference = radial.norm() > 1e-9 ? Vec3(radial.normalized()) : any_perpendicular(axis);
      }
      return geometry::arc_contour(arc, step_mm);
    }
    case FeatureType::Line: {
      if (!(g.length_mm > 0)) return tl::unexpected(std::string("scanning a line needs a bounded line (LINE,BND)"));
      return geometry::line_contour(g.position, g.position + g.length_mm * axis, nominal_normal_at(g, g.position),
                                    step_mm);
    }
    case FeatureType::Plane: {
      // A circle of 5 mm radius on the plane (the touch planner's 4 points lie on it too).
      const Vec3 u = any_perpendicular(axis), v = axis.cross(u);
      const std::size_t n =
          std::max<std::size_t>(8, static_cast<std::size_t>(std::ceil(2 * std::numbers::pi * 5.0 / step_mm)));
      geometry::Contour c;
      c.closed = true;
      for (std::size_t i = 0; i <= n; ++i) {
        const double a = 2 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(n);
        c.points.push_back({g.position + 5.0 * (std::cos(a) * u + std::sin(a) * v), axis});
      }
      c.points.back() = c.points.front();
      return c;
    }
    default:
      return tl::unexpected(
          fmt::format("metron scans CIRCLE, ARC, LINE (BND) and PLANE features by their nominal; "
                      "scan a {} along a PATH with PAMEAS",
                      dmis_word(g.type)));
  }
}

tl::expected<geometry::Contour, std::string> nominal_contour_between(const Geometry& g, const Vec3& start,
                                                                     const Vec3& end, const Vec3& normal,
                                                                     double step_mm) {
  const Vec3 axis = g.direction.normalized();
  switch (g.type) {
    case FeatureType::Circle:
    case FeatureType::Arc:
    case FeatureType::Cylinder: {
      const Vec3 a = start - g.position, b = end - g.position;
      const double ha = a.dot(axis), hb = b.dot(axis);
      const Vec3 ra = a - ha * axis, rb = b - hb * axis;
      if (ra.norm() < 1e-9 || rb.norm() < 1e-9)
        return tl::unexpected(std::string("a scan's start or end lies on the feature's axis"));
      double sweep = std::atan2(ra.cross(rb).dot(axis), ra.dot(rb)) * 180 / std::numbers::pi;
      if (sweep <= 1e-9) sweep += 360;  // counterclockwise; the same point twice is a full turn
      geometry::ArcSpec arc;
      arc.centre = g.position + ha * axis;
      arc.axis = axis;
      arc.radius_mm = g.diameter_mm / 2;
      arc.reference = ra.normalized();
      arc.sweep_deg = sweep;
      arc.inner = g.side != Side::Outer;
      arc.pitch_mm = (hb - ha) * 360.0 / sweep;
      return geometry::arc_contour(arc, step_mm);
    }
    case FeatureType::Line:
    case FeatureType::Plane:
      if ((end - start).norm() < 1e-9) return tl::unexpected(std::string("a scan's start and end are the same point"));
      return geometry::line_contour(start, end, normal, step_mm);
    default:
      return tl::unexpected(
          fmt::format("scan mode with PTMEAS scans CIRCLE, ARC, CYLNDR, LINE and PLANE features; scan a {} "
                      "along a PATH with PAMEAS",
                      dmis_word(g.type)));
  }
}

Result<void> MeasurementRuntime::define_path(PathDefinition path, Span span) {
  // Given in the current frame: stored in machine coordinates like feature nominals.
  path.point = m_alignment.to_machine_point(path.point);
  path.point2 = m_alignment.to_machine_point(path.point2);
  path.direction = m_alignment.to_machine_vector(path.direction);
  path.reference = m_alignment.to_machine_vector(path.reference);
  if (path.direction.norm() < 1e-12) return program_error(span, "the PATH direction i,j,k is a zero vector");
  path.direction.normalize();
  if (path.kind == PathDefinition::Kind::Section) {
    // The model is in part coordinates: place it with the current alignment, then cut it.
    auto it = m_models.find(path.model_path);
    if (it == m_models.end()) {
      if (auto refused = m_policy.refuse_read(path.model_path)) return program_error(span, "PATH/SECTION: " + *refused);
      auto mesh = geometry::load_mesh(path.model_path);
      if (!mesh) return program_error(span, "cannot load the CAD model: " + mesh.error().message);
      it = m_models.emplace(path.model_path, std::move(*mesh)).first;
    }
    const geometry::Mesh placed = it->second.transformed(m_alignment.part_to_machine);
    auto contour = geometry::nearest_contour(geometry::mesh_section_contours(placed, path.point, path.direction, 0.05),
                                             path.point2);
    if (!contour) return program_error(span, "the PATH/SECTION plane does not cut the CAD model");
    if (path.point3) {
      // A sub-range: from the start to the contour's point nearest the end hint, in the contour's
      // direction.
      const Vec3 end = m_alignment.to_machine_point(*path.point3);
      std::size_t last = 0;
      for (std::size_t i = 1; i < contour->points.size(); ++i)
        if ((contour->points[i].position - end).norm() < (contour->points[last].position - end).norm()) last = i;
      if (last == 0) return program_error(span, "PATH/SECTION: the end of the sub-range is where it starts");
      contour->points.resize(last + 1);
      contour->closed = false;
    }
    path.section = std::move(*contour);
  }
  if (path.kind == PathDefinition::Kind::Line && (path.point2 - path.point).norm() < 1e-9)
    return program_error(span, "PATH/LINE needs two different end points");
  const bool round = path.kind == PathDefinition::Kind::Arc || path.kind == PathDefinition::Kind::Helical;
  if (round && !(path.radius_mm > 0)) return program_error(span, "the PATH radius must be positive");
  if (round && path.end_deg == path.start_deg) return program_error(span, "the PATH start and end angles are equal");
  path.span = span;
  m_paths[path.label] = path;
  return {};
}

}  // namespace metron::runtime
