// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <tl/expected.hpp>

#include "metron/stdlib/error_space/error_space.hpp"
#include "metron/stdlib/error_space/interpolation.hpp"

/// The error-space file (docs/error-space.md): JSON, "format": "metron-error-space",
/// "version": 1; one grid, the spaces at their temperatures, the interpolation to use.
namespace metron::error_space {

/// What an error-space file holds.
struct ErrorSpaceFile {
  std::vector<ErrorSpace> spaces;   ///< one per temperature, all on the same grid with the same components
  InterpolationSpec interpolation;  ///< how the controller interpolates between grid points
  std::string description;          ///< free text (how it was measured)
  /// The measuring tip's offset from the ram reference point during the calibration (the grid is
  /// in ram positions): the map describes the error at the tip position grid + offset
  /// (docs/error-space.md, "Compensation"). Optional in the file; default zero.
  std::array<double, 3> sensor_offset_mm{0, 0, 0};
};

/// A file that could not be read: "pointer: message" (pointer as RFC 6901).
struct FileError {
  std::string pointer;  ///< where
  std::string message;  ///< what was expected
};

/// The file's JSON. Throws std::invalid_argument when the spaces are empty or inconsistent.
nlohmann::json to_json(const ErrorSpaceFile& file);

/// Reads the JSON strictly: unknown keys, wrong types, non-increasing grids, value arrays of the
/// wrong length, duplicate temperatures are errors naming their JSON pointer.
tl::expected<ErrorSpaceFile, FileError> from_json(const nlohmann::json& j);

/// Writes the file (pretty-printed); an error message when it cannot be written.
tl::expected<void, std::string> write_error_space_file(const std::string& path, const ErrorSpaceFile& file);

/// Reads and parses a file; the error names the path, the pointer and what was expected.
tl::expected<ErrorSpaceFile, FileError> read_error_space_file(const std::string& path);

}  // namespace metron::error_space
