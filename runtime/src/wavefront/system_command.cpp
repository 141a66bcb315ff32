// SPDX-License-Identifier: GPL-3.0-or-later
// CALL/EXTERN,SYS,'CALIBRATE WAVEFRONT world [step]' (docs/wavefront.md, "Calling it from a DMIS
// program"): the SEEDS.md 5 calibration on a simulated wavefront station, from a part program.
#include <filesystem>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "metron/machine/wavefront/wavefront_machine.hpp"
#include "metron/runtime/measurement_runtime.hpp"
#include "metron/runtime/outputs.hpp"
#include "metron/runtime/wavefront/calibration.hpp"

namespace metron::runtime {

std::string wavefront_result_file_name(const std::string& step) {
  return step == "all" ? std::string("wavefront-calibration.json") : fmt::format("wavefront-calibration-{}.json", step);
}

Result<void> MeasurementRuntime::calibrate_wavefront(const std::string& world_path, const std::string& step,
                                                     Span span) {
  if (auto refused = m_policy.refuse_read(world_path)) return program_error(span, "CALIBRATE WAVEFRONT: " + *refused);
  if (!m_wavefront_stations)
    return program_error(span, "CALIBRATE WAVEFRONT: this run has no wavefront station (the backend provides none)");
  auto station = m_wavefront_stations(world_path);
  if (!station) return program_error(span, "CALIBRATE WAVEFRONT: " + station.error());
  auto report = wavefront::calibrate(**station, step);
  if (!report) return program_error(span, "CALIBRATE WAVEFRONT " + step + ": calibration failed: " + report.error());
  nlohmann::json j = wavefront::to_json(*report);
  j["world"] = world_path;
  j["step"] = step;
  // Always the run's output directory, under a name made from the step (never a path the program
  // chose: docs/wavefront.md).
  const std::string name = wavefront_result_file_name(step);
  const std::string full = (std::filesystem::path(m_output_dir) / name).string();
  const std::string json_text = j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  if (auto failed = write_file_atomically(full, json_text))
    return program_error(span, "CALIBRATE WAVEFRONT: " + *failed);
  std::string summary =
      fmt::format("wavefront calibration ({}, {} gauge maps) written to {}", step, report->maps, name);
  if (report->b_rotation)
    summary +=
        fmt::format("; B rotation: xb {:.4f} um, zF {:.4f} mm, B tilt {:.3f} urad", report->b_rotation->xb_mm * 1e3,
                    report->b_rotation->zf_mm, report->b_rotation->b_axis_tilt_rad * 1e6);
  if (report->a_to_z && !report->a_to_z->iterations.empty())
    summary += fmt::format("; A to Z {} after {} iterations", report->a_to_z->converged ? "parallel" : "NOT parallel",
                           report->a_to_z->iterations.size());
  text("PRINT", summary);
  return {};
}

}  // namespace metron::runtime
