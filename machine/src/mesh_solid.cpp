// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/mesh_solid.hpp"

#include <cmath>
#include <stdexcept>

namespace metron::machine {

MeshSolid::MeshSolid(std::shared_ptr<const geometry::Mesh> mesh, const Frame& part_to_machine,
                     std::vector<Bump> bumps)
    : m_mesh(std::move(mesh)),
      m_part_to_machine(part_to_machine),
      m_machine_to_part(part_to_machine.inverse(Eigen::Isometry)),
      m_bumps(std::move(bumps)) {
  if (!m_mesh) throw std::invalid_argument("MeshSolid needs a mesh");
  // A Gaussian's steepest slope is amplitude / sigma * exp(-1/2).
  for (const Bump& b : m_bumps) m_lipschitz += std::abs(b.amplitude_mm) / b.sigma_mm * std::exp(-0.5);
}

double MeshSolid::bump_height(const Vec3& surface_point) const {
  double h = 0;
  for (const Bump& b : m_bumps)
    h += b.amplitude_mm * std::exp(-(surface_point - b.centre_mm).squaredNorm() / (2 * b.sigma_mm * b.sigma_mm));
  return h;
}

double MeshSolid::signed_distance(const Vec3& p) const {
  const Vec3 q = m_machine_to_part * p;
  const geometry::Mesh::Closest c = m_mesh->closest(q);
  // When the closest point is inside a face, the query lies on that face's normal line and the
  // side is the sign of the offset; at edges and vertices the face normal does not decide it,
  // so ask the (slower) inside test.
  const Vec3 offset = q - c.point;
  const double along = offset.dot(m_mesh->face_normal(c.face));
  const bool on_normal_line = c.distance_mm > 1e-9 && std::abs(std::abs(along) - c.distance_mm) < 1e-12 * (1 + c.distance_mm);
  const bool inside = on_normal_line ? along < 0 : m_mesh->contains(q);
  return (inside ? -c.distance_mm : c.distance_mm) - bump_height(c.point);
}

Vec3 MeshSolid::normal(const Vec3& p) const {
  // The face (or edge/vertex contact) normal; the bumps' slope is neglected.
  return m_part_to_machine.linear() * m_mesh->closest(m_machine_to_part * p).normal;
}

std::string MeshSolid::feature_at(const Vec3& p) const {
  return "face " + std::to_string(m_mesh->closest(m_machine_to_part * p).face);
}

}  // namespace metron::machine
