// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/error_space/report_svg.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

namespace metron::error_space {
namespace {

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else
      out += c;
  }
  return out;
}

// Diverging blue-white-red, symmetric about zero (t in [-1, 1]).
std::string colour(double t) {
  t = std::clamp(t, -1.0, 1.0);
  const double a = std::abs(t);
  int r, g, b;
  if (t >= 0)
    r = 255, g = static_cast<int>(255 * (1 - 0.85 * a)), b = static_cast<int>(255 * (1 - 0.95 * a));
  else
    r = static_cast<int>(255 * (1 - 0.95 * a)), g = static_cast<int>(255 * (1 - 0.7 * a)), b = 255;
  return fmt::format("#{:02x}{:02x}{:02x}", r, g, b);
}

void draw_map(std::string& svg, const HeatMap& m, double x0, double y0, double w, double h) {
  const auto nx = static_cast<std::size_t>(m.values_mm.rows()), ny = static_cast<std::size_t>(m.values_mm.cols());
  double vmax = 0, vmin = std::numeric_limits<double>::infinity(), vhi = -vmin;
  for (Eigen::Index i = 0; i < m.values_mm.rows(); ++i)
    for (Eigen::Index j = 0; j < m.values_mm.cols(); ++j)
      if (std::isfinite(m.values_mm(i, j)))
        vmax = std::max(vmax, std::abs(m.values_mm(i, j))), vmin = std::min(vmin, m.values_mm(i, j)),
        vhi = std::max(vhi, m.values_mm(i, j));
  if (vmax == 0) vmax = 1e-9;
  svg += fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="14" font-weight="bold">{}</text>)"
                     "\n",
                     x0, y0 - 8, escape(m.title));
  const double cw = w / static_cast<double>(nx), ch = h / static_cast<double>(ny);
  for (std::size_t i = 0; i < nx; ++i)
    for (std::size_t j = 0; j < ny; ++j) {
      const double v = m.values_mm(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
      // y grows upward on the page, as on the machine table seen from above.
      svg += fmt::format(R"(<rect x="{:.2f}" y="{:.2f}" width="{:.2f}" height="{:.2f}" fill="{}"/>)",
                         x0 + static_cast<double>(i) * cw, y0 + h - static_cast<double>(j + 1) * ch, cw + 0.3, ch + 0.3,
                         std::isfinite(v) ? colour(v / vmax) : "#bbbbbb");
    }
  svg += "\n";
  svg += fmt::format(R"(<rect x="{:.1f}" y="{:.1f}" width="{:.1f}" height="{:.1f}" fill="none" stroke="#333"/>)"
                     "\n",
                     x0, y0, w, h);
  auto lab = [&](double v) { return fmt::format("{:g}", std::round(v * 10) / 10); };
  if (!m.x_mm.empty()) {
    svg += fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="11">{}</text>)", x0, y0 + h + 14, lab(m.x_mm.front()));
    svg += fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="11" text-anchor="end">{}</text>)", x0 + w, y0 + h + 14,
                       lab(m.x_mm.back()));
    svg += fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="11" text-anchor="middle">{}</text>)", x0 + w / 2,
                       y0 + h + 14, escape(m.x_label));
  }
  if (!m.y_mm.empty()) {
    svg += fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="11" text-anchor="end">{}</text>)", x0 - 4, y0 + h,
                       lab(m.y_mm.front()));
    svg += fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="11" text-anchor="end">{}</text>)", x0 - 4, y0 + 10,
                       lab(m.y_mm.back()));
    svg += fmt::format(
        R"svg(<text x="{:.1f}" y="{:.1f}" font-size="11" text-anchor="middle" transform="rotate(-90 {:.1f} {:.1f})">{}</text>)svg",
        x0 - 14, y0 + h / 2, x0 - 14, y0 + h / 2, escape(m.y_label));
  }
  // Colour bar: -max .. +max in um, with the data's range printed.
  const double bx = x0 + w + 10, bw = 12;
  for (int s = 0; s < 40; ++s) {
    const double t = 1 - 2 * (s + 0.5) / 40;
    svg += fmt::format(R"(<rect x="{:.1f}" y="{:.2f}" width="{:.1f}" height="{:.2f}" fill="{}"/>)", bx, y0 + s * h / 40,
                       bw, h / 40 + 0.3, colour(t));
  }
  svg +=
      fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="10">+{:.2f} um</text>)", bx + bw + 3, y0 + 9, 1e3 * vmax);
  svg += fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="10">0</text>)", bx + bw + 3, y0 + h / 2 + 4);
  svg +=
      fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="10">-{:.2f} um</text>)", bx + bw + 3, y0 + h, 1e3 * vmax);
  if (std::isfinite(vmin))
    svg += fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="11">range {:.3f} .. {:.3f} um</text>)"
                       "\n",
                       x0, y0 + h + 28, 1e3 * vmin, 1e3 * vhi);
}

}  // namespace

HeatMap slice_map(const ErrorSpace& s, Component c, std::size_t k, const std::string& title) {
  HeatMap m;
  m.title = title;
  m.x_label = "x (mm)", m.y_label = "y (mm)";
  m.x_mm = s.grid.axes_mm[0], m.y_mm = s.grid.axes_mm[1];
  const auto& v = s.values_mm[static_cast<int>(c)];
  m.values_mm =
      Eigen::MatrixXd::Constant(static_cast<Eigen::Index>(m.x_mm.size()), static_cast<Eigen::Index>(m.y_mm.size()),
                                std::numeric_limits<double>::quiet_NaN());
  if (v.empty()) return m;
  for (std::size_t i = 0; i < m.x_mm.size(); ++i)
    for (std::size_t j = 0; j < m.y_mm.size(); ++j)
      m.values_mm(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = v[s.grid.index(i, j, k)];
  return m;
}

tl::expected<HeatMap, std::string> validation_map(const ErrorSpace& s, Component c, std::size_t k,
                                                  const InterpolationSpec& spec, const std::string& title) {
  const auto& g = s.grid;
  const auto& v = s.values_mm[static_cast<int>(c)];
  Grid sub;
  for (int a = 0; a < 3; ++a)
    for (std::size_t i = 0; i<g.axes_mm[a].size(); i += g.axes_mm[a].size()> 1 ? 2 : 1)
      sub.axes_mm[a].push_back(g.axes_mm[a][i]);
  std::vector<double> sv;
  for (std::size_t kk = 0; kk<g.axes_mm[2].size(); kk += g.axes_mm[2].size()> 1 ? 2 : 1)
    for (std::size_t j = 0; j<g.axes_mm[1].size(); j += g.axes_mm[1].size()> 1 ? 2 : 1)
      for (std::size_t i = 0; i<g.axes_mm[0].size(); i += g.axes_mm[0].size()> 1 ? 2 : 1)
        sv.push_back(v[g.index(i, j, kk)]);
  auto f = make_field(sub, sv, spec);
  if (!f) return tl::unexpected(f.error());
  HeatMap m = slice_map(s, c, k, title);
  const double xmax = sub.axes_mm[0].back(), ymax = sub.axes_mm[1].back(), zmax = sub.axes_mm[2].back();
  for (std::size_t i = 0; i < g.axes_mm[0].size(); ++i)
    for (std::size_t j = 0; j < g.axes_mm[1].size(); ++j) {
      const bool fitted = (g.axes_mm[0].size() == 1 || i % 2 == 0) && (g.axes_mm[1].size() == 1 || j % 2 == 0) &&
                          (g.axes_mm[2].size() == 1 || k % 2 == 0);
      const double x = g.axes_mm[0][i], y = g.axes_mm[1][j], z = g.axes_mm[2][k];
      double& cell = m.values_mm(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
      cell = fitted || x > xmax || y > ymax || z > zmax ? std::numeric_limits<double>::quiet_NaN()
                                                        : (*f)->value(x, y, z) - v[g.index(i, j, k)];
    }
  return m;
}

std::string report_svg(const ReportInput& in) {
  const double map_w = 300, map_h = 240, col_w = 420, row_h = 320,
               top = 60 + 18.0 * static_cast<double>(in.notes.size()) + 30;
  const std::size_t rows = (in.maps.size() + 2) / 3;
  const double width = 3 * col_w + 40, height = top + static_cast<double>(rows) * row_h + 20;
  std::string svg = fmt::format(
      R"(<svg xmlns="http://www.w3.org/2000/svg" width="{:.0f}" height="{:.0f}" viewBox="0 0 {:.0f} {:.0f}" font-family="sans-serif">)"
      "\n",
      width, height, width, height);
  svg += fmt::format(
      R"(<rect width="100%" height="100%" fill="white"/><text x="30" y="36" font-size="22" font-weight="bold">{}</text>)"
      "\n",
      escape(in.title));
  for (std::size_t i = 0; i < in.notes.size(); ++i)
    svg += fmt::format(R"(<text x="30" y="{:.0f}" font-size="13">{}</text>)"
                       "\n",
                       62 + 18.0 * static_cast<double>(i), escape(in.notes[i]));
  for (std::size_t m = 0; m < in.maps.size(); ++m) {
    const double x0 = 60 + static_cast<double>(m % 3) * col_w, y0 = top + static_cast<double>(m / 3) * row_h;
    draw_map(svg, in.maps[m], x0, y0, map_w, map_h);
  }
  svg += "</svg>\n";
  return svg;
}

}  // namespace metron::error_space
