// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <vector>

#include "metron/stdlib/geometry/vec.hpp"

namespace metron::machine {

/// A commercially flat plate (SEEDS.md 4: no precision artefact needed) with a hidden smooth
/// profile, placeable with its face normal along any machine axis. Simulated truth: only the rig's
/// sensors read it.
class FlatPlate {
 public:
  /// One smooth undulation of the face: A cos(2 pi u / lu + pu) cos(2 pi v / lv + pv) (l = 0: flat that way).
  struct Mode {
    double amplitude_mm = 0;     ///< A
    double wavelength_u_mm = 0;  ///< lu
    double wavelength_v_mm = 0;  ///< lv
    double phase_u = 0;          ///< pu, rad
    double phase_v = 0;          ///< pv, rad
  };
  /// A plate with the given undulations and a bow b ((u/size)^2 + (v/size)^2).
  FlatPlate(std::vector<Mode> modes, double bow_mm, double size_mm);
  /// A commercial plate: 5 random modes of wavelengths 0.4 to 2.5 sizes and a bow, peak-to-valley
  /// about `form_mm` (several um for an ordinary rolled plate), drawn from `seed`.
  static FlatPlate commercial(double form_mm, double size_mm, std::uint64_t seed);

  /// Places the face: normal along machine axis `normal_axis` (0 x, 1 y, 2 z) pointing to
  /// `normal_sign` (+1: the head is on the + side), the face's (u, v) = (0, 0) at `origin_mm`.
  /// u and v are the two other machine axes in ascending order.
  void place(int normal_axis, int normal_sign, const Vec3& origin_mm);

  /// The face height along the normal at plate coordinates (u, v), mm (hidden truth).
  [[nodiscard]] double profile_mm(double u_mm, double v_mm) const;
  /// Height of a machine point above the nominal face plane (along the normal).
  [[nodiscard]] double height_mm(const Vec3& p) const { return m_sign * (p[m_axis] - m_origin[m_axis]); }
  /// Plate coordinates (u, v) of a machine point.
  [[nodiscard]] Vec2 plate_uv(const Vec3& p) const;
  /// The normal axis and sign.
  [[nodiscard]] int normal_axis() const { return m_axis; }
  [[nodiscard]] int normal_sign() const { return m_sign; }  ///< +1 or -1

 private:
  std::vector<Mode> m_modes;
  double m_bow_mm = 0, m_size_mm = 1000;
  int m_axis = 2, m_sign = 1;
  Vec3 m_origin = Vec3::Zero();
};

}  // namespace metron::machine
