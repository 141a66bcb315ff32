// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <optional>
#include <string>

#include <tl/expected.hpp>

#include "metron/interpreter/session.hpp"
#include "metron/machine/compensation/compensated_machine.hpp"
#include "metron/machine/error_space/calibration.hpp"
#include "metron/machine/nominal_machine.hpp"
#include "metron/machine/virtual_cmm.hpp"
#include "metron/machine/wavefront/simulated_wavefront_machine.hpp"

// The composition root's choice of backend: the virtual CMM of a world file. Header-only so the
// end-to-end tests build the same backend as `metron run`; a real controller would be another
// BackendFactory here.
namespace metron::cli {

/// The calibration plan of CALIBRATE ERROR-SPACE's words or `metron calibrate error-space`'s options
/// (both held as a runtime::ErrorSpaceRequest): the grid from origin in steps of the head's spacing.
inline machine::SpaceCalibrationPlan error_space_plan(const runtime::ErrorSpaceRequest& r, std::uint64_t seed) {
  machine::SpaceCalibrationPlan plan;
  plan.head.spacing_mm = r.step_mm;
  plan.head.noise_sd_mm = r.sensor_noise_um * 1e-3;
  plan.head.sensor_offset_mm = Vec3(r.sensor_offset_mm[0], r.sensor_offset_mm[1], r.sensor_offset_mm[2]);
  for (int a = 0; a < 3; ++a)
    for (int i = 0; i < r.size[a]; ++i) plan.grid.axes_mm[a].push_back(r.origin_mm[a] + r.step_mm * i);
  plan.components = r.components;
  plan.delta_by_reversal = r.reversal;
  plan.head.angle_instrument = r.angle_instrument;
  plan.head.angle_noise_sd_rad = r.angle_noise_urad * 1e-6;
  plan.runs = r.runs;
  plan.laser_cycles = r.laser_cycles;
  plan.seed = seed;
  return plan;
}

/// The virtual CMM for a world file (none: the embedded default) and a seed (none: the world's).
inline tl::expected<interpreter::Backend, std::string> virtual_cmm_backend(const std::optional<std::string>& world_path,
                                                                           std::optional<std::uint64_t> seed) {
  auto cmm = machine::open_virtual_cmm(world_path, seed);
  if (!cmm) return tl::unexpected(cmm.error().message);
  const std::uint64_t run_seed = (*cmm)->seed();
  // The controller's compensation (docs/error-space.md): none until `--compensation` or a
  // program's CALL/EXTERN,SYS,'COMPENSATION file' gives a map; without one it is the identity.
  interpreter::Backend b{std::make_unique<machine::CompensatedMachine>(std::move(*cmm), nullptr),
                         world_path ? *world_path : std::string("<default>"),
                         run_seed,
                         {},
                         {}};
  // CALIBRATE WAVEFRONT: the simulated station of a wavefront world, with the world's own seed
  // (the same run as `metron calibrate wavefront --world W`).
  b.wavefront_stations =
      [](const std::string& path) -> tl::expected<std::unique_ptr<machine::wavefront::WavefrontMachine>, std::string> {
    auto w = machine::wavefront::load_wavefront_world(path);
    if (!w) return tl::unexpected(w.error());
    const auto world_seed = w->seed;
    return std::make_unique<machine::wavefront::SimulatedWavefrontMachine>(std::move(*w), world_seed);
  };
  // CALIBRATE ERROR-SPACE: the two-point rig on this world's machine (its hidden errors, which
  // only the rig's simulated sensors read) with the run's seed, as `metron calibrate error-space`.
  b.error_space_rig =
      [world_path,
       run_seed](const runtime::ErrorSpaceRequest& r) -> tl::expected<runtime::ErrorSpaceOutcome, std::string> {
    auto world = machine::load_world_or_default(world_path);
    if (!world) return tl::unexpected(world.error().message);
    const machine::SpaceCalibrationPlan plan = error_space_plan(r, run_seed);
    try {
      machine::SpaceCalibration run = machine::calibrate_space(world->truth.errors, plan);
      return runtime::ErrorSpaceOutcome{std::move(run.space), static_cast<int>(run.planes.size()),
                                        run.planes_to_remeasure};
    } catch (const std::invalid_argument& e) {
      return tl::unexpected(std::string(e.what()));
    }
  };
  return b;
}

/// `metron run --dry-run`: the dry-run machine (every touch at its nominal) with the world's
/// probe library and feeds (none: the embedded default world's).
inline tl::expected<interpreter::Backend, std::string> nominal_backend(const std::optional<std::string>& world_path) {
  auto world = machine::load_world_or_default(world_path);
  if (!world) return tl::unexpected(world.error().message);
  return interpreter::Backend{std::make_unique<machine::NominalMachine>(world->machine),
                              (world_path ? *world_path : std::string("<default>")) + " (dry run)",
                              0,
                              {},
                              {}};
}

}  // namespace metron::cli
