// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target: the machine characterisation loader (runtime::load_characterisation, as
// `metron run --characterisation` reaches it through the session), then its text report.
#include <cstddef>
#include <cstdint>

#include "fuzz_file.hpp"
#include "metron/runtime/characterisation.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = metron::fuzz::input_file(data, size, "characterisation.json");
  const auto c = metron::runtime::load_characterisation(path);
  if (c) return metron::runtime::format_characterisation(*c).empty() ? 0 : 0;
  return 0;
}
