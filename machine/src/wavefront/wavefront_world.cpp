// SPDX-License-Identifier: GPL-3.0-or-later
// The strict loader of worlds of kind "wavefront" (docs/wavefront.md, "World file").
#include <cmath>
#include <fstream>
#include <numbers>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "metron/machine/wavefront/wavefront_world.hpp"
#include "metron/stdlib/json_reader.hpp"

namespace metron::machine::wavefront {
namespace {

using nlohmann::json;

struct ParseError {
  std::string pointer;
  std::string message;
};

[[noreturn]] void fail(const std::string& pointer, std::string message) {
  throw ParseError{pointer.empty() ? "/" : pointer, std::move(message)};
}

constexpr double kRad = std::numbers::pi / 180;

// An object being read; finish() reports every key the schema did not ask for.
class Object {
 public:
  Object(const json& j, std::string pointer) : m_json(j), m_pointer(std::move(pointer)) {
    if (!j.is_object()) fail(m_pointer, "expected an object");
  }
  [[nodiscard]] std::string at(const std::string& key) const { return m_pointer + "/" + key; }
  const json* find(const std::string& key) {
    m_known.insert(key);
    const auto it = m_json.find(key);
    return it == m_json.end() ? nullptr : &*it;
  }
  void number(const std::string& key, double& out, double min = -1e9, double max = 1e9) {
    if (const json* j = find(key)) {
      if (!j->is_number() || !std::isfinite(j->get<double>())) fail(at(key), "expected a finite number");
      out = j->get<double>();
      if (out < min || out > max) fail(at(key), fmt::format("expected a number in [{}, {}]", min, max));
    }
  }
  void vec(const std::string& key, double* out, int n) {
    if (const json* j = find(key)) {
      if (!j->is_array() || static_cast<int>(j->size()) != n)
        fail(at(key), fmt::format("expected an array of {} numbers", n));
      for (int i = 0; i < n; ++i) {
        const json& v = (*j)[static_cast<std::size_t>(i)];
        if (!v.is_number() || !std::isfinite(v.get<double>()))
          fail(at(key) + "/" + std::to_string(i), "expected a finite number");
        out[i] = v.get<double>();
      }
    }
  }
  void finish() const {
    for (const auto& item : m_json.items())
      if (!m_known.count(item.key())) fail(at(item.key()), fmt::format("unknown key '{}'", item.key()));
  }

 private:
  const json& m_json;
  std::string m_pointer;
  std::set<std::string> m_known;
};

void read_gauge(const json& j, const std::string& ptr, GaugeSpec& g) {
  Object o(j, ptr);
  o.number("wavelength_nm", g.wavelength_nm, 100, 20000);
  double pixels = g.pixels;
  o.number("pixels", pixels, 16, 4096);
  if (pixels != std::floor(pixels)) fail(o.at("pixels"), "expected an integer");
  g.pixels = static_cast<int>(pixels);
  o.number("sphere_sin_max", g.sphere_sin_max, 0.01, 0.95);
  o.number("sphere_reference_radius_mm", g.sphere_reference_radius_mm, 1, 10000);
  o.number("flat_radius_mm", g.flat_radius_mm, 1, 1000);
  o.number("noise_nm", g.noise_nm, 0, 1000);
  if (const json* e = o.find("element")) {
    if (*e == "sphere")
      g.element = Element::Sphere;
    else if (*e == "flat")
      g.element = Element::Flat;
    else
      fail(o.at("element"), "expected \"sphere\" or \"flat\"");
  }
  o.finish();
}

void read_nominal(const json& j, const std::string& ptr, NominalGeometry& n) {
  Object o(j, ptr);
  o.vec("step_mm", n.step_mm.data(), 3);
  o.number("zc_mm", n.zc_mm);
  o.number("table_height_mm", n.table_height_mm);
  o.vec("focus_mm", n.focus_mm.data(), 3);
  o.finish();
  for (int i = 0; i < 3; ++i)
    if (n.step_mm[i] <= 0) fail(ptr + "/step_mm/" + std::to_string(i), "expected a step size > 0");
}

void read_hidden(const json& j, const std::string& ptr, HiddenGeometry& h) {
  Object o(j, ptr);
  o.vec("step_mm", h.step_mm.data(), 3);
  o.vec("focus_mm", h.focus_mm.data(), 3);
  double deg[2];
  auto angle = [&](const std::string& key, double& out) {
    double d = out / kRad;
    o.number(key, d, -10, 10);
    out = d * kRad;
  };
  auto angle2 = [&](const std::string& key, Vec2& out) {
    deg[0] = out.x() / kRad, deg[1] = out.y() / kRad;
    o.vec(key, deg, 2);
    out = Vec2(deg[0], deg[1]) * kRad;
  };
  angle("gauge_tilt_x_deg", h.gauge_tilt_x_rad);
  angle("gauge_tilt_y_deg", h.gauge_tilt_y_rad);
  angle("gauge_clocking_deg", h.gauge_clocking_rad);
  angle("b_zero_deg", h.b_zero_rad);
  angle("c_zero_deg", h.c_zero_rad);
  angle2("a_tilt_deg", h.a_tilt_rad);
  angle("b_axis_tilt_deg", h.b_axis_tilt_rad);
  o.number("zc_mm", h.zc_mm);
  o.number("xb_mm", h.xb_mm);
  o.number("yc_mm", h.yc_mm);
  o.number("table_height_mm", h.table_height_mm);
  angle2("table_tilt_deg", h.table_tilt_rad);
  o.finish();
  for (int i = 0; i < 3; ++i)
    if (h.step_mm[i] <= 0) fail(ptr + "/step_mm/" + std::to_string(i), "expected a step size > 0");
}

PartSpec read_part(const json& j, const std::string& ptr) {
  Object o(j, ptr);
  PartSpec p;
  const json* name = o.find("name");
  if (!name || !name->is_string() || name->get<std::string>().empty()) fail(o.at("name"), "expected a part name");
  p.name = name->get<std::string>();
  if (const json* k = o.find("kind")) {
    if (*k == "sphere")
      p.kind = PartKind::Sphere;
    else if (*k == "flat")
      p.kind = PartKind::Flat;
    else
      fail(o.at("kind"), "expected \"sphere\" or \"flat\"");
  }
  o.number("radius_mm", p.radius_mm);
  if (p.kind == PartKind::Sphere && std::abs(p.radius_mm) < 0.1) fail(o.at("radius_mm"), "expected |radius| >= 0.1 mm");
  o.number("thickness_mm", p.thickness_mm, 0, 1e4);
  o.number("mount_height_mm", p.mount_height_mm, 0, 1e4);
  o.number("clear_radius_mm", p.clear_radius_mm, 0.1, 1e4);
  o.vec("decentre_mm", p.decentre_mm.data(), 2);
  double w[2] = {0, 0};
  o.vec("wedge_deg", w, 2);
  p.wedge_rad = Vec2(w[0], w[1]) * kRad;
  o.number("astigmatism_nm", p.astigmatism_nm);
  o.number("trefoil_nm", p.trefoil_nm);
  o.number("spherical_nm", p.spherical_nm);
  o.finish();
  return p;
}

WavefrontWorld read_world(const json& j) {
  Object o(j, "");
  const json* kind = o.find("kind");
  if (!kind || *kind != "wavefront") fail("/kind", "expected \"wavefront\"");
  WavefrontWorld w;
  if (const json* n = o.find("name")) {
    if (!n->is_string()) fail("/name", "expected a string");
    w.name = n->get<std::string>();
  }
  double seed = 1;
  o.number("seed", seed, 0, 9.0e15);
  w.seed = static_cast<std::uint64_t>(seed);
  if (const json* g = o.find("gauge")) read_gauge(*g, "/gauge", w.gauge);
  if (const json* n = o.find("nominal")) read_nominal(*n, "/nominal", w.nominal);
  if (const json* h = o.find("hidden")) read_hidden(*h, "/hidden", w.hidden);
  if (const json* ps = o.find("parts")) {
    if (!ps->is_array()) fail("/parts", "expected an array of parts");
    for (std::size_t i = 0; i < ps->size(); ++i) {
      w.parts.push_back(read_part((*ps)[i], "/parts/" + std::to_string(i)));
      for (std::size_t k = 0; k + 1 < w.parts.size(); ++k)
        if (w.parts[k].name == w.parts.back().name)
          fail("/parts/" + std::to_string(i) + "/name", "duplicate part name");
    }
  }
  if (const json* m = o.find("mounted")) {
    if (!m->is_string()) fail("/mounted", "expected a part name");
    w.mounted = m->get<std::string>();
    bool found = w.mounted.empty();
    for (const auto& p : w.parts) found = found || p.name == w.mounted;
    if (!found) fail("/mounted", fmt::format("no part named '{}' in /parts", w.mounted));
  }
  if (const json* s = o.find("start")) {
    Object so(*s, "/start");
    so.vec("steps", w.start.steps.data(), 3);
    so.number("a_deg", w.start.a_deg);
    so.number("b_deg", w.start.b_deg, -180, 180);
    so.number("c_deg", w.start.c_deg, -180, 180);
    so.finish();
  }
  o.finish();
  return w;
}

}  // namespace

tl::expected<WavefrontWorld, std::string> parse_wavefront_world(const nlohmann::json& json,
                                                                const std::string& source_name) {
  try {
    return read_world(json);
  } catch (const ParseError& e) {
    return tl::unexpected(fmt::format("{}: {}: {}", source_name, e.pointer, e.message));
  }
}

tl::expected<WavefrontWorld, std::string> load_wavefront_world(const std::string& path) {
  // The strict reader: a regular file within the input cap, bounded nesting, numbers in range,
  // never an exception (nlohmann's parse threw out_of_range on 1e400, which nothing caught).
  auto j = strict_json::read_document(path);
  if (!j) return tl::unexpected(j.error());
  return parse_wavefront_world(*j, path);
}

}  // namespace metron::machine::wavefront
