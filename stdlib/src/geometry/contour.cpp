// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/geometry/contour.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace metron::geometry {
namespace {

std::size_t sample_count(double length_mm, double step_mm) {
  const double step = step_mm > 0 ? step_mm : 0.05;
  return std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(length_mm / step)));
}

}  // namespace

Contour arc_contour(const ArcSpec& arc, double step_mm) {
  const Vec3 axis = arc.axis.normalized();
  Vec3 u = arc.reference - arc.reference.dot(axis) * axis;
  u = u.norm() > 1e-12 ? Vec3(u.normalized()) : any_perpendicular(axis);
  const Vec3 v = axis.cross(u);
  const double sweep = arc.sweep_deg * std::numbers::pi / 180.0;
  const double c = arc.pitch_mm / (2 * std::numbers::pi);  // axial advance per radian
  const double length = std::abs(sweep) * std::hypot(arc.radius_mm, c);
  const std::size_t n = sample_count(length, step_mm);
  Contour out;
  out.closed = arc.pitch_mm == 0 && std::abs(std::abs(arc.sweep_deg) - 360.0) < 1e-9;
  out.points.reserve(n + 1);
  for (std::size_t i = 0; i <= n; ++i) {
    const double dt = sweep * static_cast<double>(i) / static_cast<double>(n);
    const double t = arc.start_deg * std::numbers::pi / 180.0 + dt;
    const Vec3 radial = std::cos(t) * u + std::sin(t) * v;
    out.points.push_back({arc.centre + arc.radius_mm * radial + c * dt * axis, arc.inner ? Vec3(-radial) : radial});
  }
  if (out.closed) out.points.back() = out.points.front();
  return out;
}

Contour line_contour(const Vec3& start, const Vec3& end, const Vec3& normal, double step_mm) {
  const Vec3 d = end - start;
  const double length = d.norm();
  const Vec3 dir = length > 0 ? Vec3(d / length) : Vec3::Zero();
  Vec3 n = normal - normal.dot(dir) * dir;
  n = n.norm() > 1e-12 ? Vec3(n.normalized()) : any_perpendicular(dir);
  const std::size_t count = sample_count(length, step_mm);
  Contour out;
  for (std::size_t i = 0; i <= count; ++i)
    out.points.push_back({start + d * (static_cast<double>(i) / static_cast<double>(count)), n});
  return out;
}

Contour height_field_contour(const HeightField& f, const Vec2& from_xy, const Vec2& to_xy, double step_mm) {
  const std::size_t count = sample_count((to_xy - from_xy).norm(), step_mm);
  constexpr double h = 1e-4;
  Contour out;
  for (std::size_t i = 0; i <= count; ++i) {
    const Vec2 q = from_xy + (to_xy - from_xy) * (static_cast<double>(i) / static_cast<double>(count));
    const double fx = (f(q.x() + h, q.y()) - f(q.x() - h, q.y())) / (2 * h);
    const double fy = (f(q.x(), q.y() + h) - f(q.x(), q.y() - h)) / (2 * h);
    out.points.push_back({Vec3(q.x(), q.y(), f(q.x(), q.y())), Vec3(-fx, -fy, 1.0).normalized()});
  }
  return out;
}

std::vector<Contour> mesh_section_contours(const Mesh& mesh, const Vec3& plane_point, const Vec3& plane_normal,
                                           double step_mm) {
  std::vector<Contour> out;
  for (const auto& raw : mesh.section(plane_point, plane_normal)) {
    std::vector<Vec3> poly;
    for (const auto& p : raw)
      if (poly.empty() || (p - poly.back()).norm() > 1e-9) poly.push_back(p);
    if (poly.size() < 2) continue;
    const bool closed = poly.size() > 2 && (poly.front() - poly.back()).norm() < 1e-9;
    if (closed) poly.back() = poly.front();
    // The midpoint of a section segment lies inside the face it crosses: take that face's normal
    // (not the closest-point normal, which for a query on the surface can be rounding noise).
    std::vector<Vec3> seg_normal;
    for (std::size_t i = 0; i + 1 < poly.size(); ++i)
      seg_normal.push_back(mesh.face_normal(mesh.closest(0.5 * (poly[i] + poly[i + 1])).face));
    const std::size_t m = seg_normal.size();
    Contour c;
    c.closed = closed;
    // A vertex between two faces: a convex edge gets a fan of normals (the ball rolls around it,
    // so the offset has an arc of radius r - E0 there); a concave one the mean normal.
    const auto vertex = [&](const Vec3& at, const Vec3& before, const Vec3& after, const Vec3& travel_after,
                            bool full) {
      const double angle = std::acos(std::clamp(before.dot(after), -1.0, 1.0));
      const bool convex = before.dot(travel_after) < 0;
      if (!(angle > 1e-3) || !convex) {
        const Vec3 n = before + after;
        c.points.push_back({at, n.norm() > 1e-12 ? Vec3(n.normalized()) : after});
        return;
      }
      const Vec3 axis = before.cross(after).normalized();
      const std::size_t k = sample_count(angle, 2.0 * std::numbers::pi / 180.0);
      for (std::size_t j = full ? 0 : k; j <= k; ++j)
        c.points.push_back(
            {at, Eigen::AngleAxisd(angle * static_cast<double>(j) / static_cast<double>(k), axis) * before});
    };
    for (std::size_t i = 0; i < m; ++i) {
      const Vec3 travel = (poly[i + 1] - poly[i]).normalized();
      if (i == 0 && !closed)
        c.points.push_back({poly[0], seg_normal[0]});
      else if (i == 0)
        vertex(poly[0], seg_normal[m - 1], seg_normal[0], travel, false);
      else
        vertex(poly[i], seg_normal[i - 1], seg_normal[i], travel, true);
      const std::size_t k = sample_count((poly[i + 1] - poly[i]).norm(), step_mm);
      for (std::size_t j = 1; j < k; ++j)
        c.points.push_back(
            {poly[i] + (static_cast<double>(j) / static_cast<double>(k)) * (poly[i + 1] - poly[i]), seg_normal[i]});
    }
    if (closed) {
      vertex(poly[0], seg_normal[m - 1], seg_normal[0], (poly[1] - poly[0]).normalized(), true);
      c.points.back() = c.points.front();
    } else {
      c.points.push_back({poly.back(), seg_normal[m - 1]});
    }
    out.push_back(std::move(c));
  }
  return out;
}

std::optional<Contour> nearest_contour(const std::vector<Contour>& contours, const Vec3& near) {
  double best = std::numeric_limits<double>::infinity();
  const Contour* found = nullptr;
  std::size_t at = 0;
  for (const auto& c : contours)
    for (std::size_t i = 0; i < c.points.size(); ++i) {
      const double d = (c.points[i].position - near).norm();
      if (d < best) {
        best = d;
        found = &c;
        at = i;
      }
    }
  if (!found) return std::nullopt;
  Contour out = *found;
  if (out.closed && at > 0 && at + 1 < out.points.size()) {
    out.points.pop_back();  // drop the repeated first point, rotate, close again
    std::rotate(out.points.begin(), out.points.begin() + static_cast<std::ptrdiff_t>(at), out.points.end());
    out.points.push_back(out.points.front());
  }
  if (!out.closed && (out.points.back().position - near).norm() < (out.points.front().position - near).norm())
    std::reverse(out.points.begin(), out.points.end());
  return out;
}

Contour reversed(const Contour& contour) {
  Contour out = contour;
  std::reverse(out.points.begin(), out.points.end());
  return out;
}

Contour offset_contour(const Contour& contour, double offset_mm) {
  Contour out = contour;
  for (auto& p : out.points) p.position += offset_mm * p.normal;
  return out;
}

}  // namespace metron::geometry
