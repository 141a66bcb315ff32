// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target: the point-file reader of `metron fit` (NIST .ds, CSV, plain x y z), then
// the least-squares fits the command offers on whatever it read.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "metron/stdlib/fitting/fit.hpp"
#include "metron/stdlib/fitting/point_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto points = metron::fitting::parse_point_text(text);
  if (!points || points->size() > 2000) return 0;  // the fits are O(n) per iteration: keep runs fast
  // The first byte picks the shape, as `metron fit TYPE` would.
  const char* names[] = {"point", "line", "plane", "circle", "sphere", "cylinder", "cone"};
  const auto shape = metron::fitting::shape_from_name(names[size > 0 ? data[0] % 7 : 0]);
  if (!shape) std::abort();
  const auto result = metron::fitting::fit(*shape, *points);
  return result ? 0 : 0;
}
