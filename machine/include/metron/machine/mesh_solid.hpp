// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <memory>
#include <vector>

#include "metron/machine/solid.hpp"
#include "metron/machine/world.hpp"
#include "metron/stdlib/geometry/mesh.hpp"

namespace metron::machine {

/// A closed triangle mesh (e.g. a tessellated STEP part) as a solid: distance to the closest
/// surface point, negative inside (geometry::Mesh::contains), minus a deviation field of
/// Gaussian bumps evaluated at the closest surface point.
class MeshSolid final : public Solid {
 public:
  MeshSolid(std::shared_ptr<const geometry::Mesh> mesh, const Frame& part_to_machine,
            std::vector<Bump> bumps = {});
  [[nodiscard]] double signed_distance(const Vec3& p) const override;
  [[nodiscard]] Vec3 normal(const Vec3& p) const override;
  [[nodiscard]] double lipschitz() const override { return m_lipschitz; }
  [[nodiscard]] std::string feature_at(const Vec3& p) const override;

 private:
  [[nodiscard]] double bump_height(const Vec3& surface_point) const;
  std::shared_ptr<const geometry::Mesh> m_mesh;
  Frame m_part_to_machine;
  Frame m_machine_to_part;
  std::vector<Bump> m_bumps;
  double m_lipschitz = 1;
};

}  // namespace metron::machine
