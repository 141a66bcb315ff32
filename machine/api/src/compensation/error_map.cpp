// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/compensation/error_map.hpp"

#include <fmt/format.h>

namespace metron::machine {

tl::expected<ErrorSpaceMap, std::string> ErrorSpaceMap::build(const error_space::ErrorSpaceFile& file,
                                                              double monitored_temperature_c) {
  if (file.spaces.empty()) return tl::unexpected(std::string("an error-space file without spaces"));
  error_space::ErrorSpace space;
  try {
    space = error_space::at_temperature(file.spaces, monitored_temperature_c);
  } catch (const std::invalid_argument& e) {
    return tl::unexpected(std::string(e.what()));
  }
  auto interpolator = error_space::SpaceInterpolator::build(space, file.interpolation);
  if (!interpolator) return tl::unexpected(interpolator.error());
  return ErrorSpaceMap(std::move(*interpolator), std::make_shared<const error_space::ErrorSpaceFile>(file),
                       monitored_temperature_c);
}

Vec3 ErrorSpaceMap::error_at_mm(const Vec3& q_mm) const {
  // The grid is in ram positions of the calibration's sensor: the tip at q had the ram at q - offset.
  const Vec3 ram = q_mm - m_sensor_offset_mm;
  const auto e = m_interpolator.error_at(ram.x(), ram.y(), ram.z());
  return {e[0], e[1], e[2]};
}

tl::expected<std::shared_ptr<const ErrorMap>, std::string> load_error_map(const std::string& path,
                                                                          double monitored_temperature_c) {
  auto file = error_space::read_error_space_file(path);
  if (!file) {
    const auto& e = file.error();
    return tl::unexpected(e.pointer.empty() ? e.message : fmt::format("{}: {}: {}", path, e.pointer, e.message));
  }
  auto map = ErrorSpaceMap::build(*file, monitored_temperature_c);
  if (!map) return tl::unexpected(fmt::format("{}: {}", path, map.error()));
  return std::make_shared<const ErrorSpaceMap>(std::move(*map));
}

}  // namespace metron::machine
