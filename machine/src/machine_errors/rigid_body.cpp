// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/machine_errors/rigid_body.hpp"

namespace metron::machine {

RigidBodyTerm::RigidBodyTerm(std::array<AxisErrors, 3> axes, Squareness squareness, std::array<int, 3> stacking)
    : m_axes(std::move(axes)), m_squareness(squareness), m_stacking(stacking) {}

Vec3 RigidBodyTerm::displacement(const MachinePose& pose, double) const {
  const Vec3& q = pose.axes_mm;
  Vec3 e = Vec3::Zero();
  for (std::size_t s = 0; s < 3; ++s) {
    const int a = m_stacking[s];
    const AxisErrors& ax = m_axes[static_cast<std::size_t>(a)];
    const double qa = q[a];
    Vec3 d, eps;
    for (int c = 0; c < 3; ++c) {
      d[c] = ax.translation_mm[static_cast<std::size_t>(c)](qa);
      eps[c] = ax.rotation_rad[static_cast<std::size_t>(c)](qa);
    }
    // ISO 230-1 annex A, first order: the axis' rotation acts on the lever to the tip, i.e. the
    // positions of the axes it carries plus the probe offset (the Abbe error).
    Vec3 lever = pose.probe_offset_mm;
    for (std::size_t later = s + 1; later < 3; ++later) lever[m_stacking[later]] += q[m_stacking[later]];
    e += d + eps.cross(lever);
  }
  e.x() += m_squareness.xy_rad * q.y() + m_squareness.xz_rad * q.z();
  e.y() += m_squareness.yz_rad * q.z();
  return e;
}

Vec3 ReversalTerm::displacement(const MachinePose& pose, double) const {
  Vec3 e = Vec3::Zero();
  for (int a = 0; a < 3; ++a)
    e[a] = 0.5 * m_reversal_mm[static_cast<std::size_t>(a)] * pose.approach[static_cast<std::size_t>(a)];
  return e;
}

}  // namespace metron::machine
