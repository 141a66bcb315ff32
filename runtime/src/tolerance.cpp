// SPDX-License-Identifier: GPL-3.0-or-later
// Tolerance evaluation. Every formula here is written out in docs/tolerances.md.
#include "metron/runtime/tolerance.hpp"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <numbers>
#include <stdexcept>

#include <fmt/format.h>

#include "detail/form_per_unit.hpp"
#include "metron/runtime/alignment_ops.hpp"
#include "metron/runtime/datum_frame.hpp"
#include "metron/stdlib/fitting/minimum_zone.hpp"
#include "metron/stdlib/geometry/ellipse.hpp"

namespace metron::runtime {

const char* dmis_word(ToleranceKind kind) {
  switch (kind) {
    case ToleranceKind::Diam: return "DIAM";
    case ToleranceKind::Rad: return "RAD";
    case ToleranceKind::DistB: return "DISTB";
    case ToleranceKind::Pos: return "POS";
    case ToleranceKind::Flat: return "FLAT";
    case ToleranceKind::Cirlty: return "CIRLTY";
    case ToleranceKind::Cylcty: return "CYLCTY";
    case ToleranceKind::Sphcty: return "SPHCTY";
    case ToleranceKind::Strght: return "STRGHT";
    case ToleranceKind::Perp: return "PERP";
    case ToleranceKind::Parlel: return "PARLEL";
    case ToleranceKind::Anglb: return "ANGLB";
    case ToleranceKind::Angl: return "ANGL";
    case ToleranceKind::Compos: return "COMPOS";
    case ToleranceKind::Profs: return "PROFS";
    case ToleranceKind::DistWrt: return "DISTWRT";
    case ToleranceKind::AngWrt: return "ANGWRT";
    case ToleranceKind::Cortol: return "CORTOL";
    case ToleranceKind::Concen: return "CONCEN";
    case ToleranceKind::Coaxial: return "COAXIAL";
    case ToleranceKind::Crnout: return "CRNOUT";
    case ToleranceKind::Totrun: return "TOTRUN";
    case ToleranceKind::Profl: return "PROFL";
    case ToleranceKind::Profp: return "PROFP";
    case ToleranceKind::Width: return "WIDTH";
    case ToleranceKind::Symmty: return "SYMMTY";
    case ToleranceKind::Anglr: return "ANGLR";
  }
  return "DIAM";
}

namespace {

using Error = tl::unexpected<std::string>;
using Outcome = tl::expected<ToleranceResult, std::string>;
using Types = std::initializer_list<FeatureType>;

// A value equal to a limit up to floating-point rounding (50.01 - 50.0) is in tolerance;
// 1 nm (or 1e-6 deg) is far below any CMM's resolution.
constexpr double k_limit_slack = 1e-6;
// Below this |cos| a direction counts as perpendicular to an axis (intersections undefined).
constexpr double k_parallel_cos = 1e-9;
constexpr double k_pi = 3.14159265358979323846;

double to_deg(double rad) { return rad * 180.0 / k_pi; }
double to_rad(double deg) { return deg * k_pi / 180.0; }

/// Angle between two unit vectors in degrees, 0..180; atan2 keeps small angles accurate.
double angle_deg(const Vec3& a, const Vec3& b) { return to_deg(std::atan2(a.cross(b).norm(), a.dot(b))); }
/// The same for directions without a sense (normals and axes as lines): 0..90.
double line_angle_deg(const Vec3& a, const Vec3& b) { return std::min(angle_deg(a, b), angle_deg(a, -b)); }

const char* lowercase_name(FeatureType type) {
  switch (type) {
    case FeatureType::Point: return "point";
    case FeatureType::Plane: return "plane";
    case FeatureType::Line: return "line";
    case FeatureType::Circle: return "circle";
    case FeatureType::Arc: return "arc";
    case FeatureType::Sphere: return "sphere";
    case FeatureType::Cylinder: return "cylinder";
    case FeatureType::Cone: return "cone";
    case FeatureType::ParallelPlanes: return "pair of parallel planes";
    case FeatureType::GenericSurface: return "GSURF";
    case FeatureType::GenericCurve: return "GCURVE";
    case FeatureType::ClosedSlot: return "closed slot (CPARLN)";
    case FeatureType::Torus: return "torus";
    case FeatureType::Ellipse: return "ellipse";
  }
  return "point";
}

const char* article(const char* word) {
  const char c = word[0];
  const bool vowel = c == 'a' || c == 'e' || c == 'i' || c == 'o' || c == 'u' || c == 'A' || c == 'E' || c == 'I' ||
                     c == 'O' || c == 'U';
  return vowel ? "an" : "a";
}

bool is_one_of(FeatureType type, Types types) { return std::find(types.begin(), types.end(), type) != types.end(); }

/// "a circle, arc, sphere or cylinder"
std::string type_list(Types types) {
  std::string out;
  std::size_t i = 0;
  for (const FeatureType t : types) {
    if (i == 0)
      out += std::string(article(lowercase_name(t))) + " ";
    else
      out += i + 1 == types.size() ? " or " : ", ";
    out += lowercase_name(t);
    ++i;
  }
  return out;
}

Error wrong_type(ToleranceKind kind, Types types, FeatureType got) {
  return Error(fmt::format("{} applies to {}, not to {} {}", dmis_word(kind), type_list(types), article(dmis_word(got)),
                           dmis_word(got)));
}

void add_note(ToleranceResult& result, const std::string& note) {
  if (note.empty()) return;
  if (!result.note.empty()) result.note += "; ";
  result.note += note;
}

/// Location tolerances with datums: the datum reference frame the DAT labels build, fitted for
/// this feature (datum_frame.hpp); the feature's actual is moved with it. Without datums the
/// actual is compared as it stands (the current alignment is the frame).
///
/// A program's datum nominals can be read two ways: where their FEAT put them on the machine, or
/// as part-frame numbers to be read in the toleranced feature's alignment (datum features defined
/// under a rough alignment, the feature under the fine one). Real programs do both (the NIST DCX
/// program writes its datum planes in a shifted, turned frame of its own), so metron fits both
/// and keeps the reading under which the datums' nominals and actuals agree best: the one that
/// moves the feature least. The note says which.
tl::expected<DatumFrame, std::string> frame_of_datums(const ToleranceSpec& spec, const Feature& feature,
                                                      const ToleranceContext& context) {
  if (spec.datums.empty()) return DatumFrame{};
  for (std::size_t i = 0; i < spec.datums.size(); ++i)
    if (i >= context.datums.size() || !context.datums[i])
      return Error(
          fmt::format("datum {} is not defined: DATDEF/FA(feature),DAT({}) first", spec.datums[i], spec.datums[i]));
  auto as_defined = fit_datum_frame(context.datums, feature.nominal_frame, DatumNominals::AsDefined);
  if (!as_defined) return as_defined;
  auto in_frame = fit_datum_frame(context.datums, feature.nominal_frame, DatumNominals::InFeaturesFrame);
  const Vec3 p = feature.actual ? feature.actual->position : feature.nominal.position;
  const auto moved = [&](const DatumFrame& f) { return (f.actual_to_nominal * p - p).norm(); };
  if (moved(*in_frame) + 1e-9 < moved(*as_defined)) {
    in_frame->description += " (datum nominals read in the feature's alignment)";
    return in_frame;
  }
  return as_defined;
}

/// The note of a datum frame, with how far it moved the feature's actual position.
std::string datum_frame_note(const DatumFrame& frame, const Vec3& actual_position) {
  if (frame.description.empty()) return {};
  return fmt::format("{}; the feature's actual moved {:.4f} mm", frame.description,
                     (frame.actual_to_nominal * actual_position - actual_position).norm());
}

void set_limits(ToleranceResult& result, double lower, double upper) {
  result.lower = lower;
  result.upper = upper;
  result.in_tolerance = result.value >= lower - k_limit_slack && result.value <= upper + k_limit_slack;
}

tl::expected<const Geometry*, std::string> actual_of(const Feature& feature) {
  if (!feature.actual)
    return Error(fmt::format("feature {} has no actual: measure or construct it first", feature.label));
  return &*feature.actual;
}

tl::expected<Vec3, std::string> unit(const Vec3& v, const std::string& what) {
  const double n = v.norm();
  if (!(n > 1e-12) || !std::isfinite(n)) return Error(fmt::format("{} has no direction", what));
  return Vec3(v / n);
}

/// The direction an orientation tolerance measures: a CPARLN's long axis, else `direction`.
const Vec3& oriented_direction(const Geometry& g) {
  return g.type == FeatureType::ClosedSlot ? g.slot_axis : g.direction;
}

bool has_axis(FeatureType type) {
  return type == FeatureType::Line || type == FeatureType::Cylinder || type == FeatureType::Cone;
}

/// The derived median surface of a pair of opposite faces (ISO 14660-2): for each surface point,
/// the middle of it and its opposite point, which lies on the other face's least-squares plane
/// along `normal` (the pair's actual normal; a face of fewer than three points, or one whose points
/// fit no plane within 30 deg of it, is the plane through its centroid normal to it). A face is
/// the points on one side of the plane through `centre` normal to `normal`. One face leaning by an
/// angle leans the median by half that angle, as pairs of opposite points do.
std::vector<Vec3> derived_median_points(const std::vector<Vec3>& surface, const Vec3& centre, const Vec3& normal) {
  std::vector<Vec3> faces[2];
  for (const Vec3& q : surface) faces[(q - centre).dot(normal) >= 0 ? 0 : 1].push_back(q);
  struct Plane {
    Vec3 point, normal;
  };
  Plane planes[2];
  for (int f = 0; f < 2; ++f) {
    Vec3 centroid = centre;
    if (!faces[f].empty()) {
      centroid = Vec3::Zero();
      for (const Vec3& q : faces[f]) centroid += q / static_cast<double>(faces[f].size());
    }
    planes[f] = {centroid, normal};
    if (faces[f].size() >= 3) {
      const auto fitted = fitting::fit(fitting::Shape::Plane, faces[f]);
      if (fitted && std::abs(fitted->direction.normalized().dot(normal)) >= std::cos(30 * k_pi / 180))
        planes[f] = {fitted->position, fitted->direction.normalized()};
    }
  }
  std::vector<Vec3> median;
  for (int f = 0; f < 2; ++f) {
    const Plane& other = planes[1 - f];
    for (const Vec3& q : faces[f]) {
      const double t = (other.point - q).dot(other.normal) / normal.dot(other.normal);
      median.push_back(q + 0.5 * t * normal);
    }
  }
  return median;
}

// ---------------------------------------------------------------- size

// A helical scan has no gap in height to cut at: taken in its order, its points turn steadily
// about the axis. Cut into turns (each a full revolution, the last part-turn kept as its own
// section when it spans half a turn, else joined to the turn before), each turn is a section.
// Empty when the points are not such a scan: fewer than 16, under two turns in all, or turning
// back and forth (|net turn| under 90% of the turning).
std::vector<std::vector<std::size_t>> helix_turns(const std::vector<double>& angles) {
  constexpr double two_pi = 2 * std::numbers::pi;
  if (angles.size() < 16) return {};
  std::vector<double> unwrapped = {0.0};
  double travelled = 0;
  for (std::size_t i = 1; i < angles.size(); ++i) {
    const double step = std::remainder(angles[i] - angles[i - 1], two_pi);
    unwrapped.push_back(unwrapped.back() + step);
    travelled += std::abs(step);
  }
  const double net = std::abs(unwrapped.back());
  if (net < 2 * two_pi || net < 0.9 * travelled) return {};
  std::vector<std::vector<std::size_t>> turns(1);
  double turn_start = 0;
  for (std::size_t i = 0; i < angles.size(); ++i) {
    if (std::abs(unwrapped[i] - turn_start) >= two_pi - 1e-12) {
      turns.emplace_back();
      turn_start = unwrapped[i];
    }
    turns.back().push_back(i);
  }
  if (turns.size() > 1 && std::abs(unwrapped.back() - turn_start) < std::numbers::pi) {
    auto last = std::move(turns.back());
    turns.pop_back();
    turns.back().insert(turns.back().end(), last.begin(), last.end());
  }
  return turns;
}

// A cylinder's points in sections: sorted by their height along the axis, a new section where
// consecutive heights part by more than 5% of their whole range; points of a helical scan (one
// such section) in its turns (helix_turns). `angles` about the axis, in the order taken.
std::vector<std::vector<std::size_t>> sections_by_height(const std::vector<double>& heights,
                                                         const std::vector<double>& angles) {
  std::vector<std::size_t> order(heights.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return heights[a] < heights[b]; });
  std::vector<std::vector<std::size_t>> sections;
  const double range = order.empty() ? 0.0 : heights[order.back()] - heights[order.front()];
  for (std::size_t k = 0; k < order.size(); ++k) {
    if (k == 0 || heights[order[k]] - heights[order[k - 1]] > 0.05 * range + 1e-9) sections.emplace_back();
    sections.back().push_back(order[k]);
  }
  if (sections.size() == 1 && range > 0) {
    auto turns = helix_turns(angles);
    if (!turns.empty()) return turns;
  }
  return sections;
}

// ISO 14405-1's two-point size (LP) at each measured point: its distance to the opposite point of
// the profile on the line through the least-squares centre, in the section normal to the axis it
// lies in. The opposite point's radius is interpolated linearly in angle between the measured
// points on either side of it (one exactly opposite is taken as it is); a point whose opposite
// falls in a gap wider than 120 deg has none. A cylinder's sections: its points grouped by height
// along the axis, a new section where consecutive heights part by more than 5% of their range.
tl::expected<std::vector<double>, std::string> two_point_sizes(const Geometry& g,
                                                               const std::vector<MeasuredPoint>& points) {
  const Vec3 axis = g.direction.norm() > 1e-12 ? Vec3(g.direction.normalized()) : Vec3::UnitZ();
  const Vec3 u = axis.unitOrthogonal(), v = axis.cross(u);
  struct Polar {
    double height, angle, radius;
  };
  std::vector<Polar> polar;
  std::vector<double> heights;
  for (const MeasuredPoint& p : points) {
    const Vec3 d = p.surface_mm() - g.position;
    const Vec3 across = d - d.dot(axis) * axis;
    polar.push_back({d.dot(axis), std::atan2(across.dot(v), across.dot(u)), across.norm()});
    heights.push_back(d.dot(axis));
  }
  std::vector<std::vector<Polar>> sections;
  if (g.type == FeatureType::Cylinder) {
    std::vector<double> angles;
    for (const Polar& p : polar) angles.push_back(p.angle);
    for (const auto& indices : sections_by_height(heights, angles)) {
      sections.emplace_back();
      for (const std::size_t i : indices) sections.back().push_back(polar[i]);
    }
  } else if (!polar.empty()) {
    sections.push_back(polar);
  }
  constexpr double two_pi = 2 * std::numbers::pi;
  const auto wrapped = [&](double a) { return a - two_pi * std::floor(a / two_pi); };  // [0, 2 pi)
  std::vector<double> sizes;
  for (auto& section : sections) {
    if (section.size() < 3) continue;
    std::sort(section.begin(), section.end(), [](const Polar& a, const Polar& b) { return a.angle < b.angle; });
    std::vector<double> angles;
    for (const Polar& p : section) angles.push_back(p.angle);
    const std::size_t n = section.size();
    for (const Polar& p : section) {
      // The measured points on either side of the opposite direction (angles in (-pi, pi]).
      const double opposite = p.angle > 0 ? p.angle - std::numbers::pi : p.angle + std::numbers::pi;
      const std::size_t hi =
          static_cast<std::size_t>(std::upper_bound(angles.begin(), angles.end(), opposite) - angles.begin()) % n;
      const std::size_t lo = (hi + n - 1) % n;
      const double gap = wrapped(angles[hi] - angles[lo]);
      if (gap < 1e-15 || gap > two_pi / 3 + 1e-9) continue;  // all at one angle, or too wide a gap
      const double t = std::min(1.0, wrapped(opposite - angles[lo]) / gap);
      sizes.push_back(p.radius + (1 - t) * section[lo].radius + t * section[hi].radius);
    }
  }
  if (sizes.empty())
    return tl::unexpected(
        std::string("no measured point has an opposite one within 60 deg (a section needs at "
                    "least three points around it)"));
  return sizes;
}

Outcome evaluate_size(const ToleranceSpec& spec, const Feature& feature, ToleranceResult result) {
  static constexpr Types k_types = {FeatureType::Circle, FeatureType::Arc, FeatureType::Sphere, FeatureType::Cylinder};
  static constexpr Types k_widths = {FeatureType::ParallelPlanes, FeatureType::ClosedSlot};
  static constexpr Types k_lengths = {FeatureType::ClosedSlot};
  const bool width = spec.kind == ToleranceKind::Width;
  // DMIS TOL/WIDTH,...,LONG: the long side of a CPARLN, its length; SHORT (the default) its width.
  const bool length = width && spec.long_side;
  const Types& types = length ? k_lengths : width ? k_widths : k_types;
  if (!is_one_of(feature.nominal.type, types)) return wrong_type(spec.kind, types, feature.nominal.type);
  const auto actual = actual_of(feature);
  if (!actual) return Error(actual.error());
  const double scale = spec.kind == ToleranceKind::Rad ? 0.5 : 1.0;
  const auto size_of = [&](const Geometry& g) {
    return length ? g.length_mm : width ? g.width_mm : scale * g.diameter_mm;
  };
  result.actual = size_of(**actual);
  result.nominal = size_of(feature.nominal);
  if (length) add_note(result, "LONG: the length of the slot, end to end");
  if (!width && spec.extent != DistanceExtent::Average) {
    // DIAM|RAD,lo,up,MAX|MIN: twice the largest (smallest) distance of a measured surface point
    // from the fitted centre (circle, arc: in its plane; cylinder: from its axis; sphere: from it).
    const Geometry& g = **actual;
    const Vec3 axis = g.direction.norm() > 1e-12 ? Vec3(g.direction.normalized()) : Vec3::UnitZ();
    if (feature.points.empty())
      return Error(fmt::format("{} of {} at {} needs its measured points: it has none", dmis_word(spec.kind),
                               feature.label, spec.extent == DistanceExtent::Maximum ? "MAX" : "MIN"));
    double lo = std::numeric_limits<double>::infinity(), hi = 0;
    for (const MeasuredPoint& p : feature.points) {
      Vec3 v = p.surface_mm() - g.position;
      if (g.type != FeatureType::Sphere) v -= v.dot(axis) * axis;
      lo = std::min(lo, v.norm());
      hi = std::max(hi, v.norm());
    }
    const bool maximum = spec.extent == DistanceExtent::Maximum;
    result.actual = 2 * scale * (maximum ? hi : lo);
    add_note(result,
             fmt::format("{}: the {} {} of the {} measured points about the fitted centre (least squares {:.4f})",
                         maximum ? "MAX" : "MIN", maximum ? "largest" : "smallest",
                         spec.kind == ToleranceKind::Rad ? "radius" : "diameter", feature.points.size(), size_of(g)));
  }
  if (!width && spec.two_point_size) {
    const Geometry& g = **actual;
    if (feature.nominal.type != FeatureType::Circle && feature.nominal.type != FeatureType::Cylinder)
      return Error(fmt::format("{} of {} at DIAMLP: the two-point size is taken of a CIRCLE or a CYLNDR, not of a {}",
                               dmis_word(spec.kind), feature.label, dmis_word(feature.nominal.type)));
    const auto sizes = two_point_sizes(g, feature.points);
    if (!sizes) return Error(fmt::format("{} of {} at DIAMLP: {}", dmis_word(spec.kind), feature.label, sizes.error()));
    const auto [least, most] = std::minmax_element(sizes->begin(), sizes->end());
    // Every local size must lie within the limits: the one farther beyond (or nearer to) its
    // limit is the tolerance's actual.
    const double over = scale * *most - result.nominal - spec.upper;
    const double under = spec.lower - (scale * *least - result.nominal);
    result.actual = scale * (over >= under ? *most : *least);
    add_note(result, fmt::format("DIAMLP: the two-point sizes (ISO 14405-1 LP) at {} of the {} measured points run "
                                 "from {:.4f} to {:.4f}; the one nearer its limit is given (least squares {:.4f})",
                                 sizes->size(), feature.points.size(), scale * *least, scale * *most, size_of(g)));
  }
  result.value = result.actual - result.nominal;
  set_limits(result, spec.lower, spec.upper);
  return result;
}

// ---------------------------------------------------------------- ANGL

// TOL/ANGL,lo,up: the included (apex) angle of a cone against its nominal, in degrees.
Outcome evaluate_cone_angle(const ToleranceSpec& spec, const Feature& feature, ToleranceResult result) {
  static constexpr Types k_types = {FeatureType::Cone};
  if (!is_one_of(feature.nominal.type, k_types)) return wrong_type(spec.kind, k_types, feature.nominal.type);
  const auto actual = actual_of(feature);
  if (!actual) return Error(actual.error());
  result.actual = (*actual)->apex_angle_deg;
  result.nominal = feature.nominal.apex_angle_deg;
  result.value = result.actual - result.nominal;
  set_limits(result, spec.lower, spec.upper);
  return result;
}

// ---------------------------------------------------------------- DISTB

const char* axis_word(DistanceAxis axis) {
  switch (axis) {
    case DistanceAxis::XAxis: return "XAXIS";
    case DistanceAxis::YAxis: return "YAXIS";
    case DistanceAxis::ZAxis: return "ZAXIS";
    case DistanceAxis::PointToPoint: return "PT2PT";
  }
  return "PT2PT";
}

/// A DISTB distance and the unit direction (MCS) it is measured along.
struct DirectedDistance {
  double distance = 0;
  Vec3 direction = Vec3::UnitX();
};

Vec3 unit_or(const Vec3& v, const Vec3& fallback) { return v.norm() > 1e-12 ? Vec3(v.normalized()) : fallback; }

/// The DISTB distance between two geometries (both actual or both nominal), see docs/tolerances.md.
tl::expected<DirectedDistance, std::string> distance_between(const Geometry& first, const Geometry& second,
                                                             const std::string& first_label,
                                                             const std::string& second_label, DistanceAxis axis,
                                                             const Alignment& frame) {
  const bool first_plane = first.type == FeatureType::Plane;
  const bool second_plane = second.type == FeatureType::Plane;
  if (axis == DistanceAxis::PointToPoint) {
    if (first_plane) {
      const Vec3 n = first.direction.normalized();
      return DirectedDistance{std::abs(n.dot(second.position - first.position)), n};
    }
    if (second_plane) {
      const Vec3 n = second.direction.normalized();
      return DirectedDistance{std::abs(n.dot(first.position - second.position)), n};
    }
    const auto is_line = [](const Geometry& g) {
      return g.type == FeatureType::Line || g.type == FeatureType::Cylinder;
    };
    if (is_line(first) || is_line(second)) {
      const Geometry& line = is_line(first) ? first : second;
      const Vec3& point = is_line(first) ? second.position : first.position;
      const Vec3 a = line.direction.normalized();
      const Vec3 v = point - line.position;
      const Vec3 across = v - v.dot(a) * a;
      return DirectedDistance{across.norm(), unit_or(across, any_perpendicular(a))};
    }
    const Vec3 d = second.position - first.position;
    return DirectedDistance{d.norm(), unit_or(d, Vec3::UnitX())};
  }
  const Vec3 part_axis = axis == DistanceAxis::XAxis   ? Vec3::UnitX()
                         : axis == DistanceAxis::YAxis ? Vec3::UnitY()
                                                       : Vec3::UnitZ();
  const Vec3 e = frame.to_machine_vector(part_axis);
  if (first_plane || second_plane) {
    // From the other feature's position along e to the plane, so a plane that is not exactly
    // normal to e still gives its distance at that position, not at its (arbitrary) centroid.
    const Geometry& plane = first_plane ? first : second;
    const Geometry& other = first_plane ? second : first;
    const Vec3 n = plane.direction.normalized();
    const double cos_e = n.dot(e);
    if (std::abs(cos_e) < k_parallel_cos)
      return Error(fmt::format("DISTB along {}: plane {} is parallel to that axis", axis_word(axis),
                               first_plane ? first_label : second_label));
    return DirectedDistance{std::abs(n.dot(plane.position - other.position) / cos_e), e};
  }
  return DirectedDistance{std::abs(e.dot(second.position - first.position)), e};
}

/// How far a feature of size reaches from its position along the unit direction u: a circle's or
/// arc's radius projected into its plane, a cylinder's across its axis, a sphere's radius, half a
/// PARPLN's width along its normal; 0 for features without a size. MINIM and MAXIM take it off or
/// add it (the "subtract radius" and "add radius" distances of CMM software).
double half_extent(const Geometry& g, const Vec3& u) {
  const double r = g.diameter_mm / 2;
  const auto across = [&](const Vec3& axis) {
    const double c = axis.normalized().dot(u);
    return std::sqrt(std::max(0.0, 1 - c * c));
  };
  switch (g.type) {
    case FeatureType::Circle:
    case FeatureType::Arc:
    case FeatureType::Cylinder: return r * across(g.direction);
    case FeatureType::Sphere: return r;
    case FeatureType::ParallelPlanes: return g.width_mm / 2 * std::abs(g.direction.normalized().dot(u));
    default: return 0;
  }
}

/// The distance between two geometries with the spec's extent (AVG: between their positions).
tl::expected<double, std::string> extent_distance(const Geometry& first, const Geometry& second,
                                                  const std::string& first_label, const std::string& second_label,
                                                  const ToleranceSpec& spec, const Alignment& frame) {
  const auto d = distance_between(first, second, first_label, second_label, spec.axis, frame);
  if (!d) return Error(d.error());
  if (spec.extent == DistanceExtent::Average) return d->distance;
  const double reach = half_extent(first, d->direction) + half_extent(second, d->direction);
  return spec.extent == DistanceExtent::Minimum ? d->distance - reach : d->distance + reach;
}

Outcome evaluate_distb(const ToleranceSpec& spec, const Feature& first, const Feature& second,
                       const ToleranceContext& context, ToleranceResult result) {
  const auto a = actual_of(first);
  if (!a) return Error(a.error());
  const auto b = actual_of(second);
  if (!b) return Error(b.error());
  const Alignment mcs;
  const Alignment& frame = context.alignment ? *context.alignment : mcs;
  const auto actual = extent_distance(**a, **b, first.label, second.label, spec, frame);
  if (!actual) return Error(actual.error());
  const auto nominal = extent_distance(first.nominal, second.nominal, first.label, second.label, spec, frame);
  result.actual = *actual;
  result.nominal = nominal ? *nominal : std::numeric_limits<double>::quiet_NaN();
  result.value = *actual - spec.nominal;
  set_limits(result, spec.lower, spec.upper);
  if (spec.axis != DistanceAxis::PointToPoint)
    add_note(result, fmt::format("along {} of {}", axis_word(spec.axis), frame.label));
  if (spec.extent != DistanceExtent::Average) {
    const auto sized = [](const Geometry& g) {
      return g.type == FeatureType::Circle || g.type == FeatureType::Arc || g.type == FeatureType::Cylinder ||
             g.type == FeatureType::Sphere || g.type == FeatureType::ParallelPlanes;
    };
    const bool any_sized = sized(**a) || sized(**b);
    add_note(result, any_sized ? (spec.extent == DistanceExtent::Minimum ? "MINIM: between the near sides"
                                                                         : "MAXIM: between the far sides")
                               : "MINIM/MAXIM: neither feature has a size, the distance is between their positions");
  }
  if (spec.limits)
    add_note(result, fmt::format("LIMIT form: the distance between {} and {}, deviations from their middle",
                                 length_text(spec.nominal + spec.lower, context.units),
                                 length_text(spec.nominal + spec.upper, context.units)));
  else if (!nominal)
    add_note(result, "no nominal distance from the feature nominals: " + nominal.error());
  else if (std::abs(*nominal - spec.nominal) > 1e-4)
    add_note(result, fmt::format("the feature nominals give {}, the tolerance nominal is {}",
                                 length_text(*nominal, context.units), length_text(spec.nominal, context.units)));
  return result;
}

// ---------------------------------------------------------------- POS

// The point of `actual` whose offset from the nominal position is its position deviation: 2D, an
// axis where it crosses the plane through the nominal position normal to the nominal axis (else
// the actual position); 3D, the actual position.
tl::expected<Vec3, std::string> position_point(const Geometry& nominal, const Geometry& actual, bool three_d,
                                               const std::string& label) {
  if (three_d || !has_axis(nominal.type)) return actual.position;
  const auto n = unit(nominal.direction, "the nominal of " + label);
  if (!n) return Error(n.error());
  const auto axis = unit(actual.direction, "the actual of " + label);
  if (!axis) return Error(axis.error());
  const double cos_a = axis->dot(*n);
  if (std::abs(cos_a) < k_parallel_cos)
    return Error(fmt::format("POS 2D of {}: the actual axis is perpendicular to the nominal axis", label));
  return Vec3(actual.position + (n->dot(nominal.position - actual.position) / cos_a) * *axis);
}

/// The features of size a material condition applies to (POS's bonus, a datum's shift): the
/// round ones by their diameter, a PARPLN or CPARLN by its width.
constexpr Types k_material_sized = {FeatureType::Circle,         FeatureType::Arc,
                                    FeatureType::Sphere,         FeatureType::Cylinder,
                                    FeatureType::ParallelPlanes, FeatureType::ClosedSlot};

double size_of(const Geometry& g) {
  return g.type == FeatureType::ParallelPlanes || g.type == FeatureType::ClosedSlot ? g.width_mm : g.diameter_mm;
}

/// How far a feature of size as made departs from its MMC (LMC) size, taken as the nominal
/// size (a tolerance carries no size limits): a hole or slot grows away from MMC, a boss or tab
/// shrinks; 0 beyond that size.
double departure_from(MaterialCondition condition, const Geometry& nominal, const Geometry& actual) {
  const double growth_mm = size_of(actual) - size_of(nominal);
  const double away_from_mmc = nominal.side == Side::Inner ? growth_mm : -growth_mm;
  return std::max(0.0, condition == MaterialCondition::Mmc ? away_from_mmc : -away_from_mmc);
}

// The MMC or LMC bonus of a position zone: the actual size's departure from that material
// condition, taken at the nominal diameter (the spec carries no size limits).
tl::expected<double, std::string> material_bonus(MaterialCondition condition, const Geometry& nominal,
                                                 const Geometry& actual, const ReportUnits& units,
                                                 ToleranceResult& result) {
  if (condition == MaterialCondition::Rfs) return 0.0;
  const char* modifier = condition == MaterialCondition::Mmc ? "MMC" : "LMC";
  if (!is_one_of(nominal.type, k_material_sized))
    return Error(fmt::format("{} applies to {}, not to {} {}", modifier, type_list(k_material_sized),
                             article(dmis_word(nominal.type)), dmis_word(nominal.type)));
  const double bonus_mm = departure_from(condition, nominal, actual);
  const char* size = size_of(nominal) == nominal.width_mm && nominal.width_mm > 0 ? "width" : "diameter";
  add_note(result, fmt::format("{} bonus {}: actual {} {} against the {} size, taken "
                               "as the nominal {} {} (the tolerance has no size limits)",
                               modifier, length_text(bonus_mm, units), size, length_text(size_of(actual), units),
                               modifier, size, length_text(size_of(nominal), units)));
  if (nominal.side == Side::None) add_note(result, "side unknown: treated as OUTER");
  return bonus_mm;
}

// The bonus of a tolerance's MMC or LMC where only a feature of size takes one (orientation,
// coaxiality): material_bonus for a feature of size, else 0 with a note (the modifier means
// nothing on a plane or a line; the zone stays RFS).
tl::expected<double, std::string> sized_bonus(const ToleranceSpec& spec, const Feature& feature, const Geometry& actual,
                                              const ReportUnits& units, ToleranceResult& result) {
  if (spec.condition == MaterialCondition::Rfs) return 0.0;
  if (is_one_of(feature.nominal.type, k_material_sized))
    return material_bonus(spec.condition, feature.nominal, actual, units, result);
  add_note(result, fmt::format("{} has no size: {} does not apply, the zone is RFS", feature.label,
                               spec.condition == MaterialCondition::Mmc ? "MMC" : "LMC"));
  return 0.0;
}

// Datum shift (ASME Y14.5: a datum feature referenced at its maximum material boundary; ISO 2692:
// the maximum material requirement applied to a datum feature): a datum feature of size referenced at MMC (LMC) that
// departs from that size lets the datum reference frame move by half the departure, here a translation normal to the
// datum's axis. For one feature the best shift takes up to that much off the deviation's
// component across the datum's axis: |d_perp| -> max(0, |d_perp| - departure / 2). Only the first
// datum of size with a modifier shifts; the rotation a further one would allow is not taken.
void apply_datum_shift(const ToleranceSpec& spec, const ToleranceContext& context, Vec3& deviation,
                       ToleranceResult& result) {
  bool shifted = false;
  for (std::size_t i = 0; i < spec.datum_conditions.size() && i < context.datums.size(); ++i) {
    const MaterialCondition condition = spec.datum_conditions[i];
    if (condition == MaterialCondition::Rfs || !context.datums[i]) continue;
    const Datum& datum = *context.datums[i];
    const char* modifier = condition == MaterialCondition::Mmc ? "MMC" : "LMC";
    // A round datum feature shifts across its axis; a width's shift (across its faces only) is not
    // taken.
    static constexpr Types k_round_sized = {FeatureType::Circle, FeatureType::Arc, FeatureType::Sphere,
                                            FeatureType::Cylinder};
    if (!is_one_of(datum.nominal.type, k_round_sized)) {
      add_note(result, fmt::format("DAT({}) at {}: a {} datum does not shift here (only a round datum feature's "
                                   "shift across its axis is taken)",
                                   datum.label, modifier, dmis_word(datum.nominal.type)));
      continue;
    }
    if (shifted) {
      add_note(result,
               fmt::format("DAT({}) at {}: the rotation its departure allows is not applied", datum.label, modifier));
      continue;
    }
    shifted = true;
    const double departure = departure_from(condition, datum.nominal, datum.geometry);
    const double allowed = departure / 2;
    Vec3 across = deviation;
    if (datum.nominal.type != FeatureType::Sphere) {
      const Vec3 axis = datum.nominal.direction.normalized();
      across -= across.dot(axis) * axis;
    }
    const double before = 2.0 * deviation.norm();
    const double taken = std::min(allowed, across.norm());
    if (across.norm() > 0) deviation -= taken * across.normalized();
    add_note(result, fmt::format("datum shift: DAT({}) at {} departs {} from that size, the frame may move {}; "
                                 "without the shift {}",
                                 datum.label, modifier, length_text(departure, context.units),
                                 length_text(allowed, context.units), length_text(before, context.units)));
  }
}

Outcome evaluate_pos(const ToleranceSpec& spec, const Feature& feature, const ToleranceContext& context,
                     ToleranceResult result) {
  static constexpr Types k_types = {FeatureType::Point,   FeatureType::Circle,        FeatureType::Arc,
                                    FeatureType::Sphere,  FeatureType::Cylinder,      FeatureType::Cone,
                                    FeatureType::Line,    FeatureType::ClosedSlot,    FeatureType::Torus,
                                    FeatureType::Ellipse, FeatureType::ParallelPlanes};
  const Geometry& nominal = feature.nominal;
  if (!is_one_of(nominal.type, k_types)) return wrong_type(spec.kind, k_types, nominal.type);
  const auto actual_or = actual_of(feature);
  if (!actual_or) return Error(actual_or.error());
  const auto frame = frame_of_datums(spec, feature, context);
  if (!frame) return Error(frame.error());
  const Geometry actual = to_machine(**actual_or, frame->actual_to_nominal);
  Vec3 deviation = Vec3::Zero();
  const auto n = unit(nominal.direction, "the nominal of " + feature.label);
  if (nominal.type == FeatureType::ParallelPlanes) {
    // A width's position (ASME Y14.5-2018, ISO 1101; clauses not checked here): its derived median
    // plane within two planes t apart about the true position, normal to the nominal normal: 2 |d|
    // for the median point farthest from it, d along the normal (tilt and form included); a width
    // without points (constructed, stated) by its median plane's centre.
    if (!n) return Error(n.error());
    deviation = (actual.position - nominal.position).dot(*n) * *n;
    const auto own = unit((*actual_or)->direction, "the actual of " + feature.label);
    if (own && !feature.points.empty()) {
      std::vector<Vec3> surface;
      for (const MeasuredPoint& p : feature.points) surface.push_back(p.surface_mm());
      double worst = -1;
      for (const Vec3& m : derived_median_points(surface, (*actual_or)->position, *own)) {
        const double along = (frame->actual_to_nominal * m - nominal.position).dot(*n);
        if (std::abs(along) > worst) {
          worst = std::abs(along);
          deviation = along * *n;
        }
      }
      add_note(result, fmt::format("the derived median plane's farthest point from the true position, along its "
                                   "normal (a zone of two parallel planes), of {} median points",
                                   feature.points.size()));
    } else {
      add_note(result, "the median plane's position along its normal (a zone of two parallel planes)");
    }
  } else {
    const auto at = position_point(nominal, actual, spec.three_d, feature.label);
    if (!at) return Error(at.error());
    deviation = *at - nominal.position;
    if (!spec.three_d) {
      if (!n) return Error(n.error());
      deviation -= deviation.dot(*n) * *n;
    }
  }
  apply_datum_shift(spec, context, deviation, result);
  result.value = 2.0 * deviation.norm();
  result.actual = result.value;
  result.nominal = 0;
  const auto bonus_mm = material_bonus(spec.condition, nominal, actual, context.units, result);
  if (!bonus_mm) return Error(bonus_mm.error());
  set_limits(result, 0, spec.zone + *bonus_mm);
  add_note(result, datum_frame_note(*frame, (*actual_or)->position));
  return result;
}

// ---------------------------------------------------------------- form

// A round feature's measured points in sections normal to its actual axis (sections_by_height).
struct Sections {
  Vec3 axis = Vec3::UnitZ();
  std::vector<Vec3> surface;                    ///< the compensated points
  std::vector<double> heights;                  ///< along the axis, from the actual's position
  std::vector<std::vector<std::size_t>> rings;  ///< indices into `surface`, by height
};

Sections sections_of(const Feature& feature, const Geometry& actual) {
  Sections s;
  if (actual.direction.norm() > 1e-12) s.axis = actual.direction.normalized();
  const Vec3 u = s.axis.unitOrthogonal(), v = s.axis.cross(u);
  std::vector<double> angles;
  for (const MeasuredPoint& p : feature.points) {
    s.surface.push_back(p.surface_mm());
    const Vec3 d = s.surface.back() - actual.position;
    s.heights.push_back(d.dot(s.axis));
    angles.push_back(std::atan2(d.dot(v), d.dot(u)));
  }
  s.rings = sections_by_height(s.heights, angles);
  return s;
}

// STRGHT of a CYLNDR: the straightness of its derived median line (ISO 1101 and ISO 14660-2: the
// centres of its sections' least-squares circles; ASME Y14.5-2018, the axis of a feature
// of size): the sections as sections_by_height groups the points, each circle in the plane normal
// to the least-squares axis, and the zone the narrowest cylinder about a line that holds every
// centre (a zone of diameter t, as a drawing's straightness with a diameter sign gives it).
// MMC/LMC: the zone grows by the size's departure from that condition (material_bonus).
Outcome evaluate_axis_straightness(const ToleranceSpec& spec, const Feature& feature, const ReportUnits& units,
                                   ToleranceResult result) {
  const auto actual = actual_of(feature);
  if (!actual) return Error(actual.error());
  if (feature.points.empty())
    return Error(
        fmt::format("feature {} has no measured points: the straightness of its axis needs the centres of "
                    "its sections",
                    feature.label));
  const Sections sections = sections_of(feature, **actual);
  std::vector<Vec3> centres;
  std::size_t skipped = 0;
  for (const auto& section : sections.rings) {
    std::vector<Vec3> ring;
    for (const std::size_t i : section) ring.push_back(sections.surface[i]);
    fitting::FitOptions options;
    options.direction_hint = sections.axis;
    options.circle_in_plane_of_hint = true;
    const auto circle =
        ring.size() >= 3
            ? fitting::fit(fitting::Shape::Circle, ring, options)
            : tl::expected<fitting::FitResult, fitting::FitFailure>(tl::unexpected(fitting::FitFailure::TooFewPoints));
    if (circle)
      centres.push_back(circle->position);
    else
      ++skipped;
  }
  if (centres.size() < 2)
    return Error(
        fmt::format("feature {}'s points lie in {} section{} with a circle (three points or more at one "
                    "height along the axis): the straightness of its axis needs two at least",
                    feature.label, centres.size(), centres.size() == 1 ? "" : "s"));
  double zone_mm = 0;
  if (centres.size() > 2) {
    const auto mz = fitting::minimum_zone(fitting::Shape::Line, centres);
    const auto ls = fitting::fit(fitting::Shape::Line, centres);
    zone_mm = mz ? mz->form_mm : ls ? ls->form_mm : 0.0;
  }
  result.value = zone_mm;
  result.actual = zone_mm;
  const auto bonus = material_bonus(spec.condition, feature.nominal, **actual, units, result);
  if (!bonus) return Error(bonus.error());
  add_note(result, fmt::format("the axis (derived median line): the centres of {} section{}{}, within a cylinder of "
                               "diameter {} about a line (minimum zone, ISO 1101){}",
                               centres.size(), centres.size() == 1 ? "" : "s",
                               skipped > 0 ? fmt::format(" ({} with fewer than three points left out)", skipped) : "",
                               length_text(zone_mm, units, 6),
                               centres.size() == 2 ? ": two centres always lie on a line" : ""));
  set_limits(result, 0, spec.zone + *bonus);
  if (spec.unit_zone > 0 || spec.unit_length > 0) {
    // Per unit length: the centres in every stretch of the unit along the axis within a cylinder
    // of diameter tu (no material bonus is added to the unit zone).
    const auto unit = straightness_per_unit_length(centres, sections.axis, std::nullopt, spec.unit_length);
    if (!unit) {
      add_note(result, fmt::format("per unit length {}: not evaluated, no stretch of it holds three section centres",
                                   length_text(spec.unit_length, units, 4)));
    } else {
      const bool unit_in = unit->form_mm <= spec.unit_zone + k_limit_slack;
      result.in_tolerance = result.in_tolerance && unit_in;
      add_note(result, fmt::format("per unit length {}: the largest minimum zone of the centres {} (zone {}, {})",
                                   length_text(spec.unit_length, units, 4), length_text(unit->form_mm, units, 6),
                                   length_text(spec.unit_zone, units, 6), unit_in ? "IN" : "OUT"));
    }
  }
  return result;
}

// CIRLTY of a CYLNDR or CONE: ISO 1101 roundness holds in every section normal to the axis, so
// the value is the largest of the sections' minimum-zone roundness (concentric circles in the
// plane normal to the least-squares axis; the points grouped into sections as sections_by_height
// groups them; a section of fewer than four points cannot show any and is left out).
Outcome evaluate_section_roundness(const ToleranceSpec& spec, const Feature& feature, const ReportUnits& units,
                                   ToleranceResult result) {
  const auto actual = actual_of(feature);
  if (!actual) return Error(actual.error());
  const Sections sections = sections_of(feature, **actual);
  double worst = -1, worst_height = 0;
  std::size_t judged = 0;
  for (const auto& section : sections.rings) {
    if (section.size() < 4) continue;
    std::vector<Vec3> ring;
    double height = 0;
    for (const std::size_t i : section) {
      ring.push_back(sections.surface[i]);
      height += sections.heights[i] / static_cast<double>(section.size());
    }
    const auto mz = fitting::minimum_zone(fitting::Shape::Circle, ring, sections.axis);
    if (!mz) continue;
    ++judged;
    if (mz->form_mm > worst) {
      worst = mz->form_mm;
      worst_height = height;
    }
  }
  if (judged == 0)
    return Error(
        fmt::format("feature {} has no section of four points or more (points at one height along its "
                    "axis): CIRLTY of a {} is the roundness of its sections",
                    feature.label, dmis_word(feature.nominal.type)));
  result.value = worst;
  result.actual = worst;
  add_note(result, fmt::format("the largest minimum-zone roundness (ISO 1101) of {} section{} normal to the axis, {} "
                               "along it from the feature's centre",
                               judged, judged == 1 ? "" : "s", length_text(worst_height, units, 3)));
  set_limits(result, 0, spec.zone);
  return result;
}

Outcome evaluate_form(const ToleranceSpec& spec, const Feature& feature, const ToleranceContext& context,
                      ToleranceResult result) {
  const ReportUnits& units = context.units;
  static constexpr Types k_flat = {FeatureType::Plane};
  // A SPHERE's circularity (ASME Y14.5: the points of every plane through a common centre
  // equidistant from it) is its minimum-zone sphericity: any two points lie in one plane through
  // the centre, so the worst section's radial range is the whole surface's about that centre.
  static constexpr Types k_round = {FeatureType::Circle, FeatureType::Arc, FeatureType::Sphere};
  static constexpr Types k_cylinder = {FeatureType::Cylinder};
  static constexpr Types k_sphere = {FeatureType::Sphere};
  static constexpr Types k_line = {FeatureType::Line};
  const Types types = spec.kind == ToleranceKind::Cirlty   ? k_round
                      : spec.kind == ToleranceKind::Cylcty ? k_cylinder
                      : spec.kind == ToleranceKind::Sphcty ? k_sphere
                      : spec.kind == ToleranceKind::Strght ? k_line
                                                           : k_flat;
  if (spec.kind == ToleranceKind::Strght && feature.nominal.type == FeatureType::Cylinder)
    return evaluate_axis_straightness(spec, feature, context.units, std::move(result));
  if (spec.kind == ToleranceKind::Cirlty &&
      (feature.nominal.type == FeatureType::Cylinder || feature.nominal.type == FeatureType::Cone))
    return evaluate_section_roundness(spec, feature, context.units, std::move(result));
  if (!is_one_of(feature.nominal.type, types)) return wrong_type(spec.kind, types, feature.nominal.type);
  const auto actual = actual_of(feature);
  if (!actual) return Error(actual.error());
  if (!feature.fit)
    return Error(
        fmt::format("feature {} has no fit: {} needs the form of measured points, and it was "
                    "constructed without any",
                    feature.label, dmis_word(spec.kind)));
  // ISO 1101 defines form by the minimum zone; the least-squares form stays in the note.
  result.value = feature.fit->form_mm;
  const auto shape = feature.nominal.type == FeatureType::Plane      ? fitting::Shape::Plane
                     : feature.nominal.type == FeatureType::Cylinder ? fitting::Shape::Cylinder
                     : feature.nominal.type == FeatureType::Sphere   ? fitting::Shape::Sphere
                     : feature.nominal.type == FeatureType::Line     ? fitting::Shape::Line
                                                                     : fitting::Shape::Circle;
  std::vector<Vec3> surface;
  for (const auto& p : feature.points) surface.push_back(p.surface_mm());
  std::optional<Vec3> plane = shape == fitting::Shape::Line     ? std::optional<Vec3>(feature.nominal.normal2)
                              : shape == fitting::Shape::Circle ? std::optional<Vec3>(feature.nominal.direction)
                                                                : std::nullopt;
  if (plane && !(plane->norm() > 1e-12)) plane.reset();
  const auto mz = surface.empty() ? tl::unexpected(fitting::FitFailure::TooFewPoints)
                                  : fitting::minimum_zone(shape, surface, plane);
  if (mz && mz->form_mm <= feature.fit->form_mm + 1e-9) {
    result.value = mz->form_mm;
    add_note(result, fmt::format("minimum zone (ISO 1101) over {} points; least squares gives {}", surface.size(),
                                 length_text(feature.fit->form_mm, units, 6)));
    if (spec.kind == ToleranceKind::Cirlty && shape == fitting::Shape::Sphere)
      add_note(result,
               "a sphere's circularity: every section through the minimum-zone centre, which is its sphericity");
  } else {
    add_note(result, "least-squares form (no minimum zone for these points)");
  }
  result.actual = result.value;
  set_limits(result, 0, spec.zone);
  if (spec.unit_zone > 0 || spec.unit_length > 0) {
    // Per unit area (length): a second zone every unit of the feature must meet; the result stays
    // the whole feature's form, and is out of tolerance when either zone is exceeded.
    const bool flat = spec.kind == ToleranceKind::Flat;
    const Frame frame = context.alignment ? context.alignment->part_to_machine : Frame::Identity();
    const Vec3 x = frame.linear().col(0), y = frame.linear().col(1);
    const Vec3 normal = actual.value()->direction.normalized();
    const Vec3 length_axis = std::abs(x.dot(normal)) < std::cos(30 * std::numbers::pi / 180) ? x : y;
    const auto unit = flat ? flatness_per_unit_area(surface, normal, length_axis, spec.unit_length, spec.unit_width)
                           : straightness_per_unit_length(surface, actual.value()->direction, plane, spec.unit_length);
    const std::string area = flat ? fmt::format("per unit area {} x {}", length_text(spec.unit_length, units, 4),
                                                length_text(spec.unit_width, units, 4))
                                  : fmt::format("per unit length {}", length_text(spec.unit_length, units, 4));
    if (!unit) {
      // Three points always lie in a plane: the points say nothing against the zone per unit,
      // and nothing for it either; the result is the whole feature's, and the note says why.
      add_note(result, fmt::format("{}: not evaluated, no unit holds {} of the measured points (they lie farther "
                                   "apart than a unit: measure them closer to judge it)",
                                   area, flat ? "four" : "three"));
    } else {
      const bool unit_in = unit->form_mm <= spec.unit_zone + k_limit_slack;
      const Vec3 at = frame.inverse() * unit->centre;  // in the reporting frame
      result.in_tolerance = result.in_tolerance && unit_in;
      add_note(result,
               fmt::format("{}: the largest minimum zone {} (zone {}, {}), about ({}, {}, {}); {} distinct unit{}, {} "
                           "judged by their minimum zone (the others' least-squares form is below it){}",
                           area, length_text(unit->form_mm, units, 6), length_text(spec.unit_zone, units, 6),
                           unit_in ? "IN" : "OUT", length_text(at.x(), units, 3), length_text(at.y(), units, 3),
                           length_text(at.z(), units, 3), unit->units, unit->units == 1 ? "" : "s", unit->judged,
                           unit->sampled ? "; the units' corners sampled: more points than the search takes" : ""));
    }
  }
  return result;
}

// ---------------------------------------------------------------- datums and orientation

struct Reference {
  Vec3 direction;      ///< unit: plane normal or axis direction
  bool plane = false;  ///< a plane (direction = normal), else an axis
  std::string name;    ///< "datum A" or "F2", for notes
};

tl::expected<Reference, std::string> reference_of(const Geometry& g, const std::string& name, ToleranceKind kind) {
  static constexpr Types k_types = {FeatureType::Plane,         FeatureType::Line,   FeatureType::Cylinder,
                                    FeatureType::Cone,          FeatureType::Circle, FeatureType::Arc,
                                    FeatureType::ParallelPlanes};
  if (!is_one_of(g.type, k_types))
    return Error(fmt::format("{} is {} {}: it has no direction to measure {} against", name, article(dmis_word(g.type)),
                             dmis_word(g.type), dmis_word(kind)));
  const auto d = unit(g.direction, name);
  if (!d) return Error(d.error());
  // A PARPLN orients like its median plane.
  return Reference{*d, g.type == FeatureType::Plane || g.type == FeatureType::ParallelPlanes, name};
}

tl::expected<Reference, std::string> primary_datum(const ToleranceSpec& spec, const ToleranceContext& context) {
  const char* word = dmis_word(spec.kind);
  if (spec.datums.empty() && context.datums.empty())
    return Error(fmt::format("{} needs a datum: TOL/{},...,DAT(A)", word, word));
  const Datum* datum = context.datums.empty() ? nullptr : context.datums.front();
  if (!datum) {
    const std::string& label = spec.datums.front();
    return Error(fmt::format("datum {} is not defined: DATDEF/FA(feature),DAT({}) first", label, label));
  }
  return reference_of(datum->geometry, "datum " + datum->label, spec.kind);
}

std::string join_datums(const ToleranceSpec& spec) {
  std::string out;
  for (const auto& d : spec.datums) out += (out.empty() ? "" : "|") + d;
  return out;
}

std::string secondary_datum_note(const ToleranceSpec& spec) {
  if (spec.datums.size() < 2) return {};
  return fmt::format("only the primary datum {} orients the zone", spec.datums.front());
}

/// The length of an axis for orientation zones: the actual length, else the extent of the
/// measured points along the axis, else the nominal length.
double axis_length_mm(const Feature& feature, const Geometry& actual, const Vec3& axis) {
  if (actual.length_mm > 0) return actual.length_mm;
  if (feature.points.size() >= 2) {
    double lo = std::numeric_limits<double>::infinity();
    double hi = -lo;
    for (const MeasuredPoint& p : feature.points) {
      const double h = p.surface_mm().dot(axis);
      lo = std::min(lo, h);
      hi = std::max(hi, h);
    }
    if (hi - lo > 0) return hi - lo;
  }
  return feature.nominal.length_mm;
}

/// The angle (degrees, 0..90) the feature's direction (a plane's normal, an axis) must make
/// with the datum's (a plane's normal, an axis). PERP and PARLEL: 90 or 0. ANGLR: the basic angle
/// is the drawing's, between the elements themselves (ASME Y14.5 angularity: a surface, median
/// plane or axis at the basic angle to the datum), which between a plane and an axis is the
/// complement of the normal's; an obtuse basic angle is the same lines' acute one.
double tolerated_direction_angle_deg(const ToleranceSpec& spec, bool feature_plane, bool datum_plane) {
  const bool same = feature_plane == datum_plane;
  switch (spec.kind) {
    case ToleranceKind::Perp: return same ? 90.0 : 0.0;
    case ToleranceKind::Parlel: return same ? 0.0 : 90.0;
    default: {
      double basic = std::fmod(std::abs(spec.nominal), 180.0);
      basic = std::min(basic, 180.0 - basic);
      return same ? basic : 90.0 - basic;
    }
  }
}

/// The direction at `angle_deg` from `d` in the half-plane of d and `toward` (its part across d
/// and the sense of its part along d): the tolerated direction nearest `toward`. Empty when
/// `toward` runs along d and the angle is not 0.
std::optional<Vec3> tilted_toward(const Vec3& d, const Vec3& toward, double angle_deg) {
  const double along = toward.dot(d);
  const Vec3 across = toward - along * d;
  const double sense = along < 0 ? -1.0 : 1.0;
  if (angle_deg <= 0) return sense * d;
  if (across.norm() < 1e-9) return std::nullopt;
  if (angle_deg >= 90) return Vec3(across.normalized());
  const double a = to_rad(angle_deg);
  return Vec3(std::cos(a) * sense * d + std::sin(a) * across.normalized());
}

Outcome evaluate_orientation(const ToleranceSpec& spec, const Feature& feature, const ToleranceContext& context,
                             ToleranceResult result) {
  static constexpr Types k_types = {FeatureType::Plane,         FeatureType::Line,       FeatureType::Cylinder,
                                    FeatureType::Cone,          FeatureType::ClosedSlot,  // a CPARLN: its long axis
                                    FeatureType::ParallelPlanes};                         // a PARPLN: its median plane
  if (!is_one_of(feature.nominal.type, k_types)) return wrong_type(spec.kind, k_types, feature.nominal.type);
  const auto actual_or = actual_of(feature);
  if (!actual_or) return Error(actual_or.error());
  const Geometry& actual = **actual_or;
  const auto datum = primary_datum(spec, context);
  if (!datum) return Error(datum.error());
  const Vec3& d = datum->direction;
  const auto own = unit(oriented_direction(actual), "the actual of " + feature.label);
  if (!own) return Error(own.error());
  const bool angularity = spec.kind == ToleranceKind::Anglr;
  // MMC or LMC of a feature of size (a bore's or pin's axis, a width's median plane): the zone
  // grows by the size's departure from that condition (ASME Y14.5 bonus tolerance, as POS's).
  const auto bonus = sized_bonus(spec, feature, actual, context.units, result);
  if (!bonus) return Error(bonus.error());
  const double bonus_mm = *bonus;
  const bool feature_plane =
      feature.nominal.type == FeatureType::Plane || feature.nominal.type == FeatureType::ParallelPlanes;
  const double tolerated_deg = tolerated_direction_angle_deg(spec, feature_plane, datum->plane);
  // The elements' angle as the drawing states it (ANGLR's note): between a plane and an axis the
  // complement of the normal's.
  const auto drawn_angle = [&](const Vec3& v) {
    const double a = line_angle_deg(v, d);
    return feature_plane == datum->plane ? a : 90.0 - a;
  };
  // The tolerated direction nearest the feature's own, else its nominal's (an actual along d
  // leaves the rotation about d to the drawing).
  const auto tolerated_near_feature = [&]() {
    const auto near_own = tilted_toward(d, *own, tolerated_deg);
    return near_own ? near_own : tilted_toward(d, feature.nominal.direction, tolerated_deg);
  };
  const auto basic_note = [&](const Vec3& v) {
    return fmt::format("the {} at {:.4f} deg to {}, basic {:g} deg", feature_plane ? "plane" : "axis", drawn_angle(v),
                       datum->name, spec.nominal);
  };

  if (feature_plane) {
    if (feature.points.empty())
      return Error(
          fmt::format("{} of plane {} needs its measured points: it has none", dmis_word(spec.kind), feature.label));
    // A PARPLN's derived median plane (derived_median_points).
    std::vector<Vec3> surface;
    for (const MeasuredPoint& p : feature.points) surface.push_back(p.surface_mm());
    if (feature.nominal.type == FeatureType::ParallelPlanes)
      surface = derived_median_points(surface, actual.position, *own);
    // Zone: two planes of the tolerated orientation. Their normal is at the tolerated angle to
    // the reference direction; the rotation about it that leaves free is the plane's own (the
    // most favourable) unless a secondary datum fixes it.
    std::optional<Vec3> zone_normal;
    bool oriented_by_secondary = false;
    if (tolerated_deg > 0 && spec.datums.size() >= 2) {
      // A secondary datum fixes the rotation the primary leaves free: the zone's normal is the
      // plane's nominal normal in the datum reference frame (ASME Y14.5 6.3), brought to the
      // tolerated angle to the primary datum.
      const auto frame = frame_of_datums(spec, feature, context);
      if (!frame) return Error(frame.error());
      if (frame->rotations_fixed == 3) {
        const Vec3 n = frame->actual_to_nominal.linear().transpose() * feature.nominal.direction.normalized();
        zone_normal = tilted_toward(d, n, tolerated_deg);
        oriented_by_secondary = zone_normal.has_value();
      }
    }
    if (!zone_normal) zone_normal = tolerated_near_feature();
    if (!zone_normal)
      return Error(
          fmt::format("{} of {}: the plane is parallel to {}, so the zone orientation is "
                      "undefined",
                      dmis_word(spec.kind), feature.label, datum->name));
    double lo = std::numeric_limits<double>::infinity();
    double hi = -lo;
    for (const Vec3& q : surface) {
      const double h = q.dot(*zone_normal);
      lo = std::min(lo, h);
      hi = std::max(hi, h);
    }
    result.value = hi - lo;
    add_note(result, fmt::format("normal of {}{} at {:.4f} deg to {} ({})", feature.label,
                                 feature.nominal.type == FeatureType::ParallelPlanes ? "'s median plane" : "",
                                 line_angle_deg(*own, d), datum->name, datum->plane ? "normal" : "axis"));
    if (angularity) add_note(result, basic_note(*own));
    if (oriented_by_secondary) {
      add_note(result, fmt::format("zone oriented by datums {}: its normal at {:.4f} deg to the plane's",
                                   join_datums(spec), line_angle_deg(*own, *zone_normal)));
      set_limits(result, 0, spec.zone + bonus_mm);
      result.actual = result.value;
      return result;
    }
  } else {
    const double length_mm = axis_length_mm(feature, actual, *own);
    if (!(length_mm > 0))
      return Error(fmt::format("{} of {}: the axis has no length and no points to take it from", dmis_word(spec.kind),
                               feature.label));
    // The axis should run at the tolerated angle to d: along d (PERP to a plane, PARLEL to an
    // axis) a cylindrical zone whose diameter is the axis's sideways excursion; otherwise two
    // planes holding the tolerated direction, square to the plane of d and the axis. Either way
    // the axis's excursion over its length is L sin of its angle to the tolerated direction
    // nearest it.
    const std::optional<Vec3> tolerated = tolerated_near_feature();
    if (!tolerated)
      return Error(
          fmt::format("{} of {}: the axis runs along {} and so does its nominal: the zone orientation is "
                      "undefined",
                      dmis_word(spec.kind), feature.label, datum->name));
    const bool along = tolerated_deg <= 0;
    result.value = length_mm * own->cross(*tolerated).norm();
    add_note(result, fmt::format("axis of {} at {:.4f} deg to {} ({}), over {:.4f} mm ({} zone)", feature.label,
                                 line_angle_deg(*own, d), datum->name, datum->plane ? "normal" : "axis", length_mm,
                                 along ? "diametral" : "two-plane"));
    if (angularity) add_note(result, basic_note(*own));
    // Between 0 and 90 deg the rotation about d of the two-plane zone is free to the primary datum
    // alone; a secondary fixes it (ASME Y14.5 angularity oriented by two datums): the zone's planes
    // hold the nominal axis of the datum reference frame, brought to the basic angle, and the
    // direction square to d and it; only the axis's tilt toward or away from d counts.
    if (tolerated_deg > 0 && tolerated_deg < 90 && spec.datums.size() >= 2) {
      const auto frame = frame_of_datums(spec, feature, context);
      if (!frame) return Error(frame.error());
      if (frame->rotations_fixed == 3) {
        const Vec3 n = frame->actual_to_nominal.linear().transpose() * feature.nominal.direction.normalized();
        const auto drawn = tilted_toward(d, n, tolerated_deg);
        if (drawn) {
          const Vec3 zone_normal = (d - d.dot(*drawn) * *drawn).normalized();
          result.value = length_mm * std::abs(own->dot(zone_normal));
          add_note(result, fmt::format("zone oriented by datums {}: the axis at {:.4f} deg to the drawn direction",
                                       join_datums(spec), line_angle_deg(*own, *drawn)));
          result.actual = result.value;
          set_limits(result, 0, spec.zone + bonus_mm);
          return result;
        }
      }
    }
  }
  result.actual = result.value;
  set_limits(result, 0, spec.zone + bonus_mm);
  add_note(result, secondary_datum_note(spec));
  return result;
}

Outcome evaluate_anglb(const ToleranceSpec& spec, const std::vector<const Feature*>& features,
                       const ToleranceContext& context, ToleranceResult result) {
  static constexpr Types k_types = {FeatureType::Plane,         FeatureType::Line,   FeatureType::Cylinder,
                                    FeatureType::Cone,          FeatureType::Circle, FeatureType::Arc,
                                    FeatureType::ClosedSlot,       // a CPARLN: its long axis
                                    FeatureType::ParallelPlanes};  // a PARPLN: its median plane's normal
  const Feature& feature = *features.front();
  if (!is_one_of(feature.nominal.type, k_types)) return wrong_type(spec.kind, k_types, feature.nominal.type);
  const auto actual = actual_of(feature);
  if (!actual) return Error(actual.error());
  const auto own = unit(oriented_direction(**actual), "the actual of " + feature.label);
  if (!own) return Error(own.error());

  tl::expected<Reference, std::string> reference = Error("");
  if (features.size() == 2) {
    const Feature& other = *features[1];
    if (!is_one_of(other.nominal.type, k_types)) return wrong_type(spec.kind, k_types, other.nominal.type);
    const auto other_actual = actual_of(other);
    if (!other_actual) return Error(other_actual.error());
    reference = reference_of(**other_actual, other.label, spec.kind);
  } else {
    reference = primary_datum(spec, context);
  }
  if (!reference) return Error(reference.error());

  // Lines and planes have no sense along their direction: fold to 0..90, and report the
  // supplement when the nominal is obtuse so the two compare.
  double angle = angle_deg(*own, reference->direction);
  angle = std::min(angle, 180.0 - angle);
  if (spec.nominal > 90.0) angle = 180.0 - angle;
  result.actual = angle;
  result.nominal = spec.nominal;
  result.value = angle - spec.nominal;
  set_limits(result, spec.lower, spec.upper);
  add_note(result,
           fmt::format("angle between the {} of {} and the {} of {}",
                       feature.nominal.type == FeatureType::Plane || feature.nominal.type == FeatureType::ParallelPlanes
                           ? "normal"
                           : "axis",
                       feature.label, reference->plane ? "normal" : "axis", reference->name));
  if (features.size() == 1) add_note(result, secondary_datum_note(spec));
  return result;
}

// ---------------------------------------------------------------- PROFS

/// Signed distance of a surface point from the nominal surface, + outside the material.
double profile_deviation(const Geometry& nominal, const Vec3& s) {
  const Vec3 n = nominal.direction.normalized();
  const Vec3 v = s - nominal.position;
  const double radius_mm = 0.5 * nominal.diameter_mm;
  double outward = 0;  // + away from the centre/axis (for a plane: along its normal)
  switch (nominal.type) {
    case FeatureType::Plane:
    case FeatureType::Point: return n.dot(v);  // a point: along its nominal normal
    case FeatureType::Line: {
      // In the line's working plane (normal2), across the line: + on the side of n2 x direction.
      const Vec3 across = nominal.normal2.cross(n).normalized();
      return across.dot(v);
    }
    case FeatureType::Sphere: outward = v.norm() - radius_mm; break;
    case FeatureType::Circle:
    case FeatureType::Arc:
    case FeatureType::Cylinder: outward = (v - v.dot(n) * n).norm() - radius_mm; break;
    case FeatureType::Cone: {
      // Orthogonal distance to the nappe: rho cos(a/2) - h sin(a/2) (h along the axis from the apex).
      const double half = 0.5 * nominal.apex_angle_deg * k_pi / 180.0;
      const double h = v.dot(n);
      const double rho = (v - h * n).norm();
      outward = rho * std::cos(half) - std::abs(h) * std::sin(half);
      break;
    }
    case FeatureType::Torus: {
      // From the centre circle, less the tube's radius (+ away from the tube's centre).
      const double h = v.dot(n);
      outward = std::hypot((v - h * n).norm() - radius_mm, h) - 0.5 * nominal.minor_diameter_mm;
      break;
    }
    case FeatureType::Ellipse: {
      // In the ellipse's plane (the point projected along its normal): the exact distance from
      // the nominal ellipse, + outside it.
      const Vec3 major = (nominal.slot_axis - nominal.slot_axis.dot(n) * n).normalized();
      outward =
          geometry::ellipse_foot(radius_mm, 0.5 * nominal.minor_diameter_mm, {v.dot(major), v.dot(n.cross(major))})
              .signed_distance;
      break;
    }
    default: break;
  }
  // Outside the material of a bore is toward its axis.
  return nominal.side == Side::Inner ? -outward : outward;
}

Outcome evaluate_profs(const ToleranceSpec& spec, const Feature& feature, const ToleranceContext& context,
                       ToleranceResult result) {
  static constexpr Types k_surfaces = {FeatureType::Plane,          FeatureType::Circle,   FeatureType::Arc,
                                       FeatureType::Sphere,         FeatureType::Cylinder, FeatureType::Cone,
                                       FeatureType::GenericSurface, FeatureType::Torus,    FeatureType::Ellipse};
  static constexpr Types k_lines = {FeatureType::Line, FeatureType::Circle, FeatureType::Arc, FeatureType::GenericCurve,
                                    FeatureType::Ellipse};
  static constexpr Types k_points = {FeatureType::Point};
  const Types types = spec.kind == ToleranceKind::Profl   ? k_lines
                      : spec.kind == ToleranceKind::Profp ? k_points
                                                          : k_surfaces;
  if (!is_one_of(feature.nominal.type, types)) return wrong_type(spec.kind, types, feature.nominal.type);
  const auto actual = actual_of(feature);
  if (!actual) return Error(actual.error());
  // A point's profile is its own position when it has no probed point (a constructed point).
  std::vector<MeasuredPoint> own;
  if (spec.kind == ToleranceKind::Profp && feature.points.empty()) {
    MeasuredPoint p;
    p.centre_mm = (*actual)->position;
    own.push_back(p);
  }
  const std::vector<MeasuredPoint>& points = own.empty() ? feature.points : own;
  if (points.empty())
    return Error(fmt::format("{} of {} needs measured points: it has none", dmis_word(spec.kind), feature.label));
  const auto frame = frame_of_datums(spec, feature, context);
  if (!frame) return Error(frame.error());
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  for (const MeasuredPoint& p : points) {
    const Vec3 s = frame->actual_to_nominal * p.surface_mm();
    // A GSURF's or GCURVE's point: along its own nominal normal from its own nominal.
    if (is_point_set(feature.nominal.type) && !p.nominal_mm)
      return Error(fmt::format("{} of {}: a point has no nominal (a {} is measured by PTMEAS points)",
                               dmis_word(spec.kind), feature.label, dmis_word(feature.nominal.type)));
    const double dev = is_point_set(feature.nominal.type) ? (s - *p.nominal_mm).dot(p.nominal_normal)
                                                          : profile_deviation(feature.nominal, s);
    lo = std::min(lo, dev);
    hi = std::max(hi, dev);
  }
  result.value = std::abs(lo) > std::abs(hi) ? lo : hi;
  result.actual = result.value;
  result.lower = spec.lower;
  result.upper = spec.upper;
  result.in_tolerance = lo >= spec.lower - k_limit_slack && hi <= spec.upper + k_limit_slack;
  add_note(result, fmt::format("deviations from the nominal {}: min {:+.4f}, max {:+.4f} over {} point{}",
                               spec.kind == ToleranceKind::Profs ? "surface" : "profile", lo, hi, points.size(),
                               points.size() == 1 ? "" : "s"));
  if (feature.nominal.type != FeatureType::Plane && feature.nominal.type != FeatureType::Line &&
      feature.nominal.type != FeatureType::Point && !is_point_set(feature.nominal.type) &&
      feature.nominal.side == Side::None)
    add_note(result, "side unknown: treated as OUTER");
  add_note(result, datum_frame_note(*frame, (*actual)->position));
  return result;
}

bool needs_two(ToleranceKind kind) {
  return kind == ToleranceKind::DistB || kind == ToleranceKind::DistWrt || kind == ToleranceKind::AngWrt;
}

// ---------------------------------------------------------------- CORTOL

// T(l)=TOL/CORTOL,XAXIS|YAXIS|ZAXIS,lo,hi: the deviation of one coordinate of the feature's
// position from its nominal, in the current coordinate system (DMIS 5.3 6.163 CORTOL).
// CORTOL,RADIUS|ANGLE: the feature's position in polar coordinates of the working plane (WKPLAN)
// of the current alignment: the radius from the origin in that plane and the angle from its first
// axis toward its second (XYPLAN: from X toward Y, as PTMEAS/POL's angle; YZPLAN: from Y toward
// Z; ZXPLAN: from Z toward X). The angle's deviation is taken the short way round.
Outcome evaluate_polar_cortol(const ToleranceSpec& spec, const Feature& feature, const Geometry& actual,
                              const Alignment& frame, const ToleranceContext& context, ToleranceResult result) {
  const auto in_plane = [&](const Vec3& machine_point) {
    const Vec3 p = frame.to_part_point(machine_point);
    switch (context.working_plane) {
      case WorkingPlane::XY: return Vec2(p.x(), p.y());
      case WorkingPlane::YZ: return Vec2(p.y(), p.z());
      case WorkingPlane::ZX: return Vec2(p.z(), p.x());
    }
    return Vec2(p.x(), p.y());
  };
  const Vec2 a = in_plane(actual.position);
  const Vec2 n = in_plane(feature.nominal.position);
  const char* plane = context.working_plane == WorkingPlane::XY   ? "XYPLAN"
                      : context.working_plane == WorkingPlane::YZ ? "YZPLAN"
                                                                  : "ZXPLAN";
  if (spec.polar == PolarCoordinate::Radius) {
    result.actual = a.norm();
    result.nominal = n.norm();
    result.value = result.actual - result.nominal;
    add_note(result, fmt::format("polar radius in {} of {}", plane, frame.label));
  } else {
    if (a.norm() < 1e-9 || n.norm() < 1e-9)
      return Error(
          fmt::format("CORTOL,ANGLE of {}: its {} position is at the origin of {} in {}, where the polar "
                      "angle is undefined",
                      feature.label, a.norm() < 1e-9 ? "actual" : "nominal", frame.label, plane));
    constexpr double deg = 180.0 / std::numbers::pi;
    result.actual = std::atan2(a.y(), a.x()) * deg;
    result.nominal = std::atan2(n.y(), n.x()) * deg;
    result.value = std::remainder(result.actual - result.nominal, 360.0);
    result.angle_value = true;
    add_note(result, fmt::format("polar angle in {} of {}", plane, frame.label));
  }
  set_limits(result, spec.lower, spec.upper);
  return result;
}

Outcome evaluate_cortol(const ToleranceSpec& spec, const Feature& feature, const ToleranceContext& context,
                        ToleranceResult result) {
  const auto actual = actual_of(feature);
  if (!actual) return Error(actual.error());
  const Alignment mcs;
  const Alignment& frame = context.alignment ? *context.alignment : mcs;
  if (spec.polar != PolarCoordinate::None)
    return evaluate_polar_cortol(spec, feature, **actual, frame, context, std::move(result));
  if (spec.axis == DistanceAxis::PointToPoint) return Error("CORTOL needs the coordinate: XAXIS, YAXIS or ZAXIS");
  const int k = spec.axis == DistanceAxis::XAxis ? 0 : spec.axis == DistanceAxis::YAxis ? 1 : 2;
  const double a = frame.to_part_point((*actual)->position)[k];
  const double n = frame.to_part_point(feature.nominal.position)[k];
  result.actual = a;
  result.nominal = n;
  result.value = a - n;
  set_limits(result, spec.lower, spec.upper);
  add_note(result, fmt::format("{} coordinate in {}", axis_word(spec.axis), frame.label));
  return result;
}

// ---------------------------------------------------------------- CONCEN, COAXIAL, runout

/// The datum axis of a coaxiality or runout tolerance (ISO 5459 common datums, ASME Y14.5 4.12):
/// one axis datum (line, circle, arc, cylinder, cone) is its axis; two axis datums A-B are the
/// common axis through their centres; a plane then an axis is the axis through the second's
/// centre along the plane's normal; a sphere or point alone is a datum point.
struct DatumAxis {
  Vec3 point = Vec3::Zero();
  Vec3 direction = Vec3::UnitZ();
  bool is_point = false;  ///< a datum point (sphere, point): distances are to it
  std::string name;
};

bool is_axis_type(FeatureType t) {
  return t == FeatureType::Line || t == FeatureType::Circle || t == FeatureType::Arc || t == FeatureType::Cylinder ||
         t == FeatureType::Cone;
}

tl::expected<DatumAxis, std::string> datum_axis(const ToleranceSpec& spec, const ToleranceContext& context) {
  const char* word = dmis_word(spec.kind);
  if (spec.datums.empty()) return Error(fmt::format("{} needs a datum axis: TOL/{},zone,DAT(A)", word, word));
  for (std::size_t i = 0; i < spec.datums.size(); ++i)
    if (i >= context.datums.size() || !context.datums[i])
      return Error(
          fmt::format("datum {} is not defined: DATDEF/FA(feature),DAT({}) first", spec.datums[i], spec.datums[i]));
  const Geometry& first = context.datums[0]->geometry;
  DatumAxis axis;
  axis.name = "datum " + spec.datums[0];
  if (first.type == FeatureType::Sphere || first.type == FeatureType::Point) {
    axis.point = first.position;
    axis.is_point = true;
    return axis;
  }
  const auto d = unit(first.direction, axis.name);
  if (!d) return Error(d.error());
  axis.point = first.position;
  axis.direction = *d;
  if (context.datums.size() >= 2) {
    const Geometry& second = context.datums[1]->geometry;
    const std::string common = "common datum axis " + spec.datums[0] + "-" + spec.datums[1];
    if (is_axis_type(first.type) && is_axis_type(second.type)) {
      const Vec3 span = second.position - first.position;
      if (std::abs(span.dot(*d)) > 1.0) {  // centres at least 1 mm apart along the axis
        axis.direction = (span.dot(*d) > 0 ? span : Vec3(-span)).normalized();
        axis.name = common;
      }
    } else if (first.type == FeatureType::Plane && is_axis_type(second.type)) {
      axis.point = second.position;
      axis.name = "the axis of datum " + spec.datums[1] + " normal to datum " + spec.datums[0];
      return axis;
    }
  }
  if (first.type == FeatureType::Plane)
    return Error(
        fmt::format("{} is a PLANE: {} needs a datum axis (a cylinder, circle, cone or line)", axis.name, word));
  return axis;
}

double distance_from(const DatumAxis& axis, const Vec3& p) {
  const Vec3 v = p - axis.point;
  return axis.is_point ? v.norm() : (v - v.dot(axis.direction) * axis.direction).norm();
}

// CONCEN (ISO 1101 18.13.1, concentricity of a point): the centre of a circle, arc or sphere
// within a circle (sphere about a datum point) of diameter t about the datum axis:
//     value = 2 * distance(centre, datum axis)
// COAXIAL (ISO 1101 18.13.2): the feature's axis within a cylinder of diameter t about the datum
// axis. The distance from a line to a straight segment is largest at an end, so
//     value = 2 * max(distance(e1), distance(e2)),
// e1, e2 the ends of the actual axis over the extent of its points along it (else its length).
Outcome evaluate_coaxiality(const ToleranceSpec& spec, const Feature& feature, const ToleranceContext& context,
                            ToleranceResult result) {
  static constexpr Types k_axes = {FeatureType::Cylinder, FeatureType::Cone, FeatureType::Line};
  static constexpr Types k_all = {FeatureType::Circle,   FeatureType::Arc,  FeatureType::Sphere, FeatureType::Point,
                                  FeatureType::Cylinder, FeatureType::Cone, FeatureType::Line};
  if (!is_one_of(feature.nominal.type, k_all)) return wrong_type(spec.kind, k_all, feature.nominal.type);
  const auto actual = actual_of(feature);
  if (!actual) return Error(actual.error());
  const auto axis = datum_axis(spec, context);
  if (!axis) return Error(axis.error());
  const Geometry& g = **actual;
  double largest_mm = distance_from(*axis, g.position);
  if (is_one_of(g.type, k_axes)) {
    const auto a = unit(g.direction, "the actual of " + feature.label);
    if (!a) return Error(a.error());
    double lo = -0.5 * g.length_mm;
    double hi = 0.5 * g.length_mm;
    if (!feature.points.empty()) {
      lo = std::numeric_limits<double>::infinity();
      hi = -lo;
      for (const MeasuredPoint& p : feature.points) {
        const double t = (p.surface_mm() - g.position).dot(*a);
        lo = std::min(lo, t);
        hi = std::max(hi, t);
      }
    }
    largest_mm = std::max(distance_from(*axis, g.position + lo * *a), distance_from(*axis, g.position + hi * *a));
    add_note(result, fmt::format("axis of {} over {:.3f} mm, to {}", feature.label, hi - lo, axis->name));
    if (spec.kind == ToleranceKind::Concen)
      add_note(result, fmt::format("CONCEN of {} {} is evaluated as its coaxiality", article(dmis_word(g.type)),
                                   dmis_word(g.type)));
  } else {
    add_note(result, fmt::format("centre of {} to {}", feature.label, axis->name));
  }
  result.value = 2.0 * largest_mm;
  result.actual = result.value;
  result.nominal = 0;
  // Coaxiality at MMC or LMC (ISO 1101 with ISO 2692): a feature of size's zone grows by its
  // departure from that size, as POS's.
  const auto bonus = sized_bonus(spec, feature, g, context.units, result);
  if (!bonus) return Error(bonus.error());
  const double bonus_mm = *bonus;
  set_limits(result, 0, spec.zone + bonus_mm);
  return result;
}

/// Sections of a runout: groups of values (axial positions of the points for a radial runout,
/// radii for an axial one) closer than 0.5 mm to their neighbours. Returns one index list a group.
std::vector<std::vector<std::size_t>> sections(const std::vector<double>& keys) {
  std::vector<std::size_t> order(keys.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return keys[a] < keys[b]; });
  std::vector<std::vector<std::size_t>> groups;
  for (std::size_t k = 0; k < order.size(); ++k) {
    if (k == 0 || keys[order[k]] - keys[order[k - 1]] > 0.5) groups.emplace_back();
    groups.back().push_back(order[k]);
  }
  return groups;
}

// Runout about the datum axis (ISO 1101 18.16, 18.17), from the measured surface points:
//   radial (circle, arc, cylinder, cone, sphere): r_k = distance of point k from the datum axis;
//   axial (plane, a face square to the axis): h_k = its position along the datum axis.
// CRNOUT: in each section (points at one axial position, or one radius for a face)
//     value = max over sections of (max r - min r)         (cone: times cos(apex/2), normal to it)
// TOTRUN: the same over all points at once.
Outcome evaluate_runout(const ToleranceSpec& spec, const Feature& feature, const ToleranceContext& context,
                        ToleranceResult result) {
  static constexpr Types k_types = {FeatureType::Circle, FeatureType::Arc,    FeatureType::Cylinder,
                                    FeatureType::Cone,   FeatureType::Sphere, FeatureType::Plane};
  if (!is_one_of(feature.nominal.type, k_types)) return wrong_type(spec.kind, k_types, feature.nominal.type);
  const auto actual = actual_of(feature);
  if (!actual) return Error(actual.error());
  const auto axis = datum_axis(spec, context);
  if (!axis) return Error(axis.error());
  if (axis->is_point)
    return Error(fmt::format("{} is a datum point: {} needs a datum axis", axis->name, dmis_word(spec.kind)));
  if (feature.points.size() < 2)
    return Error(fmt::format("{} of {} needs measured points: it has {}", dmis_word(spec.kind), feature.label,
                             feature.points.size()));
  const bool axial = feature.nominal.type == FeatureType::Plane;
  std::vector<double> measured, keys;
  for (const MeasuredPoint& p : feature.points) {
    const Vec3 s = p.surface_mm();
    const double along = (s - axis->point).dot(axis->direction);
    const double radius = distance_from(*axis, s);
    measured.push_back(axial ? along : radius);
    keys.push_back(axial ? radius : along);
  }
  std::vector<std::vector<std::size_t>> groups;
  if (spec.kind == ToleranceKind::Totrun || feature.nominal.type == FeatureType::Circle ||
      feature.nominal.type == FeatureType::Arc) {
    groups.emplace_back();
    for (std::size_t i = 0; i < measured.size(); ++i) groups.back().push_back(i);
  } else {
    groups = sections(keys);
  }
  double value = 0;
  std::size_t used = 0;
  for (const auto& group : groups) {
    if (group.size() < 2) continue;
    double lo = std::numeric_limits<double>::infinity();
    double hi = -lo;
    for (const std::size_t i : group) {
      lo = std::min(lo, measured[i]);
      hi = std::max(hi, measured[i]);
    }
    value = std::max(value, hi - lo);
    ++used;
  }
  if (used == 0)
    return Error(
        fmt::format("CRNOUT of {}: no section holds two points (points of one section lie within 0.5 mm "
                    "{}); measure circles, or use TOTRUN",
                    feature.label, axial ? "of one radius" : "of one axial position"));
  if (feature.nominal.type == FeatureType::Cone) value *= std::cos(0.5 * feature.nominal.apex_angle_deg * k_pi / 180.0);
  result.value = value;
  result.actual = value;
  result.nominal = 0;
  set_limits(result, 0, spec.zone);
  add_note(result,
           fmt::format("{} runout about {} over {} point{} in {} section{}", axial ? "axial" : "radial", axis->name,
                       measured.size(), measured.size() == 1 ? "" : "s", used, used == 1 ? "" : "s"));
  return result;
}

}  // namespace

// SYMMTY (ISO 1101 18.14, symmetry of a median plane): the derived median surface of a slot or
// tab within two parallel planes t apart, symmetric about the datum's median plane. The median
// point of each measured surface point is that point moved half the actual width toward the
// other face, along the fitted normal (so the faces' form enters as it does on the part); then
//     value = 2 * max |distance(median point, datum plane)|.
// The datum plane is a PARPLN's median plane or a PLANE, taken as measured (both actuals are in
// one system, so the alignment does not matter).
Outcome evaluate_symmetry(const ToleranceSpec& spec, const Feature& feature, const ToleranceContext& context,
                          ToleranceResult result) {
  static constexpr Types k_types = {FeatureType::ParallelPlanes, FeatureType::ClosedSlot};
  if (!is_one_of(feature.nominal.type, k_types)) return wrong_type(spec.kind, k_types, feature.nominal.type);
  const auto actual = actual_of(feature);
  if (!actual) return Error(actual.error());
  const auto datum = primary_datum(spec, context);
  if (!datum) return Error(datum.error());
  if (!datum->plane)
    return Error(
        fmt::format("{} is not a plane: SYMMTY needs a datum median plane (a PARPLN) or a PLANE", datum->name));
  const Geometry& datum_plane = context.datums.front()->geometry;
  const Geometry& g = **actual;
  // A closed slot's median plane runs along its long axis, across its width: its normal is the
  // width direction, and only the points on its two sides (probed across the width, within 30
  // deg) have an opposite side to be the middle of; the ends' points do not.
  const bool slot = feature.nominal.type == FeatureType::ClosedSlot;
  const auto n = unit(slot ? Vec3(g.direction.cross(g.slot_axis)) : g.direction, "the actual of " + feature.label);
  if (!n) return Error(n.error());
  std::vector<Vec3> sides;
  std::size_t ends = 0;
  for (const MeasuredPoint& p : feature.points) {
    if (slot && !(std::abs(p.normal.dot(*n)) >= std::cos(to_rad(30)) * p.normal.norm())) {
      ++ends;
      continue;
    }
    sides.push_back(p.surface_mm());
  }
  std::vector<Vec3> median = derived_median_points(sides, g.position, *n);
  if (median.empty() && !feature.points.empty())
    return Error(fmt::format("SYMMTY of {}: none of its {} points lies on its sides (probed across its width)",
                             feature.label, feature.points.size()));
  if (median.empty()) median.push_back(g.position);  // a constructed or stated actual: its median plane's point
  double largest_mm = 0;
  for (const Vec3& m : median)
    largest_mm = std::max(largest_mm, std::abs((m - datum_plane.position).dot(datum->direction)));
  result.value = 2.0 * largest_mm;
  result.actual = result.value;
  result.nominal = 0;
  add_note(result,
           fmt::format("median plane of {} from {} median points{}, about the median plane of {}", feature.label,
                       median.size(), ends > 0 ? fmt::format(" (its {} end points left out)", ends) : "", datum->name));
  if (line_angle_deg(*n, datum->direction) > 45)
    add_note(result, fmt::format("{}'s median plane is {:.1f} deg from the datum plane: not a symmetry about it",
                                 feature.label, line_angle_deg(*n, datum->direction)));
  set_limits(result, 0, spec.zone);
  return result;
}

bool is_angle_result(const ToleranceResult& result) { return is_angle_kind(result.kind) || result.angle_value; }

// The type lists of the evaluators above, in one table (test ToleranceTypes.TheTableIsTheEvaluators).
bool tolerance_applies(ToleranceKind kind, FeatureType type) {
  using T = FeatureType;
  const auto in = [&](std::initializer_list<T> ts) { return std::find(ts.begin(), ts.end(), type) != ts.end(); };
  switch (kind) {
    case ToleranceKind::Diam:
    case ToleranceKind::Rad: return in({T::Circle, T::Arc, T::Sphere, T::Cylinder});
    case ToleranceKind::Flat: return in({T::Plane});
    case ToleranceKind::Cirlty: return in({T::Circle, T::Arc, T::Cylinder, T::Cone, T::Sphere});
    case ToleranceKind::Cylcty: return in({T::Cylinder});
    case ToleranceKind::Sphcty: return in({T::Sphere});
    case ToleranceKind::Strght: return in({T::Line, T::Cylinder});
    case ToleranceKind::Pos:
      return in({T::Point, T::Circle, T::Arc, T::Sphere, T::Cylinder, T::Cone, T::Line, T::ClosedSlot, T::Torus,
                 T::Ellipse, T::ParallelPlanes});
    case ToleranceKind::Compos:
      return in(
          {T::Point, T::Circle, T::Arc, T::Sphere, T::Cylinder, T::Cone, T::Line, T::ClosedSlot, T::Torus, T::Ellipse});
    case ToleranceKind::Perp:
    case ToleranceKind::Parlel:
    case ToleranceKind::Anglr: return in({T::Plane, T::Line, T::Cylinder, T::Cone, T::ClosedSlot, T::ParallelPlanes});
    case ToleranceKind::Anglb:
      return in({T::Plane, T::Line, T::Cylinder, T::Cone, T::Circle, T::Arc, T::ClosedSlot, T::ParallelPlanes});
    case ToleranceKind::Concen:
    case ToleranceKind::Coaxial: return in({T::Circle, T::Arc, T::Sphere, T::Point, T::Cylinder, T::Cone, T::Line});
    case ToleranceKind::Crnout:
    case ToleranceKind::Totrun: return in({T::Circle, T::Arc, T::Cylinder, T::Cone, T::Sphere, T::Plane});
    case ToleranceKind::Profs:
      return in(
          {T::Plane, T::Circle, T::Arc, T::Sphere, T::Cylinder, T::Cone, T::GenericSurface, T::Torus, T::Ellipse});
    case ToleranceKind::Profl: return in({T::Line, T::Circle, T::Arc, T::GenericCurve, T::Ellipse});
    case ToleranceKind::Width: return in({T::ParallelPlanes, T::ClosedSlot});
    case ToleranceKind::Symmty: return in({T::ParallelPlanes, T::ClosedSlot});
    case ToleranceKind::Profp: return in({T::Point});
    case ToleranceKind::Angl: return in({T::Cone});
    default: return true;
  }
}

tl::expected<ToleranceResult, std::string> evaluate_tolerance(const ToleranceSpec& spec,
                                                              const std::vector<const Feature*>& features,
                                                              const ToleranceContext& context) {
  for (const Feature* f : features)
    if (!f) throw std::invalid_argument("evaluate_tolerance: null feature");
  const char* word = dmis_word(spec.kind);
  if (needs_two(spec.kind) && features.size() != 2)
    return Error(fmt::format("{} needs two features, got {}", word, features.size()));
  if (spec.kind == ToleranceKind::Anglb && (features.empty() || features.size() > 2))
    return Error(
        fmt::format("{} applies to one feature and a datum, or to two features, got {}", word, features.size()));
  if (!needs_two(spec.kind) && spec.kind != ToleranceKind::Anglb && features.size() != 1)
    return Error(fmt::format("{} applies to one feature, got {}", word, features.size()));

  ToleranceResult result;
  result.label = spec.label;
  result.kind = spec.kind;
  result.three_d = spec.kind == ToleranceKind::Pos && spec.three_d;
  for (const Feature* f : features) result.features.push_back(f->label);
  const Feature& feature = *features.front();

  switch (spec.kind) {
    case ToleranceKind::Diam:
    case ToleranceKind::Rad: return evaluate_size(spec, feature, std::move(result));
    case ToleranceKind::DistB: return evaluate_distb(spec, feature, *features[1], context, std::move(result));
    case ToleranceKind::Pos: return evaluate_pos(spec, feature, context, std::move(result));
    case ToleranceKind::Flat:
    case ToleranceKind::Cirlty:
    case ToleranceKind::Cylcty:
    case ToleranceKind::Sphcty:
    case ToleranceKind::Strght: return evaluate_form(spec, feature, context, std::move(result));
    case ToleranceKind::Perp:
    case ToleranceKind::Parlel:
    case ToleranceKind::Anglr: return evaluate_orientation(spec, feature, context, std::move(result));
    case ToleranceKind::Anglb: return evaluate_anglb(spec, features, context, std::move(result));
    case ToleranceKind::Profs: return evaluate_profs(spec, feature, context, std::move(result));
    case ToleranceKind::DistWrt: return evaluate_distb(spec, feature, *features[1], context, std::move(result));
    case ToleranceKind::AngWrt: return evaluate_anglb(spec, features, context, std::move(result));
    case ToleranceKind::Cortol: return evaluate_cortol(spec, feature, context, std::move(result));
    case ToleranceKind::Concen:
    case ToleranceKind::Coaxial: return evaluate_coaxiality(spec, feature, context, std::move(result));
    case ToleranceKind::Crnout:
    case ToleranceKind::Totrun: return evaluate_runout(spec, feature, context, std::move(result));
    case ToleranceKind::Profl:
    case ToleranceKind::Profp: return evaluate_profs(spec, feature, context, std::move(result));
    case ToleranceKind::Width: return evaluate_size(spec, feature, std::move(result));
    case ToleranceKind::Symmty: return evaluate_symmetry(spec, feature, context, std::move(result));
    case ToleranceKind::Angl: return evaluate_cone_angle(spec, feature, std::move(result));
    case ToleranceKind::Compos: return Error("COMPOS has two tiers: evaluate_composite");
  }
  return Error(fmt::format("{} is not evaluated", word));
}

// ---------------------------------------------------------------- COMPOS

// One feature's zone into a COMPOS tier: the tier reports its worst margin, and is in tolerance
// when every feature is.
static void merge_into_tier(ToleranceResult& tier, const ToleranceResult& feature, const std::string& label, bool first,
                            std::string& per_feature) {
  per_feature += fmt::format("{}{} {:.4f}", per_feature.empty() ? "" : ", ", label, feature.value);
  if (first || feature.value - feature.upper > tier.value - tier.upper) {
    tier.value = feature.value;
    tier.lower = feature.lower;
    tier.upper = feature.upper;
    tier.note = feature.note;
  }
  tier.in_tolerance = first ? feature.in_tolerance : tier.in_tolerance && feature.in_tolerance;
}

// Composite position (ASME Y14.5-2018 10.5.1). The PATERN tier (pattern-locating zone framework)
// is POS of each feature in its datums' frame. The FEATUR tier (feature-relating zone framework)
// lets the pattern move as one rigid group: its datums orient it and never locate it. So the
// actual positions are brought into the FEATUR datums' frame, and the pattern's remaining
// freedom (any translation; the rotation about the axis those datums leave free, if any) is
// taken by a least-squares fit onto the true positions: the residuals are the deviations. A
// least-squares group fit never gives a smaller zone than the minimax one, so a pattern it
// accepts is accepted by minimax too.
tl::expected<std::vector<ToleranceResult>, std::string> evaluate_composite(const ToleranceSpec& spec,
                                                                           const std::vector<const Feature*>& features,
                                                                           const ToleranceContext& context) {
  if (features.empty()) return Error("COMPOS applies to a pattern of one or more features, got none");
  ToleranceResult pattern;
  pattern.label = spec.label;
  pattern.kind = ToleranceKind::Compos;
  pattern.tier = "PATERN";
  pattern.three_d = spec.three_d;
  for (const Feature* f : features) pattern.features.push_back(f->label);
  ToleranceResult relating = pattern;
  relating.tier = "FEATUR";

  // PATERN: each feature's POS in the pattern datums' frame; the worst margin is reported.
  ToleranceSpec pos = spec;
  pos.kind = ToleranceKind::Pos;
  bool first = true;
  std::string per_feature;
  for (const Feature* f : features) {
    auto r = evaluate_tolerance(pos, {f}, context);
    if (!r) return Error(r.error());
    merge_into_tier(pattern, *r, f->label, first, per_feature);
    first = false;
  }
  pattern.actual = pattern.value;
  add_note(pattern, "each feature's zone: " + per_feature);

  // FEATUR: the actual positions in the FEATUR datums' frame (orientation only matters: the
  // translation is refitted below).
  DatumFrame oriented;
  if (!spec.feature_datums.empty()) {
    for (std::size_t i = 0; i < spec.feature_datums.size(); ++i)
      if (i >= context.feature_datums.size() || !context.feature_datums[i])
        return Error(fmt::format("datum {} is not defined: DATDEF/FA(feature),DAT({}) first", spec.feature_datums[i],
                                 spec.feature_datums[i]));
    auto frame = fit_datum_frame(context.feature_datums, features.front()->nominal_frame, DatumNominals::AsDefined);
    if (!frame) return Error(frame.error());
    oriented = *frame;
  }
  const std::size_t n = features.size();
  std::vector<Vec3> nominal(n), actual(n), normal(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Feature& f = *features[i];
    const auto a = actual_of(f);
    if (!a) return Error(a.error());
    const Geometry moved = to_machine(**a, oriented.actual_to_nominal);
    const auto at = position_point(f.nominal, moved, spec.three_d, f.label);
    if (!at) return Error(at.error());
    const auto dir = unit(f.nominal.direction, "the nominal of " + f.label);
    if (!dir) return Error(dir.error());
    nominal[i] = f.nominal.position;
    actual[i] = *at;
    normal[i] = *dir;
  }
  // The rotation left free: none when the FEATUR datums fix all three; else about the first
  // FEATUR datum's direction, or without datums about the pattern's axis direction.
  std::optional<Vec3> free_axis;
  if (oriented.rotations_fixed < 3) {
    const Vec3 a = spec.feature_datums.empty() ? normal.front() : context.feature_datums.front()->nominal.direction;
    if (a.norm() > 1e-12) free_axis = a.normalized();
  }
  // Linearised least squares for the translation t and the small rotation angle w about the free
  // axis through the pattern's centroid, iterated with the exact rotation: residual
  // r_i = P_i (R(w) (q_i - c) + c + t - p_i), P_i the projection normal to the feature's axis (2D).
  Vec3 centroid = Vec3::Zero();
  for (const Vec3& q : actual) centroid += q;
  centroid /= static_cast<double>(n);
  const auto project = [&](std::size_t i, const Vec3& v) {
    return spec.three_d ? v : Vec3(v - v.dot(normal[i]) * normal[i]);
  };
  std::vector<Vec3> fitted = actual;
  for (int iteration = 0; iteration < 3; ++iteration) {
    const int unknowns = free_axis ? 4 : 3;
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(3 * n), unknowns);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(3 * n));
    Vec3 c = Vec3::Zero();
    for (const Vec3& q : fitted) c += q;
    c /= static_cast<double>(n);
    for (std::size_t i = 0; i < n; ++i) {
      const auto row = static_cast<Eigen::Index>(3 * i);
      for (int k = 0; k < 3; ++k) a.block(row, k, 3, 1) = project(i, Vec3::Unit(k));
      if (free_axis) a.block(row, 3, 3, 1) = project(i, free_axis->cross(fitted[i] - c));
      b.segment(row, 3) = project(i, nominal[i] - fitted[i]);
    }
    const Eigen::VectorXd x = a.completeOrthogonalDecomposition().solve(b);
    const Vec3 t(x(0), x(1), x(2));
    const Eigen::Matrix3d r =
        free_axis ? Eigen::AngleAxisd(x(3), *free_axis).toRotationMatrix() : Eigen::Matrix3d::Identity();
    for (Vec3& q : fitted) q = r * (q - c) + c + t;
  }
  first = true;
  per_feature.clear();
  for (std::size_t i = 0; i < n; ++i) {
    const Feature& f = *features[i];
    ToleranceResult r = relating;
    r.value = 2.0 * project(i, fitted[i] - nominal[i]).norm();
    const auto bonus = material_bonus(spec.feature_condition, f.nominal, *f.actual, context.units, r);
    if (!bonus) return Error(bonus.error());
    set_limits(r, 0, spec.feature_zone + *bonus);
    merge_into_tier(relating, r, f.label, first, per_feature);
    first = false;
  }
  relating.actual = relating.value;
  add_note(relating,
           fmt::format("the pattern fitted as a group (least squares: translation{}); each feature's zone: {}",
                       free_axis ? ", and rotation about the axis its datums leave free" : " only", per_feature));
  return std::vector<ToleranceResult>{pattern, relating};
}

}  // namespace metron::runtime
