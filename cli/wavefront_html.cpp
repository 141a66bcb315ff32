// SPDX-License-Identifier: GPL-3.0-or-later
// Pictures of a wavefront calibration as one self-contained HTML page with inline SVG (no
// network): a gauge map, the part-on-mount tilt circles with their fits, the A axis offset against
// Z with the fitted lines, and the A-Z iteration's convergence (docs/wavefront.md).
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "metron/machine/wavefront/gauge_map.hpp"

namespace metron::cli {
namespace {

using nlohmann::json;

struct Series {
  std::vector<double> x, y;
  std::string colour;
  bool line = false;  // polyline instead of dots
  std::string label;
};

// A plot with a frame, the data ranges as tick labels, equal scales when `square`.
std::string plot(const std::string& title, const std::string& xlabel, const std::string& ylabel,
                 const std::vector<Series>& series, bool square = false, bool log_y = false) {
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  const auto ty = [&](double v) { return log_y ? std::log10(std::max(v, 1e-300)) : v; };
  for (const auto& s : series)
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      x0 = std::min(x0, s.x[i]), x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, ty(s.y[i])), y1 = std::max(y1, ty(s.y[i]));
    }
  if (!(x1 > x0)) x0 -= 1, x1 += 1;
  if (!(y1 > y0)) y0 -= 1, y1 += 1;
  const double mx = 0.08 * (x1 - x0), my = 0.08 * (y1 - y0);
  x0 -= mx, x1 += mx, y0 -= my, y1 += my;
  if (square) {
    const double c = std::max(x1 - x0, y1 - y0), cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
    x0 = cx - c / 2, x1 = cx + c / 2, y0 = cy - c / 2, y1 = cy + c / 2;
  }
  const double w = 420, h = square ? 420 : 300, l = 70, t = 30;
  const auto px = [&](double v) { return l + (v - x0) / (x1 - x0) * w; };
  const auto py = [&](double v) { return t + h - (ty(v) - y0) / (y1 - y0) * h; };
  std::string s = fmt::format(
      "<svg xmlns='http://www.w3.org/2000/svg' width='{}' height='{}' font-family='sans-serif' font-size='11'>",
      w + l + 20, h + t + 45);
  s += fmt::format("<text x='{}' y='18' font-size='13' font-weight='bold'>{}</text>", l, title);
  s += fmt::format("<rect x='{}' y='{}' width='{}' height='{}' fill='none' stroke='#444'/>", l, t, w, h);
  const auto tick = [&](double v) { return log_y ? fmt::format("1e{:.1f}", v) : fmt::format("{:.4g}", v); };
  s += fmt::format("<text x='{}' y='{}'>{:.4g}</text><text x='{}' y='{}' text-anchor='end'>{:.4g}</text>", l,
                   t + h + 14, x0, l + w, t + h + 14, x1);
  s += fmt::format("<text x='{}' y='{}' text-anchor='end'>{}</text><text x='{}' y='{}' text-anchor='end'>{}</text>",
                   l - 4, t + h, tick(y0), l - 4, t + 10, tick(y1));
  s += fmt::format("<text x='{}' y='{}' text-anchor='middle'>{}</text>", l + w / 2, t + h + 32, xlabel);
  s += fmt::format("<text x='14' y='{}' transform='rotate(-90 14 {})' text-anchor='middle'>{}</text>", t + h / 2,
                   t + h / 2, ylabel);
  int legend = 0;
  for (const auto& se : series) {
    if (se.line) {
      std::string pts;
      for (std::size_t i = 0; i < se.x.size(); ++i) pts += fmt::format("{:.2f},{:.2f} ", px(se.x[i]), py(se.y[i]));
      s += fmt::format("<polyline points='{}' fill='none' stroke='{}' stroke-width='1.5'/>", pts, se.colour);
    } else {
      for (std::size_t i = 0; i < se.x.size(); ++i)
        s += fmt::format("<circle cx='{:.2f}' cy='{:.2f}' r='3.5' fill='{}'/>", px(se.x[i]), py(se.y[i]), se.colour);
    }
    if (!se.label.empty())
      s += fmt::format("<text x='{}' y='{}' fill='{}'>{}</text>", l + 8, t + 16 + 14 * legend++, se.colour, se.label);
  }
  return s + "</svg>";
}

std::string map_svg(const machine::wavefront::GaugeMap& m, const std::string& title) {
  const int cells = std::min(m.pixels, 96), step = std::max(1, m.pixels / cells);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double v : m.opd_nm)
    if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
  const double size = 4;
  std::string s = fmt::format(
      "<svg xmlns='http://www.w3.org/2000/svg' width='{}' height='{}' font-family='sans-serif' font-size='11'>",
      cells * size + 40, cells * size + 60);
  s += fmt::format("<text x='10' y='18' font-size='13' font-weight='bold'>{}</text>", title);
  for (int iy = 0; iy < cells; ++iy)
    for (int ix = 0; ix < cells; ++ix) {
      const double v = m.at(std::min(ix * step, m.pixels - 1), std::min(iy * step, m.pixels - 1));
      if (!std::isfinite(v)) continue;
      const double f = hi > lo ? (v - lo) / (hi - lo) : 0.5;  // blue - white - red
      const int r = static_cast<int>(255 * std::min(1.0, 2 * f)),
                b = static_cast<int>(255 * std::min(1.0, 2 * (1 - f)));
      const int g = std::min(r, b);
      s += fmt::format("<rect x='{}' y='{}' width='{}' height='{}' fill='rgb({},{},{})'/>", 10 + ix * size,
                       30 + (cells - 1 - iy) * size, size, size, r, g, b);
    }
  s += fmt::format("<text x='10' y='{}'>OPD {:.1f} nm (blue) to {:.1f} nm (red), {} x {} pixels</text>",
                   30 + cells * size + 16, lo, hi, m.pixels, m.pixels);
  return s + "</svg>";
}

std::string circle_plot(const json& pom, const std::string& title, double scale, const std::string& unit) {
  Series pts{{}, {}, "#c0392b", false, "measured tilt per spindle angle"};
  for (const auto& p : pom["tilts"])
    pts.x.push_back(p[0].get<double>() * scale), pts.y.push_back(p[1].get<double>() * scale);
  Series fit{{}, {}, "#2c3e50", true, "phased circle fit"};
  const double cx = pom["centre"][0].get<double>() * scale, cy = pom["centre"][1].get<double>() * scale;
  const double r = pom["radius"].get<double>() * scale;
  for (int i = 0; i <= 90; ++i) {
    const double a = 2 * std::numbers::pi * i / 90;
    fit.x.push_back(cx + r * std::cos(a)), fit.y.push_back(cy + r * std::sin(a));
  }
  Series centre{{cx}, {cy}, "#2c3e50", false, "centre (gauge to spindle)"};
  Series origin{{0}, {0}, "#27ae60", false, "gauge origin"};
  return plot(title, "x tilt [" + unit + "]", "y tilt [" + unit + "]", {fit, pts, centre, origin}, true);
}

}  // namespace

std::string wavefront_html(const json& r, const machine::wavefront::GaugeMap* map) {
  std::string body;
  if (map) body += map_svg(*map, "gauge map of the last part at the end of the run");
  if (r.contains("gauge_frame"))
    body += circle_plot(r["gauge_frame"]["part_on_mount"], "step 2: optical flat, part-on-mount", 1e6, "urad");
  if (r.contains("part_on_mount")) {
    const bool sphere = r["part_on_mount"]["element"] == "sphere";
    body += circle_plot(r["part_on_mount"], "part-on-mount", sphere ? 1e3 : 1e6, sphere ? "um" : "urad");
  }
  if (r.contains("reversal")) {
    body += circle_plot(r["reversal"]["at_0"], "reversal: part as mounted", 1e6, "urad");
    body += circle_plot(r["reversal"]["at_180"], "reversal: part turned 180 deg on the table", 1e6, "urad");
  }
  if (r.contains("a_to_z")) {
    const auto& its = r["a_to_z"]["iterations"];
    std::vector<Series> sx;
    const char* colours[] = {"#c0392b", "#2980b9", "#27ae60", "#8e44ad", "#d35400", "#16a085"};
    Series conv{{}, {}, "#2c3e50", true, "|A to Z| recovered"};
    Series conv_pts{{}, {}, "#2c3e50", false, ""};
    for (std::size_t i = 0; i < its.size(); ++i) {
      Series px{{}, {}, colours[i % 6], false, fmt::format("iteration {}: x (dots), y (line)", i + 1)};
      Series py{{}, {}, colours[i % 6], true, ""};
      for (const auto& p : its[i]["points"]) {
        px.x.push_back(p["z_mm"].get<double>());
        px.y.push_back(p["a_offset_mm"][0].get<double>() * 1e3);
        py.x.push_back(p["z_mm"].get<double>());
        py.y.push_back(p["a_offset_mm"][1].get<double>() * 1e3);
      }
      sx.push_back(px);
      sx.push_back(py);
      const double a = std::hypot(its[i]["angle_rad"][0].get<double>(), its[i]["angle_rad"][1].get<double>()) * 1e6;
      conv.x.push_back(static_cast<double>(i + 1)), conv.y.push_back(a);
      conv_pts.x.push_back(static_cast<double>(i + 1)), conv_pts.y.push_back(a);
    }
    body += plot("step 5: A axis from the focus against table Z", "table Z [mm]", "offset [um]", sx);
    body += plot("step 5: convergence of A parallel to Z", "iteration", "|A to Z| [urad], log", {conv, conv_pts}, false,
                 true);
  }
  if (r.contains("b_rotation")) {
    Series x{{}, {}, "#c0392b", false, "X null - first [um]"}, z{{}, {}, "#2980b9", false, "Z null - first [um]"};
    const auto& n = r["b_rotation"]["nulls"];
    for (const auto& p : n) {
      x.x.push_back(p["b_deg"].get<double>()), z.x.push_back(p["b_deg"].get<double>());
      x.y.push_back((p["steps"][0].get<double>() - n[0]["steps"][0].get<double>()) *
                    r["knowledge"]["step_mm"][0].get<double>() * 1e3);
      z.y.push_back((p["steps"][2].get<double>() - n[0]["steps"][2].get<double>()) *
                    r["knowledge"]["step_mm"][2].get<double>() * 1e3);
    }
    body += plot("step 4: nulls against B", "B [deg]", "[um]", {x, z});
  }
  return "<!DOCTYPE html><html><head><meta charset='utf-8'><title>metron: wavefront calibration</title>"
         "<style>body{font-family:sans-serif;margin:16px} svg{margin:6px;border:1px solid #ddd}</style></head><body>"
         "<h2>metron calibrate wavefront: " +
         r.value("world", std::string()) + " (step " + r.value("step", std::string()) + ")</h2>" + body +
         "</body></html>\n";
}

}  // namespace metron::cli
