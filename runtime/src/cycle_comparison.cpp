// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/runtime/cycle_comparison.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <fmt/format.h>

namespace metron::runtime {
namespace {

struct Runner {
  machine::Machine& m;
  std::uint64_t tag = std::uint64_t{1} << 26;
  machine::Response exec(decltype(machine::Command::body) b) {
    m.submit({tag++, std::move(b)});
    auto rs = m.execute();
    return rs.empty() ? machine::Response{} : rs.front();
  }
};

std::string fault_of(const machine::Response& r) { return r.fault ? r.fault->message : "no hit"; }

}  // namespace

tl::expected<CycleComparison, std::string> compare_cycles(machine::Machine& machine, const MachineCharacterisation& c,
                                                          const CycleComparisonSettings& s, double ball_diameter_mm) {
  Runner run{machine};
  // The characterisation's touch point: the last qualification point (a surface point with a
  // known normal; the latched centre lies on it with the effective radius).
  for (decltype(machine::Command::body) b :
       {decltype(machine::Command::body){machine::DefineTool{"METRON_CMP", ball_diameter_mm, -Vec3::UnitZ(), 50}},
        decltype(machine::Command::body){machine::SelectTool{"METRON_CMP"}},
        decltype(machine::Command::body){machine::QualifyTool{}}}) {
    const auto r = run.exec(b);
    if (r.status == machine::Response::Status::Fault) return tl::unexpected("tool qualification: " + fault_of(r));
  }
  const machine::MachineState st = machine.state();
  if (!st.last_hit || !st.tool) return tl::unexpected(std::string("qualification gave no point"));
  const Vec3 n = st.last_hit->normal.normalized();
  const double r_eff = st.tool->effective_radius_mm;
  const Vec3 surface = st.last_hit->centre_mm - r_eff * n;
  machine::SetFeeds feeds;
  feeds.positioning_mm_s = s.positioning_mm_s;
  run.exec(feeds);

  const double tol = c.nominal_tolerance_mm, fs = c.measuring_feed_mm_s;
  // One cycle with the nominal `offset` along the normal from the surface, from rest at the
  // clearance; returns {time, latched height along the normal}.
  const auto cycle = [&](machine::PtMeas p, double offset) -> tl::expected<std::pair<double, double>, std::string> {
    p.nominal_mm = surface + offset * n;
    p.normal = n;
    p.retract_mm = s.clearance_mm;
    p.search_mm = std::max(p.search_mm, 2 * tol + c.over_travel_mm + 1);
    const auto go = run.exec(machine::GoTo{p.nominal_mm + (r_eff + s.clearance_mm) * n, std::nullopt});
    if (go.status == machine::Response::Status::Fault) return tl::unexpected(fault_of(go));
    const auto r = run.exec(p);
    if (!r.hit) return tl::unexpected(fault_of(r));
    return std::pair{r.end_time_s - r.start_time_s, (r.hit->centre_mm - surface).dot(n)};
  };
  // Reference: constant-speed touches at the measuring feed from far away, nominal on the surface.
  double reference = 0;
  {
    machine::PtMeas p;
    p.approach_mm = s.clearance_mm + 4 * c.acceleration_distance_mm(-n, fs);
    p.speed_mm_s = fs;
    const int k = 2 * s.points;
    for (int i = 0; i < k; ++i) {
      auto got = cycle(p, 0);
      if (!got) return tl::unexpected("reference touch: " + got.error());
      reference += got->second / k;
    }
  }
  std::vector<CycleComparisonRow> rows;
  const auto add = [&](const std::string& name, bool baseline,
                       const machine::PtMeas& p) -> tl::expected<void, std::string> {
    CycleComparisonRow row{name, baseline};
    std::vector<double> err;
    for (int k = 0; k < s.points; ++k) {
      const double offset = tol * (2 * (k + 0.5) / s.points - 1);
      auto got = cycle(p, offset);
      if (!got) return tl::unexpected(name + ": " + got.error());
      row.time_s += got->first / s.points;
      err.push_back(1e3 * (got->second - reference));
    }
    for (double e : err) row.bias_um += e / s.points;
    row.spread_um = *std::max_element(err.begin(), err.end()) - *std::min_element(err.begin(), err.end());
    rows.push_back(row);
    return {};
  };
  const auto from_plan = [](const TouchPlan& plan) {
    machine::PtMeas p;
    apply_touch_plan(plan, p);
    return p;
  };
  // Conventional baselines (docs/touch-trigger.md): a plain one-touch from the clearance at the
  // measuring feed, two-touch cycles with fixed 1 mm and 0.5 mm back-offs.
  {
    machine::PtMeas p;
    p.approach_mm = s.clearance_mm;
    p.speed_mm_s = fs;
    if (auto ok = add("baseline: plain one-touch from the clearance", true, p); !ok) return tl::unexpected(ok.error());
  }
  for (double backoff : {1.0, 0.5}) {
    machine::PtMeas p;
    p.approach_mm = s.clearance_mm;
    p.speed_mm_s = fs;
    p.two_touch = machine::PtMeas::TwoTouch{c.first_feed_mm_s, backoff};
    if (auto ok = add(fmt::format("baseline: two-touch, {:.1f} mm back-off", backoff), true, p); !ok)
      return tl::unexpected(ok.error());
  }
  const RestingHead rest{s.clearance_mm, s.positioning_mm_s};
  MachineCharacterisation two = c, one = c, blend = c;
  two.one_touch = false, two.blend = false;
  one.one_touch = true, one.blend = false;
  blend.blend = true;
  if (auto ok = add("seed: two-touch (D1+D2+D3)", false, from_plan(two.plan(n, fs, std::nullopt, rest))); !ok)
    return tl::unexpected(ok.error());
  if (auto ok = add("seed: one-touch (D1+D3+tol)", false, from_plan(one.plan(n, fs, std::nullopt, rest))); !ok)
    return tl::unexpected(ok.error());
  if (auto ok = add("beyond seed: blended one-touch", false, from_plan(blend.plan(n, fs, s.clearance_mm))); !ok)
    return tl::unexpected(ok.error());
  return CycleComparison{rows, n};
}

std::string format_cycle_comparison(const std::vector<CycleComparisonRow>& rows, double threshold_mm, double limit_s) {
  std::ostringstream o;
  // The best baseline: the fastest conventional cycle whose bias and spread meet the threshold.
  double best = 0;
  for (const auto& r : rows)
    if (r.baseline && r.spread_um <= 1e3 * threshold_mm && std::abs(r.bias_um) <= 1e3 * threshold_mm &&
        (best == 0 || r.time_s < best))
      best = r.time_s;
  o << fmt::format("  {:<46} {:>8} {:>14} {:>9} {:>10}{}\n", "cycle", "time s", "vs best base.", "bias um", "spread um",
                   limit_s > 0 ? "    /limit" : "");
  for (const auto& r : rows) {
    const bool valid = r.spread_um <= 1e3 * threshold_mm && std::abs(r.bias_um) <= 1e3 * threshold_mm;
    o << fmt::format("  {:<46} {:8.4f} {:>14} {:9.2f} {:10.2f}{}{}\n", r.name, r.time_s,
                     best > 0 ? fmt::format("{:+.1f} %", 100 * (r.time_s / best - 1)) : std::string("-"), r.bias_um,
                     r.spread_um, limit_s > 0 ? fmt::format(" {:9.3f}", r.time_s / limit_s) : std::string(),
                     valid ? "" : "  (outside the threshold)");
  }
  return o.str();
}

}  // namespace metron::runtime
