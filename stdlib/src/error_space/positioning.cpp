// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/error_space/positioning.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include <fmt/format.h>

namespace metron::error_space {

tl::expected<PositioningEvaluation, std::string> evaluate_positioning(const std::vector<PositioningRecord>& records) {
  if (records.empty()) return tl::unexpected(std::string("no positioning records"));
  struct Acc {
    std::vector<double> up, down;
    double target = 0;
  };
  std::map<int, Acc> by_target;
  for (const auto& r : records) {
    if (r.axis != records[0].axis) return tl::unexpected(std::string("positioning records of more than one axis"));
    auto& a = by_target[r.target];
    a.target = r.target_mm;
    (r.direction > 0 ? a.up : a.down).push_back(r.deviation_mm);
  }
  auto mean = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return s / static_cast<double>(v.size());
  };
  auto sd = [&](const std::vector<double>& v) {
    if (v.size() < 2) return 0.0;
    const double m = mean(v);
    double s = 0;
    for (double x : v) s += (x - m) * (x - m);
    return std::sqrt(s / static_cast<double>(v.size() - 1));  // ISO 230-2 3.3: n - 1
  };
  PositioningEvaluation out;
  double lo = INFINITY, hi = -INFINITY, alo = INFINITY, ahi = -INFINITY;
  for (auto& [i, a] : by_target) {
    if (a.up.empty() || a.down.empty())
      return tl::unexpected(fmt::format("target {} lacks a {} run", i, a.up.empty() ? "+" : "-"));
    TargetEvaluation t;
    t.target_mm = a.target;
    t.mean_up_mm = mean(a.up), t.mean_down_mm = mean(a.down);
    t.sd_up_mm = sd(a.up), t.sd_down_mm = sd(a.down);
    t.reversal_mm = t.mean_up_mm - t.mean_down_mm;  // ISO 230-2 3.9
    t.mean_mm = 0.5 * (t.mean_up_mm + t.mean_down_mm);
    out.reversal_max_mm = std::max(out.reversal_max_mm, std::abs(t.reversal_mm));
    lo = std::min({lo, t.mean_up_mm, t.mean_down_mm}), hi = std::max({hi, t.mean_up_mm, t.mean_down_mm});
    alo = std::min({alo, t.mean_up_mm - 2 * t.sd_up_mm, t.mean_down_mm - 2 * t.sd_down_mm});
    ahi = std::max({ahi, t.mean_up_mm + 2 * t.sd_up_mm, t.mean_down_mm + 2 * t.sd_down_mm});
    // ISO 230-2 3.14: R_i = max(2 s_up + 2 s_down + |B_i|, 4 s_up, 4 s_down)
    const double r =
        std::max({2 * t.sd_up_mm + 2 * t.sd_down_mm + std::abs(t.reversal_mm), 4 * t.sd_up_mm, 4 * t.sd_down_mm});
    out.repeatability_mm = std::max(out.repeatability_mm, r);
    out.targets.push_back(t);
  }
  out.systematic_mm = hi - lo;  // ISO 230-2 3.19
  out.accuracy_mm = ahi - alo;  // ISO 230-2 3.21
  return out;
}

std::string positioning_csv(const std::vector<PositioningRecord>& records) {
  std::string s = "axis,target,target_mm,cycle,direction,deviation_mm,time_s,line_u_mm,line_v_mm\n";
  for (const auto& r : records)
    s += fmt::format("{},{},{:.6f},{},{},{:.9f},{:.3f},{:.6f},{:.6f}\n", "xyz"[r.axis], r.target, r.target_mm, r.cycle,
                     r.direction > 0 ? "+" : "-", r.deviation_mm, r.time_s, r.line_u_mm, r.line_v_mm);
  return s;
}

tl::expected<std::vector<PositioningRecord>, std::string> parse_positioning_csv(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  std::vector<PositioningRecord> out;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (n == 1) {
      if (line.rfind("axis,target,target_mm,cycle,direction,deviation_mm", 0) != 0)
        return tl::unexpected(
            std::string("line 1: expected the header axis,target,target_mm,cycle,direction,deviation_mm,..."));
      continue;
    }
    if (line.empty()) continue;
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) f.push_back(cell);
    if (f.size() != 9) return tl::unexpected(fmt::format("line {}: expected 9 fields, got {}", n, f.size()));
    PositioningRecord r;
    if (f[0] != "x" && f[0] != "y" && f[0] != "z")
      return tl::unexpected(fmt::format("line {}: expected the axis x, y or z", n));
    r.axis = f[0][0] - 'x';
    if (f[4] != "+" && f[4] != "-") return tl::unexpected(fmt::format("line {}: expected the direction + or -", n));
    r.direction = f[4] == "+" ? 1 : -1;
    try {
      std::size_t pos = 0;
      auto num = [&](const std::string& s) {
        const double v = std::stod(s, &pos);
        if (pos != s.size() || !std::isfinite(v)) throw std::invalid_argument(s);
        return v;
      };
      r.target = static_cast<int>(num(f[1]));
      r.target_mm = num(f[2]);
      r.cycle = static_cast<int>(num(f[3]));
      r.deviation_mm = num(f[5]);
      r.time_s = num(f[6]);
      r.line_u_mm = num(f[7]);
      r.line_v_mm = num(f[8]);
    } catch (const std::exception&) {
      return tl::unexpected(fmt::format("line {}: expected numbers in the numeric fields", n));
    }
    out.push_back(r);
  }
  if (n == 0) return tl::unexpected(std::string("line 1: expected the header"));
  return out;
}

}  // namespace metron::error_space
