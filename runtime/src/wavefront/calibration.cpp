// SPDX-License-Identifier: GPL-3.0-or-later
// The wavefront-gauge geometry calibration (SEEDS.md 5; docs/wavefront.md "The procedure").
// Every number here comes from gauge maps, axis commands and design data (ARCHITECTURE.md rule 1).
#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>
#include <Eigen/Dense>

#include "metron/runtime/wavefront/calibration.hpp"
#include "metron/runtime/wavefront/form_stitching.hpp"
#include "metron/stdlib/wavefront/circle_fit.hpp"

namespace metron::runtime::wavefront {
namespace {

using machine::wavefront::Element;
using machine::wavefront::GaugeError;
using machine::wavefront::GaugeFault;
using machine::wavefront::PartKind;
using machine::wavefront::PartSpec;

constexpr double kDeg = 180 / std::numbers::pi;

void say(const Log& log, const std::string& line) {
  if (log) log(line);
}

void observe(const Knowledge& k, const std::string& tag) {
  if (k.observe) k.observe(tag);
}

std::optional<PartSpec> part_named(const WavefrontMachine& m, const std::string& name) {
  for (const auto& p : m.parts())
    if (p.name == name) return p;
  return std::nullopt;
}

// Height of the part's centre of curvature (sphere) or top face (flat) above the table (design).
double design_height_mm(const PartSpec& p) {
  return p.mount_height_mm + p.thickness_mm - (p.kind == PartKind::Sphere ? p.radius_mm : 0);
}

// Z that puts the table surface at the focus: measured (cat's eye) or from the design.
double table_at_focus_z(const WavefrontMachine& m, const Knowledge& k) {
  if (k.focus_table_z_steps) return *k.focus_table_z_steps;
  const auto& n = m.nominal();
  return (n.focus_mm.z() - n.zc_mm - n.table_height_mm) / k.step_mm.z();
}

Vec2 a_through_focus_xy(const WavefrontMachine& m, const Knowledge& k) {
  if (k.a_through_focus_steps) return *k.a_through_focus_steps;
  const auto& n = m.nominal();
  return {n.focus_mm.x() / k.step_mm.x(), n.focus_mm.y() / k.step_mm.y()};
}

// Puts the named part on the table (if it is not there) at its predicted null position.
tl::expected<void, std::string> mount_at_null_guess(WavefrontMachine& m, const Knowledge& k, const std::string& name) {
  const auto p = part_named(m, name);
  if (!p) return tl::unexpected(fmt::format("no part named '{}' in the world", name));
  if (m.mounted_part() != name) m.mount(name);
  AxisCommand c = m.position();
  const Vec2 xy = a_through_focus_xy(m, k);
  c.steps = Vec3(xy.x(), xy.y(), table_at_focus_z(m, k) - design_height_mm(*p) / k.step_mm.z());
  m.move(c);
  return {};
}

tl::expected<GaugeReading, std::string> read_here(WavefrontMachine& m) {
  auto map = m.measure();
  if (!map) return tl::unexpected(map.error().message);
  auto r = read_gauge_map(*map, m.gauge());
  if (!r) return tl::unexpected(std::string(r.error()));
  return *r;
}

// The half-capture of the Nyquist rule (docs/wavefront.md): the largest axial and lateral
// displacement of a sphere's centre that keeps the fringes below 0.5 per pixel, halved.
double axial_search_step_mm(const machine::wavefront::GaugeSpec& g) {
  const double s = g.sphere_sin_max;
  return 0.25 * g.wavelength_nm * 1e-6 * g.pixels * std::sqrt(1 - s * s) / (8 * s * s);
}
double lateral_search_step_mm(const machine::wavefront::GaugeSpec& g) {
  return 0.5 * g.wavelength_nm * 1e-6 * g.pixels / (8 * g.sphere_sin_max);
}

// Finds a position where the gauge reads: Z first (the operator's "feed Z until fringes
// appear"), then an X-Y spiral at the starting Z.
tl::expected<GaugeReading, std::string> acquire(WavefrontMachine& m, const Knowledge& k, int& maps, const Log& log) {
  const AxisCommand start = m.position();
  auto first = read_here(m);
  ++maps;
  if (first) return first;
  say(log, fmt::format("  no reading at the start ({}); searching", first.error()));
  const double dz = axial_search_step_mm(m.gauge()) / k.step_mm.z();
  const int nz = static_cast<int>(std::ceil(2.0 / (axial_search_step_mm(m.gauge()))));
  for (int i = 1; i <= nz; ++i)
    for (int sign : {1, -1}) {
      AxisCommand c = start;
      c.steps.z() += sign * i * dz;
      m.move(c);
      auto r = read_here(m);
      ++maps;
      if (r) return r;
    }
  // X-Y spiral, each point with a short Z search (an uncalibrated dz leaves a tall part's Z off by
  // a fraction of a millimetre).
  const double dl = lateral_search_step_mm(m.gauge());
  for (int ring = 1; ring * dl <= 0.2; ++ring)
    for (int j = 0; j < 8 * ring; ++j) {
      const double t = 2 * std::numbers::pi * j / (8 * ring);
      for (int iz = 0; iz <= 10; ++iz) {
        AxisCommand c = start;
        c.steps.x() += ring * dl * std::cos(t) / k.step_mm.x();
        c.steps.y() += ring * dl * std::sin(t) / k.step_mm.y();
        c.steps.z() += (iz % 2 ? 1 : -1) * ((iz + 1) / 2) * dz;
        m.move(c);
        auto r = read_here(m);
        ++maps;
        if (r) return r;
      }
    }
  m.move(start);
  return tl::unexpected(fmt::format(
      "the gauge reads nowhere near the start (Z +-2 mm; X-Y within 0.2 mm, Z +-5 search steps): {}", first.error()));
}

// The translation (steps) that would null a reading, from the knowledge's responses.
Vec3 null_move(const Knowledge& k, const GaugeReading& r, bool z_only) {
  const double dzeta = -r.axial_mm / k.step_mm.z();
  if (z_only) return {0, 0, dzeta};
  const Vec2 lateral = r.lateral_mm + k.lateral_per_z_step * dzeta;
  const Vec2 dxy = -k.lateral_per_step.inverse() * lateral;
  return {dxy.x(), dxy.y(), dzeta};
}

// Gauge-frame directions to the part's frame at the commanded A, B, C (degrees, with the zero
// shifts applied so far) and the calibrated clocking: the simulated chain's rotations without
// the small hidden tilts (docs/wavefront.md "The machine"), all the form stitching needs.
Mat3 gauge_to_part(const Knowledge& k, double a_deg, double b_deg, double c_deg) {
  using AA = Eigen::AngleAxisd;
  const double b = (b_deg + k.az_correction_deg.x()) / kDeg, c = (c_deg + k.az_correction_deg.y()) / kDeg;
  return (AA(-a_deg / kDeg, Vec3::UnitZ()) * AA(-c, Vec3::UnitX()) * AA(-b, Vec3::UnitY()) *
          AA(k.gauge_clocking_rad, Vec3::UnitZ()))
      .toRotationMatrix();
}

// The map at a null, for the form stitching of a rotation series: the machine moves onto the null
// estimate and takes one more map.
tl::expected<SubApertureMap, std::string> map_at_null(WavefrontMachine& m, const Knowledge& k, const Vec3& null_steps) {
  AxisCommand at = m.position();
  at.steps = null_steps;
  m.move(at);
  auto map = m.measure();
  if (!map) return tl::unexpected("the map at the null: " + map.error().message);
  return SubApertureMap{*map, gauge_to_part(k, at.a_deg, at.b_deg, at.c_deg)};
}

double max_shift(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  double m = 0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, (a[i] - b[i]).norm());
  return m;
}

// Sub-aperture stitching of the nulls' maps (docs/wavefront.md "The part's form in the rotation
// nulls"): each null moves by what its placement alone reads once the common form is removed.
tl::expected<FormStitch, std::string> remove_form(const WavefrontMachine& m, const Knowledge& k, const PartSpec& part,
                                                  const std::vector<SubApertureMap>& maps, std::vector<Vec3>& nulls) {
  auto st = stitch_common_form(maps, m.gauge(), part.radius_mm, part.clear_radius_mm);
  if (!st) return tl::unexpected(st.error());
  for (std::size_t i = 0; i < nulls.size(); ++i) nulls[i] += null_move(k, st->readings[i], false);
  return st;
}

}  // namespace

Knowledge initial_knowledge(const WavefrontMachine& machine) {
  Knowledge k;
  k.step_mm = machine.nominal().step_mm;
  k.lateral_per_step = Eigen::Matrix2d{{k.step_mm.x(), 0}, {0, k.step_mm.y()}};
  return k;
}

tl::expected<NullResult, std::string> null_sphere(WavefrontMachine& m, const Knowledge& k, const Log& log,
                                                  bool z_only) {
  NullResult out;
  auto r = acquire(m, k, out.maps, log);
  if (!r) return tl::unexpected(r.error());
  for (int it = 0; it < 20; ++it) {
    const Vec3 d = null_move(k, *r, z_only);
    const double mm = d.cwiseProduct(k.step_mm).norm();
    if (mm < 2e-6 || it == 19) {
      out.steps = m.position().steps + d;  // the null, from the last reading's residual
      out.reading = *r;
      if (mm >= 2e-6) say(log, fmt::format("  null not settled after 20 maps ({:.2e} mm left)", mm));
      return out;
    }
    AxisCommand c = m.position();
    c.steps += d;
    m.move(c);
    r = read_here(m);
    ++out.maps;
    if (!r) return tl::make_unexpected("the null lost the fringes: " + r.error());
  }
  return out;
}

namespace {

// The cat's eye (step 3 ii): the flat's face at the focus, by nulling the focus term with Z only.
tl::expected<NullResult, std::string> cat_eye(WavefrontMachine& m, Knowledge& k, const PartSpec& flat, const Log& log) {
  m.fit_element(Element::Sphere);
  if (auto ok = mount_at_null_guess(m, k, flat.name); !ok) return tl::unexpected(ok.error());
  auto cat = null_sphere(m, k, log, true);
  if (!cat) return tl::unexpected("cat's eye: " + cat.error());
  k.cat_eye_z_steps = cat->steps.z();
  k.cat_eye_height_mm = design_height_mm(flat);
  k.focus_table_z_steps = cat->steps.z() + design_height_mm(flat) / k.step_mm.z();
  return cat;
}

// A step that needs a ball near null first needs the focus' Z (the design's is too far off for
// the gauge's capture): the cat's eye on the first flat, unless already known.
tl::expected<void, std::string> ensure_focus_z(WavefrontMachine& m, Knowledge& k, const Log& log) {
  if (k.focus_table_z_steps) return {};
  for (const auto& p : m.parts())
    if (p.kind == PartKind::Flat) {
      const Element was = m.element();
      const std::string had = m.mounted_part();
      auto cat = cat_eye(m, k, p, log);
      if (!cat) return tl::unexpected(cat.error());
      say(log, fmt::format("  focus Z from the cat's eye on '{}': table at the focus at Z {:.1f} steps", p.name,
                           *k.focus_table_z_steps));
      m.fit_element(was);
      m.mount(had);
      return {};
    }
  return {};
}

}  // namespace

tl::expected<PartOnMountResult, std::string> part_on_mount(WavefrontMachine& m, const Knowledge& k,
                                                           const PartOnMountOptions& o, const Log& log) {
  if (o.angles_deg.size() < 2) return tl::unexpected(std::string("part-on-mount needs at least 2 spindle angles"));
  const auto part = part_named(m, m.mounted_part());
  if (!part) return tl::unexpected(std::string("part-on-mount: no part on the table"));
  PartOnMountResult res;
  res.sphere = m.element() == Element::Sphere;
  if (res.sphere && part->kind != PartKind::Sphere)
    return tl::unexpected(fmt::format("part-on-mount: '{}' is a flat; fit the transmission flat", part->name));
  res.radius_of_curvature_mm = std::abs(part->radius_mm);
  AxisCommand c = m.position();
  c.a_deg = o.angles_deg.front();
  m.move(c);
  if (res.sphere && o.null_first) {
    auto n = null_sphere(m, k, log);
    if (!n) return tl::make_unexpected("part-on-mount: " + n.error());
    res.maps += n->maps;
    c = m.position();
    c.steps = n->steps;
    m.move(c);
  }
  res.steps = m.position().steps;
  std::vector<double> angles_rad;
  for (double a : o.angles_deg) {
    c.a_deg = a;
    m.move(c);
    auto r = read_here(m);
    ++res.maps;
    if (!r) return tl::unexpected(fmt::format("part-on-mount at A = {} deg: {}", a, r.error()));
    res.angles_deg.push_back(a);
    angles_rad.push_back(a / kDeg);
    res.tilts.push_back(res.sphere ? r->lateral_mm : r->angle_rad);
    res.centroids_mm.push_back(r->centroid);
  }
  c.a_deg = o.angles_deg.front();
  m.move(c);
  auto circle = metron::wavefront::fit_circle_phased(res.tilts, angles_rad, o.angles_deg.size() >= 3 ? 0 : 1);
  if (!circle) return tl::unexpected(fmt::format("part-on-mount: circle fit: {}", circle.error()));
  res.circle = *circle;
  if (res.tilts.size() >= 3)
    if (auto g = metron::wavefront::fit_circle_geometric(res.tilts)) res.geometric = *g;
  if (!res.sphere) {
    res.gauge_to_spindle_rad = res.circle.centre;
    res.spindle_to_part_rad = res.circle.radius_vector;
    auto cc = metron::wavefront::fit_circle_phased(res.centroids_mm, angles_rad, res.circle.sense);
    if (cc) res.centroid_circle = *cc;
  } else {
    const double r = res.radius_of_curvature_mm;
    res.gauge_to_spindle_rad = Vec2(std::atan(res.circle.centre.x() / r), std::atan(res.circle.centre.y() / r));
    res.spindle_to_part_rad =
        Vec2(std::atan(res.circle.radius_vector.x() / r), std::atan(res.circle.radius_vector.y() / r));
  }
  say(log, fmt::format("  part-on-mount ({}, {} angles): centre ({:.6g}, {:.6g}) {}, radius {:.6g}", part->name,
                       res.angles_deg.size(), res.circle.centre.x(), res.circle.centre.y(), res.sphere ? "mm" : "rad",
                       res.circle.radius_vector.norm()));
  return res;
}

tl::expected<AxisResponseResult, std::string> axis_response(WavefrontMachine& m, Knowledge& k, double move_steps,
                                                            const Log& log) {
  if (auto ok = ensure_focus_z(m, k, log); !ok) return tl::unexpected("axis-response: " + ok.error());
  if (m.element() != Element::Sphere) m.fit_element(Element::Sphere);
  std::string ball = m.mounted_part();
  const auto p = part_named(m, ball);
  if (!p || p->kind != PartKind::Sphere)
    for (const auto& q : m.parts())
      if (q.kind == PartKind::Sphere) {
        ball = q.name;
        break;
      }
  if (auto ok = mount_at_null_guess(m, k, ball); !ok) return tl::unexpected(ok.error());
  AxisResponseResult res;
  auto n = null_sphere(m, k, log);
  if (!n) return tl::make_unexpected("axis-response: " + n.error());
  res.maps += n->maps;
  AxisCommand base = m.position();
  base.steps = n->steps;
  // Columns: gauge (lateral x, lateral y, axial) per step of X, Y, Z, by central differences.
  Eigen::Matrix3d resp;
  for (int axis = 0; axis < 3; ++axis) {
    Vec3 reading[2];
    for (int side = 0; side < 2; ++side) {
      AxisCommand c = base;
      c.steps[axis] += side == 0 ? move_steps : -move_steps;
      m.move(c);
      auto r = read_here(m);
      ++res.maps;
      if (!r)
        return tl::unexpected(
            fmt::format("axis-response: moving {} by {} steps: {}", "XYZ"[axis], move_steps, r.error()));
      reading[side] = Vec3(r->lateral_mm.x(), r->lateral_mm.y(), r->axial_mm);
    }
    resp.col(axis) = (reading[0] - reading[1]) / (2 * move_steps);
  }
  m.move(base);
  // Lateral is exact (s = sin_max against the wavelength); the axial row is first order, so dx and
  // dy come from the lateral columns alone (the gauge axis is within mrad of Z).
  res.step_mm = Vec3(resp.col(0).head<2>().norm(), resp.col(1).head<2>().norm(), std::abs(resp(2, 2)));
  res.gauge_clocking_rad = std::atan2(-resp(1, 0), resp(0, 0));
  res.gauge_axis_to_z_rad = resp.col(2).head<2>() / res.step_mm.z();
  k.step_mm = res.step_mm;
  k.steps_calibrated = true;
  observe(k, "axis-response");
  k.lateral_per_step = resp.topLeftCorner<2, 2>();
  k.lateral_per_z_step = resp.col(2).head<2>();
  k.gauge_clocking_rad = res.gauge_clocking_rad;
  say(log, fmt::format("  axis response: dx {:.7f} dy {:.7f} dz {:.7f} mm/step, clocking {:.4f} deg", res.step_mm.x(),
                       res.step_mm.y(), res.step_mm.z(), res.gauge_clocking_rad * kDeg));
  return res;
}

tl::expected<GaugeFrameResult, std::string> align_gauge_frame(WavefrontMachine& m, Knowledge& k,
                                                              const std::string& flat, const PartOnMountOptions& o,
                                                              const Log& log) {
  const auto p = part_named(m, flat);
  if (!p || p->kind != PartKind::Flat) return tl::unexpected(fmt::format("gauge-frame: '{}' is not a flat part", flat));
  const Element was = m.element();
  m.fit_element(Element::Flat);
  if (auto ok = mount_at_null_guess(m, k, flat); !ok) return tl::unexpected(ok.error());
  GaugeFrameResult res;
  auto before = part_on_mount(m, k, o, log);
  if (!before) return tl::make_unexpected("gauge-frame: " + before.error());
  observe(k, "gauge-frame");
  res.before = *before;
  res.maps += before->maps;
  res.gauge_to_a_rad = before->circle.centre;
  if (before->centroid_circle) res.a_axis_in_gauge_mm = before->centroid_circle->centre;
  // Tipping the mount about gauge x by t adds t to the A axis' y slope seen by the gauge; tilting
  // about gauge y by t subtracts t from its x slope (docs/wavefront.md, step 2).
  m.tilt_gauge_mount(-res.gauge_to_a_rad.y(), res.gauge_to_a_rad.x());
  auto after = part_on_mount(m, k, o, log);
  if (!after) return tl::make_unexpected("gauge-frame (check): " + after.error());
  res.maps += after->maps;
  res.residual_rad = after->circle.centre;
  observe(k, "gauge-frame:after");
  m.fit_element(was);
  return res;
}

tl::expected<FocusResult, std::string> focus_on_axis(WavefrontMachine& m, Knowledge& k, const std::string& flat,
                                                     const std::string& ball, const PartOnMountOptions& o,
                                                     const Log& log) {
  const auto pf = part_named(m, flat);
  const auto pb = part_named(m, ball);
  if (!pf || pf->kind != PartKind::Flat) return tl::unexpected(fmt::format("focus: '{}' is not a flat part", flat));
  if (!pb || pb->kind != PartKind::Sphere) return tl::unexpected(fmt::format("focus: '{}' is not a sphere", ball));
  FocusResult res;
  auto cat = cat_eye(m, k, *pf, log);
  if (!cat) return tl::unexpected("focus: " + cat.error());
  res.maps += cat->maps;
  res.cat_eye_z_steps = cat->steps.z();
  observe(k, "focus:cat");
  res.focus_table_z_steps = *k.focus_table_z_steps;
  say(log, fmt::format("  cat's eye at Z {:.1f} steps: table at the focus at Z {:.1f}", res.cat_eye_z_steps,
                       res.focus_table_z_steps));
  // The A axis from the focus by part-on-mount on the ball; X and Y move it onto the focus.
  if (auto ok = mount_at_null_guess(m, k, ball); !ok) return tl::unexpected(ok.error());
  PartOnMountOptions first = o;
  first.null_first = true;
  auto pom = part_on_mount(m, k, first, log);
  if (!pom) return tl::make_unexpected("focus: " + pom.error());
  res.maps += pom->maps;
  res.focus_to_a_mm = pom->circle.centre;
  observe(k, "focus:pom");
  const Vec2 dxy = -k.lateral_per_step.inverse() * pom->circle.centre;
  AxisCommand c = m.position();
  c.steps.x() = pom->steps.x() + dxy.x();
  c.steps.y() = pom->steps.y() + dxy.y();
  c.steps.z() = pom->steps.z();
  m.move(c);
  res.a_through_focus_steps = Vec2(c.steps.x(), c.steps.y());
  k.a_through_focus_steps = res.a_through_focus_steps;
  PartOnMountOptions check = o;
  check.null_first = false;  // a null would move the focus off the axis again
  auto after = part_on_mount(m, k, check, log);
  if (!after) return tl::make_unexpected("focus (check): " + after.error());
  res.maps += after->maps;
  res.residual_mm = after->circle.centre;
  observe(k, "focus:after");
  return res;
}

namespace {

// docs/wavefront.md "The B-rotation null": for B angle t (rad), in units of dx,
//   c = (Q + P, 0, R), u = (sin E, cos E, 0), v = Rot(u, t) c
//   X - X_A = Q - v_x,  Y dy/dx = Y0 - v_y,  Z = (Z0 - v_z) / S.
struct BModel {
  std::vector<double> t, x, y, z;
  double x_a = 0, y_scale = 1;
  Eigen::VectorXd residual(const Eigen::Matrix<double, 7, 1>& p) const {
    const double P = p[0], Q = p[1], R = p[2], S = p[3], Z0 = p[4], Y0 = p[5], E = p[6];
    const Vec3 u(std::sin(E), std::cos(E), 0), c(Q + P, 0, R);
    Eigen::VectorXd r(3 * t.size());
    for (std::size_t i = 0; i < t.size(); ++i) {
      const Vec3 v = Eigen::AngleAxisd(t[i], u) * c;
      r[static_cast<Eigen::Index>(3 * i)] = (x[i] - x_a) - (Q - v.x());
      r[static_cast<Eigen::Index>(3 * i + 1)] = y[i] * y_scale - (Y0 - v.y());
      r[static_cast<Eigen::Index>(3 * i + 2)] = z[i] - (Z0 - v.z()) / S;
    }
    return r;
  }
};

}  // namespace

tl::expected<BRotationResult, std::string> b_rotation(WavefrontMachine& m, Knowledge& k, const std::string& ball,
                                                      std::vector<double> b_deg, const Log& log) {
  if (b_deg.empty()) b_deg = {0, 5, 10, 15, 20, -5, -10, -15, -20};
  const auto pb = part_named(m, ball);
  if (!pb || pb->kind != PartKind::Sphere) return tl::unexpected(fmt::format("b-rotation: '{}' is not a sphere", ball));
  if (auto ok = ensure_focus_z(m, k, log); !ok) return tl::unexpected("b-rotation: " + ok.error());
  m.fit_element(Element::Sphere);
  if (auto ok = mount_at_null_guess(m, k, ball); !ok) return tl::unexpected(ok.error());
  BRotationResult res;
  // (b) the A axis through the focus and (c) the part's eccentricity along +X, by part-on-mount.
  auto pom = part_on_mount(m, k, {}, log);
  if (!pom) return tl::make_unexpected("b-rotation: " + pom.error());
  res.maps += pom->maps;
  const Vec2 dxy = -k.lateral_per_step.inverse() * pom->circle.centre;
  const Vec2 xy_a(pom->steps.x() + dxy.x(), pom->steps.y() + dxy.y());
  const double g = k.gauge_clocking_rad;
  const Vec2 r_machine = Eigen::Rotation2Dd(g) * pom->circle.radius_vector;
  AxisCommand c = m.position();
  c.a_deg -= pom->circle.sense * std::atan2(r_machine.y(), r_machine.x()) * kDeg;
  c.steps = Vec3(xy_a.x(), xy_a.y(), pom->steps.z());
  m.move(c);
  // (d)-(e) null at each B, predicting the next null from the design's zF (then the data's).
  const auto& nom = m.nominal();
  double zf_guess = (nom.zc_mm + nom.table_height_mm + design_height_mm(*pb));
  double ecc_guess = 0;
  std::vector<double> t;
  Vec3 last_null{0, 0, 0};
  double last_t = 0;
  const double base_a = c.a_deg;
  std::vector<SubApertureMap> sub_maps;
  for (std::size_t i = 0; i < b_deg.size(); ++i) {
    const double th = b_deg[i] / kDeg;
    AxisCommand cmd = m.position();
    cmd.a_deg = base_a;
    cmd.b_deg = b_deg[i];
    if (i > 0) {
      const double from = (b_deg[i] < 0 && b_deg[i - 1] > 0) ? 0.0 : last_t;  // the negative run starts from B = 0
      const Vec3 from_steps = from == 0.0 ? Vec3(res.null_steps.front()) : last_null;
      const double dcx = ecc_guess * (std::cos(th) - std::cos(from)) + zf_guess * (std::sin(th) - std::sin(from));
      const double dcz = -ecc_guess * (std::sin(th) - std::sin(from)) + zf_guess * (std::cos(th) - std::cos(from));
      cmd.steps = from_steps - Vec3(dcx / k.step_mm.x(), 0, dcz / k.step_mm.z());
    }
    m.move(cmd);
    auto n = null_sphere(m, k, log);
    if (!n) return tl::unexpected(fmt::format("b-rotation at B = {} deg: {}", b_deg[i], n.error()));
    res.maps += n->maps;
    res.b_deg.push_back(b_deg[i]);
    res.null_steps.push_back(n->steps);
    if (i == 0) observe(k, "b-rotation");
    if (k.remove_form) {
      auto sm = map_at_null(m, k, n->steps);
      ++res.maps;
      if (!sm) return tl::unexpected(fmt::format("b-rotation at B = {} deg: {}", b_deg[i], sm.error()));
      sub_maps.push_back(std::move(*sm));
    }
    t.push_back(th);
    last_null = n->steps;
    last_t = th;
    if (t.size() >= 2) {  // refine zF from the X nulls so far: X - X_0 ~ -(zF sin t + e (cos t - 1)) / dx
      Eigen::MatrixXd a(static_cast<Eigen::Index>(t.size()), 2);
      Eigen::VectorXd b(static_cast<Eigen::Index>(t.size()));
      for (std::size_t j = 0; j < t.size(); ++j) {
        a.row(static_cast<Eigen::Index>(j)) << -std::sin(t[j]), 1 - std::cos(t[j]);
        b[static_cast<Eigen::Index>(j)] = (res.null_steps[j].x() - res.null_steps[0].x()) * k.step_mm.x();
      }
      const Eigen::Vector2d sol = a.colPivHouseholderQr().solve(b);
      if (std::isfinite(sol[0]) && t.size() >= 3)
        zf_guess = sol[0], ecc_guess = sol[1];
      else if (std::isfinite(sol[0]))
        zf_guess = sol[0];
    }
  }
  {
    AxisCommand back = m.position();
    back.b_deg = 0;
    back.steps = res.null_steps.front();
    m.move(back);
  }
  res.raw_null_steps = res.null_steps;
  if (k.remove_form) {
    auto st = remove_form(m, k, *pb, sub_maps, res.null_steps);
    if (!st) return tl::unexpected("b-rotation: " + st.error());
    res.form_height_nm = st->form_height_nm;
    res.form_residual_rms_nm = st->residual_rms_nm;
    say(log, fmt::format("  B rotation: the part's form stitched from {} maps (rms {:.2f} nm left); nulls moved by up "
                         "to {:.2f} steps",
                         sub_maps.size(), st->residual_rms_nm, max_shift(res.raw_null_steps, res.null_steps)));
  }
  // (f) least squares of P, Q, R, S (and Z0, Y0, E) by Gauss-Newton from a linear start.
  BModel model;
  model.t = t;
  for (const auto& s : res.null_steps) model.x.push_back(s.x()), model.y.push_back(s.y()), model.z.push_back(s.z());
  model.x_a = xy_a.x();
  model.y_scale = k.step_mm.y() / k.step_mm.x();
  const auto n = static_cast<Eigen::Index>(t.size());
  if (n < 3) return tl::unexpected(std::string("b-rotation needs at least 3 B angles"));
  Eigen::Matrix<double, 7, 1> p;
  {
    Eigen::MatrixXd a(n, 3);
    Eigen::VectorXd b(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      a.row(i) << -std::cos(t[i]), 1 - std::cos(t[i]), -std::sin(t[i]);
      b[i] = model.x[i] - model.x_a;
    }
    const Eigen::Vector3d pqr = a.colPivHouseholderQr().solve(b);
    Eigen::MatrixXd az(n, 2);
    Eigen::VectorXd bz(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      az.row(i) << model.z[i], -1;
      bz[i] = (pqr[0] + pqr[1]) * std::sin(t[i]) - pqr[2] * std::cos(t[i]);
    }
    const Eigen::Vector2d sz = az.colPivHouseholderQr().solve(bz);
    double y0 = 0;
    for (double y : model.y) y0 += y * model.y_scale / static_cast<double>(n);
    p << pqr[0], pqr[1], pqr[2], sz[0], sz[1], y0, 0;
  }
  for (int it = 0; it < 30; ++it) {
    const Eigen::VectorXd r0 = model.residual(p);
    Eigen::MatrixXd jac(r0.size(), 7);
    for (int j = 0; j < 7; ++j) {
      Eigen::Matrix<double, 7, 1> q = p;
      const double h = 1e-7 * std::max(1.0, std::abs(p[j]));
      q[j] += h;
      jac.col(j) = (model.residual(q) - r0) / h;
    }
    const Eigen::VectorXd step = jac.colPivHouseholderQr().solve(-r0);
    p += step;
    bool settled = true;  // per parameter: E is 1e-4 while R is 1e6 steps
    for (int j = 0; j < 7; ++j) settled = settled && std::abs(step[j]) <= 1e-12 * std::max(1.0, std::abs(p[j]));
    if (settled) break;
  }
  const Eigen::VectorXd r = model.residual(p);
  res.p_steps = p[0];
  res.q = p[1];
  res.r = p[2];
  res.s = p[3];
  res.b_axis_tilt_rad = p[6];
  res.residual_rms_steps = std::sqrt(r.squaredNorm() / static_cast<double>(r.size()));
  const double dx = k.step_mm.x();
  res.eccentricity_mm = res.p_steps * dx;
  res.xb_mm = res.q * dx;
  res.zf_mm = res.r * dx;
  res.dz_mm = res.s * dx;
  k.step_mm.z() = res.dz_mm;
  k.zf_mm = res.zf_mm;
  say(log, fmt::format("  B rotation: P {:.6f} mm, xb {:.6f} mm, zF {:.5f} mm, dz {:.8f} mm/step, B tilt {:.3f} urad",
                       res.eccentricity_mm, res.xb_mm, res.zf_mm, res.dz_mm, res.b_axis_tilt_rad * 1e6));
  return res;
}

tl::expected<CRotationResult, std::string> c_rotation(WavefrontMachine& m, Knowledge& k, const std::string& ball,
                                                      std::vector<double> c_deg, const Log& log) {
  if (c_deg.empty()) c_deg = {0, 5, 10, 15, 20, -5, -10, -15, -20};
  const auto pb = part_named(m, ball);
  if (!pb || pb->kind != PartKind::Sphere) return tl::unexpected(fmt::format("c-rotation: '{}' is not a sphere", ball));
  if (auto ok = ensure_focus_z(m, k, log); !ok) return tl::unexpected("c-rotation: " + ok.error());
  m.fit_element(Element::Sphere);
  if (auto ok = mount_at_null_guess(m, k, ball); !ok) return tl::unexpected(ok.error());
  CRotationResult res;
  auto pom = part_on_mount(m, k, {}, log);
  if (!pom) return tl::unexpected("c-rotation: " + pom.error());
  res.maps += pom->maps;
  const Vec2 xy_a = pom->steps.head<2>() - k.lateral_per_step.inverse() * pom->circle.centre;
  AxisCommand c = m.position();
  c.steps = Vec3(xy_a.x(), xy_a.y(), pom->steps.z());
  c.c_deg = 0;
  m.move(c);
  const auto& nom = m.nominal();
  double rc_guess = k.zf_mm.value_or(nom.zc_mm + nom.table_height_mm + design_height_mm(*pb)) - nom.zc_mm;
  double ey_guess = 0;
  std::vector<SubApertureMap> sub_maps;
  std::vector<double> t;
  Vec3 last_null{0, 0, 0};
  double last_t = 0;
  for (std::size_t i = 0; i < c_deg.size(); ++i) {
    const double th = c_deg[i] / kDeg;
    AxisCommand cmd = m.position();
    cmd.c_deg = c_deg[i];
    if (i > 0) {  // Rot_X: y' = y cos - z sin, z' = y sin + z cos
      const double from = (c_deg[i] < 0 && c_deg[i - 1] > 0) ? 0.0 : last_t;
      const Vec3 from_steps = from == 0.0 ? Vec3(res.null_steps.front()) : last_null;
      const double dcy = ey_guess * (std::cos(th) - std::cos(from)) - rc_guess * (std::sin(th) - std::sin(from));
      const double dcz = ey_guess * (std::sin(th) - std::sin(from)) + rc_guess * (std::cos(th) - std::cos(from));
      cmd.steps = from_steps - Vec3(0, dcy / k.step_mm.y(), dcz / k.step_mm.z());
    }
    m.move(cmd);
    auto n = null_sphere(m, k, log);
    if (!n) return tl::unexpected(fmt::format("c-rotation at C = {} deg: {}", c_deg[i], n.error()));
    res.maps += n->maps;
    res.c_deg.push_back(c_deg[i]);
    res.null_steps.push_back(n->steps);
    if (i == 0) observe(k, "c-rotation");
    if (k.remove_form) {
      auto sm = map_at_null(m, k, n->steps);
      ++res.maps;
      if (!sm) return tl::unexpected(fmt::format("c-rotation at C = {} deg: {}", c_deg[i], sm.error()));
      sub_maps.push_back(std::move(*sm));
    }
    t.push_back(th);
    last_null = n->steps;
    last_t = th;
    if (t.size() >= 3) {  // (Y - Y_0) dy = Rc sin t + e (1 - cos t)
      Eigen::MatrixXd a(static_cast<Eigen::Index>(t.size()), 2);
      Eigen::VectorXd b(static_cast<Eigen::Index>(t.size()));
      for (std::size_t j = 0; j < t.size(); ++j) {
        a.row(static_cast<Eigen::Index>(j)) << std::sin(t[j]), 1 - std::cos(t[j]);
        b[static_cast<Eigen::Index>(j)] = (res.null_steps[j].y() - res.null_steps[0].y()) * k.step_mm.y();
      }
      const Eigen::Vector2d sol = a.colPivHouseholderQr().solve(b);
      if (std::isfinite(sol[0])) rc_guess = sol[0], ey_guess = sol[1];
    }
  }
  {
    AxisCommand back = m.position();
    back.c_deg = 0;
    back.steps = res.null_steps.front();
    m.move(back);
  }
  res.raw_null_steps = res.null_steps;
  if (k.remove_form) {
    auto st = remove_form(m, k, *pb, sub_maps, res.null_steps);
    if (!st) return tl::unexpected("c-rotation: " + st.error());
    res.form_height_nm = st->form_height_nm;
    res.form_residual_rms_nm = st->residual_rms_nm;
    say(log, fmt::format("  C rotation: the part's form stitched from {} maps (rms {:.2f} nm left); nulls moved by up "
                         "to {:.2f} steps",
                         sub_maps.size(), st->residual_rms_nm, max_shift(res.raw_null_steps, res.null_steps)));
  }
  // docs/wavefront.md "The C-rotation null": in steps of dy, c = (., Q_c + P_y, R_c),
  //   Y - Y_A = Q_c - v_y, Z = (Z0 - v_z) / S_c, v = Rot_X(t) c.
  const auto n = static_cast<Eigen::Index>(t.size());
  if (n < 3) return tl::unexpected(std::string("c-rotation needs at least 3 C angles"));
  std::vector<double> y, z;
  for (const auto& s : res.null_steps) y.push_back(s.y()), z.push_back(s.z());
  const auto residual = [&](const Eigen::Matrix<double, 5, 1>& p) {
    Eigen::VectorXd r(2 * n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const double cy = p[1] + p[0], cz = p[2], co = std::cos(t[i]), si = std::sin(t[i]);
      r[2 * i] = (y[i] - xy_a.y()) - (p[1] - (cy * co - cz * si));
      r[2 * i + 1] = z[i] - (p[4] - (cy * si + cz * co)) / p[3];
    }
    return r;
  };
  Eigen::Matrix<double, 5, 1> p;
  {
    Eigen::MatrixXd a(n, 3);
    Eigen::VectorXd b(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      a.row(i) << -std::cos(t[i]), 1 - std::cos(t[i]), std::sin(t[i]);
      b[i] = y[i] - xy_a.y();
    }
    const Eigen::Vector3d pqr = a.colPivHouseholderQr().solve(b);
    Eigen::MatrixXd az(n, 2);
    Eigen::VectorXd bz(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      az.row(i) << z[i], -1;
      bz[i] = -(pqr[0] + pqr[1]) * std::sin(t[i]) - pqr[2] * std::cos(t[i]);
    }
    const Eigen::Vector2d sz = az.colPivHouseholderQr().solve(bz);
    p << pqr[0], pqr[1], pqr[2], sz[0], sz[1];
  }
  for (int it = 0; it < 30; ++it) {
    const Eigen::VectorXd r0 = residual(p);
    Eigen::MatrixXd jac(r0.size(), 5);
    for (int j = 0; j < 5; ++j) {
      Eigen::Matrix<double, 5, 1> q = p;
      const double h = 1e-7 * std::max(1.0, std::abs(p[j]));
      q[j] += h;
      jac.col(j) = (residual(q) - r0) / h;
    }
    const Eigen::VectorXd step = jac.colPivHouseholderQr().solve(-r0);
    p += step;
    bool settled = true;
    for (int j = 0; j < 5; ++j) settled = settled && std::abs(step[j]) <= 1e-12 * std::max(1.0, std::abs(p[j]));
    if (settled) break;
  }
  const Eigen::VectorXd r = residual(p);
  res.p_steps = p[0];
  res.q = p[1];
  res.r = p[2];
  res.s = p[3];
  res.residual_rms_steps = std::sqrt(r.squaredNorm() / static_cast<double>(r.size()));
  const double dy = k.step_mm.y();
  res.yc_mm = res.q * dy;
  res.zf_minus_zc_mm = res.r * dy;
  if (k.zf_mm) res.zc_mm = *k.zf_mm - res.zf_minus_zc_mm;
  say(log, fmt::format("  C rotation: yc {:.6f} mm, zF - zc {:.5f} mm{}", res.yc_mm, res.zf_minus_zc_mm,
                       res.zc_mm ? fmt::format(", zc {:.5f} mm", *res.zc_mm) : std::string()));
  return res;
}

tl::expected<AzResult, std::string> align_a_to_z(WavefrontMachine& m, Knowledge& k, const AzOptions& o,
                                                 const Log& log) {
  std::vector<PartSpec> balls;
  if (o.balls.empty()) {
    for (const auto& p : m.parts())
      if (p.kind == PartKind::Sphere) balls.push_back(p);
  } else {
    for (const auto& name : o.balls) {
      const auto p = part_named(m, name);
      if (!p || p->kind != PartKind::Sphere) return tl::unexpected(fmt::format("a-z: '{}' is not a sphere", name));
      balls.push_back(*p);
    }
  }
  if (balls.size() < 2) return tl::unexpected(std::string("a-z needs spheres at two or more heights"));
  if (auto ok = ensure_focus_z(m, k, log); !ok) return tl::unexpected("a-z: " + ok.error());
  m.fit_element(Element::Sphere);
  AzResult res;
  // Each height's centre is referred to one X, Y through the lateral response: it must be the
  // calibrated one (the gauge's clocking turns a nominal one by degrees).
  if (!k.steps_calibrated) {
    m.mount(balls.front().name);
    auto ar = axis_response(m, k, 100, log);
    if (!ar) return tl::unexpected("a-z: " + ar.error());
    res.maps += ar->maps;
  }
  PartOnMountOptions pom_o = o.part_on_mount;
  // Each height is nulled on its own; its centre is then referred back to the first height's X, Y
  // through the calibrated lateral response, which is what keeping X and Y fixed (the seed's step
  // 5 b) measures, without losing the fringes when the A axis is far off Z.
  pom_o.null_first = true;
  for (int iter = 0; iter < o.max_iterations; ++iter) {
    AzIteration it;
    std::vector<double> ox, oy;
    std::optional<Vec2> ref_xy;
    Vec2 ref_centre{0, 0};
    for (const auto& b : balls) {
      if (auto ok = mount_at_null_guess(m, k, b.name); !ok) return tl::unexpected(ok.error());
      auto pom = part_on_mount(m, k, pom_o, log);
      if (!pom) return tl::unexpected(fmt::format("a-z (iteration {}, {}): {}", iter + 1, b.name, pom.error()));
      res.maps += pom->maps;
      const Vec2 xy = pom->steps.head<2>();
      if (!ref_xy) ref_xy = xy;
      // Where the A axis would cross the focal plane with the table at the reference X, Y.
      const Vec2 centre = pom->circle.centre - k.lateral_per_step * (xy - *ref_xy);
      if (ref_xy == xy) ref_centre = centre;
      // The A axis from the focus in machine x, y: the gauge's lateral turned by its clocking.
      const Vec2 off = Eigen::Rotation2Dd(k.gauge_clocking_rad) * centre;
      it.z_mm.push_back(pom->steps.z() * k.step_mm.z());
      it.a_offset_mm.push_back(off);
      ox.push_back(off.x());
      oy.push_back(off.y());
    }
    auto lx = metron::wavefront::fit_line(it.z_mm, ox);
    auto ly = metron::wavefront::fit_line(it.z_mm, oy);
    if (!lx || !ly) return tl::unexpected(std::string("a-z: the parts' heights do not differ"));
    // Raising the table by dZ moves the A axis' crossing of the focal plane by -dZ tan(tilt).
    it.angle_rad = Vec2(-std::atan(lx->slope), -std::atan(ly->slope));
    k.a_through_focus_steps = *ref_xy - k.lateral_per_step.inverse() * ref_centre;
    const bool done = it.angle_rad.norm() < o.tolerance_rad;
    observe(k, fmt::format("a-z:{}", iter + 1));
    if (!done && o.correct) {
      // B turns about +Y (adds to the x slope), C about +X (subtracts from the y slope).
      it.correction_deg = Vec2(-it.angle_rad.x() * kDeg, it.angle_rad.y() * kDeg);
      m.shift_rotary_zeros(it.correction_deg.x(), it.correction_deg.y());
      k.az_correction_deg += it.correction_deg;
    }
    say(log,
        fmt::format("  A-Z iteration {}: tilt ({:.3f}, {:.3f}) urad, B/C zero shift ({:.6f}, {:.6f}) deg", iter + 1,
                    it.angle_rad.x() * 1e6, it.angle_rad.y() * 1e6, it.correction_deg.x(), it.correction_deg.y()));
    res.iterations.push_back(it);
    if (o.on_iteration) o.on_iteration(res.iterations.back());
    if (done) {
      res.converged = true;
      break;
    }
    if (!o.correct) break;
  }
  return res;
}

tl::expected<ReversalResult, std::string> reversal(WavefrontMachine& m, Knowledge& k, const std::string& part,
                                                   const PartOnMountOptions& o, const Log& log) {
  const auto p = part_named(m, part);
  if (!p) return tl::unexpected(fmt::format("reversal: no part named '{}'", part));
  m.fit_element(p->kind == PartKind::Flat ? Element::Flat : Element::Sphere);
  if (auto ok = mount_at_null_guess(m, k, part); !ok) return tl::unexpected(ok.error());
  ReversalResult res;
  auto a = part_on_mount(m, k, o, log);
  if (!a) return tl::make_unexpected("reversal: " + a.error());
  observe(k, "reversal");
  m.turn_part_on_table(180);
  auto b = part_on_mount(m, k, o, log);
  m.turn_part_on_table(-180);
  if (!b) return tl::make_unexpected("reversal (turned): " + b.error());
  res.at_0 = *a;
  res.at_180 = *b;
  res.maps = a->maps + b->maps;
  res.part_rad = (a->circle.radius_vector - b->circle.radius_vector) / 2;
  res.table_rad = (a->circle.radius_vector + b->circle.radius_vector) / 2;
  say(log, fmt::format("  reversal: part ({:.4g}, {:.4g}), table ({:.4g}, {:.4g})", res.part_rad.x(), res.part_rad.y(),
                       res.table_rad.x(), res.table_rad.y()));
  return res;
}

tl::expected<CalibrationReport, std::string> calibrate(WavefrontMachine& m, const std::string& step, const Log& log,
                                                       const AzOptions& az,
                                                       const std::function<void(const std::string&)>& observer,
                                                       bool remove_form) {
  CalibrationReport rep;
  Knowledge& k = rep.knowledge;
  k = initial_knowledge(m);
  k.observe = observer;
  k.remove_form = remove_form;
  std::vector<PartSpec> flats, spheres;
  for (const auto& p : m.parts()) (p.kind == PartKind::Flat ? flats : spheres).push_back(p);
  const auto need = [&](bool ok, const char* what) -> tl::expected<void, std::string> {
    if (!ok) return tl::unexpected(fmt::format("step '{}' needs {} in the world's parts", step, what));
    return {};
  };
  const bool all = step == "all";
  const long maps0 = m.maps_taken();
  bool known = false;
  if (step == "part-on-mount") {
    known = true;
    const std::string part = m.mounted_part();
    if (m.element() == Element::Sphere) {
      if (auto ok = ensure_focus_z(m, k, log); !ok) return tl::unexpected(ok.error());
      if (auto ok = mount_at_null_guess(m, k, part); !ok) return tl::unexpected(ok.error());
    }
    auto r = part_on_mount(m, k, {}, log);
    if (!r) return tl::unexpected(r.error());
    observe(k, "part-on-mount");
    rep.part_on_mount = *r;
  }
  if (all || step == "gauge-frame") {
    known = true;
    if (auto ok = need(!flats.empty(), "a flat"); !ok) return tl::unexpected(ok.error());
    say(log, "step 2: gauge frame (transmission flat, part-on-mount on an optical flat)");
    auto r = align_gauge_frame(m, k, flats.front().name, {}, log);
    if (!r) return tl::unexpected(r.error());
    rep.gauge_frame = *r;
  }
  if (all || step == "focus") {
    known = true;
    if (auto ok = need(!flats.empty() && !spheres.empty(), "a flat and a sphere"); !ok)
      return tl::unexpected(ok.error());
    say(log, "step 3: the focus on the A axis (cat's eye, part-on-mount on a ball)");
    auto r = focus_on_axis(m, k, flats.front().name, spheres.front().name, {}, log);
    if (!r) return tl::unexpected(r.error());
    rep.focus = *r;
  }
  if (all || step == "axis-response") {
    known = true;
    if (auto ok = need(!spheres.empty(), "a sphere"); !ok) return tl::unexpected(ok.error());
    say(log, "axis response: step sizes and gauge clocking against the wavelength");
    m.fit_element(Element::Sphere);
    m.mount(spheres.front().name);
    auto r = axis_response(m, k, 100, log);
    if (!r) return tl::unexpected(r.error());
    rep.axis_response = *r;
  }
  if (all || step == "a-z") {
    known = true;
    say(log, "step 5: A-Z alignment (part-on-mount at two or more heights, line fit, B/C zeros)");
    auto r = align_a_to_z(m, k, az, log);
    if (!r) return tl::unexpected(r.error());
    rep.a_to_z = *r;
  }
  if (all || step == "b-rotation") {
    known = true;
    if (auto ok = need(!spheres.empty(), "a sphere"); !ok) return tl::unexpected(ok.error());
    say(log, "step 4: B rotation null and the P, Q, R, S fit");
    auto r = b_rotation(m, k, spheres.front().name, {}, log);
    if (!r) return tl::unexpected(r.error());
    rep.b_rotation = *r;
  }
  if (all || step == "c-rotation") {
    known = true;
    if (auto ok = need(!spheres.empty(), "a sphere"); !ok) return tl::unexpected(ok.error());
    say(log, "step 4 for C: C rotation null, yc and zc");
    auto r = c_rotation(m, k, spheres.front().name, {}, log);
    if (!r) return tl::unexpected(r.error());
    rep.c_rotation = *r;
  }
  if (all || step == "reversal") {
    known = true;
    if (auto ok = need(!flats.empty(), "a flat"); !ok) return tl::unexpected(ok.error());
    if (!all) {  // a flat in the collimated beam needs the gauge aligned to A first (step 2)
      say(log, "step 2 first: gauge frame (the wedged flat is beyond the fringe limit otherwise)");
      auto g = align_gauge_frame(m, k, flats.front().name, {}, log);
      if (!g) return tl::unexpected(g.error());
      rep.gauge_frame = *g;
    }
    say(log, "reversal: the part turned 180 degrees on the table");
    auto r = reversal(m, k, flats.back().name, {}, log);
    if (!r) return tl::unexpected(r.error());
    rep.reversal = *r;
    m.fit_element(Element::Sphere);
  }
  if (!known)
    return tl::unexpected(
        fmt::format("unknown step '{}' (expected part-on-mount, gauge-frame, axis-response, focus, a-z, b-rotation, "
                    "c-rotation, reversal, all)",
                    step));
  // The focus Z with the step size the later steps calibrated (the cat's eye used the one then known).
  if (k.cat_eye_z_steps) {
    k.focus_table_z_steps = *k.cat_eye_z_steps + k.cat_eye_height_mm / k.step_mm.z();
    if (rep.focus) rep.focus->focus_table_z_steps = *k.focus_table_z_steps;
  }
  rep.maps = m.maps_taken() - maps0;
  return rep;
}

}  // namespace metron::runtime::wavefront
