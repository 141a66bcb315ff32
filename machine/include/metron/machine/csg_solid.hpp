// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <map>
#include <string>
#include <vector>

#include "metron/machine/csg.hpp"
#include "metron/machine/solid.hpp"

namespace metron::machine {

/// A CSG tree of analytic primitives as a solid. Each primitive has an exact signed distance
/// (half-space, sphere, infinite and capped cylinder, infinite cone); union is min, intersection
/// max, difference max(a, -b): exact where one face is nearest, a lower bound near edges.
/// Deviations act in each primitive's local frame (csg::local_frame): the primitive is moved by
/// offset and tilt, its distance reduced by the size term and by the form (first order in the
/// form slope, which is why lipschitz() grows with it).
class CsgSolid final : public Solid {
 public:
  /// `part_to_machine` places the design; deviations are keyed by primitive name, and a name
  /// that no primitive has throws std::invalid_argument.
  CsgSolid(const csg::Node& design, const Frame& part_to_machine,
           const std::map<std::string, csg::Deviation>& deviations = {});
  ~CsgSolid() override;
  CsgSolid(CsgSolid&&) noexcept;
  CsgSolid& operator=(CsgSolid&&) noexcept;

  [[nodiscard]] double signed_distance(const Vec3& p) const override;
  [[nodiscard]] double lipschitz() const override { return m_lipschitz; }
  [[nodiscard]] std::string feature_at(const Vec3& p) const override;

 private:
  struct Compiled;
  std::unique_ptr<Compiled> m_compiled;
  Frame m_machine_to_part;
  double m_lipschitz = 1;
};

}  // namespace metron::machine
