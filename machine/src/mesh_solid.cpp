// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/mesh_solid.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace metron::machine {
namespace {

using Kind = geometry::CadFace::Kind;

// Below this a direction from an axis or centre is undefined; the mesh's normal is used there.
constexpr double degenerate_mm = 1e-9;

}  // namespace

MeshSolid::MeshSolid(std::shared_ptr<const geometry::Mesh> mesh, const Frame& part_to_machine,
                     std::vector<Bump> bumps, const std::vector<geometry::CadFace>& faces,
                     double chord_tolerance_mm)
    : m_mesh(std::move(mesh)),
      m_part_to_machine(part_to_machine),
      m_machine_to_part(part_to_machine.inverse(Eigen::Isometry)),
      m_bumps(std::move(bumps)) {
  if (!m_mesh) throw std::invalid_argument("MeshSolid needs a mesh");
  // A Gaussian's steepest slope is amplitude / sigma * exp(-1/2).
  for (const Bump& b : m_bumps) m_lipschitz += std::abs(b.amplitude_mm) / b.sigma_mm * std::exp(-0.5);
  if (faces.empty()) return;

  // Inside a face the closest triangle is at most a chord's sagitta from the surface, so the
  // exact and the mesh distance differ by about the chord tolerance there (1.2 um seen on the DCX
  // part, hence the margin); a larger difference means the closest point is at the face's
  // boundary, where the untrimmed surface can pass much nearer than the face (or on the wrong
  // side), and the mesh's answer is kept.
  m_guard_mm = 1.5 * chord_tolerance_mm + 1e-7;
  const std::size_t n_triangles = m_mesh->face_count();
  m_surface_of_triangle.assign(n_triangles, -1);
  m_shape_of_triangle.assign(n_triangles, 0);
  const auto& vertices = m_mesh->vertices();
  const auto& triangles = m_mesh->faces();
  // Nodes inside a face lie on its surface to rounding; nodes on its boundary come from the edge
  // curves and may be off by the model's edge tolerance (the DCX part: up to 0.94 um).
  constexpr std::uint32_t unowned = 0, shared = ~0u;
  std::vector<std::uint32_t> owner(vertices.size(), unowned);  // the one face using a node
  for (const geometry::CadFace& f : faces)
    for (std::uint32_t t : f.triangles)
      if (t < n_triangles)
        for (std::uint32_t v : triangles[t]) owner[v] = owner[v] == unowned || owner[v] == f.shape_index ? f.shape_index : shared;
  const double interior_mm = 1e-6, boundary_mm = 10 * chord_tolerance_mm;
  for (const geometry::CadFace& f : faces) {
    for (std::uint32_t t : f.triangles)
      if (t < n_triangles) m_shape_of_triangle[t] = f.shape_index;
    auto surface = surface_of(f);
    if (!surface || f.triangles.empty()) continue;
    Surface& s = *surface;
    // Trust the description only if the face's triangles lie on it, and orient it like them
    // (a plane's normal and a curved face's side agree with the mesh's outward winding).
    bool on_surface = true;
    double facing = 0;
    for (std::uint32_t t : f.triangles) {
      if (t >= n_triangles) {
        on_surface = false;
        break;
      }
      const auto& tri = triangles[t];
      Vec3 centroid = Vec3::Zero();
      for (std::uint32_t v : tri) {
        const auto e = exact(s, vertices[v]);
        if (e && std::abs(e->distance_mm) > (owner[v] == f.shape_index ? interior_mm : boundary_mm)) on_surface = false;
        centroid += vertices[v] / 3;
      }
      if (!on_surface) break;
      if (const auto e = exact(s, centroid)) facing += e->normal.dot(m_mesh->face_normal(t));
    }
    if (!on_surface || facing == 0) continue;
    if (facing < 0) {
      if (s.kind == Kind::Plane)
        s.axis = -s.axis;
      else
        s.inner = !s.inner;
    }
    for (std::uint32_t t : f.triangles) m_surface_of_triangle[t] = static_cast<std::int32_t>(m_surfaces.size());
    m_surfaces.push_back(s);
  }
}

std::optional<MeshSolid::Surface> MeshSolid::surface_of(const geometry::CadFace& f) {
  Surface s;
  s.kind = f.kind;
  s.origin = f.origin;
  s.axis = f.axis.normalized();
  s.radius_mm = f.radius_mm;
  s.minor_radius_mm = f.minor_radius_mm;
  s.inner = f.inner;
  switch (f.kind) {
    case Kind::Plane:
    case Kind::Cylinder:
    case Kind::Sphere:
    case Kind::Torus:
      return s;
    case Kind::Cone:
      if (!(f.semi_angle_rad > 1e-9 && f.semi_angle_rad < std::numbers::pi / 2 - 1e-9)) return std::nullopt;
      s.cos_a = std::cos(f.semi_angle_rad);
      s.sin_a = std::sin(f.semi_angle_rad);
      s.origin = f.origin - f.radius_mm / std::tan(f.semi_angle_rad) * s.axis;  // the apex
      return s;
    case Kind::Other:
      break;
  }
  return std::nullopt;
}

std::optional<MeshSolid::Exact> MeshSolid::exact(const Surface& s, const Vec3& q) {
  const Vec3 r = q - s.origin;
  const double h = r.dot(s.axis);
  const Vec3 radial = r - h * s.axis;
  const double rho = radial.norm();
  Exact e{0, Vec3::Zero()};
  switch (s.kind) {
    case Kind::Plane:
      e = {h, s.axis};
      break;
    case Kind::Cylinder:
      if (rho < degenerate_mm) return std::nullopt;
      e = {rho - s.radius_mm, radial / rho};
      break;
    case Kind::Sphere: {
      const double d = r.norm();
      if (d < degenerate_mm) return std::nullopt;
      e = {d - s.radius_mm, r / d};
      break;
    }
    case Kind::Cone: {
      // In the half-plane through the axis: the generator from the apex at the semi-angle, or
      // the apex itself behind it (one nappe, the one the face lies on).
      if (h * s.cos_a + rho * s.sin_a <= 0) {
        const double d = r.norm();
        if (d < degenerate_mm) return std::nullopt;
        e = {d, r / d};
      } else {
        if (rho < degenerate_mm) return std::nullopt;
        e = {rho * s.cos_a - h * s.sin_a, s.cos_a * radial / rho - s.sin_a * s.axis};
      }
      break;
    }
    case Kind::Torus: {
      if (rho < degenerate_mm) return std::nullopt;
      const Vec3 w = r - s.radius_mm / rho * radial;  // from the tube's centre circle
      const double d = w.norm();
      if (d < degenerate_mm) return std::nullopt;
      e = {d - s.minor_radius_mm, w / d};
      break;
    }
    case Kind::Other:
      return std::nullopt;
  }
  if (s.inner) e = {-e.distance_mm, -e.normal};
  return e;
}

MeshSolid::Contact MeshSolid::contact(const Vec3& q, bool need_sign) const {
  const geometry::Mesh::Closest c = m_mesh->closest(q);
  // When the closest point is inside a triangle, the query lies on its normal line and the side
  // is the sign of the offset; at edges and vertices the face normal does not decide it.
  const double along = (q - c.point).dot(m_mesh->face_normal(c.face));
  const bool on_normal_line =
      c.distance_mm > 1e-9 && std::abs(std::abs(along) - c.distance_mm) < 1e-12 * (1 + c.distance_mm);
  const std::int32_t si = m_surface_of_triangle.empty() ? -1 : m_surface_of_triangle[c.face];
  if (si >= 0) {
    if (const auto e = exact(m_surfaces[static_cast<std::size_t>(si)], q)) {
      // Consistent with the mesh distance of either sign unless the side is known; near the
      // surface (both within the guard) the exact side is the better one.
      const double outside = c.distance_mm, inside = -c.distance_mm;
      const bool match = on_normal_line ? std::abs(e->distance_mm - (along < 0 ? inside : outside)) <= m_guard_mm
                                        : std::min(std::abs(e->distance_mm - outside),
                                                   std::abs(e->distance_mm - inside)) <= m_guard_mm;
      if (match) return {e->distance_mm, e->normal, q - e->distance_mm * e->normal};
    }
  }
  double d = c.distance_mm;
  if (need_sign && (on_normal_line ? along < 0 : m_mesh->contains(q))) d = -d;
  return {d, c.normal, c.point};
}

double MeshSolid::bump_height(const Vec3& surface_point) const {
  double h = 0;
  for (const Bump& b : m_bumps)
    h += b.amplitude_mm * std::exp(-(surface_point - b.centre_mm).squaredNorm() / (2 * b.sigma_mm * b.sigma_mm));
  return h;
}

double MeshSolid::signed_distance(const Vec3& p) const {
  const Contact c = contact(m_machine_to_part * p, true);
  return c.distance_mm - bump_height(c.point);
}

Vec3 MeshSolid::normal(const Vec3& p) const {
  // The surface's (or the mesh's contact) normal; the bumps' slope is neglected.
  return m_part_to_machine.linear() * contact(m_machine_to_part * p, false).normal;
}

std::string MeshSolid::feature_at(const Vec3& p) const {
  const std::uint32_t t = m_mesh->closest(m_machine_to_part * p).face;
  if (!m_shape_of_triangle.empty() && m_shape_of_triangle[t] != 0)
    return "face " + std::to_string(m_shape_of_triangle[t]);
  return "face " + std::to_string(t);
}

}  // namespace metron::machine
