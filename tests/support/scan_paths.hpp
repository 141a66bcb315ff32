// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Simple scan paths and parts for the scanning tests and benchmark (the general path generator
// from CAD lives in stdlib). Header-only, in metron_test_support: shared by the machine and
// runtime tests and the scanning benchmarks.
#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "metron/machine/command.hpp"
#include "metron/machine/csg.hpp"
#include "metron/machine/measurement_command.hpp"
#include "metron/machine/world.hpp"
#include "metron/stdlib/fitting/fit.hpp"
#include "metron/stdlib/geometry/mesh.hpp"
#include "metron/stdlib/geometry/pcc.hpp"

namespace metron::scan_test {

constexpr double deg = std::numbers::pi / 180;

/// Left normal in the x-z plane of a direction along the path: (-tz, 0, tx).
inline Vec3 left_normal_xz(const Vec3& t) { return Vec3(-t.z(), 0, t.x()).normalized(); }

/// Appends straight hermite segments from a to b, each at most max_seg_mm long.
inline void add_line(geometry::PccPath& path, const Vec3& a, const Vec3& b, double max_seg_mm, const Vec3& normal) {
  const double len = (b - a).norm();
  if (len < 1e-9) return;
  const Vec3 u = (b - a) / len;
  const int n = std::max(1, static_cast<int>(std::ceil(len / max_seg_mm)));
  for (int i = 0; i < n; ++i) {
    path.segments.push_back(geometry::PccSegment::hermite(a + (b - a) * i / n, a + (b - a) * (i + 1) / n, u, u));
    path.normals.push_back(normal);
  }
}

/// Appends a circular arc (centre c, from unit radial e0 through angle phi about axis w) as
/// hermite segments of at most 10 degrees; `outward` picks the normal (+radial or -radial).
inline void add_arc(geometry::PccPath& path, const Vec3& c, double radius, const Vec3& e0, const Vec3& w, double phi,
                    double normal_sign) {
  const int n = std::max(1, static_cast<int>(std::ceil(std::abs(phi) / (10 * deg))));
  const Vec3 e1 = w.cross(e0);
  const auto radial = [&](double a) { return Vec3(std::cos(a) * e0 + std::sin(a) * e1); };
  const auto tangent = [&](double a) { return Vec3((phi > 0 ? 1 : -1) * (-std::sin(a) * e0 + std::cos(a) * e1)); };
  for (int i = 0; i < n; ++i) {
    const double a0 = phi * i / n, a1 = phi * (i + 1) / n;
    path.segments.push_back(
        geometry::PccSegment::hermite(c + radius * radial(a0), c + radius * radial(a1), tangent(a0), tangent(a1)));
    path.normals.push_back(normal_sign * radial(a0));
  }
}

/// The ball-centre path over a profile in the x-z plane (material on the right of the travel
/// direction, i.e. below when travelling +x): the surface polyline offset by offset_mm along its
/// left normal (SEEDS.md 1: contour offset by r - E0), corners rounded with fillet_mm arcs (a
/// convex corner's offset is exactly such an arc when fillet_mm == offset_mm).
inline geometry::PccPath profile_path_xz(const std::vector<Vec3>& surface, double offset_mm, double fillet_mm,
                                         double max_seg_mm = 5) {
  const std::size_t m = surface.size();
  std::vector<Vec3> dir(m - 1), nrm(m - 1);
  for (std::size_t i = 0; i + 1 < m; ++i) {
    dir[i] = (surface[i + 1] - surface[i]).normalized();
    nrm[i] = left_normal_xz(dir[i]);
  }
  // Offset polyline: the start and end moved along their edge's normal, inner corners where
  // consecutive offset lines meet.
  std::vector<Vec3> q(m);
  q[0] = surface[0] + offset_mm * nrm[0];
  q[m - 1] = surface[m - 1] + offset_mm * nrm[m - 2];
  for (std::size_t i = 1; i + 1 < m; ++i) {
    const Vec3 a = surface[i] + offset_mm * nrm[i - 1], b = surface[i] + offset_mm * nrm[i];
    // a + s*dir[i-1] = b + t*dir[i] in x-z.
    const double det = dir[i - 1].x() * (-dir[i].z()) - dir[i - 1].z() * (-dir[i].x());
    if (std::abs(det) < 1e-12) {
      q[i] = a;
      continue;
    }
    const Vec3 d = b - a;
    const double s = (d.x() * (-dir[i].z()) - d.z() * (-dir[i].x())) / det;
    q[i] = a + s * dir[i - 1];
  }
  geometry::PccPath path;
  Vec3 cursor = q[0];
  for (std::size_t i = 1; i + 1 < m; ++i) {
    const Vec3 din = dir[i - 1], dout = dir[i];
    const double phi = std::acos(std::clamp(din.dot(dout), -1.0, 1.0));
    if (phi < 1e-9) continue;
    const double l = fillet_mm * std::tan(phi / 2);
    const Vec3 a = q[i] - l * din;
    add_line(path, cursor, a, max_seg_mm, nrm[i - 1]);
    const Vec3 toward = (dout - dout.dot(din) * din).normalized();  // the side the path turns to
    const Vec3 centre = a + fillet_mm * toward;
    const Vec3 w = (-toward).cross(din).normalized();  // rotation axis: radial x tangent
    // Normal along the arc: the left normal, +/- the radial direction.
    const double sign = nrm[i - 1].dot(-toward) > 0 ? 1.0 : -1.0;
    add_arc(path, centre, fillet_mm, -toward, w, phi, sign);
    cursor = q[i] + l * dout;
  }
  add_line(path, cursor, q[m - 1], max_seg_mm, nrm[m - 2]);
  path.normals.push_back(nrm[m - 2]);
  return path;
}

/// A full circle of ball centres in the plane z = centre.z, counterclockwise from start_deg;
/// normal +radial for a boss (outward), -radial for a bore.
inline geometry::PccPath circle_path(const Vec3& centre, double radius, bool boss, double start_deg = 0,
                                     double turn_deg = 360) {
  geometry::PccPath path;
  const Vec3 e0(std::cos(start_deg * deg), std::sin(start_deg * deg), 0);
  add_arc(path, centre, radius, e0, Vec3::UnitZ(), turn_deg * deg, boss ? 1.0 : -1.0);
  const double a = (start_deg + turn_deg) * deg;
  path.normals.push_back((boss ? 1.0 : -1.0) * Vec3(std::cos(a), std::sin(a), 0));
  return path;
}

/// The surface profile (y = 0 section) of the ramp part: flat at z = base from x = 0 to x0,
/// a ramp of angle_deg rising `rise` mm, then a plateau; total length x_end.
inline std::vector<Vec3> ramp_profile(double angle_deg, double x0 = 20, double rise = 5, double x_end = 60,
                                      double base = 10) {
  if (angle_deg <= 0) return {Vec3(0, 0, base), Vec3(x_end, 0, base)};
  const double run = rise / std::tan(angle_deg * deg);
  return {Vec3(0, 0, base), Vec3(x0, 0, base), Vec3(x0 + run, 0, base + rise),
          Vec3(x0 + run + x_end - x0, 0, base + rise)};
}

/// The ramp part as CSG (part coordinates): (below the flat or below the ramp) and below the
/// plateau, within x in [-20, 200] and y in [-30, 30].
inline machine::csg::Node ramp_design(double angle_deg, double x0 = 20, double rise = 5, double base = 10) {
  using namespace machine::csg;
  const auto half = [](const Vec3& p, const Vec3& n) {
    Node leaf;
    leaf.primitive = {"", HalfSpace{p, n.normalized()}};
    return leaf;
  };
  Node top;
  if (angle_deg <= 0) {
    top = half(Vec3(0, 0, base), Vec3::UnitZ());
  } else {
    const double a = angle_deg * deg;
    Node climb;
    climb.op = Node::Op::Union;
    climb.children = {half(Vec3(0, 0, base), Vec3::UnitZ()),
                      half(Vec3(x0, 0, base), Vec3(-std::sin(a), 0, std::cos(a)))};
    top.op = Node::Op::Intersection;
    top.children = {climb, half(Vec3(0, 0, base + rise), Vec3::UnitZ())};
  }
  Node block;
  block.op = Node::Op::Intersection;
  block.children = {top,
                    half(Vec3(-20, 0, 0), -Vec3::UnitX()),
                    half(Vec3(200, 0, 0), Vec3::UnitX()),
                    half(Vec3(0, -30, 0), -Vec3::UnitY()),
                    half(Vec3(0, 30, 0), Vec3::UnitY()),
                    half(Vec3(0, 0, 0), -Vec3::UnitZ())};
  return block;
}

/// The lobed boss of the segmented-scanning tests and benchmark: diameter 50 with a hidden
/// 3-lobe form of 2.5 um amplitude (5 um roundness) at 20 degrees, its axis at (100, 100).
constexpr double boss_ball_radius_mm = 2, boss_e0_mm = 0.3, boss_diameter_mm = 50, boss_lobe_mm = 0.0025;
inline const Vec3 boss_centre_mm(100, 100, 0);

inline machine::World lobed_boss_world() {
  machine::World w = machine::default_world();
  machine::csg::Node boss;
  boss.primitive = {"BOSS", machine::csg::Cylinder{Vec3::Zero(), Vec3::UnitZ(), boss_diameter_mm, 30.0}};
  machine::PartSpec part;
  part.design = boss;
  part.pose.translation_mm = boss_centre_mm;
  part.seed = 5;
  machine::csg::Deviation dev;
  dev.lobing = machine::csg::Lobing{3, boss_lobe_mm, 20.0};
  part.deviations["BOSS"] = dev;
  w.truth.part = part;
  return w;
}

/// `turns` turns around the lobed boss at z = 15 (ball centres r - E0 off the surface) in
/// segments of about `segment_mm`, with the outward normals; Vc2 law, a sample every 0.2 mm.
inline machine::ScanPath boss_scan(double turns, double segment_mm) {
  machine::ScanPath c;
  const double r = boss_diameter_mm / 2 + boss_ball_radius_mm - boss_e0_mm;
  const auto n = static_cast<std::size_t>(std::ceil(turns * 2 * std::numbers::pi * r / segment_mm));
  const double da = turns * 2 * std::numbers::pi / static_cast<double>(n);
  const auto radial = [](double a) { return Vec3(std::cos(a), std::sin(a), 0); };
  const auto tangent = [](double a) { return Vec3(-std::sin(a), std::cos(a), 0); };
  const Vec3 c0 = boss_centre_mm + Vec3(0, 0, 15);
  for (std::size_t k = 0; k < n; ++k) {
    const double a0 = da * static_cast<double>(k), a1 = a0 + da;
    c.path.segments.push_back(
        geometry::PccSegment::hermite(c0 + r * radial(a0), c0 + r * radial(a1), tangent(a0), tangent(a1)));
    c.path.normals.push_back(radial(a0));
  }
  c.path.normals.push_back(radial(da * static_cast<double>(n)));
  c.approach_normal = Vec3::UnitX();
  c.law = machine::ScanLaw::Vc2;
  c.sample_spacing_mm = 0.2;
  return c;
}

/// Commands of P segments each, the last one shorter (the host's averaging rule is runtime's
/// and tested there); normals are copied when the path has them.
inline std::vector<machine::segmented::MeasurementCommand> split(const geometry::PccPath& path, std::size_t P) {
  std::vector<machine::segmented::MeasurementCommand> out;
  const bool with_normals = path.normals.size() == path.segments.size() + 1;
  for (std::size_t first = 0, i = 0; first < path.segments.size(); first += P, ++i) {
    machine::segmented::MeasurementCommand c;
    c.index = i;
    c.first_segment = first;
    const std::size_t n = std::min(P, path.segments.size() - first);
    c.segments.assign(path.segments.begin() + static_cast<long>(first),
                      path.segments.begin() + static_cast<long>(first + n));
    if (with_normals)
      c.normals.assign(path.normals.begin() + static_cast<long>(first),
                       path.normals.begin() + static_cast<long>(first + n + 1));
    c.last = first + n == path.segments.size();
    out.push_back(std::move(c));
  }
  return out;
}

/// Least-squares circle (outer, axis along Z) of scanned samples compensated with `ball_radius_mm`.
inline auto fit_scanned_boss(const std::vector<machine::ScanSample>& samples, double ball_radius_mm) {
  std::vector<Vec3> pts;
  for (const machine::ScanSample& s : samples) pts.push_back(s.surface_mm(ball_radius_mm));
  fitting::FitOptions o;
  o.inner = false;
  o.direction_hint = Vec3::UnitZ();
  return fitting::fit(fitting::Shape::Circle, pts, o);
}

// A closed mesh of the free-form block 0 <= z <= height(x, y) over [x0, x1] x [y0, y1].
template <class F>
inline geometry::Mesh heightfield_block(F height, double x0, double x1, double y0, double y1, int nx, int ny) {
  std::vector<Vec3> v;
  std::vector<geometry::Mesh::Face> f;
  const auto at = [&](int i, int j, bool top) {
    return static_cast<std::uint32_t>((top ? 0 : (nx + 1) * (ny + 1)) + j * (nx + 1) + i);
  };
  for (int top = 1; top >= 0; --top)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        const double x = x0 + (x1 - x0) * i / nx, y = y0 + (y1 - y0) * j / ny;
        v.emplace_back(x, y, top ? height(x, y) : 0.0);
      }
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      f.push_back({at(i, j, true), at(i + 1, j, true), at(i + 1, j + 1, true)});
      f.push_back({at(i, j, true), at(i + 1, j + 1, true), at(i, j + 1, true)});
      f.push_back({at(i, j, false), at(i + 1, j + 1, false), at(i + 1, j, false)});
      f.push_back({at(i, j, false), at(i, j + 1, false), at(i + 1, j + 1, false)});
    }
  // Walls: each boundary edge of the top joined to the bottom, facing out.
  const auto wall = [&](std::uint32_t a, std::uint32_t b, std::uint32_t a0, std::uint32_t b0) {
    f.push_back({a, b0, a0});
    f.push_back({a, b, b0});
  };
  for (int i = 0; i < nx; ++i) {
    wall(at(i + 1, 0, true), at(i, 0, true), at(i + 1, 0, false), at(i, 0, false));      // y = y0
    wall(at(i, ny, true), at(i + 1, ny, true), at(i, ny, false), at(i + 1, ny, false));  // y = y1
  }
  for (int j = 0; j < ny; ++j) {
    wall(at(0, j, true), at(0, j + 1, true), at(0, j, false), at(0, j + 1, false));      // x = x0
    wall(at(nx, j + 1, true), at(nx, j, true), at(nx, j + 1, false), at(nx, j, false));  // x = x1
  }
  auto m = geometry::Mesh::from_triangles(std::move(v), std::move(f));
  if (!m) throw std::runtime_error(m.error().message);
  return *m;
}

/// The ramp part's block with a plane top through (0, 0, base + raise_mm) tilted sideways (about
/// x) by tilt_deg: its outward normal is (0, -sin(tilt), cos(tilt)). A flat design's path along x
/// then deviates from the actual surface across the scan direction (SEEDS.md 1, Vc2's case).
inline machine::csg::Node tilted_block_design(double tilt_deg, double raise_mm, double base = 10) {
  using namespace machine::csg;
  const auto half = [](const Vec3& p, const Vec3& n) {
    Node leaf;
    leaf.primitive = {"", HalfSpace{p, n.normalized()}};
    return leaf;
  };
  const double a = tilt_deg * deg;
  Node block;
  block.op = Node::Op::Intersection;
  block.children = {half(Vec3(0, 0, base + raise_mm), Vec3(0, -std::sin(a), std::cos(a))),
                    half(Vec3(-20, 0, 0), -Vec3::UnitX()),
                    half(Vec3(200, 0, 0), Vec3::UnitX()),
                    half(Vec3(0, -30, 0), -Vec3::UnitY()),
                    half(Vec3(0, 30, 0), Vec3::UnitY()),
                    half(Vec3(0, 0, 0), -Vec3::UnitZ())};
  return block;
}

/// Hermite segments through the points f(u), u from u0 to u1 in n steps, tangents by central
/// differences, with normals g(u): a smooth nominal path from a parametric contour.
template <class F, class G>
inline geometry::PccPath sampled_path(F f, G g, double u0, double u1, int n) {
  geometry::PccPath path;
  const double h = (u1 - u0) * 1e-5;
  const auto tangent = [&](double u) { return Vec3((f(u + h) - f(u - h)).normalized()); };
  for (int i = 0; i < n; ++i) {
    const double a = u0 + (u1 - u0) * i / n, b = u0 + (u1 - u0) * (i + 1) / n;
    path.segments.push_back(geometry::PccSegment::hermite(f(a), f(b), tangent(a), tangent(b)));
    path.normals.push_back(g(a));
  }
  path.normals.push_back(g(u1));
  return path;
}

/// A scan whose path deviates from the actual surface across the scan direction (issue 11 item 1):
/// the world (its part as machined), the nominal command, and where the head starts.
struct LateralCase {
  std::string name;              ///< for tables
  machine::World world;          ///< the part as machined (hidden)
  machine::ScanPath command;     ///< the path from the design
  Vec3 start_mm = Vec3::Zero();  ///< the head's start (the approach point, or off it)
};

/// The design pose of the lateral cases' parts.
inline const Vec3 lateral_origin_mm(100, 100, 0);

/// The flat block's design path: along x at y = 100 over the top z = 10, ball centres r - E0 above.
inline machine::ScanPath flat_line_scan(double ball_radius_mm = 2, double e0_mm = 0.3) {
  machine::ScanPath c;
  c.path = profile_path_xz(ramp_profile(0), ball_radius_mm - e0_mm, ball_radius_mm - e0_mm);
  for (auto& s : c.path.segments) s.k.col(0) += lateral_origin_mm;
  c.approach_normal = Vec3::UnitZ();
  c.sample_spacing_mm = 0.1;
  return c;
}

inline machine::World lateral_world(std::variant<machine::csg::Node, machine::CadDesign> design, const Vec3& at_mm,
                                    double roughness_mm) {
  machine::World w = machine::default_world();
  machine::PartSpec part;
  part.design = std::move(design);
  part.pose.translation_mm = at_mm;
  part.roughness = {roughness_mm, 0.5};
  part.seed = 7;
  w.truth.part = part;
  w.truth.probe.ball_radius_error_mm = 0;
  return w;
}

/// Case 1: the flat design's line over a top that is actually tilted sideways by tilt_deg and
/// raised by raise_mm.
inline LateralCase tilted_plane_case(double tilt_deg = 20, double raise_mm = 0.3, double roughness_mm = 0) {
  LateralCase c{"plane tilted sideways",
                lateral_world(tilted_block_design(tilt_deg, raise_mm), lateral_origin_mm, roughness_mm),
                flat_line_scan(), Vec3::Zero()};
  c.start_mm = c.command.path.segments.front().start() + c.command.approach_mm * Vec3::UnitZ();
  return c;
}

/// Case 2: the flat part as designed, the head starting offset_mm sideways (+y) of the approach point.
inline LateralCase start_offset_case(double offset_mm = 0.5, double roughness_mm = 0) {
  LateralCase c{"lateral start offset", lateral_world(tilted_block_design(0, 0), lateral_origin_mm, roughness_mm),
                flat_line_scan(), Vec3::Zero()};
  c.start_mm = c.command.path.segments.front().start() + c.command.approach_mm * Vec3::UnitZ() + Vec3(0, offset_mm, 0);
  return c;
}

/// Case 3: a latitude circle (polar angle polar_deg) on a sphere of diameter 40 designed at
/// sphere_centre_mm, actually centred `offset_mm` away.
inline const Vec3 sphere_centre_mm(100, 100, 50);
constexpr double sphere_diameter_mm = 40;
inline LateralCase sphere_latitude_case(const Vec3& offset_mm, double polar_deg = 45, double roughness_mm = 0,
                                        double ball_radius_mm = 2, double e0_mm = 0.3) {
  machine::csg::Node ball;
  ball.primitive = {"SPHERE", machine::csg::Sphere{Vec3::Zero(), sphere_diameter_mm}};
  LateralCase c{
      "sphere latitude, centre off", lateral_world(ball, sphere_centre_mm + offset_mm, roughness_mm), {}, Vec3::Zero()};
  const double r = sphere_diameter_mm / 2 + ball_radius_mm - e0_mm, th = polar_deg * deg;
  const auto radial = [th](double phi) {
    return Vec3(std::sin(th) * std::cos(phi), std::sin(th) * std::sin(phi), std::cos(th));
  };
  c.command.path = sampled_path([&](double phi) { return Vec3(sphere_centre_mm + r * radial(phi)); }, radial, 0,
                                2 * std::numbers::pi, 72);
  c.command.approach_normal = radial(0);
  c.command.sample_spacing_mm = 0.1;
  c.start_mm = c.command.path.segments.front().start() + c.command.approach_mm * radial(0);
  return c;
}

/// Case 4: a free-form surface z = 20 + 1.5 sin(x/12) cos(y/15) + tan(slope) y (a mesh), the path
/// along its y = 0 contour, the part actually shifted shift_mm sideways (+y).
inline double free_form_height(double x, double y, double slope_deg = 20) {
  return 20 + 1.5 * std::sin(x / 12) * std::cos(y / 15) + std::tan(slope_deg * deg) * y;
}
inline LateralCase free_form_case(double shift_mm = 0.5, double roughness_mm = 0, double ball_radius_mm = 2,
                                  double e0_mm = 0.3) {
  auto mesh = std::make_shared<const geometry::Mesh>(
      heightfield_block([](double x, double y) { return free_form_height(x, y); }, 0, 60, -20, 20, 120, 80));
  machine::CadDesign cad;
  cad.path = "<free-form heightfield>";
  cad.mesh = mesh;
  LateralCase c{"free-form shifted sideways",
                lateral_world(cad, lateral_origin_mm + Vec3(0, shift_mm, 0), roughness_mm),
                {},
                Vec3::Zero()};
  const auto normal = [](double x) {
    const double h = 1e-5;
    const double hx = (free_form_height(x + h, 0) - free_form_height(x - h, 0)) / (2 * h);
    const double hy = (free_form_height(x, h) - free_form_height(x, -h)) / (2 * h);
    return Vec3(Vec3(-hx, -hy, 1).normalized());
  };
  c.command.path = sampled_path(
      [&](double x) {
        return Vec3(lateral_origin_mm + Vec3(x, 0, free_form_height(x, 0)) + (ball_radius_mm - e0_mm) * normal(x));
      },
      normal, 5, 55, 50);
  c.command.approach_normal = normal(5);
  c.command.sample_spacing_mm = 0.1;
  c.start_mm = c.command.path.segments.front().start() + c.command.approach_mm * normal(5);
  return c;
}

}  // namespace metron::scan_test
