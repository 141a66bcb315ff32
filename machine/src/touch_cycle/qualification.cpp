// SPDX-License-Identifier: GPL-3.0-or-later
// Tool qualification on the reference sphere (SEEDS.md 3: the effective radius calibrates out
// pre-travel and the constant delays), from the sphere's certificate only.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "controller.hpp"
#include "metron/stdlib/fitting/fit.hpp"

namespace metron::machine::detail {

// Tool qualification on the reference sphere, from what the controller was told about it.
tl::expected<ToolInfo, Fault> Controller::qualify() {
  Tool* tool = active_tool();
  if (!tool) return fault(FaultKind::NoTool, "no tool selected", position, now());
  const double sphere_r = config.reference_sphere.certified_diameter_mm / 2;
  const double r = tool->info.effective_radius_mm;
  constexpr double clearance_mm = 10;

  // Each point: up to a safe height, over the approach point, down and probe. All points are
  // on or above the equator, so the vertical descent stays clear of the sphere and post.
  const auto probe_all = [&](const Vec3& centre, const std::vector<Vec3>& dirs, double approach,
                             double search) -> tl::expected<std::vector<Vec3>, Fault> {
    std::vector<Vec3> centres;
    for (const Vec3& d : dirs) {
      const double safe_z = std::max(centre.z() + sphere_r + r + clearance_mm, position.z());
      const Vec3 over = centre + (sphere_r + r + approach) * d;
      if (auto ok = move_to({position.x(), position.y(), safe_z}, positioning_feed); !ok)
        return tl::unexpected(ok.error());
      if (auto ok = move_to({over.x(), over.y(), safe_z}, positioning_feed); !ok) return tl::unexpected(ok.error());
      PtMeas pt;
      pt.nominal_mm = centre + sphere_r * d;
      pt.normal = d;
      pt.approach_mm = approach;
      pt.search_mm = search;
      pt.retract_mm = 2;
      auto hit = measure_point(pt);
      if (!hit) return tl::unexpected(hit.error());
      centres.push_back(hit->centre_mm);
    }
    if (auto ok = move_to({position.x(), position.y(), centre.z() + sphere_r + r + clearance_mm}, positioning_feed);
        !ok)
      return tl::unexpected(ok.error());
    return centres;
  };
  const auto direction = [](double azimuth_deg, double elevation_deg) {
    const double a = azimuth_deg * std::numbers::pi / 180, e = elevation_deg * std::numbers::pi / 180;
    return Vec3(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
  };
  const auto fit_sphere = [&](const std::vector<Vec3>& pts) -> tl::expected<fitting::FitResult, Fault> {
    fitting::FitOptions options;
    options.inner = false;
    auto f = fitting::fit(fitting::Shape::Sphere, pts, options);
    if (!f)
      return fault(FaultKind::BadCommand, "qualification sphere fit failed: " + fitting::to_string(f.error()), position,
                   now());
    return *f;
  };

  // Back where the qualification started when it is done, over the safe height: the program's
  // next move starts where the program left the probe, not over the reference sphere (a straight
  // move from there to the part may cross it).
  const Vec3 start = position;
  const auto return_to_start = [&]() -> tl::expected<void, Fault> {
    if (auto ok = move_to({start.x(), start.y(), std::max(position.z(), start.z())}, positioning_feed); !ok)
      return tl::unexpected(ok.error());
    if (auto ok = move_to(start, positioning_feed); !ok) return tl::unexpected(ok.error());
    return {};
  };

  // First pass: 5 points about the nominal centre, generous search, to find the sphere.
  std::vector<Vec3> dirs = {Vec3::UnitZ(), direction(0, 0), direction(90, 0), direction(180, 0), direction(270, 0)};
  auto rough = probe_all(config.reference_sphere.nominal_centre_mm, dirs, 5, 5);
  if (!rough) return tl::unexpected(rough.error());
  auto first = fit_sphere(*rough);
  if (!first) return tl::unexpected(first.error());

  // Second pass: 25 points (pole and three rings of 8) about the centre found.
  dirs = {Vec3::UnitZ()};
  const double elevations[] = {0, 30, 60};
  for (int ring = 0; ring < 3; ++ring)
    for (int i = 0; i < 8; ++i) dirs.push_back(direction(45.0 * i + 22.5 * (ring % 2), elevations[ring]));
  auto fine = probe_all(first->position, dirs, 2, 2);
  if (!fine) return tl::unexpected(fine.error());
  auto result = fit_sphere(*fine);
  if (!result) return tl::unexpected(result.error());

  // The fitted sphere of ball centres has radius R + r_effective: pre-travel and the delays
  // shorten it just as they shorten every later probing.
  tool->info.effective_radius_mm = result->diameter_mm / 2 - sphere_r;
  tool->info.qualified = true;
  tool->info.qualification_form_mm = result->form_mm;
  tool->info.qualification_centres_mm = *fine;
  tool->info.reference_diameter_mm = config.reference_sphere.certified_diameter_mm;
  if (auto back = return_to_start(); !back) return tl::unexpected(back.error());
  return tool->info;
}

}  // namespace metron::machine::detail
