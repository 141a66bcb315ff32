// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target: a point file (NIST .ds or CSV x,y,z) as `metron fit` reads it.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "metron/stdlib/fitting/point_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto p = metron::fitting::parse_point_text(std::string_view(reinterpret_cast<const char*>(data), size));
  return p ? 0 : 0;
}
