// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/machine_errors/error_model.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

#include "metron/machine/machine_errors/catalogue_terms.hpp"
#include "metron/machine/machine_errors/grid_field.hpp"
#include "metron/machine/machine_errors/rigid_body.hpp"
#include "metron/machine/machine_errors/thermal.hpp"

namespace metron::machine {

Vec3 MachineErrorModel::displacement(const MachinePose& pose, double t) const {
  Vec3 e = Vec3::Zero();
  for (const auto& term : m_terms) e += term->displacement(pose, t);
  return e;
}

Vec3 MachineErrorModel::tool_displacement(const MachinePose& pose, double t) const {
  Vec3 e = Vec3::Zero();
  for (const auto& term : m_terms)
    if (term->acts() == ErrorTerm::Acts::Tool) e += term->displacement(pose, t);
  return e;
}

namespace {

using nlohmann::json;
using namespace strict_json;

int axis_index(const json& j, const std::string& p) {
  const std::string s = string(j, p);
  if (s == "x") return 0;
  if (s == "y") return 1;
  if (s == "z") return 2;
  fail(p, "expected \"x\", \"y\" or \"z\"");
}

// A number (constant), {"poly": [c0, c1, ...]} or {"at_mm": [...], "values": [...], "interpolation": "linear"|"cubic"}.
AxisFunction axis_function(const json& j, const std::string& p) {
  if (j.is_number()) return AxisFunction::polynomial({number(j, p)});
  Object o(j, p);
  AxisFunction f;
  if (const json* poly = o.find("poly")) {
    f = AxisFunction::polynomial(numbers(*poly, o.at("poly")));
  } else {
    const auto at = numbers(o.required("at_mm"), o.at("at_mm"));
    const auto values = numbers(o.required("values"), o.at("values"), static_cast<long>(at.size()));
    if (at.size() < 2) fail(o.at("at_mm"), "expected at least 2 positions");
    for (std::size_t i = 1; i < at.size(); ++i)
      if (!(at[i] > at[i - 1])) fail(fmt::format("{}/{}", o.at("at_mm"), i), "expected increasing positions");
    auto interp = AxisFunction::Interpolation::Linear;
    if (const json* in = o.find("interpolation")) {
      const std::string s = string(*in, o.at("interpolation"));
      if (s == "cubic")
        interp = AxisFunction::Interpolation::Cubic;
      else if (s != "linear")
        fail(o.at("interpolation"), "expected \"linear\" or \"cubic\"");
    }
    f = AxisFunction::table(at, values, interp);
  }
  o.finish();
  return f;
}

std::shared_ptr<const TemperatureHistory> history(const json& j, const std::string& p, const json* air,
                                                  const std::string& air_p) {
  // {"lag_s": 600, "initial_c": 20.5} against the shared air history, or its own {"t_s", "temperature_c"}.
  Object o(j, p);
  double lag = 0, initial = std::numeric_limits<double>::quiet_NaN();
  if (const json* l = o.find("lag_s")) {
    lag = number(*l, o.at("lag_s"));
    if (lag < 0) fail(o.at("lag_s"), "expected a number >= 0");
  }
  if (const json* i = o.find("initial_c")) initial = number(*i, o.at("initial_c"));
  const json* own = o.find("air_c");
  const json* src = own ? own : air;
  const std::string sp = own ? o.at("air_c") : air_p;
  if (!src) fail(p, "missing key 'air_c' (no thermal.air_c to follow)");
  Object a(*src, sp);
  const auto t = numbers(a.required("t_s"), a.at("t_s"));
  const auto temp = numbers(a.required("temperature_c"), a.at("temperature_c"), static_cast<long>(t.size()));
  if (t.empty()) fail(a.at("t_s"), "expected at least one time");
  for (std::size_t i = 1; i < t.size(); ++i)
    if (!(t[i] > t[i - 1])) fail(fmt::format("{}/{}", a.at("t_s"), i), "expected increasing times");
  a.finish();
  o.finish();
  return std::make_shared<TemperatureHistory>(t, temp, lag, initial);
}

MachineErrorModel parse(const json& j, const std::string& p) {
  MachineErrorModel model;
  Object root(j, p);
  std::array<int, 3> stacking{1, 0, 2};
  if (const json* s = root.find("stacking")) {
    if (!s->is_array() || s->size() != 3) fail(root.at("stacking"), "expected 3 axes from the base to the ram");
    int seen = 0;
    for (std::size_t i = 0; i < 3; ++i) {
      stacking[i] = axis_index((*s)[i], fmt::format("{}/{}", root.at("stacking"), i));
      if (seen & (1 << stacking[i])) fail(fmt::format("{}/{}", root.at("stacking"), i), "expected each axis once");
      seen |= 1 << stacking[i];
    }
  }
  std::array<AxisErrors, 3> axes;
  bool rigid = false;
  if (const json* a = root.find("axes")) {
    Object ao(*a, root.at("axes"));
    for (int ax = 0; ax < 3; ++ax) {
      const std::string name(1, "xyz"[ax]);
      const json* e = ao.find(name);
      if (!e) continue;
      Object eo(*e, ao.at(name));
      const char* tkeys[3] = {"tx_mm", "ty_mm", "tz_mm"};
      const char* rkeys[3] = {"rx_rad", "ry_rad", "rz_rad"};
      for (int c = 0; c < 3; ++c) {
        if (const json* f = eo.find(tkeys[c]))
          axes[ax].translation_mm[c] = axis_function(*f, eo.at(tkeys[c])), rigid = true;
        if (const json* f = eo.find(rkeys[c]))
          axes[ax].rotation_rad[c] = axis_function(*f, eo.at(rkeys[c])), rigid = true;
      }
      eo.finish();
    }
    ao.finish();
  }
  Squareness sq;
  if (const json* s = root.find("squareness_rad")) {
    Object so(*s, root.at("squareness_rad"));
    if (const json* v = so.find("xy")) sq.xy_rad = number(*v, so.at("xy")), rigid = true;
    if (const json* v = so.find("xz")) sq.xz_rad = number(*v, so.at("xz")), rigid = true;
    if (const json* v = so.find("yz")) sq.yz_rad = number(*v, so.at("yz")), rigid = true;
    so.finish();
  }
  if (rigid) model.add(std::make_shared<RigidBodyTerm>(axes, sq, stacking));
  if (const json* r = root.find("reversal_mm")) {
    Object ro(*r, root.at("reversal_mm"));
    std::array<double, 3> rev{0, 0, 0};
    for (int ax = 0; ax < 3; ++ax)
      if (const json* v = ro.find(std::string(1, "xyz"[ax])))
        rev[static_cast<std::size_t>(ax)] = number(*v, ro.at(std::string(1, "xyz"[ax])));
    ro.finish();
    model.add(std::make_shared<ReversalTerm>(rev));
  }
  if (const json* fields = root.find("fields")) {
    if (!fields->is_array()) fail(root.at("fields"), "expected an array of grid fields");
    for (std::size_t i = 0; i < fields->size(); ++i) {
      const std::string fp = fmt::format("{}/{}", root.at("fields"), i);
      Object fo((*fields)[i], fp);
      const int comp = axis_index(fo.required("component"), fo.at("component"));
      error_space::Grid grid;
      grid.axes_mm = {std::vector<double>{0.0}, std::vector<double>{0.0}, std::vector<double>{0.0}};
      int n_axes = 0;
      for (int ax = 0; ax < 3; ++ax) {
        const std::string key = std::string(1, "xyz"[ax]) + "_mm";
        if (const json* g = fo.find(key)) {
          grid.axes_mm[ax] = numbers(*g, fo.at(key));
          if (grid.axes_mm[ax].size() < 2) fail(fo.at(key), "expected at least 2 grid coordinates");
          for (std::size_t k = 1; k < grid.axes_mm[ax].size(); ++k)
            if (!(grid.axes_mm[ax][k] > grid.axes_mm[ax][k - 1]))
              fail(fmt::format("{}/{}", fo.at(key), k), "expected increasing coordinates");
          ++n_axes;
        }
      }
      if (n_axes < 2) fail(fp, "expected a grid on 2 or 3 of x_mm, y_mm, z_mm");
      const auto values = numbers(fo.required("values_mm"), fo.at("values_mm"), static_cast<long>(grid.size()));
      fo.finish();
      model.add(std::make_shared<GridFieldTerm>(comp, grid, values));
    }
  }
  if (const json* th = root.find("thermal")) {
    Object to(*th, root.at("thermal"));
    const json* air = to.find("air_c");  // checked where a body follows it
    if (const json* sc = to.find("scales")) {
      Object so(*sc, to.at("scales"));
      std::array<ScaleThermalTerm::Scale, 3> scales;
      for (int ax = 0; ax < 3; ++ax) {
        const std::string name(1, "xyz"[ax]);
        const json* s = so.find(name);
        if (!s) continue;
        Object one(*s, so.at(name));
        scales[static_cast<std::size_t>(ax)].alpha_per_k = number(one.required("alpha_per_k"), one.at("alpha_per_k"));
        if (const json* f = one.find("fixed_at_mm"))
          scales[static_cast<std::size_t>(ax)].fixed_at_mm = number(*f, one.at("fixed_at_mm"));
        const json* t = one.find("temperature");
        const json empty = json::object();
        scales[static_cast<std::size_t>(ax)].temperature =
            history(t ? *t : empty, one.at("temperature"), air, to.at("air_c"));
        one.finish();
      }
      so.finish();
      model.add(std::make_shared<ScaleThermalTerm>(scales));
    }
    if (const json* pt = to.find("part")) {
      Object po(*pt, to.at("part"));
      const double alpha = number(po.required("alpha_per_k"), po.at("alpha_per_k"));
      const auto fixed = numbers(po.required("fixed_point_mm"), po.at("fixed_point_mm"), 3);
      const json* t = po.find("temperature");
      const json empty = json::object();
      auto hist = history(t ? *t : empty, po.at("temperature"), air, to.at("air_c"));
      po.finish();
      model.add(std::make_shared<PartThermalTerm>(alpha, Vec3(fixed[0], fixed[1], fixed[2]), hist));
    }
    to.finish();
  }
  // The model-discrepancy catalogue's terms (docs/discrepancy.md).
  if (const json* t = root.find("terms")) parse_catalogue_terms(*t, root.at("terms"), model);
  root.finish();
  return model;
}

}  // namespace

tl::expected<MachineErrorModel, strict_json::ReadError> parse_machine_errors(const json& j,
                                                                             const std::string& pointer) {
  if (j.is_null()) return MachineErrorModel{};
  try {
    return parse(j, pointer);
  } catch (const strict_json::ReadError& e) {
    return tl::unexpected(e);
  } catch (const std::invalid_argument& e) {
    return tl::unexpected(strict_json::ReadError{pointer, e.what()});
  }
}

}  // namespace metron::machine
