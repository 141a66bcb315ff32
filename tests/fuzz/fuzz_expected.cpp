// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target: the expected-file parser of the regression harness (`metron test`), and
// the writer `--update` uses, which must read back to the same file.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "metron/regression/regression.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto parsed = metron::regression::parse_expected(text);
  if (!parsed) return 0;
  // Round trip: what --update writes must parse again, and write identically.
  const std::string written = metron::regression::format_expected(*parsed);
  const auto again = metron::regression::parse_expected(written);
  if (!again) std::abort();
  if (metron::regression::format_expected(*again) != written) std::abort();
  return 0;
}
