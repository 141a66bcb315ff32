// SPDX-License-Identifier: GPL-3.0-or-later
// CALL/EXTERN,SYS,'CALIBRATE ERROR-SPACE ...' (docs/error-space.md, "From a DMIS program"): the
// SEEDS.md 4 calibration of the run's machine from a part program. The map is written into the
// output directory with its report and the controller compensates by it from the next statement,
// as an installation program would leave the machine.
#include "metron/runtime/error_space/calibrate_command.hpp"

#include <cmath>
#include <filesystem>
#include <optional>
#include <sstream>

#include <fmt/format.h>

#include "metron/machine/compensation/compensated_machine.hpp"
#include "metron/runtime/measurement_runtime.hpp"
#include "metron/runtime/outputs.hpp"
#include "metron/stdlib/error_space/error_space_file.hpp"
#include "metron/stdlib/error_space/report_svg.hpp"

namespace metron::runtime {

namespace {

std::string upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

// The whole word as a finite number.
std::optional<double> whole_number(const std::string& word) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(word, &used);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  if (used == 0 || used != word.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

// "a,b,c" as three numbers.
template <typename T>
tl::expected<std::array<T, 3>, std::string> triple(const std::string& key, const std::string& value) {
  std::array<T, 3> out{};
  std::istringstream in(value);
  std::string part;
  int n = 0;
  while (std::getline(in, part, ',')) {
    if (n == 3) return tl::unexpected(fmt::format("{}={}: expected three numbers", key, value));
    const auto v = whole_number(part);
    if (!v) return tl::unexpected(fmt::format("{}={}: '{}' is not a number", key, value, part));
    if constexpr (std::is_integral_v<T>) {
      if (*v != std::floor(*v) || *v < 1 || *v > 1000)
        return tl::unexpected(fmt::format("{}={}: counts are whole numbers 1 to 1000", key, value));
    }
    out[static_cast<std::size_t>(n++)] = static_cast<T>(*v);
  }
  if (n != 3) return tl::unexpected(fmt::format("{}={}: expected three numbers", key, value));
  return out;
}

tl::expected<double, std::string> one_number(const std::string& key, const std::string& value, double lo, double hi) {
  const auto v = whole_number(value);
  if (!v || !(*v >= lo && *v <= hi))
    return tl::unexpected(fmt::format("{}={}: expected a number from {} to {}", key, value, lo, hi));
  return *v;
}

}  // namespace

tl::expected<ErrorSpaceRequest, std::string> parse_error_space_request(const std::string& words) {
  ErrorSpaceRequest r;
  std::istringstream in(words);
  std::string word;
  while (in >> word) {
    const auto eq = word.find('=');
    const std::string key = upper(word.substr(0, eq));
    const std::string value = eq == std::string::npos ? std::string() : word.substr(eq + 1);
    if (key == "REVERSAL" && eq == std::string::npos) {
      r.reversal = true;
      continue;
    }
    if (key == "ANGLE") {
      r.angle_instrument = true;
      if (eq == std::string::npos) continue;
      auto v = one_number(key, value, 0, 100);
      if (!v) return tl::unexpected(v.error());
      r.angle_noise_urad = *v;
      continue;
    }
    if (eq == std::string::npos || value.empty())
      return tl::unexpected(
          fmt::format("'{}': expected KEY=VALUE (SIZE, ORIGIN, STEP, COMPONENTS, NOISE, OFFSET, RUNS, "
                      "LASER, ANGLE) or REVERSAL, ANGLE",
                      word));
    if (key == "SIZE") {
      auto t = triple<int>(key, value);
      if (!t) return tl::unexpected(t.error());
      r.size = *t;
    } else if (key == "ORIGIN") {
      auto t = triple<double>(key, value);
      if (!t) return tl::unexpected(t.error());
      r.origin_mm = *t;
    } else if (key == "OFFSET") {
      auto t = triple<double>(key, value);
      if (!t) return tl::unexpected(t.error());
      r.sensor_offset_mm = *t;
    } else if (key == "STEP") {
      auto v = one_number(key, value, 1, 1000);
      if (!v) return tl::unexpected(v.error());
      r.step_mm = *v;
    } else if (key == "NOISE") {
      auto v = one_number(key, value, 0, 100);
      if (!v) return tl::unexpected(v.error());
      r.sensor_noise_um = *v;
    } else if (key == "RUNS" || key == "LASER") {
      auto v = one_number(key, value, 1, 100);
      if (!v || *v != std::floor(*v))
        return tl::unexpected(fmt::format("{}={}: expected a whole number from 1 to 100", key, value));
      (key == "RUNS" ? r.runs : r.laser_cycles) = static_cast<int>(*v);
    } else if (key == "COMPONENTS") {
      const std::string axes = upper(value);
      r.components = {false, false, false};
      for (char c : axes) {
        if (c != 'X' && c != 'Y' && c != 'Z')
          return tl::unexpected(fmt::format("COMPONENTS={}: the axes are X, Y and Z", value));
        r.components[static_cast<std::size_t>(c - 'X')] = true;
      }
    } else {
      return tl::unexpected(
          fmt::format("unknown word '{}' (SIZE, ORIGIN, STEP, COMPONENTS, NOISE, OFFSET, RUNS, LASER, "
                      "REVERSAL, ANGLE)",
                      word));
    }
  }
  const long points = static_cast<long>(r.size[0]) * r.size[1] * r.size[2];
  if (points > 250000) return tl::unexpected(fmt::format("SIZE: {} grid points; at most 250000", points));
  return r;
}

Result<void> MeasurementRuntime::calibrate_error_space(const ErrorSpaceRequest& request, Span span) {
  const std::string what = "CALIBRATE ERROR-SPACE";
  auto* compensated = dynamic_cast<machine::CompensatedMachine*>(&m_machine);
  if (!compensated || !m_error_space_rig)
    return program_error(span, what + ": this machine backend has no error-space rig and takes no compensation map");
  const std::filesystem::path dir(m_output_dir);
  const std::string map_path = (dir / kErrorSpaceFileName).string(),
                    report_path = (dir / kErrorSpaceReportName).string();
  for (const std::string& p : {map_path, report_path})
    if (auto refused = m_policy.refuse_write(p)) return program_error(span, what + ": " + *refused);
  auto outcome = m_error_space_rig(request);
  if (!outcome) return program_error(span, what + ": " + outcome.error());

  error_space::ErrorSpaceFile file;
  file.spaces.push_back(outcome->space);
  file.sensor_offset_mm = request.sensor_offset_mm;
  file.description = "CALL/EXTERN,SYS 'CALIBRATE ERROR-SPACE', sequential two-point method (SEEDS.md 4)";
  auto map = machine::ErrorSpaceMap::build(file);
  if (!map) return program_error(span, what + ": " + map.error());
  if (auto failed = write_file_atomically(map_path, error_space::to_json(file).dump(1) + "\n"))
    return program_error(span, what + ": " + *failed);

  error_space::ReportInput report;
  report.title = "Error-space calibration from a DMIS program, sequential two-point method (SEEDS.md 4)";
  report.notes.push_back(
      fmt::format("grid {} x {} x {}, step {} mm; sensor noise {} um; {} planes, S7 planes to re-measure: {}",
                  request.size[0], request.size[1], request.size[2], request.step_mm, request.sensor_noise_um,
                  outcome->planes, outcome->planes_to_remeasure));
  std::string summary =
      fmt::format("error space {} x {} x {} written to {} (report {}); the controller compensates by it from here on",
                  request.size[0], request.size[1], request.size[2], kErrorSpaceFileName, kErrorSpaceReportName);
  for (int c = 0; c < 3; ++c) {
    const auto comp = static_cast<error_space::Component>(c);
    if (!outcome->space.has(comp)) continue;
    const char axis = "xyz"[c];
    const double z0 = outcome->space.grid.axes_mm[2].front();
    report.maps.push_back(
        error_space::slice_map(outcome->space, comp, 0, fmt::format("recovered e_{} at z = {} mm", axis, z0)));
    if (auto m = error_space::validation_map(outcome->space, comp, 0, error_space::InterpolationSpec{},
                                             fmt::format("validation residual, e_{}", axis)))
      report.maps.push_back(*m);
    double v2 = 0, f2 = 0;
    const auto& values = outcome->space.values_mm[c];
    const auto& sd = outcome->space.sd_mm[c];
    for (std::size_t i = 0; i < values.size(); ++i) {
      v2 += values[i] * values[i];
      if (i < sd.size()) f2 += sd[i] * sd[i];
    }
    const double n = static_cast<double>(std::max<std::size_t>(1, values.size()));
    summary += fmt::format("; e_{} RMS {:.3f} um (noise floor {:.3f} um)", axis, 1e3 * std::sqrt(v2 / n),
                           1e3 * std::sqrt(f2 / n));
  }
  if (outcome->planes_to_remeasure > 0)
    warn(span, fmt::format("{}: {} planes fail the S7 disagreement check and should be measured again", what,
                           outcome->planes_to_remeasure));
  if (auto failed = write_file_atomically(report_path, error_space::report_svg(report)))
    return program_error(span, what + ": " + *failed);
  compensated->set_map(std::make_shared<const machine::ErrorSpaceMap>(std::move(*map)));
  text("PRINT", summary);
  return {};
}

}  // namespace metron::runtime
