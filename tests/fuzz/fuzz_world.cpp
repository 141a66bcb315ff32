// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target: the machine world loader (machine::load_world_or_default, as `metron run
// --world`, `serve`, `characterise` and `calibrate error-space` call it).
#include <cstddef>
#include <cstdint>

#include "fuzz_file.hpp"
#include "metron/machine/world.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = metron::fuzz::input_file(data, size, "world.json");
  const auto world = metron::machine::load_world_or_default(path);
  return world ? 0 : 0;
}
