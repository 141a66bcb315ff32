// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/contact.hpp"

#include <algorithm>

namespace metron::machine {

std::optional<double> first_ball_contact(const Solid& solid, const Vec3& a, const Vec3& b, double radius_mm,
                                         double tol_mm) {
  const Vec3 d = b - a;
  const double len = d.norm();
  const auto gap = [&](double t) { return solid.signed_distance(a + d * (t / len)) - radius_mm; };
  if (!(len > 0)) {
    if (solid.signed_distance(a) - radius_mm <= 0) return 0.0;
    return std::nullopt;
  }
  const double lip = std::max(1.0, solid.lipschitz());
  constexpr double min_step = 1e-6;
  double t = 0;
  double g = gap(0);
  if (g <= 0) {
    // In contact at the start: free only if the move takes the ball away from the surface.
    if (gap(std::min(len, 1e-5)) <= g) return 0.0;
    while (g <= 0) {
      t += std::max(-g / lip, min_step);  // cannot pass the point where the ball leaves
      if (t >= len) return std::nullopt;
      g = gap(t);
    }
  }
  while (true) {
    const double next = std::min(t + std::max(g / lip, min_step), len);
    const double g_next = gap(next);
    if (g_next <= 0) {
      double lo = t, hi = next;
      while (hi - lo > tol_mm) {
        const double mid = (lo + hi) / 2;
        if (mid <= lo || mid >= hi) break;  // at the resolution of doubles
        (gap(mid) <= 0 ? hi : lo) = mid;
      }
      return hi / len;
    }
    if (next >= len) return std::nullopt;
    t = next;
    g = g_next;
  }
}

}  // namespace metron::machine
