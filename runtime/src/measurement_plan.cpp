// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/runtime/measurement_plan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "metron/stdlib/geometry/ellipse.hpp"

namespace metron::runtime {
namespace {

// The height (along `up`) that AUTO moves rise to over `at`: the highest step plus the clearance
// distance (SNSET/CLRSRF,d), and at least the clearance surface (SNSET/CLRSRF,F(plane),d) with the
// ball (radius `ball_mm`, whose centre the moves position) above it. A surface steeper than 60
// degrees to `up` gives no height (the runtime refuses one when it is set).
double clearance_height(double top, const ProbeSettings& probe, double ball_mm, const Vec3& up, const Vec3& at) {
  double h = top + probe.clearance_mm;
  if (const auto& c = probe.clearance_plane) {
    const double facing = c->normal.dot(up);
    if (std::abs(facing) >= 0.5) {
      const double t = (c->point_mm - at).dot(c->normal) / facing;  // along up from `at` to the plane
      h = std::max(h, at.dot(up) + t + ball_mm);
    }
  }
  return h;
}

// Unit radial direction of `p` about the axis through `c` along `axis` (any when on the axis).
Vec3 radial(const Vec3& p, const Vec3& c, const Vec3& axis) {
  Vec3 d = p - c;
  d -= d.dot(axis) * axis;
  return d.norm() < 1e-12 ? any_perpendicular(axis) : Vec3(d.normalized());
}

// Appends a ring of probes around an axis. An OUTER ring walks around outside the material
// (a straight chord between two approach points would cut through a boss); `last_angle` carries
// the angle of the previous probe of the same feature so ring-to-ring moves walk around too.
// Walks round a boss from angle `from` to angle `to` on a polygon of legs at most 22.5 deg whose
// sides stay beyond `radius` (the walk radius is the polygon's, enlarged by 1/cos(11.25 deg)).
void walk_around(std::vector<PlannedStep>& steps, const Vec3& centre, const Vec3& u, const Vec3& v, double radius,
                 double from, double to) {
  const double walk_radius = radius / std::cos(std::numbers::pi / 16) + 0.5;
  const int legs = std::max(2, static_cast<int>(std::ceil(std::abs(to - from) / (std::numbers::pi / 8))));
  for (int k = 0; k <= legs; ++k) {
    const double b = from + (to - from) * k / legs;
    steps.push_back(
        {PlannedStep::Kind::GoTo, centre + walk_radius * (std::cos(b) * u + std::sin(b) * v), Vec3::UnitZ()});
  }
}

void ring_at(std::vector<PlannedStep>& steps, const Vec3& centre, const Vec3& u, const Vec3& v, double radius,
             const std::vector<double>& angles_rad, bool inner, double approach_mm, std::optional<double>& last_angle) {
  for (const double a : angles_rad) {
    const Vec3 dir = std::cos(a) * u + std::sin(a) * v;
    if (!inner && last_angle) walk_around(steps, centre, u, v, radius + approach_mm, *last_angle, a);
    const Vec3 surface = centre + radius * dir;
    steps.push_back({PlannedStep::Kind::Probe, surface, inner ? Vec3(-dir) : dir});
    last_angle = a;
  }
}

void ring(std::vector<PlannedStep>& steps, const Vec3& centre, const Vec3& axis, double radius, int count, bool inner,
          double approach_mm, double phase_rad, std::optional<double>& last_angle) {
  const Vec3 u = any_perpendicular(axis);
  std::vector<double> angles;
  for (int i = 0; i < count; ++i) angles.push_back(phase_rad + 2.0 * std::numbers::pi * i / count);
  ring_at(steps, centre, u, axis.cross(u), radius, angles, inner, approach_mm, last_angle);
}

// A line lies in the plane normal to its i2,j2,k2 (DMIS); the surface it is probed on is normal
// to that plane's in-plane perpendicular: direction x i2,j2,k2 (e.g. x along, z up: the -y face).
Vec3 line_surface_normal(const Geometry& g) {
  const Vec3 n = g.direction.cross(g.normal2);
  return n.norm() < 1e-12 ? any_perpendicular(g.direction) : Vec3(n.normalized());
}

// A CPARLN's frame: its long axis `a` made normal to the plane normal `n`, and b = n x a.
struct SlotFrame {
  Vec3 n, a, b;
};
SlotFrame slot_frame(const Geometry& g) {
  const Vec3 n = g.direction.normalized();
  Vec3 a = g.slot_axis - g.slot_axis.dot(n) * n;
  a = a.norm() < 1e-12 ? any_perpendicular(n) : Vec3(a.normalized());
  return {n, a, n.cross(a)};
}

// The outline's normal out of the slot's region nearest `point` (its plane's in-plane part):
// ROUND ends beyond the straight part are semicircles; FLAT ends are the nearer of side and end.
Vec3 slot_outward(const Geometry& g, const Vec3& point) {
  const SlotFrame f = slot_frame(g);
  const Vec3 d = point - g.position;
  const double x = d.dot(f.a), y = d.dot(f.b);
  const double sx = x < 0 ? -1.0 : 1.0, sy = y < 0 ? -1.0 : 1.0;
  if (g.slot_ends == SlotEnds::Round) {
    const double h = std::max(0.0, 0.5 * (g.length_mm - g.width_mm));
    if (std::abs(x) <= h) return sy * f.b;
    const Vec3 r = (x - sx * h) * f.a + y * f.b;
    return r.norm() < 1e-12 ? Vec3(sx * f.a) : Vec3(r.normalized());
  }
  const bool end = std::abs(std::abs(x) - 0.5 * g.length_mm) < std::abs(std::abs(y) - 0.5 * g.width_mm);
  return end ? Vec3(sx * f.a) : Vec3(sy * f.b);
}

}  // namespace

int minimum_points(FeatureType type) {
  switch (type) {
    case FeatureType::Point: return 1;
    case FeatureType::Line: return 2;
    case FeatureType::Plane: return 3;
    case FeatureType::ParallelPlanes: return 4;  // three on one face and one on the other fix both
    case FeatureType::ClosedSlot: return 5;      // centre, angle, length, width: two on a side, one on each other part
    case FeatureType::GenericSurface:
    case FeatureType::GenericCurve: return 1;
    case FeatureType::Circle:
    case FeatureType::Arc: return 3;
    case FeatureType::Sphere: return 4;
    case FeatureType::Cylinder: return 5;
    case FeatureType::Cone: return 6;
    case FeatureType::Torus: return 7;    // centre, axis (2), two diameters
    case FeatureType::Ellipse: return 5;  // centre (2), angle, two diameters
  }
  return 1;
}

Vec3 nominal_normal_at(const Geometry& g, const Vec3& point) {
  const Vec3 axis = g.direction.normalized();
  const double sign = g.side == Side::Inner ? -1.0 : 1.0;
  switch (g.type) {
    case FeatureType::Point:
    case FeatureType::Plane:
    case FeatureType::GenericSurface:
    case FeatureType::GenericCurve: return axis;
    case FeatureType::ParallelPlanes: {
      // The face on the +normal side of the median plane faces +normal on a tab (OUTER), -normal
      // in a slot (INNER); the other face the opposite way.
      const double face = (point - g.position).dot(axis) >= 0 ? 1.0 : -1.0;
      return (g.side == Side::Inner ? -face : face) * axis;
    }
    case FeatureType::Line: return line_surface_normal(g);
    case FeatureType::ClosedSlot: return sign * slot_outward(g, point);
    case FeatureType::Ellipse: {
      // The in-plane normal of the nominal ellipse at the foot of `point`.
      const SlotFrame f = slot_frame(g);
      const Vec3 d = point - g.position;
      const Eigen::Vector2d m =
          geometry::ellipse_foot(0.5 * g.diameter_mm, 0.5 * g.minor_diameter_mm, {d.dot(f.a), d.dot(f.b)}).normal;
      return sign * (m.x() * f.a + m.y() * f.b);
    }
    case FeatureType::Circle:
    case FeatureType::Arc:
    case FeatureType::Cylinder: return sign * radial(point, g.position, axis);
    case FeatureType::Sphere: {
      const Vec3 d = point - g.position;
      return sign * (d.norm() < 1e-12 ? Vec3::UnitZ() : Vec3(d.normalized()));
    }
    case FeatureType::Cone: {
      // Surface normal of a cone with apex at position, axis opening along direction.
      const double half = g.apex_angle_deg * std::numbers::pi / 360.0;
      const Vec3 r = radial(point, g.position, axis);
      return sign * (std::cos(half) * r - std::sin(half) * axis).normalized();
    }
    case FeatureType::Torus: {
      // Away from the tube's centre: the nearest point of the centre circle to `point`.
      const Vec3 r = radial(point, g.position, axis);
      const Vec3 tube = point - g.position - 0.5 * g.diameter_mm * r;
      return sign * (tube.norm() < 1e-12 ? r : Vec3(tube.normalized()));
    }
  }
  return axis;
}

std::vector<PlannedStep> plan_auto_points(const Geometry& g, int count, const ProbeSettings& settings,
                                          double ball_radius_mm, const Vec3& up, const Vec3& current_position,
                                          const Vec3& arc_reference) {
  // Ball-centre stand-off: the machine's PtMeas starts its ball surface APPRCH off the surface.
  ProbeSettings probe = settings;
  probe.approach_mm += ball_radius_mm;
  std::vector<PlannedStep> steps;
  const Vec3 axis = g.direction.normalized();
  const bool inner = g.side != Side::Outer;
  const double r = g.diameter_mm / 2.0;
  switch (g.type) {
    case FeatureType::Point: steps.push_back({PlannedStep::Kind::Probe, g.position, axis}); break;
    case FeatureType::GenericSurface:
    case FeatureType::GenericCurve: break;  // no nominal shape to plan on: its PTMEAS are its points
    case FeatureType::Plane: {
      const int n = count > 0 ? count : 4;
      const Vec3 u = any_perpendicular(axis);
      const Vec3 v = axis.cross(u);
      for (int i = 0; i < n; ++i) {
        const double a = 2.0 * std::numbers::pi * i / n + std::numbers::pi / 4;
        steps.push_back({PlannedStep::Kind::Probe, g.position + 5.0 * (std::cos(a) * u + std::sin(a) * v), axis});
      }
      break;
    }
    case FeatureType::ParallelPlanes: {
      // Half the points on each face, about the nominal point's foot on it; between the faces the
      // probe goes over the feature at the clearance height (the start and end moves' height).
      const int n = std::max(count > 0 ? count : 6, 4);
      const Vec3 u = any_perpendicular(axis);
      const Vec3 v = axis.cross(u);
      std::vector<PlannedStep> faces[2];
      for (int i = 0; i < n; ++i) {
        const int face = i < (n + 1) / 2 ? 0 : 1;
        const int m = face == 0 ? (n + 1) / 2 : n / 2;
        const int k = face == 0 ? i : i - (n + 1) / 2;
        const double a = 2.0 * std::numbers::pi * k / m + std::numbers::pi / 4;
        const Vec3 p =
            g.position + (face == 0 ? 0.5 : -0.5) * g.width_mm * axis + 5.0 * (std::cos(a) * u + std::sin(a) * v);
        faces[face].push_back({PlannedStep::Kind::Probe, p, nominal_normal_at(g, p)});
      }
      double top = current_position.dot(up);
      for (const auto& face : faces)
        for (const auto& s : face) top = std::max(top, (s.point + probe.approach_mm * s.normal).dot(up));
      const double clear = clearance_height(top, probe, ball_radius_mm, up, g.position);
      const auto over = [&](const PlannedStep& s) {
        const Vec3 a = s.point + probe.approach_mm * s.normal;
        return PlannedStep{PlannedStep::Kind::GoTo, Vec3(a + (clear - a.dot(up)) * up), Vec3::UnitZ()};
      };
      steps = faces[0];
      steps.push_back(over(faces[0].back()));
      steps.push_back(over(faces[1].front()));
      steps.insert(steps.end(), faces[1].begin(), faces[1].end());
      break;
    }
    case FeatureType::ClosedSlot: {
      // Like a circle, DEPTH below the nominal centre; in order around the outline: the -b side
      // toward +a, the +a end, the +b side back, the -a end. An inner slot is convex, so the
      // probe goes straight from one approach point to the next; around a tab it walks outside,
      // through the corners of a rectangle beyond the approach distance.
      const SlotFrame f = slot_frame(g);
      const Vec3 c = g.position - probe.depth_mm * (f.n.dot(up) >= 0 ? up : Vec3(-up));
      const bool round = g.slot_ends == SlotEnds::Round;
      const int n = std::max(count > 0 ? count : (round ? 10 : 8), minimum_points(g.type));
      const int per_end = round ? (n >= 10 ? 3 : 1) : (n >= 8 ? 2 : 1);
      const int on_sides = n - 2 * per_end;
      const double half_w = 0.5 * g.width_mm, half_l = 0.5 * g.length_mm;
      // Side points spread over 70 % of the straight part (clear of a flat end's corners by a ball
      // and a millimetre); flat-end points over 60 % of what the ball leaves of the width.
      const double straight = round ? std::max(0.0, half_l - half_w) : std::max(0.0, half_l - ball_radius_mm - 1.0);
      const double across_end = std::max(0.0, half_w - ball_radius_mm - 0.5);
      const auto spread = [](int k, int m) { return m == 1 ? 0.0 : -1.0 + 2.0 * k / (m - 1); };
      std::vector<std::vector<Vec3>> parts(4);  // -b side, +a end, +b side, -a end, each in walking order
      const int minus_side = (on_sides + 1) / 2, plus_side = on_sides / 2;
      for (int k = 0; k < minus_side; ++k)
        parts[0].push_back(c + 0.7 * straight * spread(k, minus_side) * f.a - half_w * f.b);
      for (int k = 0; k < plus_side; ++k)
        parts[2].push_back(c - 0.7 * straight * spread(k, plus_side) * f.a + half_w * f.b);
      for (int end = 0; end < 2; ++end) {
        const double s_end = end == 0 ? 1.0 : -1.0;
        for (int k = 0; k < per_end; ++k) {
          const double t = spread(k, per_end);
          const Vec3 p = round ? Vec3(c + s_end * (std::max(0.0, half_l - half_w) * f.a +
                                                   half_w * (std::cos(t * std::numbers::pi / 4) * f.a +
                                                             std::sin(t * std::numbers::pi / 4) * f.b)))
                               : Vec3(c + s_end * (half_l * f.a + 0.6 * across_end * t * f.b));
          parts[end == 0 ? 1 : 3].push_back(p);
        }
      }
      const double out_x = half_l + probe.approach_mm + 1.0, out_y = half_w + probe.approach_mm + 1.0;
      const Vec3 corners[4] = {c + out_x * f.a - out_y * f.b, c + out_x * f.a + out_y * f.b,
                               c - out_x * f.a + out_y * f.b, c - out_x * f.a - out_y * f.b};
      for (int part = 0; part < 4; ++part) {
        if (!inner && !steps.empty())
          steps.push_back({PlannedStep::Kind::GoTo, corners[(part + 3) % 4], Vec3::UnitZ()});
        for (std::size_t k = 0; k < parts[part].size(); ++k) {
          const Vec3& p = parts[part][k];
          if (!inner && round && (part == 1 || part == 3) && k > 0) {
            // Around a round end at the walk radius, between the two approach directions.
            const Vec3 centre = c + (part == 1 ? 1.0 : -1.0) * std::max(0.0, half_l - half_w) * f.a;
            const Vec3 mid = (p - centre).normalized() + (parts[part][k - 1] - centre).normalized();
            const Vec3 walk = centre + (half_w + probe.approach_mm + 1.0) * mid.normalized();
            steps.push_back({PlannedStep::Kind::GoTo, walk, Vec3::UnitZ()});
          }
          steps.push_back({PlannedStep::Kind::Probe, p, nominal_normal_at(g, p)});
        }
      }
      break;
    }
    case FeatureType::Ellipse: {
      // Like a circle, DEPTH below the nominal centre, at equal steps of the ellipse's parameter
      // (x = a cos t along the major axis, y = b sin t), half a step off the axes; round a boss
      // the probe walks outside the circle about its major diameter.
      const SlotFrame f = slot_frame(g);
      const Vec3 c = g.position - probe.depth_mm * (f.n.dot(up) >= 0 ? up : Vec3(-up));
      const int n = std::max(count > 0 ? count : 8, minimum_points(g.type));
      const double a = 0.5 * g.diameter_mm, b = 0.5 * g.minor_diameter_mm;
      std::optional<double> last;
      for (int i = 0; i < n; ++i) {
        const double t = 2.0 * std::numbers::pi * (i + 0.5) / n;
        const Vec3 p = c + a * std::cos(t) * f.a + b * std::sin(t) * f.b;
        const Vec3 m = (b * std::cos(t) * f.a + a * std::sin(t) * f.b).normalized();
        if (!inner) {
          // The polar angle of the approach point, unwrapped to increase with t.
          const Vec3 q = p + probe.approach_mm * m - c;
          double phi = std::atan2(q.dot(f.b), q.dot(f.a));
          if (last) phi = *last + std::remainder(phi - *last, 2.0 * std::numbers::pi);
          if (last) walk_around(steps, c, f.a, f.b, a + probe.approach_mm, *last, phi);
          last = phi;
        }
        steps.push_back({PlannedStep::Kind::Probe, p, inner ? Vec3(-m) : m});
      }
      break;
    }
    case FeatureType::Line: {
      const int n = count > 0 ? count : 3;
      const double len = g.length_mm > 0 ? g.length_mm : 20.0;
      for (int i = 0; i < n; ++i) {
        const double t = n == 1 ? 0.5 : static_cast<double>(i) / (n - 1);
        steps.push_back({PlannedStep::Kind::Probe, g.position + (0.1 + 0.8 * t) * len * axis, line_surface_normal(g)});
      }
      break;
    }
    case FeatureType::Circle: {
      // The circle lies DEPTH below its nominal centre, measured against the axis direction.
      const Vec3 c = g.position - probe.depth_mm * (axis.dot(up) >= 0 ? up : Vec3(-up));
      std::optional<double> last;
      ring(steps, c, axis, r, count > 0 ? count : 4, inner, probe.approach_mm, 0.0, last);
      break;
    }
    case FeatureType::Arc: {
      // Within the arc only: its span from the start angle (counted from `arc_reference` about the
      // axis, as a scan of it), the points at the middles of equal parts, clear of its ends.
      const Vec3 c = g.position - probe.depth_mm * (axis.dot(up) >= 0 ? up : Vec3(-up));
      Vec3 u = arc_reference - arc_reference.dot(axis) * axis;
      u = u.norm() > 1e-12 ? Vec3(u.normalized()) : any_perpendicular(axis);
      const int n = count > 0 ? count : 4;
      std::vector<double> angles;
      for (int i = 0; i < n; ++i)
        angles.push_back((g.start_angle_deg + g.included_angle_deg * (i + 0.5) / n) * std::numbers::pi / 180.0);
      std::optional<double> last;
      ring_at(steps, c, u, axis.cross(u), r, angles, inner, probe.approach_mm, last);
      break;
    }
    case FeatureType::Cylinder: {
      const int n = count > 0 ? count : 8;
      const double len = g.length_mm > 0 ? g.length_mm : 10.0;
      const int first = n / 2;
      std::optional<double> last;
      ring(steps, g.position + 0.25 * len * axis, axis, r, first, inner, probe.approach_mm, 0.0, last);
      ring(steps, g.position + 0.75 * len * axis, axis, r, n - first, inner, probe.approach_mm,
           std::numbers::pi / std::max(1, n - first), last);
      break;
    }
    case FeatureType::Sphere: {
      const int n = count > 0 ? count : 9;
      const double s = inner ? -1.0 : 1.0;
      steps.push_back({PlannedStep::Kind::Probe, g.position + r * up, s * up});
      const int rest = n - 1;
      const Vec3 u = any_perpendicular(up);
      const Vec3 v = up.cross(u);
      for (int i = 0; i < rest; ++i) {
        const double elev = (i % 2 == 0 ? 15.0 : 45.0) * std::numbers::pi / 180.0;
        const double az = 2.0 * std::numbers::pi * i / rest;
        const Vec3 d = std::cos(elev) * (std::cos(az) * u + std::sin(az) * v) + std::sin(elev) * up;
        if (!inner) {
          // Over the top, out beyond the equator, down to the approach height, then in.
          const Vec3 horizontal = std::cos(az) * u + std::sin(az) * v;
          const Vec3 approach = g.position + (r + probe.approach_mm) * d;
          const Vec3 outside = g.position + (r + probe.approach_mm + 5.0) * horizontal;
          const double high = r + probe.approach_mm + probe.clearance_mm;
          steps.push_back({PlannedStep::Kind::GoTo, g.position + high * up, Vec3::UnitZ()});
          steps.push_back({PlannedStep::Kind::GoTo, outside + high * up, Vec3::UnitZ()});
          steps.push_back({PlannedStep::Kind::GoTo, outside + (approach - g.position).dot(up) * up, Vec3::UnitZ()});
        }
        steps.push_back({PlannedStep::Kind::Probe, g.position + r * d, s * d});
      }
      break;
    }
    case FeatureType::Torus: {
      // Three tube angles round the azimuth in turn, on the tube's side toward `up`: a ring
      // (OUTER) from its outer equator over its top (0, 45, 90 deg), reached like a sphere's
      // points, from outside at the approach height; a groove (INNER) across its bottom (200, 270,
      // 340 deg), reached from above. Other parts of a torus, and a fillet (whose 340 deg is not
      // there), need PTMEAS.
      const int n = std::max(count > 0 ? count : 12, minimum_points(g.type));
      const Vec3 a = axis.dot(up) >= 0 ? axis : Vec3(-axis);
      const Vec3 u = any_perpendicular(a);
      const Vec3 v = a.cross(u);
      const double tube = 0.5 * g.minor_diameter_mm;
      static constexpr double k_ring_deg[3] = {0, 45, 90}, k_groove_deg[3] = {200, 270, 340};
      const double* tube_angles_deg = inner ? k_groove_deg : k_ring_deg;
      std::vector<PlannedStep> probes;
      double top = -std::numeric_limits<double>::infinity();
      for (int i = 0; i < n; ++i) {
        const double az = 2.0 * std::numbers::pi * i / n;
        const double t = tube_angles_deg[i % 3] * std::numbers::pi / 180.0;
        const Vec3 radial_dir = std::cos(az) * u + std::sin(az) * v;
        const Vec3 out_of_tube = std::cos(t) * radial_dir + std::sin(t) * a;
        const Vec3 p = g.position + r * radial_dir + tube * out_of_tube;
        probes.push_back({PlannedStep::Kind::Probe, p, inner ? Vec3(-out_of_tube) : out_of_tube});
        top = std::max(top, (p + probe.approach_mm * probes.back().normal).dot(up));
      }
      top = std::max(top, (g.position + (tube + probe.approach_mm) * a).dot(up)) + probe.clearance_mm;
      for (std::size_t i = 0; i < probes.size(); ++i) {
        const PlannedStep& s = probes[i];
        const Vec3 approach = s.point + probe.approach_mm * s.normal;
        const auto at_height = [&](const Vec3& q, double h) { return Vec3(q + (h - q.dot(up)) * up); };
        if (inner) {
          steps.push_back({PlannedStep::Kind::GoTo, at_height(approach, top), Vec3::UnitZ()});
        } else {
          // Up, over to beyond the ring's outside at this azimuth, down to the approach height.
          const Vec3 radial_dir = radial(s.point, g.position, a);
          const Vec3 outside = g.position + (r + tube + probe.approach_mm + 5.0) * radial_dir;
          if (i > 0) {  // from where the last point retracted to
            const Vec3 last = probes[i - 1].point + probe.approach_mm * probes[i - 1].normal;
            steps.push_back({PlannedStep::Kind::GoTo, at_height(last, top), Vec3::UnitZ()});
          }
          steps.push_back({PlannedStep::Kind::GoTo, at_height(outside, top), Vec3::UnitZ()});
          steps.push_back({PlannedStep::Kind::GoTo, at_height(outside, approach.dot(up)), Vec3::UnitZ()});
        }
        steps.push_back(s);
      }
      break;
    }
    case FeatureType::Cone: {
      const int n = count > 0 ? count : 8;
      const double half = g.apex_angle_deg * std::numbers::pi / 360.0;
      const double len = g.length_mm > 0 ? g.length_mm : 5.0;
      for (int level = 0; level < 2; ++level) {
        const double t = (level == 0 ? 0.4 : 0.8) * len;
        const int m = level == 0 ? n / 2 : n - n / 2;
        const Vec3 c = g.position + t * axis;
        const double rr = t * std::tan(half);
        const Vec3 u = any_perpendicular(axis);
        const Vec3 v = axis.cross(u);
        for (int i = 0; i < m; ++i) {
          const double a = 2.0 * std::numbers::pi * i / m + level * std::numbers::pi / m;
          const Vec3 p = c + rr * (std::cos(a) * u + std::sin(a) * v);
          steps.push_back({PlannedStep::Kind::Probe, p, nominal_normal_at(g, p)});
        }
      }
      break;
    }
  }
  if (steps.empty()) return steps;
  // Clearance: rise above the feature, move over the first approach point, then descend.
  const auto approach_of = [&](const PlannedStep& s) { return s.point + probe.approach_mm * s.normal; };
  double top = current_position.dot(up);
  for (const auto& s : steps)
    top = std::max(top, (s.kind == PlannedStep::Kind::Probe ? approach_of(s) : s.point).dot(up));
  const double clear = clearance_height(top, probe, ball_radius_mm, up, g.position);
  const Vec3 first = steps.front().kind == PlannedStep::Kind::Probe ? approach_of(steps.front()) : steps.front().point;
  std::vector<PlannedStep> out;
  out.push_back({PlannedStep::Kind::GoTo, current_position + (clear - current_position.dot(up)) * up, Vec3::UnitZ()});
  out.push_back({PlannedStep::Kind::GoTo, first + (clear - first.dot(up)) * up, Vec3::UnitZ()});
  out.insert(out.end(), steps.begin(), steps.end());
  const Vec3 last = steps.back().kind == PlannedStep::Kind::Probe ? approach_of(steps.back()) : steps.back().point;
  out.push_back({PlannedStep::Kind::GoTo, last, Vec3::UnitZ()});
  out.push_back({PlannedStep::Kind::GoTo, last + (clear - last.dot(up)) * up, Vec3::UnitZ()});
  return out;
}

}  // namespace metron::runtime
