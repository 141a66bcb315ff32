// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/active_scanning/scanning_probe.hpp"

#include <algorithm>
#include <cmath>

#include "metron/machine/mesh_solid.hpp"

namespace metron::machine {

ScanningProbe::ScanningProbe(const Solid& solid, double true_ball_radius_mm, const ScanningProbeTruth& truth,
                             double reference_deflection_mm, Rng& rng)
    : m_solid(solid),
      m_radius_mm(true_ball_radius_mm),
      m_truth(truth),
      m_reference_deflection_mm(reference_deflection_mm),
      m_rng(rng) {}

Vec3 ScanningProbe::deflection(const Vec3& head_mm) {
  // The head moves a few um per cycle: queries go to a local view of the solid (the same values,
  // cheaper when the nearest surface is within the view's radius), renewed every `renew_mm` of
  // travel. Its radius covers the ball centre (one ball radius from the surface, E0 from the
  // head) over that travel, with room for deflection errors; beyond, the view asks the solid.
  // With the mesh's coherent search (the default) a view serves longer: its build, not its
  // queries, is then the larger cost.
  const bool coherent = MeshSolid::coherent_search_enabled();
  const double renew_mm = coherent ? 1.0 : 0.2;
  const double view_radius_mm = m_radius_mm + m_reference_deflection_mm + renew_mm + 0.3;
  // A free ball stays free while the head is nearer to where it was last free than that
  // distance's excess over the radius allows (|grad d| <= lipschitz): no query needed. The slack
  // covers the steps of MeshSolid's exact CAD faces (about 1.5 chord tolerances) at face edges.
  constexpr double slack_mm = 0.01;
  if (coherent &&
      std::max(1.0, m_solid.lipschitz()) * (head_mm - m_free_head).norm() < m_free_distance_mm - m_radius_mm - slack_mm)
    return Vec3::Zero();
  if (!m_view || (head_mm - m_view_centre).norm() > renew_mm) {
    m_view = m_solid.local_view(head_mm, view_radius_mm);
    m_view_centre = head_mm;
  }
  const Solid& solid = *m_view;
  double d = solid.signed_distance(head_mm);
  m_free_distance_mm = 0;
  if (d >= m_radius_mm) {
    m_free_head = head_mm, m_free_distance_mm = d;
    return Vec3::Zero();
  }
  // The ball is pushed out along the surface normal until its centre is one radius from the
  // actual surface: Newton steps on signed_distance(c) = r (one is exact on a plane).
  Vec3 c = head_mm;
  for (int i = 0; i < 4; ++i) {
    const Vec3 n = solid.normal(c);
    c += (m_radius_mm - d) * n;
    d = solid.signed_distance(c);
    if (std::abs(d - m_radius_mm) < 1e-8) break;
  }
  return c - head_mm;
}

Vec3 ScanningProbe::read(const Vec3& true_deflection_mm) {
  if (m_truth.noise_mm <= 0) return true_deflection_mm;
  // Three normal draws always, so the draw order never depends on the contact state.
  const Vec3 noise(m_rng.normal(), m_rng.normal(), m_rng.normal());
  if (true_deflection_mm.isZero()) return true_deflection_mm;  // a free stylus reads zero (deadband)
  return true_deflection_mm + m_truth.noise_mm * noise;
}

}  // namespace metron::machine
