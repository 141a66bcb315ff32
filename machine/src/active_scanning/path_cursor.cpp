// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/active_scanning/path_cursor.hpp"

#include <algorithm>
#include <cmath>

namespace metron::machine {

PathCursor::PathCursor(const geometry::PccPath& path) : m_path(path) {
  m_cumulative.push_back(0);
  for (const auto& s : path.segments) m_cumulative.push_back(m_cumulative.back() + s.length());
}

void PathCursor::extend() {
  for (std::size_t i = m_cumulative.size() - 1; i < m_path.segments.size(); ++i)
    m_cumulative.push_back(m_cumulative.back() + m_path.segments[i].length());
}

void PathCursor::project(const Vec3& p) {
  // Newton on f(S) = (X(S) - p) . X'(S) = 0; a step past a segment end continues on the
  // neighbour (at most a few hops per cycle: the probe moves far less than a segment).
  for (int it = 0; it < 12; ++it) {
    const geometry::PccSegment& g = seg();
    const Vec3 e = g.point(m_s) - p;
    const Vec3 d1 = g.derivative(m_s);
    const double f = e.dot(d1);
    double df = d1.squaredNorm() + e.dot(g.second_derivative(m_s));
    if (df < 0.1 * d1.squaredNorm()) df = d1.squaredNorm();  // stay a descent step far off the path
    const double step = -f / df;
    double s = m_s + step;
    if (s < 0 && m_segment > 0) {
      --m_segment;
      m_s = m_path.segments[m_segment].d_mm;
      continue;
    }
    if (s > g.d_mm && m_segment + 1 < m_path.segments.size()) {
      ++m_segment;
      m_s = 0;
      continue;
    }
    s = std::clamp(s, 0.0, g.d_mm);
    const double moved = std::abs(s - m_s);
    m_s = s;
    if (moved < 1e-10) break;
  }
}

Vec3 PathCursor::nominal_normal(const Vec3& fallback) const {
  const auto& n = m_path.normals;
  if (n.size() != m_path.segments.size() + 1) return fallback;
  const double d = seg().d_mm;
  const double w = d > 0 ? m_s / d : 0;
  const Vec3 v = (1 - w) * n[m_segment] + w * n[m_segment + 1];
  return v.norm() > 1e-12 ? Vec3(v.normalized()) : fallback;
}

double PathCursor::arc_mm() const { return m_cumulative[m_segment] + seg().arc_length(m_s); }

}  // namespace metron::machine
