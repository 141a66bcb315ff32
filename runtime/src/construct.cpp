// SPDX-License-Identifier: GPL-3.0-or-later
// CONST/...: features constructed from other features' actuals.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "detail/fit_actual.hpp"
#include "detail/line_geometry.hpp"
#include "metron/runtime/measurement_runtime.hpp"
#include "metron/stdlib/fitting/fit.hpp"

namespace metron::runtime {
namespace {

// The source of an EXTREM: a feature with measured points, the only ones EXTREM picks from.
Result<const Feature*> extreme_source(const MeasurementRuntime& runtime, const std::string& label,
                                      const FeatureRef& source, Span span) {
  const Feature* f = runtime.find_feature(source.label);
  if (!f) return program_error(span, fmt::format("feature F({}) is not defined", source.label));
  if (f->points.empty())
    return program_error(span,
                         fmt::format("cannot construct POINT F({}): EXTREM picks one of the measured points of FA({}), "
                                     "which has none (it was constructed or stated)",
                                     label, source.label));
  return f;
}

bool is_planar(const Geometry& g) { return g.type == FeatureType::Plane; }
bool is_linear(const Geometry& g) {
  return g.type == FeatureType::Line || g.type == FeatureType::Cylinder || g.type == FeatureType::Cone;
}

// Line of two planes: direction n1 x n2, the point on it closest to `near`.
tl::expected<Geometry, std::string> plane_plane(const Geometry& a, const Geometry& b, const Vec3& near) {
  const Vec3 d = a.direction.cross(b.direction);
  if (d.norm() < 1e-9) return tl::unexpected(std::string("the planes are parallel: they do not intersect"));
  // Solve n1.x = n1.p1, n2.x = n2.p2, d.x = d.near (the point on the line nearest `near`).
  Mat3 m;
  m.row(0) = a.direction;
  m.row(1) = b.direction;
  m.row(2) = d;
  const Vec3 rhs(a.direction.dot(a.position), b.direction.dot(b.position), d.dot(near));
  Geometry g;
  g.type = FeatureType::Line;
  g.position = m.colPivHouseholderQr().solve(rhs);
  g.direction = d.normalized();
  return g;
}

tl::expected<Vec3, std::string> line_plane(const Geometry& line, const Geometry& plane) {
  const double den = line.direction.dot(plane.direction);
  if (std::abs(den) < 1e-9) return tl::unexpected(std::string("the line is parallel to the plane: no intersection"));
  const double t = (plane.position - line.position).dot(plane.direction) / den;
  return Vec3(line.position + t * line.direction);
}

// Where a line crosses a circle (CIRCLE or ARC), the line first projected onto the circle's plane
// (CAMIO's "Intersection: line - arc"): of the two crossings, the one nearest `near` (a tangent
// line has one). |p + t d - c|^2 = r^2 in the plane: t^2 + 2 t d.(p - c) + |p - c|^2 - r^2 = 0.
tl::expected<Vec3, std::string> line_circle(const Geometry& line, const Geometry& circle, const Vec3& near) {
  const Vec3 n = circle.direction.normalized();
  const Vec3 p = line.position - (line.position - circle.position).dot(n) * n;
  Vec3 d = line.direction - line.direction.dot(n) * n;
  if (d.norm() < 1e-9)
    return tl::unexpected(std::string("the line is along the circle's axis: it does not cross the circle"));
  d.normalize();
  const Vec3 pc = p - circle.position;
  const double r = circle.diameter_mm / 2, b = d.dot(pc), c = pc.squaredNorm() - r * r;
  const double disc = b * b - c;
  const double miss = (pc - b * d).norm() - r;  // the line's distance from the centre, less the radius
  if (disc < 0 && miss > 1e-9)
    return tl::unexpected(fmt::format("the line passes {:.4f} mm outside the circle: they do not cross", miss));
  const double root = std::sqrt(std::max(0.0, disc));
  const Vec3 first = p + (-b - root) * d, second = p + (-b + root) * d;
  return (first - near).norm() <= (second - near).norm() ? first : second;
}

// The plane a constructed LINE lies in (DMIS i2,j2,k2): its nominal's where that is normal to
// the line, else any normal.
Vec3 line_plane_normal(const Geometry& line) {
  const Vec3 n2 = line.normal2 - line.normal2.dot(line.direction) * line.direction;
  return n2.norm() > 1e-9 ? Vec3(n2.normalized()) : Vec3(line.direction.unitOrthogonal());
}

}  // namespace

Result<void> MeasurementRuntime::construct(const std::string& label, FeatureType type, ConstructMethod method,
                                           const std::vector<FeatureRef>& sources, Span span) {
  auto resolved = resolve_sources(sources, span);
  if (!resolved) return tl::unexpected(resolved.error());
  const std::vector<Geometry> in = std::move(resolved->geometry);
  const double rests_on = resolved->rests_on_s;
  auto it = m_features.find(label);
  if (it == m_features.end()) {
    warn(span, fmt::format("CONST of F({}) without a FEAT nominal; the nominal is taken from the actual", label));
  }
  Geometry nominal;
  if (it != m_features.end()) nominal = it->second.nominal;
  nominal.type = type;
  Geometry g = nominal;
  std::optional<FitFigures> figures;
  const auto fail = [&](const std::string& why) {
    return program_error(span, fmt::format("cannot construct {} F({}): {}", dmis_word(type), label, why));
  };

  switch (method) {
    case ConstructMethod::BestFit: {
      std::vector<MeasuredPoint> pts;
      // A cylinder or cone from circles (sections of one bore at several heights, PC-DMIS's
      // CONST/CYLNDR,BF,FA(C1),FA(C2)): the circles' measured points together, not their centres.
      const bool from_sections =
          sources.size() > 1 && (type == FeatureType::Cylinder || type == FeatureType::Cone) &&
          std::all_of(sources.begin(), sources.end(), [&](const FeatureRef& s) {
            const Feature* f = find_feature(s.label);
            return f && !f->points.empty() &&
                   (f->nominal.type == FeatureType::Circle || f->nominal.type == FeatureType::Arc);
          });
      if (sources.size() == 1 || from_sections) {
        for (const auto& s : sources)
          for (const auto& p : find_feature(s.label)->points) pts.push_back(p);
      } else {
        for (const auto& s : in)
          pts.push_back({s.position, nominal.direction, 0.0, 0.0, span, false, std::nullopt, Vec3::UnitZ()});
      }
      auto fitted = fit_actual(nominal, pts);
      if (!fitted) return fail(fitted.error());
      g = fitted->first;
      figures = fitted->second;
      apply_fit_algorithm(g, pts, label, span);
      if (type == FeatureType::Line && sources.size() > 1 && !from_sections) {
        // A line through features runs from the first toward the last (the construction order,
        // as CMM software builds it), whatever sense its nominal has: an alignment's XDIR on it
        // follows. CAMIO's exports carry a placeholder nominal (1, 0, 0) for every line.
        const Vec3 run = in.back().position - in.front().position;
        if (run.norm() > 1e-9 && g.direction.dot(run) < 0) g.direction = -g.direction;
        if (it != m_features.end() && nominal.direction.norm() > 0 && g.direction.dot(nominal.direction) < 0)
          warn(span, fmt::format("F({}) runs from FA({}) to FA({}), against its nominal direction: the construction "
                                 "order gives its sense",
                                 label, sources.front().label, sources.back().label));
      }
      break;
    }
    case ConstructMethod::Intersection: {
      if (in.size() != 2) return fail("INTOF needs two features");
      const Geometry& a = in[0];
      const Geometry& b = in[1];
      if (type == FeatureType::Line) {
        if (!is_planar(a) || !is_planar(b)) return fail("a line is the intersection of two planes");
        auto l = plane_plane(a, b, it != m_features.end() ? nominal.position : a.position);
        if (!l) return fail(l.error());
        g.position = l->position;
        g.direction =
            it != m_features.end() && l->direction.dot(nominal.direction) < 0 ? Vec3(-l->direction) : l->direction;
        g.normal2 = a.direction;
      } else if (type == FeatureType::Point) {
        tl::expected<Vec3, std::string> p = tl::unexpected(
            std::string("a point is the intersection of a line and a plane, of two lines, or of a line and a circle"));
        const auto round = [](const Geometry& x) {
          return x.type == FeatureType::Circle || x.type == FeatureType::Arc;
        };
        // Of a line and a circle's two crossings, the one nearest F()'s nominal (else the
        // circle's point nearest the line's).
        const Vec3 near = it != m_features.end() ? nominal.position : (is_linear(a) ? a.position : b.position);
        if (is_linear(a) && round(b))
          p = line_circle(a, b, near);
        else if (round(a) && is_linear(b))
          p = line_circle(b, a, near);
        else if (is_linear(a) && is_planar(b))
          p = line_plane(a, b);
        else if (is_planar(a) && is_linear(b))
          p = line_plane(b, a);
        else if (is_linear(a) && is_linear(b))
          p = line_line(a, b);
        if (!p) return fail(p.error());
        g.position = *p;
      } else if (type == FeatureType::Circle) {
        // A cylinder or cone cut by a plane normal to its axis (a countersink's gauge diameter):
        // the centre where the axis pierces the plane; the diameter the cylinder's, or the cone's
        // there, 2 |t| tan(half angle) at the distance t from its apex.
        const bool a_round = a.type == FeatureType::Cylinder || a.type == FeatureType::Cone;
        const Geometry& solid = a_round ? a : b;
        const Geometry& plane = a_round ? b : a;
        if (!(solid.type == FeatureType::Cylinder || solid.type == FeatureType::Cone) || !is_planar(plane))
          return fail("a circle is the intersection of a CYLNDR or CONE and a PLANE");
        const Vec3 axis = solid.direction.normalized();
        const double cos_tilt = std::abs(axis.dot(plane.direction.normalized()));
        if (cos_tilt < std::cos(1.0 * M_PI / 180))
          return fail(
              fmt::format("the plane is {:.2f} deg off normal to the axis: the section is an ellipse, not a circle",
                          std::acos(std::min(1.0, cos_tilt)) * 180 / M_PI));
        auto centre = line_plane(solid, plane);
        if (!centre) return fail(centre.error());
        g.position = *centre;
        g.direction = it != m_features.end() && nominal.direction.dot(axis) < 0 ? Vec3(-axis) : axis;
        if (solid.type == FeatureType::Cylinder) {
          g.diameter_mm = solid.diameter_mm;
        } else {
          const double t = (*centre - solid.position).dot(axis);
          g.diameter_mm = 2 * std::abs(t) * std::tan(solid.apex_angle_deg * M_PI / 360);
        }
      } else {
        return fail("INTOF constructs a LINE, a POINT or a CIRCLE (a CYLNDR or CONE and a PLANE)");
      }
      break;
    }
    case ConstructMethod::Midpoint: {
      // MIDPT of two features; MIDPL (a PLANE) of two planes and MIDLI (a LINE) of two lines: the
      // bisecting direction (the second's sense turned to the first's) through the midpoint.
      if (in.size() != 2) return fail("MIDPT, MIDPL and MIDLI need two features");
      g.position = 0.5 * (in[0].position + in[1].position);
      if (type == FeatureType::Plane || type == FeatureType::Line) {
        const bool plane = type == FeatureType::Plane;
        for (const Geometry& x : in)
          if (plane ? !is_planar(x) : !is_linear(x))
            return fail(fmt::format("the mid {} of two {}, got a {}", plane ? "plane" : "line",
                                    plane ? "PLANEs" : "LINEs (or axes)", dmis_word(x.type)));
        const Vec3 d1 = in[0].direction.normalized();
        const Vec3 d2 =
            in[1].direction.dot(d1) < 0 ? Vec3(-in[1].direction.normalized()) : Vec3(in[1].direction.normalized());
        g.direction = (d1 + d2).normalized();
        if (it != m_features.end() && g.direction.dot(nominal.direction) < 0) g.direction = -g.direction;
        if (!plane) {
          // Midway between the first line's point and the nearest point of the second line: its
          // position along the lines is not the measured points' arbitrary centroids.
          const Vec3 v = in[0].position - in[1].position;
          g.position = 0.5 * (in[0].position + in[1].position + v.dot(d2) * d2);
          g.bounded = false;
          g.normal2 = line_plane_normal(g);
        }
      }
      break;
    }
    case ConstructMethod::Copy: {
      // COPY: the source's geometry under this label; a type other than the source's is CAST's.
      if (in.front().type != type)
        return fail(fmt::format("COPY keeps the type: FA({}) is a {} (CAST makes another type)", sources.front().label,
                                dmis_word(in.front().type)));
      g = in.front();
      break;
    }
    case ConstructMethod::Vertex: {
      if (in.front().type != FeatureType::Cone)
        return fail(fmt::format("VERTEX is the apex of a CONE, got a {}", dmis_word(in.front().type)));
      g.position = in.front().position;  // a cone's position is its apex
      if (it == m_features.end()) g.direction = in.front().direction;
      break;
    }
    case ConstructMethod::ParallelThrough:
    case ConstructMethod::PerpendicularThrough: {
      // DMIS CONST PARTO/PERPTO: a PLANE or LINE through the second feature's point, its direction
      // the reference's (PARTO) or normal to it (PERPTO). A plane's direction is its normal, a
      // line's (or an axis's) its direction: PARTO keeps the reference's kind, PERPTO swaps it.
      if (in.size() != 2) return fail("PARTO and PERPTO need a reference and a point");
      const Geometry& ref = in[0];
      const bool parallel = method == ConstructMethod::ParallelThrough;
      const bool wants_plane_ref = (type == FeatureType::Plane) == parallel;
      if (wants_plane_ref ? !is_planar(ref) : !is_linear(ref))
        return fail(fmt::format("{} a {} needs a {} as its reference, got a {}", parallel ? "PARTO" : "PERPTO",
                                dmis_word(type), wants_plane_ref ? "PLANE" : "LINE, CYLNDR or CONE",
                                dmis_word(ref.type)));
      g.position = in[1].position;
      g.direction = ref.direction.normalized();
      if (it != m_features.end() && g.direction.dot(nominal.direction) < 0) g.direction = -g.direction;
      if (type == FeatureType::Line) {
        g.bounded = false;
        g.normal2 = line_plane_normal(g);
      }
      break;
    }
    case ConstructMethod::Cast: {
      // DMIS CONST CAST: the source's geometry read as another type. A POINT is any feature's
      // position (a cone's apex); a LINE the axis of a CYLNDR, CONE or LINE; a PLANE the plane
      // of a PLANE, CIRCLE, ARC or CPARLN; a CIRCLE a cylinder's (or circle's) section at its
      // position.
      const Geometry& x = in.front();
      g.position = x.position;
      if (type == FeatureType::Point) {
        if (it == m_features.end()) g.direction = x.direction;
      } else if (type == FeatureType::Line) {
        if (!is_linear(x))
          return fail(fmt::format("CAST to a LINE needs a CYLNDR, CONE or LINE, got a {}", dmis_word(x.type)));
        g.direction = x.direction.normalized();
        g.bounded = false;
        g.normal2 = line_plane_normal(g);
      } else if (type == FeatureType::Plane) {
        if (!(is_planar(x) || x.type == FeatureType::Circle || x.type == FeatureType::Arc ||
              x.type == FeatureType::ClosedSlot))
          return fail(fmt::format("CAST to a PLANE needs a PLANE, CIRCLE, ARC or CPARLN, got a {}", dmis_word(x.type)));
        g.direction = x.direction.normalized();
      } else if (type == FeatureType::Circle) {
        if (!(x.type == FeatureType::Cylinder || x.type == FeatureType::Circle || x.type == FeatureType::Arc))
          return fail(fmt::format("CAST to a CIRCLE needs a CYLNDR, CIRCLE or ARC, got a {}", dmis_word(x.type)));
        g.direction = x.direction.normalized();
        g.diameter_mm = x.diameter_mm;
      } else {
        return fail("CAST constructs a POINT, LINE, PLANE or CIRCLE");
      }
      if (type != FeatureType::Point && it != m_features.end() && g.direction.dot(nominal.direction) < 0)
        g.direction = -g.direction;
      break;
    }
    case ConstructMethod::Projection: {
      if (in.size() != 2) return fail("PROJPT needs a feature and a plane");
      const Geometry& plane = in[1];
      if (!is_planar(plane)) return fail("the second feature of a projection must be a plane");
      const Vec3 n = plane.direction.normalized();
      g.position = in[0].position - (in[0].position - plane.position).dot(n) * n;
      if (type == FeatureType::Line) {
        const Vec3 d = in[0].direction - in[0].direction.dot(n) * n;
        if (d.norm() < 1e-9) return fail("the line is perpendicular to the plane");
        g.direction = d.normalized();
        g.normal2 = n;
      } else {
        g.direction = n;
      }
      if (type == FeatureType::Circle) g.diameter_mm = in[0].diameter_mm;
      break;
    }
  }
  store_constructed(label, g, figures, rests_on, span);
  set_construction_spread(label, sources);
  return {};
}

// A construction's result: the feature's actual; a feature with no FEAT nominal takes it as its
// nominal too (construct warned).
void MeasurementRuntime::store_constructed(const std::string& label, const Geometry& actual,
                                           const std::optional<FitFigures>& figures, double rests_on_s, Span span) {
  auto it = m_features.find(label);
  if (it == m_features.end()) {
    Feature f;
    f.label = label;
    f.nominal = actual;
    f.nominal_frame = m_alignment.part_to_machine;
    f.nominal_rests_on_s = m_alignment.rests_on_s;
    f.defined_at = span;
    m_feature_order.push_back(label);
    it = m_features.emplace(label, f).first;
  }
  it->second.actual = actual;
  it->second.source = ActualSource::Constructed;
  it->second.fit = figures;
  it->second.rests_on_s = rests_on_s;
  it->second.measured_at = span;
}

// The spread of the points a construction rests on: each source a cloud of its probed surface
// points (its centroid c_i, RMS spread s_i, n_i points), or, without points, its position with
// its own construction spread (n_i = 1). The clouds together (the parallel-axis theorem):
// spread^2 = sum n_i (|c_i - c|^2 + s_i^2) / sum n_i, c the weighted centroid.
void MeasurementRuntime::set_construction_spread(const std::string& label, const std::vector<FeatureRef>& sources) {
  struct Cloud {
    Vec3 centroid;
    double spread_squared;
    double weight;
  };
  std::vector<Cloud> clouds;
  for (const FeatureRef& ref : sources) {
    const Feature* f = find_feature(ref.label);
    if (!f || !f->actual) continue;
    if (f->points.size() < 2) {
      clouds.push_back({f->actual->position, f->construction_spread_mm * f->construction_spread_mm, 1.0});
      continue;
    }
    Vec3 centroid = Vec3::Zero();
    for (const auto& p : f->points) centroid += p.surface_mm();
    centroid /= static_cast<double>(f->points.size());
    double squares = 0;
    for (const auto& p : f->points) squares += (p.surface_mm() - centroid).squaredNorm();
    const auto n = static_cast<double>(f->points.size());
    clouds.push_back({centroid, squares / n, n});
  }
  double weight = 0;
  Vec3 centre = Vec3::Zero();
  for (const Cloud& c : clouds) {
    weight += c.weight;
    centre += c.weight * c.centroid;
  }
  auto it = m_features.find(label);
  if (it == m_features.end() || weight == 0) return;
  centre /= weight;
  double squares = 0;
  for (const Cloud& c : clouds) squares += c.weight * ((c.centroid - centre).squaredNorm() + c.spread_squared);
  it->second.construction_spread_mm = std::sqrt(squares / weight);
}

// CONST/POINT,F(l),MOVEPT,FA(x),dx,dy,dz: the point of FA(x) moved by an offset in the current
// coordinate system (DMIS 5.3 6.31, MOVEPT).
Result<void> MeasurementRuntime::construct_moved_point(const std::string& label, const FeatureRef& source,
                                                       const Vec3& offset_current, Span span) {
  auto g = resolve(source, span);
  if (!g) return tl::unexpected(g.error());
  store_constructed_point(label, g->position + m_alignment.to_machine_vector(offset_current), g->direction,
                          rests_on_s(source), span);
  return {};
}

// A constructed POINT: its nominal's direction, or `direction` for one without a FEAT nominal
// (whose nominal is then taken from the actual, with a warning).
void MeasurementRuntime::store_constructed_point(const std::string& label, const Vec3& position, const Vec3& direction,
                                                 double rests_on_s, Span span) {
  const auto it = m_features.find(label);
  Geometry point = it != m_features.end() ? it->second.nominal : Geometry{};
  point.type = FeatureType::Point;
  point.position = position;
  if (it == m_features.end()) {
    warn(span, fmt::format("CONST of F({}) without a FEAT nominal; the nominal is taken from the actual", label));
    point.direction = direction;
  }
  store_constructed(label, point, std::nullopt, rests_on_s, span);
}

// CONST/POINT,F(l),EXTREM: among FA(x)'s measured points (surface points, the probe radius
// compensated), the one a plane coming from far along the direction touches first (QIF 3
// PointFeatureExtreme; PC-DMIS's extreme point on hits). Its direction: the nominal's, else the
// point's surface normal.
Result<void> MeasurementRuntime::construct_extreme_point(const std::string& label, const FeatureRef& source,
                                                         const std::optional<FeatureRef>& axis,
                                                         const Vec3& direction_current, bool minimum, Span span) {
  const auto fail = [&](const std::string& why) {
    return program_error(span, fmt::format("cannot construct POINT F({}): {}", label, why));
  };
  auto measured = extreme_source(*this, label, source, span);
  if (!measured) return tl::unexpected(measured.error());
  const Feature* f = *measured;
  Vec3 d = m_alignment.to_machine_vector(direction_current);
  double rests_on = f->rests_on_s;
  if (axis) {
    auto a = resolve(*axis, span);
    if (!a) return tl::unexpected(a.error());
    rests_on = std::min(rests_on, rests_on_s(*axis));
    if (a->type == FeatureType::Point || a->type == FeatureType::Sphere)
      return fail(fmt::format("FA({}) is a {}: it has no axis to give the direction", axis->label, dmis_word(a->type)));
    d = a->direction;
  }
  if (!(d.norm() > 1e-12)) return fail("the direction is a zero vector");
  d = (minimum ? -1.0 : 1.0) * d.normalized();
  const auto far = std::max_element(
      f->points.begin(), f->points.end(),
      [&](const MeasuredPoint& a, const MeasuredPoint& b) { return a.surface_mm().dot(d) < b.surface_mm().dot(d); });
  store_constructed_point(label, far->surface_mm(), far->normal, rests_on, span);
  return {};
}

// CONST/POINT,F(l),EXTREM,FA(x),RADIAL: the measured point of x farthest from x's actual axis
// or centre (a bore's deepest point of wear, a boss's high spot); MIN the nearest. Radial
// distance: from the axis line through `position` along `direction`, from the centre of a sphere.
Result<void> MeasurementRuntime::construct_radial_extreme_point(const std::string& label, const FeatureRef& source,
                                                                bool minimum, Span span) {
  const auto fail = [&](const std::string& why) {
    return program_error(span, fmt::format("cannot construct POINT F({}): {}", label, why));
  };
  auto measured = extreme_source(*this, label, source, span);
  if (!measured) return tl::unexpected(measured.error());
  const Feature* f = *measured;
  auto g = resolve(source, span);
  if (!g) return tl::unexpected(g.error());
  const FeatureType t = g->type;
  if (t != FeatureType::Circle && t != FeatureType::Arc && t != FeatureType::Cylinder && t != FeatureType::Cone &&
      t != FeatureType::Sphere)
    return fail(
        fmt::format("RADIAL measures from an axis or a centre: FA({}) is a {}, not a CIRCLE, ARC, CYLNDR, CONE or "
                    "SPHERE",
                    source.label, dmis_word(t)));
  const Vec3 axis = g->direction.normalized();
  const auto radial = [&](const MeasuredPoint& p) {
    const Vec3 d = p.surface_mm() - g->position;
    return t == FeatureType::Sphere ? d.norm() : (d - d.dot(axis) * axis).norm();
  };
  const auto far =
      std::max_element(f->points.begin(), f->points.end(), [&](const MeasuredPoint& a, const MeasuredPoint& b) {
        return minimum ? radial(a) > radial(b) : radial(a) < radial(b);
      });
  store_constructed_point(label, far->surface_mm(), far->normal, f->rests_on_s, span);
  return {};
}

// CONST/PLANE,F(l),OFFSET,FA(plane),d: the plane translated d along its own normal (QIF 3
// PlaneOffset; a negative d goes against the normal).
Result<void> MeasurementRuntime::construct_offset_plane(const std::string& label, const FeatureRef& source,
                                                        double distance_mm, Span span) {
  auto g = resolve(source, span);
  if (!g) return tl::unexpected(g.error());
  if (g->type != FeatureType::Plane)
    return program_error(span, fmt::format("cannot construct PLANE F({}): OFFSET moves a PLANE, FA({}) is a {}", label,
                                           source.label, dmis_word(g->type)));
  Geometry moved = *g;
  moved.position = g->position + distance_mm * g->direction.normalized();
  if (m_features.find(label) == m_features.end())
    warn(span, fmt::format("CONST of F({}) without a FEAT nominal; the nominal is taken from the actual", label));
  store_constructed(label, moved, std::nullopt, rests_on_s(source), span);
  set_construction_spread(label, {source});
  return {};
}

// A right circular cone of full apex angle a: at h from the vertex along the axis its section is a
// circle of radius h tan(a/2); the section of diameter d lies at h = (d/2) / tan(a/2).
Result<void> MeasurementRuntime::construct_cone_section(const std::string& label, const FeatureRef& source,
                                                        bool by_diameter, double value_mm, Span span) {
  auto g = resolve(source, span);
  if (!g) return tl::unexpected(g.error());
  const auto fail = [&](const std::string& why) {
    return program_error(span, fmt::format("cannot construct CIRCLE F({}): {}", label, why));
  };
  if (g->type != FeatureType::Cone)
    return fail(fmt::format("CONE cuts a CONE, FA({}) is a {}", source.label, dmis_word(g->type)));
  if (!(g->apex_angle_deg > 0 && g->apex_angle_deg < 180))
    return fail(fmt::format("FA({})'s apex angle {:g} deg is not between 0 and 180", source.label, g->apex_angle_deg));
  if (!(value_mm > 0))
    return fail(fmt::format("the {} must be positive, got {:g}", by_diameter ? "diameter" : "distance", value_mm));
  const double tan_half = std::tan(g->apex_angle_deg * std::numbers::pi / 360.0);
  const double h = by_diameter ? value_mm / 2 / tan_half : value_mm;
  Geometry circle;
  circle.type = FeatureType::Circle;
  circle.side = g->side;
  circle.direction = g->direction.normalized();
  circle.position = g->position + h * circle.direction;
  circle.diameter_mm = by_diameter ? value_mm : 2 * h * tan_half;
  if (m_features.find(label) == m_features.end())
    warn(span, fmt::format("CONST of F({}) without a FEAT nominal; the nominal is taken from the actual", label));
  store_constructed(label, circle, std::nullopt, rests_on_s(source), span);
  set_construction_spread(label, {source});
  return {};
}

}  // namespace metron::runtime
