// SPDX-License-Identifier: GPL-3.0-or-later
// CONST/LINE|CIRCLE,F(l),TANTO,...: features tangent to others, solved in the plane they lie in
// (docs/language.md, "Tangent constructions"). Each has several solutions (four lines touch two
// circles; four circles of one diameter touch two crossing lines; a triangle's incircle and its
// three excircles touch its sides): the one nearest the feature's nominal is taken, as CMM
// software picks among a construction's solutions; without a nominal, a documented choice.
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include <fmt/format.h>

#include "detail/line_geometry.hpp"
#include "metron/runtime/measurement_runtime.hpp"

namespace metron::runtime {
namespace {

using Vec2 = Eigen::Vector2d;

// The plane of a construction: an origin and two unit axes u, v with n = u x v.
struct PlaneAxes {
  Vec3 origin;
  Vec3 u, v, n;
  [[nodiscard]] Vec2 at(const Vec3& p) const { return {(p - origin).dot(u), (p - origin).dot(v)}; }
  [[nodiscard]] Vec2 along(const Vec3& d) const { return {d.dot(u), d.dot(v)}; }
  [[nodiscard]] Vec3 point(const Vec2& q) const { return origin + q.x() * u + q.y() * v; }
  [[nodiscard]] Vec3 vector(const Vec2& q) const { return q.x() * u + q.y() * v; }
};

PlaneAxes plane_axes(const Vec3& origin, const Vec3& normal) {
  PlaneAxes a;
  a.origin = origin;
  a.n = normal.normalized();
  a.u = a.n.unitOrthogonal();
  a.v = a.n.cross(a.u);
  return a;
}

Vec2 left_of(const Vec2& d) { return {-d.y(), d.x()}; }

// A source seen in the plane: a disc (a circle, an arc, a cylinder along the plane's normal, a
// sphere's outline; a point is a disc of radius 0).
struct Disc {
  Vec2 centre;
  double radius = 0;
};

// One tangent line in the plane: the points where it touches the first and the second source.
struct TangentLine {
  Vec2 first, second, direction;
  bool outer = false;  // both sources on the same side of it
};

// The lines tangent to two discs. A line with unit normal m and offset c (m.x + c = 0) has the
// signed distances m.c1 + c = s1 r1 and m.c2 + c = s2 r2 from the centres, so m.(c2 - c1) =
// s2 r2 - s1 r1 = k: m = (k/L) d + h left(d), h = +-sqrt(1 - (k/L)^2), d the unit vector from c1
// to c2 at distance L. s1 = +1 covers every line (s1 = -1 gives the same lines with m reversed).
std::vector<TangentLine> tangent_lines(const Disc& a, const Disc& b) {
  std::vector<TangentLine> lines;
  const Vec2 between = b.centre - a.centre;
  const double length = between.norm();
  const Vec2 d = between / length;
  for (const double s2 : {1.0, -1.0}) {
    const double k = s2 * b.radius - a.radius;
    if (std::abs(k) > length * (1 + 1e-12)) continue;  // one disc inside the other: no such line
    const double ratio = std::clamp(k / length, -1.0, 1.0);
    const double h = std::sqrt(std::max(0.0, 1 - ratio * ratio));
    for (const double root : {1.0, -1.0}) {
      const Vec2 m = ratio * d + root * h * left_of(d);
      TangentLine t;
      t.first = a.centre - a.radius * m;
      t.second = b.centre - s2 * b.radius * m;
      t.direction = left_of(m);
      if (t.direction.dot(t.second - t.first) < 0) t.direction = -t.direction;
      t.outer = s2 > 0;
      const bool same = std::any_of(lines.begin(), lines.end(), [&](const TangentLine& o) {
        return (o.first - t.first).norm() < 1e-9 && std::abs(o.direction.dot(left_of(t.direction))) < 1e-12;
      });
      if (!same) lines.push_back(t);
      if (h == 0) break;
    }
  }
  return lines;
}

// A source line in the plane: a point on it, its unit direction and its left normal.
struct Line2 {
  Vec2 point, direction, normal;
};

// The circles tangent to lines: a centre c and a radius r with normal_i . (c - point_i) = s_i r
// for each line i, s_i = +-1 the side of it c lies on.
struct TangentCircle {
  Vec2 centre;
  double radius = 0;
};

// Two crossing lines and r given: the four centres, one in each angle the lines make.
std::vector<TangentCircle> circles_of_radius(const Line2& a, const Line2& b, double radius) {
  std::vector<TangentCircle> circles;
  Eigen::Matrix2d m;
  m.row(0) = a.normal;
  m.row(1) = b.normal;
  if (std::abs(m.determinant()) < 1e-12) return circles;
  for (const double side_a : {1.0, -1.0})
    for (const double side_b : {1.0, -1.0}) {
      const Vec2 rhs(a.normal.dot(a.point) + side_a * radius, b.normal.dot(b.point) + side_b * radius);
      circles.push_back({m.partialPivLu().solve(rhs), radius});
    }
  return circles;
}

// Three lines, r unknown: the incircle and the three excircles of their triangle. The first
// line's side is fixed (+1): the opposite signs give the same circle with r negated.
std::vector<TangentCircle> circles_touching_three(const Line2& a, const Line2& b, const Line2& c) {
  std::vector<TangentCircle> circles;
  for (const double side_b : {1.0, -1.0})
    for (const double side_c : {1.0, -1.0}) {
      Eigen::Matrix3d m;
      m.row(0) << a.normal.x(), a.normal.y(), -1.0;
      m.row(1) << b.normal.x(), b.normal.y(), -side_b;
      m.row(2) << c.normal.x(), c.normal.y(), -side_c;
      if (std::abs(m.determinant()) < 1e-12) continue;  // two sides parallel: that circle is not there
      const Eigen::Vector3d x =
          m.partialPivLu().solve(Eigen::Vector3d(a.normal.dot(a.point), b.normal.dot(b.point), c.normal.dot(c.point)));
      if (std::abs(x.z()) > 1e-9) circles.push_back({x.head<2>(), std::abs(x.z())});
    }
  return circles;
}

}  // namespace

Result<void> MeasurementRuntime::construct_tangent(const std::string& label, FeatureType type,
                                                   const std::vector<FeatureRef>& sources,
                                                   std::optional<double> diameter_mm, Span span) {
  const auto fail = [&](const std::string& why) {
    return program_error(span, fmt::format("cannot construct {} F({}) by TANTO: {}", dmis_word(type), label, why));
  };
  auto resolved = resolve_sources(sources, span);
  if (!resolved) return tl::unexpected(resolved.error());
  const std::vector<Geometry> g = std::move(resolved->geometry);
  const double rests_on = resolved->rests_on_s;
  const auto nominal_it = m_features.find(label);
  const Geometry* nominal = nominal_it != m_features.end() ? &nominal_it->second.nominal : nullptr;
  if (!nominal)
    warn(span, fmt::format("CONST of F({}) without a FEAT nominal: of TANTO's solutions, {}; the nominal is taken "
                           "from the actual",
                           label,
                           type == FeatureType::Line ? "the outer tangent left of the way from the first to the second"
                           : sources.size() == 3     ? "the circle inside the three lines"
                                                     : "the circle in the angle the lines' directions open"));

  if (type == FeatureType::Line) {
    // The plane: the first circular source's (its axis the normal), through its centre.
    const auto round = [](const Geometry& s) {
      return s.type == FeatureType::Circle || s.type == FeatureType::Arc || s.type == FeatureType::Cylinder;
    };
    const auto first_round = std::find_if(g.begin(), g.end(), round);
    if (first_round == g.end())
      return fail(
          "a tangent LINE needs a CIRCLE, an ARC or a CYLNDR among its two features (their axis is the "
          "plane's normal)");
    const PlaneAxes plane = plane_axes(first_round->position, first_round->direction);
    std::vector<Disc> discs;
    for (std::size_t i = 0; i < g.size(); ++i) {
      const Geometry& s = g[i];
      if (round(s) && s.direction.normalized().cross(plane.n).norm() > 0.0175)  // 1 deg
        return fail(fmt::format("FA({})'s axis is not along FA({})'s: the two do not lie in one plane",
                                sources[i].label, sources[std::size_t(first_round - g.begin())].label));
      if (!round(s) && s.type != FeatureType::Sphere && s.type != FeatureType::Point)
        return fail(
            fmt::format("FA({}) is a {}: a tangent LINE touches circles, arcs, cylinders and spheres, or "
                        "passes through a point",
                        sources[i].label, dmis_word(s.type)));
      discs.push_back({plane.at(s.position), s.type == FeatureType::Point ? 0.0 : s.diameter_mm / 2});
    }
    if ((discs[1].centre - discs[0].centre).norm() < 1e-9)
      return fail(fmt::format("FA({}) and FA({}) have one centre: no line is tangent to both", sources[0].label,
                              sources[1].label));
    const std::vector<TangentLine> lines = tangent_lines(discs[0], discs[1]);
    if (lines.empty())
      return fail(
          fmt::format("FA({}) lies inside FA({}): no line is tangent to both", sources[1].label, sources[0].label));
    const double extent = (discs[1].centre - discs[0].centre).norm();
    // Nearest the nominal: its point's distance from the line, and its direction's mismatch
    // counted as the displacement it makes over the construction's extent.
    const auto mismatch = [&](const TangentLine& t) {
      if (!nominal) {
        const Vec2 d = (discs[1].centre - discs[0].centre).normalized();
        return t.outer && left_of(d).dot(0.5 * (t.first + t.second) - discs[0].centre) > 0 ? 0.0 : 1.0;
      }
      const Vec2 p = plane.at(nominal->position);
      const Vec2 dn = plane.along(nominal->direction);
      const double off = std::abs(left_of(t.direction).dot(p - t.first));
      const double turn = dn.norm() > 1e-12 ? std::abs(left_of(t.direction).dot(dn.normalized())) : 0.0;
      return off + extent * turn;
    };
    const auto best = std::min_element(lines.begin(), lines.end(), [&](const TangentLine& a, const TangentLine& b) {
      return mismatch(a) < mismatch(b);
    });
    Geometry line = nominal && nominal->type == FeatureType::Line ? *nominal : Geometry{};
    line.type = FeatureType::Line;
    line.position = plane.point(best->first);
    line.direction = plane.vector(best->direction).normalized();
    line.normal2 = plane.n;
    if (line.bounded) line.length_mm = (best->second - best->first).norm();
    store_constructed(label, line, std::nullopt, rests_on, span);
    set_construction_spread(label, sources);
    return {};
  }

  if (type != FeatureType::Circle) return fail("TANTO constructs a LINE or a CIRCLE");
  for (std::size_t i = 0; i < g.size(); ++i)
    if (g[i].type != FeatureType::Line)
      return fail(
          fmt::format("FA({}) is a {}: a tangent CIRCLE touches LINEs", sources[i].label, dmis_word(g[i].type)));
  if (diameter_mm && !(*diameter_mm > 0))
    return fail(fmt::format("the diameter must be positive, got {:g}", *diameter_mm));
  // The plane: the lines' (the first two that cross), through the middle of their common
  // perpendicular; measured lines are seldom exactly coplanar.
  std::optional<PlaneAxes> plane;
  for (std::size_t i = 0; i < g.size() && !plane; ++i)
    for (std::size_t j = i + 1; j < g.size() && !plane; ++j) {
      const Vec3 n = g[i].direction.normalized().cross(g[j].direction.normalized());
      if (n.norm() < 1e-9) continue;
      if (const auto crossing = line_line(g[i], g[j])) plane = plane_axes(*crossing, n);
    }
  if (!plane)
    return fail(diameter_mm ? "the two lines are parallel: a circle tangent to both is not fixed along them"
                            : "the lines are parallel");
  std::vector<Line2> lines;
  for (std::size_t i = 0; i < g.size(); ++i) {
    const Vec2 d = plane->along(g[i].direction);
    if (d.norm() < 0.9998)  // more than 1 deg out of the plane
      return fail(fmt::format("FA({}) does not lie in the plane of the others", sources[i].label));
    const Vec2 unit = d.normalized();
    lines.push_back({plane->at(g[i].position), unit, left_of(unit)});
  }
  const std::vector<TangentCircle> circles = diameter_mm ? circles_of_radius(lines[0], lines[1], *diameter_mm / 2)
                                                         : circles_touching_three(lines[0], lines[1], lines[2]);
  if (circles.empty()) return fail("no circle is tangent to the lines (two of them are parallel)");
  const Vec2 opening = lines[0].direction + lines[1].direction;
  const auto mismatch = [&](const TangentCircle& c) {
    if (!nominal) return diameter_mm ? -opening.dot(c.centre) : c.radius;
    return (c.centre - plane->at(nominal->position)).norm() + std::abs(c.radius - nominal->diameter_mm / 2);
  };
  const auto best =
      std::min_element(circles.begin(), circles.end(),
                       [&](const TangentCircle& a, const TangentCircle& b) { return mismatch(a) < mismatch(b); });
  Geometry circle = nominal && nominal->type == FeatureType::Circle ? *nominal : Geometry{};
  circle.type = FeatureType::Circle;
  if (!nominal) circle.side = Side::Outer;
  circle.position = plane->point(best->centre);
  circle.direction = nominal && nominal->direction.dot(plane->n) < 0 ? Vec3(-plane->n) : plane->n;
  circle.diameter_mm = 2 * best->radius;
  store_constructed(label, circle, std::nullopt, rests_on, span);
  set_construction_spread(label, sources);
  return {};
}

}  // namespace metron::runtime
