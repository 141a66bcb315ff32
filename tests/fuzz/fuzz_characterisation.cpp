// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target: a machine characterisation file (docs/touch-trigger.md) through the strict
// JSON reader and its schema.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "metron/runtime/characterisation.hpp"
#include "metron/stdlib/json_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto j = metron::strict_json::parse_document(std::string_view(reinterpret_cast<const char*>(data), size));
  if (!j) return 0;
  const auto c = metron::runtime::characterisation_from_json(*j);
  if (c) (void)metron::runtime::format_characterisation(*c);
  return 0;
}
