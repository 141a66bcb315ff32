// SPDX-License-Identifier: GPL-3.0-or-later
// The simulated six-axis machine and its Fizeau gauge (docs/wavefront.md, "The machine" and
// "The gauge").
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "metron/machine/wavefront/simulated_wavefront_machine.hpp"

namespace metron::machine::wavefront {
namespace {

constexpr double kRad = std::numbers::pi / 180;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

using AA = Eigen::AngleAxisd;

// The form of a part's surface in Noll-normalised Zernike terms on its clear disc (height, nm).
double form_height_nm(const PartSpec& p, double x, double y) {
  const double r = std::hypot(x, y), t = std::atan2(y, x), r2 = r * r;
  return p.astigmatism_nm * std::sqrt(6.0) * r2 * std::cos(2 * t) +
         p.trefoil_nm * std::sqrt(8.0) * r2 * r * std::sin(3 * t) +
         p.spherical_nm * std::sqrt(5.0) * (6 * r2 * r2 - 6 * r2 + 1);
}

// Where a ray o + t d (|d| = 1) meets a sphere of signed radius R (> 0 convex: the near side
// faces the ray; < 0 concave: the far side, seen from inside). NaN if it misses.
double ray_sphere(const Vec3& o, const Vec3& d, const Vec3& centre, double radius) {
  const Vec3 oc = o - centre;
  const double b = d.dot(oc);
  const double disc = b * b - (oc.squaredNorm() - radius * radius);
  if (disc < 0) return kNan;
  return radius > 0 ? -b - std::sqrt(disc) : -b + std::sqrt(disc);
}

double ray_plane(const Vec3& o, const Vec3& d, const Vec3& p0, const Vec3& n) {
  const double dn = d.dot(n);
  if (std::abs(dn) < 1e-12) return kNan;
  return (p0 - o).dot(n) / dn;
}

}  // namespace

SimulatedWavefrontMachine::SimulatedWavefrontMachine(WavefrontWorld world, std::uint64_t seed)
    : m_world(std::move(world)),
      m_rng(seed),
      m_position(m_world.start),
      m_element(m_world.gauge.element),
      m_mounted(m_world.mounted) {}

bool SimulatedWavefrontMachine::mount(const std::string& part) {
  if (!part.empty() &&
      std::none_of(m_world.parts.begin(), m_world.parts.end(), [&](const PartSpec& p) { return p.name == part; }))
    return false;
  m_mounted = part;
  m_part_turn_deg = 0;
  return true;
}

void SimulatedWavefrontMachine::tilt_gauge_mount(double about_x_rad, double about_y_rad) {
  m_gauge_mount = m_gauge_mount * (AA(about_x_rad, Vec3::UnitX()) * AA(about_y_rad, Vec3::UnitY())).toRotationMatrix();
}

void SimulatedWavefrontMachine::shift_rotary_zeros(double b_deg, double c_deg) {
  m_b_shift_rad += b_deg * kRad;
  m_c_shift_rad += c_deg * kRad;
}

std::vector<PartSpec> SimulatedWavefrontMachine::parts() const {
  std::vector<PartSpec> out;
  for (PartSpec p : m_world.parts) {  // design data only
    p.decentre_mm = Vec2::Zero();
    p.wedge_rad = Vec2::Zero();
    p.astigmatism_nm = p.trefoil_nm = p.spherical_nm = 0;
    out.push_back(p);
  }
  return out;
}

const PartSpec* SimulatedWavefrontMachine::mounted() const {
  for (const auto& p : m_world.parts)
    if (p.name == m_mounted) return &p;
  return nullptr;
}

// The chain T(X, Y, Z) -> B (about u_B ~ Y) -> C (about X, zc above B) -> A (xb, yc from the B and
// C axes, its own tilt) -> table; docs/wavefront.md "The machine".
Frame SimulatedWavefrontMachine::c_frame() const {
  const HiddenGeometry& h = m_world.hidden;
  const Vec3 t = m_position.steps.cwiseProduct(h.step_mm);
  const Vec3 u_b(std::sin(h.b_axis_tilt_rad), std::cos(h.b_axis_tilt_rad), 0);
  const double b = m_position.b_deg * kRad + m_b_shift_rad + h.b_zero_rad;
  const double c = m_position.c_deg * kRad + m_c_shift_rad + h.c_zero_rad;
  Frame f = Frame::Identity();
  f.translate(t);
  f.rotate(AA(b, u_b));
  f.translate(Vec3(0, 0, h.zc_mm));
  f.rotate(AA(c, Vec3::UnitX()));
  return f;
}

Frame SimulatedWavefrontMachine::spindle_frame() const {
  const HiddenGeometry& h = m_world.hidden;
  Frame f = c_frame();
  f.translate(Vec3(h.xb_mm, h.yc_mm, 0));
  f.rotate(AA(h.a_tilt_rad.x(), Vec3::UnitY()) * AA(-h.a_tilt_rad.y(), Vec3::UnitX()));
  f.rotate(AA(m_position.a_deg * kRad, Vec3::UnitZ()));
  return f;
}

Frame SimulatedWavefrontMachine::part_frame() const {
  const HiddenGeometry& h = m_world.hidden;
  Frame f = spindle_frame();
  f.translate(Vec3(0, 0, h.table_height_mm));
  f.rotate(AA(h.table_tilt_rad.x(), Vec3::UnitY()) * AA(-h.table_tilt_rad.y(), Vec3::UnitX()));
  if (const PartSpec* p = mounted()) {
    f.rotate(AA(m_part_turn_deg * kRad, Vec3::UnitZ()));
    f.translate(Vec3(p->decentre_mm.x(), p->decentre_mm.y(), p->mount_height_mm));
  }
  return f;
}

Frame SimulatedWavefrontMachine::gauge_frame() const {
  const HiddenGeometry& h = m_world.hidden;
  Frame f = Frame::Identity();
  f.translate(h.focus_mm);
  f.rotate(AA(h.gauge_tilt_x_rad, Vec3::UnitX()) * AA(h.gauge_tilt_y_rad, Vec3::UnitY()) *
           AA(h.gauge_clocking_rad, Vec3::UnitZ()));
  f.rotate(m_gauge_mount);
  return f;
}

tl::expected<GaugeMap, GaugeError> SimulatedWavefrontMachine::ideal_map() const {
  const PartSpec* part = mounted();
  if (!part) return tl::unexpected(GaugeError{GaugeFault::NoPart, "no part on the table"});
  const GaugeSpec& g = m_world.gauge;
  const Frame gf = gauge_frame();
  const Frame pf = part_frame();
  const Frame pf_inv = pf.inverse();
  const Vec3 gx = gf.linear().col(0), gy = gf.linear().col(1), gz = gf.linear().col(2);
  const Vec3 focus = gf.translation();
  const double top = part->thickness_mm;
  const Vec3 centre = pf * Vec3(0, 0, top - part->radius_mm);
  const Vec3 p0 = pf * Vec3(0, 0, top);
  const Vec3 normal = (pf.linear() * Vec3(part->wedge_rad.x(), part->wedge_rad.y(), 1)).normalized();
  // A plane mirror images the focus perfectly: the cat's-eye return is a sphere about F'.
  const Vec3 image = focus - 2 * (focus - p0).dot(normal) * normal;

  GaugeMap map;
  map.pixels = g.pixels;
  map.element = m_element;
  map.pupil_scale = m_element == Element::Flat ? g.flat_radius_mm : 1.0;
  map.opd_nm.assign(static_cast<std::size_t>(g.pixels) * g.pixels, kNan);
  const double s = g.sphere_sin_max, L = g.sphere_reference_radius_mm;
  for (int iy = 0; iy < g.pixels; ++iy) {
    for (int ix = 0; ix < g.pixels; ++ix) {
      const double u = map.coordinate(ix), v = map.coordinate(iy);
      if (u * u + v * v > 1) continue;
      Vec3 o, d;
      double t_ideal;
      if (m_element == Element::Sphere) {
        // The ray through the focus for pupil point (u, v): aplanatic, sin(angle) = rho sin_max.
        d = (u * s * gx + v * s * gy - std::sqrt(1 - (u * u + v * v) * s * s) * gz).normalized();
        o = focus - L * d;
        t_ideal = L - part->radius_mm;
      } else {
        d = -gz;
        o = focus + g.flat_radius_mm * (u * gx + v * gy) + L * gz;
        t_ideal = L;
      }
      double t;
      double opd_mm;
      if (part->kind == PartKind::Sphere) {
        t = ray_sphere(o, d, centre, part->radius_mm);
        opd_mm = 2 * (t - t_ideal);
      } else {
        t = ray_plane(o, d, p0, normal);
        opd_mm = m_element == Element::Sphere ? (o - image).norm() - L : 2 * (t - t_ideal);
      }
      if (!std::isfinite(t) || !std::isfinite(opd_mm)) continue;
      const Vec3 hit = pf_inv * (o + t * d);
      const double rx = hit.x() / part->clear_radius_mm, ry = hit.y() / part->clear_radius_mm;
      if (rx * rx + ry * ry > 1) continue;
      // A surface standing proud by h shortens the double pass by 2h.
      map.opd_nm[static_cast<std::size_t>(iy) * g.pixels + ix] = opd_mm * 1e6 - 2 * form_height_nm(*part, rx, ry);
    }
  }
  if (map.valid_count() == 0)
    return tl::unexpected(
        GaugeError{GaugeFault::NoReturn, "no light returns into the gauge's pupil: the part is far from null"});
  // Nyquist: a fringe is one wavelength of OPD; the camera resolves at most half a fringe per pixel.
  double worst = 0;
  int wx = 0, wy = 0;
  for (int iy = 0; iy < g.pixels; ++iy)
    for (int ix = 0; ix < g.pixels; ++ix) {
      const double a = map.at(ix, iy);
      if (!std::isfinite(a)) continue;
      for (const auto& [nx, ny] : {std::pair{ix + 1, iy}, std::pair{ix, iy + 1}}) {
        if (nx >= g.pixels || ny >= g.pixels) continue;
        const double b = map.at(nx, ny);
        if (!std::isfinite(b)) continue;
        const double density = std::abs(b - a) / g.wavelength_nm;
        if (density > worst) worst = density, wx = ix, wy = iy;
      }
    }
  if (worst > 0.5)
    return tl::unexpected(GaugeError{
        GaugeFault::TooManyFringes,
        fmt::format("too many fringes: {:.2f} fringes per pixel at pixel ({}, {}) exceeds the camera's Nyquist limit "
                    "of 0.5; null the part (move it toward confocal) before measuring",
                    worst, wx, wy)});
  return map;
}

tl::expected<GaugeMap, GaugeError> SimulatedWavefrontMachine::measure() {
  ++m_maps;
  auto map = ideal_map();
  if (!map) return map;
  for (double& v : map->opd_nm)
    if (std::isfinite(v)) v += m_world.gauge.noise_nm * m_rng.normal();
  return map;
}

WavefrontTruth SimulatedWavefrontMachine::truth() const {
  const HiddenGeometry& h = m_world.hidden;
  WavefrontTruth t{};
  t.step_mm = h.step_mm;
  const Frame gf = gauge_frame();
  const Mat3 g = gf.linear();
  const Vec3 focus = gf.translation();
  t.gauge_clocking_rad = std::atan2(g(1, 0), g(0, 0));
  const Frame sf = spindle_frame();
  const Vec3 a = sf.linear().col(2), a_o = sf.translation();
  const Vec3 a_g = g.transpose() * a;
  t.gauge_to_a_rad = Vec2(a_g.x() / a_g.z(), a_g.y() / a_g.z());
  t.a_to_z_rad = Vec2(a.x() / a.z(), a.y() / a.z());
  // The A line where it crosses the focal plane (normal to the gauge axis through the focus).
  const auto a_at_plane = [&](const Vec3& plane_point) {
    const double s = (plane_point - a_o).dot(g.col(2)) / a.dot(g.col(2));
    return Vec3(a_o + s * a);
  };
  const Vec3 a_f = g.transpose() * (a_at_plane(focus) - focus);
  t.focus_to_a_mm = a_f.head<2>();
  // The table's surface point on A sits at table_height along A above the spindle frame origin.
  const Vec3 table_on_a = sf * Vec3(0, 0, h.table_height_mm);
  t.focus_table_z_steps = m_position.steps.z() + (focus.z() - table_on_a.z()) / h.step_mm.z();
  const Frame pf = part_frame();
  const Vec3 base_n = g.transpose() * pf.linear().col(2);
  const Vec2 base_tilt(base_n.x() / base_n.z(), base_n.y() / base_n.z());
  t.table_tilt_rad = base_tilt - t.gauge_to_a_rad;
  const Vec3 b_o = m_position.steps.cwiseProduct(h.step_mm);
  t.b_axis_tilt_rad = h.b_axis_tilt_rad;
  {  // the C axis (through the C frame's origin along its x) against the A line and the B axis
    const Frame cf = c_frame();
    const Vec3 c_o = cf.translation();
    const double s = (c_o.z() - a_o.z()) / a.z();
    t.yc_mm = (a_o + s * a).y() - c_o.y();
    t.zc_mm = c_o.z() - b_o.z();
  }
  {  // A line at the B axis' height, against the B axis at that y
    const double s = (b_o.z() - a_o.z()) / a.z();
    const Vec3 p = a_o + s * a;
    t.xb_mm = p.x() - (b_o.x() + std::tan(h.b_axis_tilt_rad) * (p.y() - b_o.y()));
  }
  if (const PartSpec* part = mounted()) {
    if (part->kind == PartKind::Sphere) {
      const Vec3 c = pf * Vec3(0, 0, part->thickness_mm - part->radius_mm);
      const Vec3 rel = g.transpose() * (c - a_at_plane(c));
      t.part_to_a = rel.head<2>();
      t.zf_mm = c.z() - b_o.z();
      const double s = (c.z() - a_o.z()) / a.z();
      t.eccentricity_mm = c.x() - (a_o + s * a).x();
    } else {
      const Vec3 n = g.transpose() * (pf.linear() * Vec3(part->wedge_rad.x(), part->wedge_rad.y(), 1)).normalized();
      const Vec2 face(n.x() / n.z(), n.y() / n.z());
      t.part_to_a = face - t.gauge_to_a_rad;
      t.part_wedge_rad = face - base_tilt;
      const Vec3 disc = pf * Vec3(0, 0, part->thickness_mm);
      t.flat_centre_mm = (g.transpose() * (disc - a_at_plane(disc))).head<2>();
    }
  }
  return t;
}

}  // namespace metron::machine::wavefront
