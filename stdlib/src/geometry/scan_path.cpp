// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/geometry/scan_path.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

namespace metron::geometry {
namespace {

// Unit tangent at each sample: the derivative of the parabola through three neighbours in chord
// parametrisation (exact for a parabola, second order for smooth curves sampled unevenly).
std::vector<Vec3> tangents(const std::vector<Vec3>& p, bool closed) {
  const std::size_t n = p.size();
  std::vector<Vec3> t(n);
  const auto three = [](const Vec3& a, const Vec3& b, const Vec3& c) {
    const double h1 = (b - a).norm(), h2 = (c - b).norm();
    return Vec3((h1 * h1 * (c - b) + h2 * h2 * (b - a)) / (h1 * h2 * (h1 + h2)));
  };
  for (std::size_t i = 1; i + 1 < n; ++i) t[i] = three(p[i - 1], p[i], p[i + 1]).normalized();
  if (closed && n > 3) {
    t[0] = three(p[n - 2], p[0], p[1]).normalized();
    t[n - 1] = t[0];
  } else if (n > 2) {
    // Derivative at a of the parabola through a, b, c: (b-a)(h1+h2)/(h1 h2) - (c-a) h1/(h2 (h1+h2)).
    const auto start_derivative = [](const Vec3& a, const Vec3& b, const Vec3& c) {
      const double h1 = (b - a).norm(), h2 = (c - b).norm();
      return Vec3((b - a) * (h1 + h2) / (h1 * h2) - (c - a) * h1 / (h2 * (h1 + h2)));
    };
    t[0] = start_derivative(p[0], p[1], p[2]).normalized();
    t[n - 1] = (-start_derivative(p[n - 1], p[n - 2], p[n - 3])).normalized();
  } else {
    t[0] = t[n - 1] = (p[n - 1] - p[0]).normalized();
  }
  return t;
}

double distance_to_segment(const Vec3& x, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double l2 = ab.squaredNorm();
  const double t = l2 > 0 ? std::clamp((x - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
  return (a + t * ab - x).norm();
}

// Parameter of the point of `seg` nearest to q, from a starting guess (Newton on (X - q).X').
double project(const PccSegment& seg, const Vec3& q, double s) {
  for (int it = 0; it < 6; ++it) {
    const Vec3 r = seg.point(s) - q;
    const Vec3 d1 = seg.derivative(s);
    const double f = r.dot(d1);
    const double df = d1.squaredNorm() + r.dot(seg.second_derivative(s));
    if (!(df > 0)) break;
    const double next = std::clamp(s - f / df, 0.0, seg.d_mm);
    if (std::abs(next - s) < 1e-13 * (1 + seg.d_mm)) {
      s = next;
      break;
    }
    s = next;
  }
  return s;
}

// Largest distance between the segment and the polyline p[i..j] (both ways).
double deviation(const PccSegment& seg, const std::vector<Vec3>& p, std::size_t i, std::size_t j) {
  double total = 0;
  for (std::size_t k = i; k < j; ++k) total += (p[k + 1] - p[k]).norm();
  double worst = 0, along = 0, prev_s = 0;
  for (std::size_t k = i + 1; k <= j; ++k) {
    along += (p[k] - p[k - 1]).norm();
    const double s = k == j ? seg.d_mm : project(seg, p[k], total > 0 ? along / total * seg.d_mm : 0.0);
    worst = std::max(worst, (seg.point(s) - p[k]).norm());
    // The segment between two samples against the polyline chord between them.
    const double mid = 0.5 * (prev_s + s);
    worst = std::max(worst, distance_to_segment(seg.point(mid), p[k - 1], p[k]));
    prev_s = s;
  }
  return worst;
}

double max_curvature(const PccSegment& seg) {
  double k = 0;
  for (int i = 0; i <= 8; ++i) k = std::max(k, seg.curvature(seg.d_mm * i / 8.0));
  return k;
}

}  // namespace

PccFit fit_pcc(const std::vector<Vec3>& raw, bool closed, double tolerance_mm, double max_segment_mm) {
  std::vector<Vec3> p;
  for (const auto& q : raw)
    if (p.empty() || (q - p.back()).norm() > 1e-9) p.push_back(q);
  if (closed && p.size() > 1 && (p.front() - p.back()).norm() > 1e-9) p.push_back(p.front());
  if (closed && p.size() > 1) p.back() = p.front();
  PccFit out;
  if (p.size() < 2) return out;
  const auto t = tangents(p, closed);
  const std::size_t n = p.size();
  // Depth-first so segments come out in order; a closed contour starts split in two (D > 0).
  std::vector<std::pair<std::size_t, std::size_t>> stack;
  if (closed && n > 2) {
    stack.emplace_back(n / 2, n - 1);
    stack.emplace_back(0, n / 2);
  } else {
    stack.emplace_back(0, n - 1);
  }
  out.knots.push_back(0);
  while (!stack.empty()) {
    const auto [i, j] = stack.back();
    stack.pop_back();
    PccSegment seg = PccSegment::hermite(p[i], p[j], t[i], t[j]);
    const double dev = deviation(seg, p, i, j);
    const bool too_long = max_segment_mm > 0 && seg.d_mm > max_segment_mm;
    if ((dev > tolerance_mm || too_long) && j - i >= 2) {
      const std::size_t m = (i + j) / 2;
      stack.emplace_back(m, j);
      stack.emplace_back(i, m);
      continue;
    }
    out.max_deviation_mm = std::max(out.max_deviation_mm, dev);
    out.segments.push_back(seg);
    out.knots.push_back(j);
  }
  // Knots refer to the cleaned polyline; map them back to the caller's indices.
  std::vector<std::size_t> index;
  for (std::size_t k = 0; k < raw.size(); ++k)
    if (index.empty() || (raw[k] - raw[index.back()]).norm() > 1e-9) index.push_back(k);
  if (closed && index.size() < n) index.push_back(raw.size() - 1);
  for (auto& k : out.knots) k = index[std::min(k, index.size() - 1)];
  return out;
}

double curvature_speed_mm_s(double curvature_per_mm, double feed_mm_s, double centripetal_accel_mm_s2) {
  // SEEDS.md 1: the speed of a segment follows from its curvature (centripetal v^2 * kappa <= a).
  if (!(curvature_per_mm > 1e-12)) return feed_mm_s;
  return std::min(feed_mm_s, std::sqrt(centripetal_accel_mm_s2 / curvature_per_mm));
}

tl::expected<ScanPathPlan, ScanPathError> make_scan_path(const Contour& contour, const ScanPathOptions& o) {
  if (contour.points.size() < 2) return tl::unexpected(ScanPathError{"the contour has fewer than 2 points"});
  if (!(o.chord_tolerance_mm > 0)) return tl::unexpected(ScanPathError{"the chord tolerance must be positive"});
  if (!(o.feed_mm_s > 0)) return tl::unexpected(ScanPathError{"the scan feed must be positive"});
  if (!(o.centripetal_accel_mm_s2 > 0))
    return tl::unexpected(ScanPathError{"the centripetal acceleration limit must be positive"});
  if (!(o.ball_radius_mm > 0) || o.reference_deflection_mm < 0 || o.reference_deflection_mm >= o.ball_radius_mm)
    return tl::unexpected(ScanPathError{"need a ball radius r > 0 and a reference deflection 0 <= E0 < r"});
  // SEEDS.md 1: offset contour points = contour points + (r - E0) * normal.
  const double lever = o.ball_radius_mm - o.reference_deflection_mm;
  const Contour full = offset_contour(contour, lever);
  // At a concave vertex of a faceted surface (a fillet tessellated at a few degrees) the offsets of
  // the two facets cross: the points within (r - E0) tan(turn / 2) of the vertex are shadowed (the
  // ball touches both facets before it reaches them) and their offsets step backwards. Those are
  // dropped. A run of backward steps longer than a turn of corner_angle_deg could shadow means the
  // ball does not fit (a concave radius smaller than r - E0, a bore smaller than the ball).
  const double shadow_limit_mm = 2 * lever * std::tan(o.corner_angle_deg / 2 * std::numbers::pi / 180.0);
  std::vector<ContourPoint> src;
  Contour offset;
  offset.closed = full.closed;
  for (std::size_t i = 0; i < full.points.size(); ++i) {
    if (!src.empty()) {
      const Vec3 a = contour.points[i].position - src.back().position;
      const Vec3 b = full.points[i].position - offset.points.back().position;
      if (a.norm() > 1e-9 && a.dot(b) <= 0) {
        if (a.norm() <= shadow_limit_mm) continue;
        return tl::unexpected(ScanPathError{fmt::format(
            "the offset path folds over near ({:.3f}, {:.3f}, {:.3f}): the surface is curved more tightly than the "
            "ball radius minus the reference deflection ({:.3f} mm)",
            src.back().position.x(), src.back().position.y(), src.back().position.z(), lever)});
      }
    }
    src.push_back(contour.points[i]);
    offset.points.push_back(full.points[i]);
  }
  if (offset.points.size() < 2) return tl::unexpected(ScanPathError{"the ball does not fit the contour"});
  // A closed contour whose closing point was shadowed is scanned open.
  if (offset.closed && (offset.points.back().position - offset.points.front().position).norm() > 1e-9)
    offset.closed = false;
  const auto& pts = offset.points;
  // Sharp corners end a smooth piece; each piece is fitted on its own.
  const double corner_cos = std::cos(o.corner_angle_deg * std::numbers::pi / 180.0);
  std::vector<std::size_t> breaks;
  const std::size_t n = pts.size();
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const Vec3 a = pts[i].position - pts[i - 1].position, b = pts[i + 1].position - pts[i].position;
    if (a.norm() > 1e-9 && b.norm() > 1e-9 && a.normalized().dot(b.normalized()) < corner_cos) breaks.push_back(i);
  }
  bool closed_corner = false;
  if (offset.closed && n > 3) {
    const Vec3 a = pts[n - 1].position - pts[n - 2].position, b = pts[1].position - pts[0].position;
    closed_corner = a.normalized().dot(b.normalized()) < corner_cos;
  }
  ScanPathPlan plan;
  plan.corner_count = breaks.size() + (closed_corner ? 1 : 0);
  std::vector<std::size_t> knots;
  const auto fit_piece = [&](std::size_t a, std::size_t b, bool closed) {
    std::vector<Vec3> piece;
    for (std::size_t k = a; k <= b; ++k) piece.push_back(pts[k].position);
    PccFit fit = fit_pcc(piece, closed, o.chord_tolerance_mm, o.max_segment_mm);
    plan.max_deviation_mm = std::max(plan.max_deviation_mm, fit.max_deviation_mm);
    for (auto& s : fit.segments) plan.path.segments.push_back(s);
    for (std::size_t k = knots.empty() ? 0 : 1; k < fit.knots.size(); ++k) knots.push_back(a + fit.knots[k]);
  };
  if (breaks.empty()) {
    fit_piece(0, n - 1, offset.closed && !closed_corner);
  } else {
    std::size_t a = 0;
    for (auto b : breaks) {
      fit_piece(a, b, false);
      a = b;
    }
    fit_piece(a, n - 1, false);
  }
  std::vector<bool> corner(knots.size(), false);
  for (std::size_t k = 0; k < knots.size(); ++k)
    corner[k] = std::find(breaks.begin(), breaks.end(), knots[k]) != breaks.end() ||
                (closed_corner && (k == 0 || k + 1 == knots.size()));
  const auto& segs = plan.path.segments;
  for (std::size_t k = 0; k < knots.size(); ++k) {
    plan.path.normals.push_back(pts[knots[k]].normal);
    double kappa;
    if (corner[k])
      kappa = std::numeric_limits<double>::infinity();
    else if (k == 0)
      kappa = segs.front().curvature(0);
    else if (k + 1 == knots.size())
      kappa = segs.back().curvature(segs.back().d_mm);
    else
      kappa = 0.5 * (segs[k - 1].curvature(segs[k - 1].d_mm) + segs[k].curvature(0));
    plan.curvature_per_mm.push_back(kappa);
  }
  for (const auto& s : segs) {
    const double kappa = max_curvature(s);
    plan.segment_curvature_per_mm.push_back(kappa);
    plan.path.speed_mm_s.push_back(curvature_speed_mm_s(kappa, o.feed_mm_s, o.centripetal_accel_mm_s2));
  }
  return plan;
}

PathPoint point_at_length(const PccPath& path, double s_mm) {
  PathPoint out;
  if (path.segments.empty()) return out;
  double before = 0;
  for (std::size_t i = 0; i < path.segments.size(); ++i) {
    const PccSegment& seg = path.segments[i];
    const double len = seg.length();
    if (s_mm > before + len && i + 1 < path.segments.size()) {
      before += len;
      continue;
    }
    const double want = std::clamp(s_mm - before, 0.0, len);
    double s = len > 0 ? want / len * seg.d_mm : 0.0;
    for (int it = 0; it < 8; ++it) {  // Newton on arc_length(S) = want
      const double speed = seg.derivative(s).norm();
      if (!(speed > 0)) break;
      s = std::clamp(s - (seg.arc_length(s) - want) / speed, 0.0, seg.d_mm);
    }
    out.position = seg.point(s);
    out.tangent = seg.tangent(s);
    if (path.normals.size() == path.segments.size() + 1) {
      const double f = len > 0 ? want / len : 0.0;
      const Vec3 n = (1 - f) * path.normals[i] + f * path.normals[i + 1];
      out.normal = n.norm() > 1e-12 ? Vec3(n.normalized()) : path.normals[i];
    }
    return out;
  }
  return out;
}

}  // namespace metron::geometry
