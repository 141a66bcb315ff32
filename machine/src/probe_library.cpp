// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/probe_library.hpp"

#include <algorithm>
#include <cctype>
#include <set>

#include <nlohmann/json.hpp>

#include "metron/stdlib/json_reader.hpp"
#include "metron/stdlib/text_encoding.hpp"

namespace metron::machine {
namespace {

std::string upper(std::string_view s) { return upper_utf8(s); }

}  // namespace

std::optional<LibrarySensor> find_library_sensor(const std::vector<LibrarySensor>& library, std::string_view name) {
  const std::string want = upper(name);
  const auto it =
      std::find_if(library.begin(), library.end(), [&](const LibrarySensor& s) { return upper(s.name) == want; });
  if (it == library.end()) return std::nullopt;
  return *it;
}

DefineTool tool_definition(const LibrarySensor& sensor) {
  DefineTool t;
  t.name = sensor.name;
  t.ball_diameter_mm = sensor.tip_diameter_mm;
  const double length = sensor.offset_mm.norm();
  if (length > 1e-9) {
    t.stylus_direction = sensor.offset_mm / length;
    t.stylus_length_mm = length;
  }
  return t;
}

std::vector<LibrarySensor> parse_probe_library(const nlohmann::json& j, const std::string& ptr) {
  namespace sj = strict_json;
  if (!j.is_array())
    sj::fail(ptr, "expected an array of sensors [{\"name\", \"tip_diameter_mm\", \"offset_mm\"}, ...]");
  std::vector<LibrarySensor> out;
  std::set<std::string> names;
  for (std::size_t i = 0; i < j.size(); ++i) {
    const std::string p = ptr + "/" + std::to_string(i);
    sj::Object o(j[i], p);
    LibrarySensor s;
    s.name = o.get("name", sj::string);
    if (s.name.empty()) sj::fail(o.at("name"), "a sensor needs a name");
    if (!names.insert(upper(s.name)).second) sj::fail(o.at("name"), "sensor '" + s.name + "' is listed twice");
    s.tip_diameter_mm = o.get("tip_diameter_mm", sj::positive);
    o.vec3("offset_mm", s.offset_mm);
    o.finish();
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace metron::machine
