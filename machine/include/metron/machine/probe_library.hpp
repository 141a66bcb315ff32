// SPDX-License-Identifier: GPL-3.0-or-later
// The machine's probe library: the named, qualified sensors a shop-floor program selects with
// RECALL/SA(name) and SNSLCT/SA(name) without defining them (docs/world.md "probe_library").
#pragma once
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "metron/machine/command.hpp"

namespace metron::machine {

/// One sensor of the library, as the controller knows it (a tool of an I++ DME server).
struct LibrarySensor {
  std::string name;              ///< as the program writes it, compared case-insensitively
  double tip_diameter_mm = 4.0;  ///< nominal stylus ball diameter
  Vec3 offset_mm{0, 0, -50};     ///< ball centre from the head's reference point
};

/// The sensor named `name` (case-insensitive), if the library holds it.
std::optional<LibrarySensor> find_library_sensor(const std::vector<LibrarySensor>& library, std::string_view name);

/// The tool definition of a library sensor (direction and length from its offset).
DefineTool tool_definition(const LibrarySensor& sensor);

/// Reads `[{"name": ..., "tip_diameter_mm": ..., "offset_mm": [x, y, z]}, ...]` at JSON pointer
/// `ptr`; throws strict_json's error (with the pointer) on a bad entry or a repeated name.
std::vector<LibrarySensor> parse_probe_library(const nlohmann::json& j, const std::string& ptr);

}  // namespace metron::machine
