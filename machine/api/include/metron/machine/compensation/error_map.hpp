// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <memory>
#include <string>

#include <tl/expected.hpp>

#include "metron/stdlib/error_space/error_space_file.hpp"
#include "metron/stdlib/error_space/interpolation.hpp"
#include "metron/stdlib/geometry/vec.hpp"

namespace metron::machine {

/// What the controller knows of its machine's geometry errors (a compensation table, ARCHITECTURE.md
/// rule 1: a calibration result, never the simulated truth): e(q), where the tip really is at
/// q + e(q) when the scales put it at q (docs/error-space.md, "Compensation").
class ErrorMap {
 public:
  virtual ~ErrorMap() = default;
  /// The error vector e (mm) at the tip position `q_mm` as the scales read it (machine coordinates).
  [[nodiscard]] virtual Vec3 error_at_mm(const Vec3& q_mm) const = 0;
};

/// The error map of an error-space file (SEEDS.md 4): the spaces at the monitored temperature,
/// interpolated as the file says, queried at the tip position minus the calibration's sensor
/// offset (the file's grid is in ram positions). Missing components are zero.
class ErrorSpaceMap final : public ErrorMap {
 public:
  /// Builds the interpolator once (at_temperature, then the file's method); an error message when
  /// the file's spaces do not suit it.
  static tl::expected<ErrorSpaceMap, std::string> build(const error_space::ErrorSpaceFile& file,
                                                        double monitored_temperature_c = 20);
  [[nodiscard]] Vec3 error_at_mm(const Vec3& q_mm) const override;
  /// The file's spaces were measured at more than one temperature: the map depends on the monitored one.
  [[nodiscard]] bool follows_temperature() const { return m_file->spaces.size() > 1; }
  /// The monitored temperature this map was built for.
  [[nodiscard]] double temperature_c() const { return m_temperature_c; }
  /// The same file's map at another monitored temperature.
  [[nodiscard]] tl::expected<ErrorSpaceMap, std::string> at_temperature(double monitored_temperature_c) const {
    return build(*m_file, monitored_temperature_c);
  }

 private:
  ErrorSpaceMap(error_space::SpaceInterpolator interpolator, std::shared_ptr<const error_space::ErrorSpaceFile> file,
                double temperature_c)
      : m_interpolator(std::move(interpolator)), m_file(std::move(file)), m_temperature_c(temperature_c) {
    const auto& o = m_file->sensor_offset_mm;
    m_sensor_offset_mm = Vec3(o[0], o[1], o[2]);
  }
  error_space::SpaceInterpolator m_interpolator;
  std::shared_ptr<const error_space::ErrorSpaceFile> m_file;  ///< for another temperature
  double m_temperature_c = 20;
  Vec3 m_sensor_offset_mm = Vec3::Zero();
};

/// Reads an error-space file into a map; the error names the path, the JSON pointer and what was
/// expected (the way `metron run --compensation` reports a bad file).
tl::expected<std::shared_ptr<const ErrorMap>, std::string> load_error_map(const std::string& path,
                                                                          double monitored_temperature_c = 20);

}  // namespace metron::machine
