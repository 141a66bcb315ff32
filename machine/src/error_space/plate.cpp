// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/error_space/plate.hpp"

#include <cmath>
#include <numbers>

#include "metron/machine/rng.hpp"

namespace metron::machine {

FlatPlate::FlatPlate(std::vector<Mode> modes, double bow_mm, double size_mm)
    : m_modes(std::move(modes)), m_bow_mm(bow_mm), m_size_mm(size_mm) {}

FlatPlate FlatPlate::commercial(double form_mm, double size_mm, std::uint64_t seed) {
  Rng rng(seed);
  std::vector<Mode> modes;
  // Half the form in a bow, half in undulations (a rolled plate bows and waves); each mode's
  // amplitude is a fraction of it so the peak-to-valley stays near form_mm.
  for (int m = 0; m < 5; ++m) {
    Mode mode;
    mode.amplitude_mm = form_mm * 0.1 * (0.5 + rng.uniform());
    mode.wavelength_u_mm = size_mm * (0.4 + 2.1 * rng.uniform());
    mode.wavelength_v_mm = size_mm * (0.4 + 2.1 * rng.uniform());
    mode.phase_u = 2 * std::numbers::pi * rng.uniform();
    mode.phase_v = 2 * std::numbers::pi * rng.uniform();
    modes.push_back(mode);
  }
  return FlatPlate(std::move(modes), 0.25 * form_mm, size_mm);
}

void FlatPlate::place(int axis, int sign, const Vec3& origin) {
  m_axis = axis;
  m_sign = sign >= 0 ? 1 : -1;
  m_origin = origin;
}

Vec2 FlatPlate::plate_uv(const Vec3& p) const {
  const int u = m_axis == 0 ? 1 : 0, v = m_axis == 2 ? 1 : 2;
  return {p[u] - m_origin[u], p[v] - m_origin[v]};
}

double FlatPlate::profile_mm(double u, double v) const {
  const double two_pi = 2 * std::numbers::pi;
  double f = m_bow_mm * ((u / m_size_mm) * (u / m_size_mm) + (v / m_size_mm) * (v / m_size_mm));
  for (const Mode& m : m_modes) {
    const double cu = m.wavelength_u_mm > 0 ? std::cos(two_pi * u / m.wavelength_u_mm + m.phase_u) : 1.0;
    const double cv = m.wavelength_v_mm > 0 ? std::cos(two_pi * v / m.wavelength_v_mm + m.phase_v) : 1.0;
    f += m.amplitude_mm * cu * cv;
  }
  return f;
}

}  // namespace metron::machine
