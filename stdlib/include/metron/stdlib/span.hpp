// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>

namespace metron {

/// A byte range in one source file; line and column are computed on demand (SourceManager).
struct Span {
  std::uint32_t file = 0;   ///< index into the SourceManager (0 = no file)
  std::uint32_t begin = 0;  ///< first byte, physical file offset
  std::uint32_t end = 0;    ///< one past the last byte

  [[nodiscard]] bool valid() const { return file != 0; }
  [[nodiscard]] static Span join(Span a, Span b) {
    if (!a.valid()) return b;
    if (!b.valid()) return a;
    return Span{a.file, a.begin < b.begin ? a.begin : b.begin, a.end > b.end ? a.end : b.end};
  }
};

}  // namespace metron
