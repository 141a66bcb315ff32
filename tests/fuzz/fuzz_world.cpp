// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target: a world file through the strict JSON reader and the world parser (no
// "extends" to files: the base directory is empty).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "metron/machine/world.hpp"
#include "metron/stdlib/json_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto j = metron::strict_json::parse_document(std::string_view(reinterpret_cast<const char*>(data), size));
  if (!j) return 0;
  if (j->is_object() && j->contains("extends") && (*j)["extends"] != "default") return 0;
  const auto w = metron::machine::parse_world(*j, "<fuzz>", "");
  return w ? 0 : 0;
}
