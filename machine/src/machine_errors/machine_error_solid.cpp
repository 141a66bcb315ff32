// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/machine_errors/machine_error_solid.hpp"

namespace metron::machine {

MachineErrorSolid::MachineErrorSolid(std::unique_ptr<Solid> actual, MachineErrorModel errors)
    : m_actual(std::move(actual)), m_errors(std::move(errors)) {}

Vec3 MachineErrorSolid::actual_point(const Vec3& p) const {
  MachinePose pose;
  pose.axes_mm = p - m_probe_offset_mm;
  pose.probe_offset_mm = m_probe_offset_mm;
  pose.approach = m_approach;
  return m_errors.actual_tip_mm(pose, m_time_s);
}

double MachineErrorSolid::signed_distance(const Vec3& p) const { return m_actual->signed_distance(actual_point(p)); }

// The error field bends space by its gradient (tens of um per metre), so the true surface normal
// at the actual point is the normal here to within that: far below a probe's resolution.
Vec3 MachineErrorSolid::normal(const Vec3& p) const { return m_actual->normal(actual_point(p)); }

// |grad (p + e(p))| <= 1 + |grad e|; 1 % covers error fields up to 10 mm/m, far beyond any CMM's.
double MachineErrorSolid::lipschitz() const { return m_actual->lipschitz() * 1.01; }

std::string MachineErrorSolid::feature_at(const Vec3& p) const { return m_actual->feature_at(actual_point(p)); }

}  // namespace metron::machine
