// SPDX-License-Identifier: GPL-3.0-or-later
// `metron discrepancy DATA --describe D.json --world W`: the model-discrepancy analysis
// (docs/discrepancy.md). The world's virtual CMM predicts every row of a measured data set; the
// residuals are searched for structure, the catalogue's physical effects are fitted and claimed
// when significant, the extended world is written and re-simulated for the cross-validated gain.
// `--predict OUT` writes the world's predictions in place of the measured values instead.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <random>
#include <sstream>
#include <string>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "metron/machine/discrepancy/prediction.hpp"
#include "metron/machine/world.hpp"
#include "metron/stdlib/discrepancy/analysis.hpp"
#include "metron/stdlib/discrepancy/measured_data.hpp"

namespace metron::cli {
namespace {

namespace dc = metron::discrepancy;

struct DiscrepancyArgs {
  std::string data, describe;
  std::optional<std::string> world, out, predict;
  double noise_um = 0;
  std::uint64_t seed = 1;
  int max_effects = 4;
  std::vector<std::string> disable;
  bool no_significance = false, verbose = false;
};

const char* const kAxis[4] = {"x", "y", "z", "n"};

// The condition an effect follows, per observation (for the plots).
std::vector<double> condition_values(const dc::Problem& p, const std::string& cond) {
  const auto& d = *p.data;
  std::vector<double> v(p.row.size(), 0);
  for (std::size_t o = 0; o < p.row.size(); ++o) {
    const auto q = d.position_mm(p.row[o]);
    bool done = false;
    for (int a = 0; a < 3 && !done; ++a) {
      if (cond == fmt::format("{} position", kAxis[a])) v[o] = q[static_cast<std::size_t>(a)], done = true;
      for (int b = 0; b < 3 && !done; ++b)
        if (cond == fmt::format("{}*{} position", kAxis[a], kAxis[b]))
          v[o] = q[static_cast<std::size_t>(a)] * q[static_cast<std::size_t>(b)], done = true;
    }
    if (done) continue;
    if (cond == "approach angle") {
      const auto* ax = d.find(dc::Role::Approach, 0);
      const auto* ay = d.find(dc::Role::Approach, 1);
      if (ax && ay) v[o] = std::atan2(ay->values[p.row[o]], ax->values[p.row[o]]);
      continue;
    }
    std::string name = cond;
    if (auto k = name.find(" (lagged)"); k != std::string::npos) name = name.substr(0, k);
    for (const auto& s : d.series)
      if (s.name == name) v[o] = s.values[p.row[o]];
  }
  return v;
}

std::string esc(const std::string& s) {
  std::string o;
  for (char c : s) o += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : std::string(1, c);
  return o;
}

// A scatter plot of two series against x (um), SVG.
std::string scatter(const std::string& title, const std::string& xlabel, const std::vector<double>& x,
                    const std::vector<std::pair<std::string, std::vector<double>>>& ys, bool lines = false) {
  const double W = 600, H = 260, L = 60, R = 10, T = 24, B = 36;
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (double v : x) x0 = std::min(x0, v), x1 = std::max(x1, v);
  for (const auto& [n, y] : ys)
    for (double v : y) y0 = std::min(y0, v), y1 = std::max(y1, v);
  if (!(x1 > x0)) x1 = x0 + 1;
  if (!(y1 > y0)) y1 = y0 + 1e-9;
  const double pad = 0.05 * (y1 - y0);
  y0 -= pad, y1 += pad;
  auto X = [&](double v) { return L + (v - x0) / (x1 - x0) * (W - L - R); };
  auto Y = [&](double v) { return T + (y1 - v) / (y1 - y0) * (H - T - B); };
  std::string s =
      fmt::format("<svg xmlns='http://www.w3.org/2000/svg' width='{}' height='{}' style='background:#fff'>", W, H);
  s += fmt::format("<text x='{}' y='16' font-size='13' font-family='sans-serif'>{}</text>", L, esc(title));
  s +=
      fmt::format("<rect x='{}' y='{}' width='{}' height='{}' fill='none' stroke='#888'/>", L, T, W - L - R, H - T - B);
  s += fmt::format("<text x='{}' y='{}' font-size='11' font-family='sans-serif'>{}</text>", L, H - 6, esc(xlabel));
  s += fmt::format("<text x='4' y='{}' font-size='10' font-family='sans-serif'>{:.3g}</text>", T + 10, y1);
  s += fmt::format("<text x='4' y='{}' font-size='10' font-family='sans-serif'>{:.3g}</text>", H - B, y0);
  s += fmt::format("<text x='{}' y='{}' font-size='10' font-family='sans-serif'>{:.4g}</text>", L, H - B + 12, x0);
  s += fmt::format("<text x='{}' y='{}' font-size='10' font-family='sans-serif' text-anchor='end'>{:.4g}</text>", W - R,
                   H - B + 12, x1);
  if (y0 < 0 && y1 > 0)
    s += fmt::format("<line x1='{}' x2='{}' y1='{:.1f}' y2='{:.1f}' stroke='#ccc'/>", L, W - R, Y(0), Y(0));
  const char* colours[3] = {"#d62728", "#1f77b4", "#2ca02c"};
  for (std::size_t k = 0; k < ys.size(); ++k) {
    const auto& y = ys[k].second;
    const std::size_t step = std::max<std::size_t>(1, x.size() / 3000);  // keep the page light
    if (lines) {
      s += fmt::format("<polyline fill='none' stroke='{}' stroke-width='1' points='", colours[k % 3]);
      for (std::size_t i = 0; i < x.size(); i += step) s += fmt::format("{:.1f},{:.1f} ", X(x[i]), Y(y[i]));
      s += "'/>";
    } else {
      for (std::size_t i = 0; i < x.size(); i += step)
        s += fmt::format("<circle cx='{:.1f}' cy='{:.1f}' r='1.8' fill='{}' fill-opacity='0.6'/>", X(x[i]), Y(y[i]),
                         colours[k % 3]);
    }
    s += fmt::format("<text x='{}' y='{}' font-size='11' fill='{}' font-family='sans-serif'>{}</text>", W - R - 150,
                     T + 14 + 13 * static_cast<double>(k), colours[k % 3], esc(ys[k].first));
  }
  return s + "</svg>";
}

std::string report_html(const dc::Analysis& a, const dc::Problem& p, const std::string& text) {
  std::string h =
      "<!DOCTYPE html><html><head><meta charset='utf-8'><title>metron discrepancy</title>"
      "<style>body{font-family:sans-serif;margin:20px;max-width:1250px} "
      "pre{background:#f4f4f4;padding:8px;font-size:12px;white-space:pre-wrap}"
      " .g{display:flex;flex-wrap:wrap;gap:8px}</style></head><body>";
  h += "<h1>Model discrepancy</h1>";
  h += fmt::format(
      "<p><b>Cross-validated residual RMS</b>: {:.3f} &micro;m before, {:.3f} &micro;m after; noise {:.3f} &micro;m "
      "({}).</p>",
      a.cv_rms_before_mm * 1e3, a.cv_rms_after_mm * 1e3, a.noise_mm * 1e3, esc(a.noise_source));
  auto um = [](const std::vector<double>& v) {
    std::vector<double> o(v);
    for (double& x : o) x *= 1e3;
    return o;
  };
  h += "<h2>Effects found</h2><div class='g'>";
  if (a.effects.empty()) {
    std::vector<double> idx(p.row.size());
    for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = static_cast<double>(p.row[i]);
    h += scatter("no effect claimed: residual (um) by row", "row", idx, {{"residual", um(a.residual_before_mm)}});
  }
  for (const auto& e : a.effects) {
    const auto x = condition_values(p, e.condition);
    std::vector<double> before(p.row.size());
    for (std::size_t o = 0; o < before.size(); ++o) before[o] = a.residual_after_mm[o] + e.contribution_mm[o];
    h += scatter(fmt::format("{}: residual (um) before/after", e.what), e.condition, x,
                 {{"without this effect", um(before)}, {"with it", um(a.residual_after_mm)}});
  }
  h += "</div><h2>Unexplained structure</h2><div class='g'>";
  if (a.unexplained.empty()) h += "<p>none found</p>";
  for (std::size_t i = 0; i < std::min<std::size_t>(3, a.unexplained.size()); ++i) {
    const auto& s = a.unexplained[i];
    const auto x = condition_values(p, s.condition);
    h += scatter(
        fmt::format("{} residual (um) follows {} ({}, p={:.2g})", kAxis[s.component], s.condition, s.test, s.p_value),
        s.condition, x, {{"residual after the effects", um(a.residual_after_mm)}});
  }
  h += "</div><h2>Spectra (fraction of residual variance explained by one period)</h2><div class='g'>";
  for (std::size_t i = 0; i < std::min<std::size_t>(4, a.spectra_before.size()); ++i) {
    const auto& b = a.spectra_before[i];
    std::vector<std::pair<std::string, std::vector<double>>> ys{{"before", b.power}};
    for (const auto& af : a.spectra_after)
      if (af.against == b.against && af.component == b.component && af.power.size() == b.power.size())
        ys.push_back({"after", af.power});
    h += scatter(fmt::format("{} residual against {}", kAxis[b.component], b.against), "period", b.period, ys, true);
  }
  h += "</div><h2>Summary</h2><pre>" + esc(text) + "</pre></body></html>";
  return h;
}

int run_discrepancy(const DiscrepancyArgs& args) {
  auto data = dc::read_measured_data(args.data, args.describe);
  if (!data) {
    std::cerr << "error: " << data.error().text() << "\n";
    return 2;
  }
  auto world = machine::load_world_or_default(args.world);
  if (!world) {
    std::cerr << "error: " << world.error().message << "\n";
    return 2;
  }
  const auto& errors = world->truth.errors;
  if (args.predict) {
    std::mt19937_64 rng(args.seed);
    std::normal_distribution<double> noise(0.0, args.noise_um * 1e-3);
    const std::string csv = dc::write_with_deviations(*data, [&](std::size_t r, int a) {
      return machine::predicted_deviation_mm(errors, *data, r, a) + (args.noise_um > 0 ? noise(rng) : 0.0);
    });
    std::ofstream out(*args.predict);
    if (!(out << csv)) {
      std::cerr << "error: cannot write " << *args.predict << "\n";
      return 2;
    }
    std::cout << fmt::format("wrote {} ({} rows predicted by world '{}')\n", *args.predict, data->rows, world->name);
    return 0;
  }
  const auto problem = dc::make_problem(
      *data, [&](std::size_t r, int a) { return machine::predicted_deviation_mm(errors, *data, r, a); });
  dc::Options opt;
  opt.max_effects = args.max_effects;
  opt.disabled = args.disable;
  opt.significance = !args.no_significance;
  opt.progress = [&](const std::string& s) {
    if (args.verbose || s.rfind("step", 0) != 0) std::cerr << "discrepancy: " << s << "\n";
  };
  const auto analysis = dc::analyse(problem, opt);
  std::string text = dc::summary(analysis, *data);

  // The extended world: the base world's machine.errors plus the effects' terms, re-simulated.
  nlohmann::json base_errors;
  if (args.world) {
    std::ifstream in(*args.world);
    try {
      const auto wj = nlohmann::json::parse(in, nullptr, true, true);
      if (wj.contains("machine") && wj["machine"].contains("errors")) base_errors = wj["machine"]["errors"];
    } catch (const nlohmann::json::exception&) {
    }
  }
  nlohmann::json ext{{"name", world->name + "+discrepancy"},
                     {"extends", args.world ? std::filesystem::absolute(*args.world).string() : std::string("default")},
                     {"machine", {{"errors", machine::extended_errors(base_errors, analysis.effects)}}}};
  std::optional<double> resim_cv;
  if (args.out) {
    std::filesystem::create_directories(*args.out);
    const std::string wpath = (std::filesystem::path(*args.out) / "extended_world.json").string();
    std::ofstream(wpath) << ext.dump(2) << "\n";
    auto w2 = machine::load_world(wpath);
    if (!w2) {
      std::cerr << "error: the extended world does not load: " << w2.error().message << "\n";
      return 1;
    }
    const auto p2 = dc::make_problem(
        *data, [&](std::size_t r, int a) { return machine::predicted_deviation_mm(w2->truth.errors, *data, r, a); });
    dc::Options o2;
    o2.max_effects = 0;
    const auto a2 = dc::analyse(p2, o2);
    resim_cv = a2.cv_rms_before_mm;
    text += fmt::format("extended world {}: re-simulated, cross-validated RMS {:.3f} um (base world {:.3f} um)\n",
                        wpath, a2.cv_rms_before_mm * 1e3, analysis.cv_rms_before_mm * 1e3);
    auto j = dc::to_json(analysis);
    j["data"] = args.data;
    j["world"] = args.world.value_or("default");
    j["extended_world"] = wpath;
    j["resimulated_cv_rms_mm"] = *resim_cv;
    std::ofstream((std::filesystem::path(*args.out) / "results.json").string()) << j.dump(2) << "\n";
    std::ofstream((std::filesystem::path(*args.out) / "summary.txt").string()) << text;
    std::ofstream((std::filesystem::path(*args.out) / "report.html").string()) << report_html(analysis, problem, text);
  }
  std::cout << text;
  return 0;
}

}  // namespace

void add_discrepancy_command(CLI::App& app, std::vector<Command>& commands) {
  auto args = std::make_shared<DiscrepancyArgs>();
  CLI::App* c =
      app.add_subcommand("discrepancy", "model-discrepancy analysis: measured data against the world's simulation");
  c->add_option("data", args->data, "measured data (CSV or whitespace table)")->required();
  c->add_option("--describe", args->describe, "JSON description of the columns (docs/discrepancy.md)")->required();
  c->add_option("--world", args->world, "world file (default: the embedded world)");
  c->add_option("--out", args->out, "directory for results.json, summary.txt, report.html, extended_world.json");
  c->add_option("--predict", args->predict,
                "write the world's predictions in place of the measured values to this CSV and stop");
  c->add_option("--noise-um", args->noise_um, "with --predict: add Gaussian noise of this sd (um)");
  c->add_option("--seed", args->seed, "with --predict: noise seed");
  c->add_option("--max-effects", args->max_effects, "most effects to claim (default 4)");
  c->add_option("--disable", args->disable, "catalogue entries to leave out (scale, cyclic, ...)");
  c->add_flag("--no-significance", args->no_significance, "claim by cross-validation alone (for checking the test)");
  c->add_flag("--verbose", args->verbose, "show every candidate");
  commands.push_back({c, [args] { return run_discrepancy(*args); }});
}

}  // namespace metron::cli
