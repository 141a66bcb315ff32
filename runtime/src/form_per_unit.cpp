// SPDX-License-Identifier: GPL-3.0-or-later
// Form per unit area / length (ASME Y14.5-2018's "per unit" flatness and
// straightness; DMIS 5.x TOL/FLAT,t,tu,a,b and TOL/STRGHT,t,tu,l): every unit area (length)
// anywhere on the feature must hold its points within tu. The rectangles that matter are those with
// a point on their left edge and one on their lower edge: any other slides right and up, keeping its
// points, until it has (the stretches likewise from a point). Each distinct set of such a window is
// judged by its minimum zone, the sets taken in decreasing order of their least-squares form (never
// below the minimum zone: the least-squares reference is one of the zones the minimum is taken over),
// so the search stops once the next least-squares form is below the largest minimum zone found.
#include "detail/form_per_unit.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include "metron/stdlib/fitting/minimum_zone.hpp"

namespace metron::runtime {
namespace {

// Corners tried along one direction: each point's coordinate, or evenly spaced ones of them when
// there are more (a scan): the search is then a sample, and says so.
constexpr std::size_t k_max_corners = 120;

std::vector<double> corners(std::vector<double> coordinates, bool& sampled) {
  std::sort(coordinates.begin(), coordinates.end());
  coordinates.erase(std::unique(coordinates.begin(), coordinates.end()), coordinates.end());
  if (coordinates.size() <= k_max_corners) return coordinates;
  sampled = true;
  std::vector<double> out;
  for (std::size_t k = 0; k < k_max_corners; ++k)
    out.push_back(coordinates[k * (coordinates.size() - 1) / (k_max_corners - 1)]);
  return out;
}

// The minimum zones of the distinct point sets, largest first, by the bound of their least-squares form.
std::optional<PerUnitForm> largest_zone(const std::vector<Vec3>& points, std::set<std::vector<std::size_t>> sets,
                                        fitting::Shape shape, const std::optional<Vec3>& plane_normal, bool sampled) {
  struct Candidate {
    double bound;
    const std::vector<std::size_t>* set;
  };
  std::vector<Candidate> candidates;
  for (const auto& set : sets) {
    std::vector<Vec3> cloud;
    for (const std::size_t i : set) cloud.push_back(points[i]);
    fitting::FitOptions options;
    options.direction_hint = plane_normal;
    const auto ls = fitting::fit(shape, cloud, options);
    if (ls) candidates.push_back({ls->form_mm, &set});
  }
  if (candidates.empty()) return std::nullopt;
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& a, const Candidate& b) { return a.bound > b.bound; });
  PerUnitForm best;
  best.sampled = sampled;
  best.units = candidates.size();
  bool found = false;
  for (const Candidate& c : candidates) {
    if (found && c.bound <= best.form_mm) break;
    std::vector<Vec3> cloud;
    Vec3 centre = Vec3::Zero();
    for (const std::size_t i : *c.set) {
      cloud.push_back(points[i]);
      centre += points[i];
    }
    const auto mz = fitting::minimum_zone(shape, cloud, plane_normal);
    const double form = mz ? std::min(mz->form_mm, c.bound) : c.bound;
    ++best.judged;
    if (!found || form > best.form_mm) {
      best.form_mm = form;
      best.centre = centre / static_cast<double>(cloud.size());
      found = true;
    }
  }
  return best;
}

}  // namespace

std::optional<PerUnitForm> flatness_per_unit_area(const std::vector<Vec3>& points, const Vec3& normal,
                                                  const Vec3& length_axis, double length, double width) {
  const Vec3 n = normal.normalized();
  Vec3 u = length_axis - length_axis.dot(n) * n;
  if (!(u.norm() > 1e-9)) return std::nullopt;
  u.normalize();
  const Vec3 v = n.cross(u);
  std::vector<double> us, vs;
  for (const Vec3& p : points) {
    us.push_back(p.dot(u));
    vs.push_back(p.dot(v));
  }
  bool sampled = false;
  const auto left = corners(us, sampled), bottom = corners(vs, sampled);
  constexpr double slack = 1e-9;  // a point on the far edge belongs to the rectangle
  std::set<std::vector<std::size_t>> sets;
  for (const double u0 : left)
    for (const double v0 : bottom) {
      std::vector<std::size_t> set;
      for (std::size_t i = 0; i < points.size(); ++i)
        if (us[i] >= u0 - slack && us[i] <= u0 + length + slack && vs[i] >= v0 - slack && vs[i] <= v0 + width + slack)
          set.push_back(i);
      if (set.size() >= 4) sets.insert(std::move(set));
    }
  return largest_zone(points, std::move(sets), fitting::Shape::Plane, std::nullopt, sampled);
}

std::optional<PerUnitForm> straightness_per_unit_length(const std::vector<Vec3>& points, const Vec3& direction,
                                                        const std::optional<Vec3>& plane_normal, double length) {
  const Vec3 d = direction.normalized();
  std::vector<double> ts;
  for (const Vec3& p : points) ts.push_back(p.dot(d));
  bool sampled = false;
  constexpr double slack = 1e-9;
  std::set<std::vector<std::size_t>> sets;
  for (const double t0 : corners(ts, sampled)) {
    std::vector<std::size_t> set;
    for (std::size_t i = 0; i < points.size(); ++i)
      if (ts[i] >= t0 - slack && ts[i] <= t0 + length + slack) set.push_back(i);
    if (set.size() >= 3) sets.insert(std::move(set));
  }
  return largest_zone(points, std::move(sets), fitting::Shape::Line, plane_normal, sampled);
}

}  // namespace metron::runtime
