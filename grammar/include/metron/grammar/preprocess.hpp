// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace metron::grammar {

/// One logical line: `$` continuations joined and `$$` comments removed, with a map from each
/// logical byte back to its physical offset in the file so positions point into the real file.
struct LogicalLine {
  std::string text;
  std::vector<std::uint32_t> physical;  ///< physical[i] = file offset of text[i]; size text.size()+1
};

/// Splits a DMIS source into logical lines (blank and comment-only lines are dropped).
std::vector<LogicalLine> join_continuations(const std::string& source);

}  // namespace metron::grammar
