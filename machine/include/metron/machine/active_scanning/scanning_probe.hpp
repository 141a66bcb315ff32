// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <memory>

#include "metron/machine/active_scanning/scanning_spec.hpp"
#include "metron/machine/rng.hpp"
#include "metron/machine/solid.hpp"

namespace metron::machine {

/// The analogue probe in the simulated world: its stylus ball, of the true radius, rests at the
/// head position (the undeflected ball centre, what the encoders measure) unless the actual
/// surface pushes it out. Quasi-static: the stylus's own resonance is far above the servo's, so
/// the ball sits where the surface holds it in every cycle.
class ScanningProbe {
 public:
  /// `solid` is everything the ball can touch (must outlive the probe); `reference_deflection_mm`
  /// (E0 as configured) sizes the probe's local view of the solid.
  ScanningProbe(const Solid& solid, double true_ball_radius_mm, const ScanningProbeTruth& truth,
                double reference_deflection_mm, Rng& rng);

  /// The true deflection Ep for the head at `head_mm`: zero when the ball is free, else the
  /// displacement of the ball centre from the head, which points out of the material.
  [[nodiscard]] Vec3 deflection(const Vec3& head_mm);
  /// One reading of the deflection sensor: the true deflection plus the sensor's noise.
  [[nodiscard]] Vec3 read(const Vec3& true_deflection_mm);
  /// The contact force for a deflection, N.
  [[nodiscard]] double force_n(const Vec3& deflection_mm) const {
    return m_truth.stiffness_n_mm * deflection_mm.norm();
  }

 private:
  const Solid& m_solid;
  std::unique_ptr<Solid> m_view;  ///< m_solid's local view about m_view_centre
  Vec3 m_view_centre = Vec3::Zero();
  Vec3 m_free_head = Vec3::Zero();  ///< the last head position with a free ball
  double m_free_distance_mm = 0;    ///< the solid's distance there (0: in contact since)
  double m_radius_mm;
  ScanningProbeTruth m_truth;
  double m_reference_deflection_mm;
  Rng& m_rng;
};

}  // namespace metron::machine
