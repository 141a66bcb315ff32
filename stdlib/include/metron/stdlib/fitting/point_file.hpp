// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include <tl/expected.hpp>

#include "metron/stdlib/geometry/vec.hpp"

namespace metron::fitting {

/// Why a point file could not be read.
struct PointFileError {
  std::string message;   ///< complete and lowercase, naming the record: "line 7: expected 3 numbers, got 2"
  std::size_t line = 0;  ///< 1-based line the error refers to; 0 for the whole file (e.g. cannot open)
};

/// Reads points in mm from the text of a point file. Accepted layouts:
///  - NIST .ds: a first line holding the point count N, then N lines "x y z" (spaces or tabs);
///  - CSV: "x,y,z" per line, with an optional header line of non-numeric text first;
///  - plain "x y z" per line, optionally after such a header.
/// Blank lines and CRLF line ends are allowed anywhere. Any other content, a count that does not
/// match, or a non-finite coordinate is an error; corrupt input never crashes.
tl::expected<std::vector<Vec3>, PointFileError> parse_point_text(std::string_view text);

/// parse_point_text() on the contents of the file at `path`.
tl::expected<std::vector<Vec3>, PointFileError> read_point_file(const std::string& path);

}  // namespace metron::fitting
