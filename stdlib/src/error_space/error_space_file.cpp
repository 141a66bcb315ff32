// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/error_space/error_space_file.hpp"

#include <fstream>
#include <stdexcept>

#include <fmt/format.h>

#include "metron/stdlib/json_reader.hpp"

namespace metron::error_space {

using nlohmann::json;

json to_json(const ErrorSpaceFile& f) {
  if (f.spaces.empty()) throw std::invalid_argument("an error-space file needs at least one space");
  const Grid& g = f.spaces[0].grid;
  json out;
  out["format"] = "metron-error-space";
  out["version"] = 1;
  if (!f.description.empty()) out["description"] = f.description;
  if (f.sensor_offset_mm != std::array<double, 3>{0, 0, 0}) out["sensor_offset_mm"] = f.sensor_offset_mm;
  out["grid"] = {{"x_mm", g.axes_mm[0]}, {"y_mm", g.axes_mm[1]}, {"z_mm", g.axes_mm[2]}};
  json interp = {{"method", std::string(to_string(f.interpolation.method))}};
  if (f.interpolation.method == Method::LeastSquares) {
    interp["degree"] = f.interpolation.least_squares.degree;
    interp["neighbourhood"] = f.interpolation.least_squares.neighbourhood;
  }
  out["interpolation"] = interp;
  json temps = json::array();
  for (const auto& s : f.spaces) {
    if (!(s.grid == g)) throw std::invalid_argument("error spaces in one file must share the grid");
    json comps = json::object();
    for (int c = 0; c < 3; ++c) {
      if (s.values_mm[c].empty()) continue;
      json comp = {{"values_mm", s.values_mm[c]}};
      if (!s.sd_mm[c].empty()) comp["sd_mm"] = s.sd_mm[c];
      comps[std::string(to_string(static_cast<Component>(c)))] = comp;
    }
    temps.push_back({{"temperature_c", s.temperature_c}, {"components", comps}});
  }
  out["temperatures"] = temps;
  return out;
}

tl::expected<ErrorSpaceFile, FileError> from_json(const json& j) {
  using namespace strict_json;
  try {
    ErrorSpaceFile out;
    Object root(j, "");
    if (string(root.required("format"), "/format") != "metron-error-space")
      fail("/format", "expected \"metron-error-space\"");
    integer(root.required("version"), "/version", 1, 1);
    if (const json* d = root.find("description")) out.description = string(*d, "/description");
    if (const json* o = root.find("sensor_offset_mm")) {
      const auto v = numbers(*o, "/sensor_offset_mm", 3);
      for (int a = 0; a < 3; ++a) out.sensor_offset_mm[a] = v[a];
    }
    Grid grid;
    {
      Object g(root.required("grid"), "/grid");
      const char* keys[3] = {"x_mm", "y_mm", "z_mm"};
      for (int a = 0; a < 3; ++a) {
        grid.axes_mm[a] = numbers(g.required(keys[a]), g.at(keys[a]));
        const auto& x = grid.axes_mm[a];
        if (x.empty()) fail(g.at(keys[a]), "expected at least one coordinate");
        for (std::size_t i = 1; i < x.size(); ++i)
          if (!(x[i] > x[i - 1]))
            fail(fmt::format("{}/{}", g.at(keys[a]), i), "expected strictly increasing coordinates");
      }
      g.finish();
    }
    {
      Object in(root.required("interpolation"), "/interpolation");
      const std::string m = string(in.required("method"), in.at("method"));
      if (m == "trilinear")
        out.interpolation.method = Method::Trilinear;
      else if (m == "bspline")
        out.interpolation.method = Method::BSpline;
      else if (m == "least-squares")
        out.interpolation.method = Method::LeastSquares;
      else
        fail(in.at("method"), "expected \"trilinear\", \"bspline\" or \"least-squares\"");
      if (out.interpolation.method == Method::LeastSquares) {
        if (const json* d = in.find("degree"))
          out.interpolation.least_squares.degree = integer(*d, in.at("degree"), 1, 2);
        if (const json* n = in.find("neighbourhood"))
          out.interpolation.least_squares.neighbourhood = integer(*n, in.at("neighbourhood"), 1, 100);
      }
      in.finish();
    }
    const json& temps = root.required("temperatures");
    if (!temps.is_array() || temps.empty()) fail("/temperatures", "expected a non-empty array");
    for (std::size_t t = 0; t < temps.size(); ++t) {
      const std::string p = fmt::format("/temperatures/{}", t);
      Object o(temps[t], p);
      ErrorSpace s;
      s.grid = grid;
      s.temperature_c = number(o.required("temperature_c"), o.at("temperature_c"));
      for (const auto& prev : out.spaces)
        if (prev.temperature_c == s.temperature_c)
          fail(o.at("temperature_c"), "expected a temperature not given before");
      Object comps(o.required("components"), o.at("components"));
      for (int c = 0; c < 3; ++c) {
        const std::string key(to_string(static_cast<Component>(c)));
        const json* cj = comps.find(key);
        if (!cj) continue;
        Object comp(*cj, comps.at(key));
        s.values_mm[c] = numbers(comp.required("values_mm"), comp.at("values_mm"), static_cast<long>(grid.size()));
        if (const json* sd = comp.find("sd_mm"))
          s.sd_mm[c] = numbers(*sd, comp.at("sd_mm"), static_cast<long>(grid.size()));
        comp.finish();
      }
      comps.finish();
      o.finish();
      if (!out.spaces.empty())
        for (int c = 0; c < 3; ++c)
          if (s.values_mm[c].empty() != out.spaces[0].values_mm[c].empty())
            fail(o.at("components"), "expected the same components at every temperature");
      out.spaces.push_back(std::move(s));
    }
    root.finish();
    // A file must be usable: the interpolation has to suit the grid.
    if (auto f = make_field(grid, std::vector<double>(grid.size(), 0.0), out.interpolation); !f)
      fail("/interpolation", f.error());
    return out;
  } catch (const strict_json::ReadError& e) {
    return tl::unexpected(FileError{e.pointer, e.message});
  }
}

tl::expected<void, std::string> write_error_space_file(const std::string& path, const ErrorSpaceFile& file) {
  std::ofstream out(path);
  if (!out) return tl::unexpected(fmt::format("{}: cannot open for writing", path));
  out << to_json(file).dump(1) << "\n";
  if (!out) return tl::unexpected(fmt::format("{}: write failed", path));
  return {};
}

tl::expected<ErrorSpaceFile, FileError> read_error_space_file(const std::string& path) {
  auto j = strict_json::read_document(path);
  if (!j) return tl::unexpected(FileError{"", j.error()});
  auto f = from_json(*j);
  if (!f)
    return tl::unexpected(
        FileError{f.error().pointer, fmt::format("{}: {}: {}", path, f.error().pointer, f.error().message)});
  return f;
}

}  // namespace metron::error_space
