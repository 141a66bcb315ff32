// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstddef>
#include <vector>

#include "metron/stdlib/geometry/pcc.hpp"

namespace metron::machine {

/// The controller's place on a PCC path: the foot P of the perpendicular dropped from the probe
/// position onto the path (SEEDS.md 1, Vc1), tracked from cycle to cycle by local Newton steps so
/// that it moves along the path continuously (a closed or self-approaching path never jumps).
class PathCursor {
 public:
  /// `path` must have at least one segment of positive length and outlive the cursor.
  explicit PathCursor(const geometry::PccPath& path);

  /// Takes in segments appended to the path since construction or the last call (a path that
  /// grows while it is scanned: segmented scanning loads it command by command).
  void extend();

  /// Moves the foot to the local closest point of the path to `p_mm`.
  void project(const Vec3& p_mm);

  [[nodiscard]] Vec3 foot_mm() const { return seg().point(m_s); }
  /// Unit tangent at the foot, in the path's direction.
  [[nodiscard]] Vec3 tangent() const { return seg().tangent(m_s); }
  /// Curvature at the foot, 1/mm.
  [[nodiscard]] double curvature_1_mm() const { return seg().curvature(m_s); }
  /// The nominal surface normal at the foot, interpolated between interpolation points
  /// (`fallback` when the path carries no normals).
  [[nodiscard]] Vec3 nominal_normal(const Vec3& fallback) const;
  /// Arc length from the path start to the foot.
  [[nodiscard]] double arc_mm() const;
  [[nodiscard]] double length_mm() const { return m_cumulative.back(); }
  [[nodiscard]] std::size_t segment() const { return m_segment; }

 private:
  [[nodiscard]] const geometry::PccSegment& seg() const { return m_path.segments[m_segment]; }
  const geometry::PccPath& m_path;
  std::vector<double> m_cumulative;  ///< arc length at each segment start, plus the total
  std::size_t m_segment = 0;
  double m_s = 0;  ///< parameter S on the current segment
};

}  // namespace metron::machine
