// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <tl/expected.hpp>

#include "metron/machine/machine.hpp"
#include "metron/machine/world.hpp"

namespace metron::machine {

/// One controller cycle of motion, for plots and timing studies.
struct TraceSample {
  double time_s = 0;                ///< simulated time at the end of the cycle
  Vec3 position_mm = Vec3::Zero();  ///< ball centre (undeflected), machine coordinates
  double speed_mm_s = 0;            ///< path speed
};

/// The virtual CMM: a motion controller stepping in cycles of dt (jerk-limited straight moves,
/// collision checks every cycle, skip input latched or scanned) driving a simulated world (the
/// part as machined, the probe's true pre-travel and delays, noise). The controller side only
/// sees sensor data: encoder positions, the trigger signal at its skip input, the probe's
/// collision and over-travel switches. The world is split at construction: the controller keeps
/// `world.machine` (its configuration), the simulation `world.truth`. Deterministic for a given
/// world and seed.
///
/// PtMeas geometry: with r the active tool's effective radius, the ball centre approaches to
/// nominal + (r + approach) * normal, probes toward nominal + (r - search) * normal, and after
/// a hit retracts to hit + retract * normal (distances are those of the ball's surface).
class VirtualCmm final : public Machine {
 public:
  VirtualCmm(World world, std::uint64_t seed);
  ~VirtualCmm() override;

  void submit(Command command) override;
  std::vector<Response> execute() override;
  [[nodiscard]] MachineState state() const override;
  [[nodiscard]] std::vector<Command> queued() const override;
  std::optional<Response> stop_last_motion(double after_s) override;
  bool set_motion_observer(std::function<void(double time_s, const Vec3& position_mm)> observer) override;
  /// The world's part goes to its next set-up (World part.setups), if there is one.
  std::optional<std::string> operator_stop() override;

  /// The controller's clock: cycles executed times dt.
  [[nodiscard]] double simulated_time_s() const;
  /// Called once per controller cycle while the machine moves (nullptr: no tracing).
  void set_trace(std::function<void(const TraceSample&)> trace);
  /// The run seed every random draw derives from.
  [[nodiscard]] std::uint64_t seed() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
  std::uint64_t m_seed;
};

/// A virtual CMM for `world`, every random draw seeded from `seed`.
std::unique_ptr<Machine> make_virtual_cmm(const World& world, std::uint64_t seed);

/// The virtual CMM of the world file at `world_path` (none: the embedded default world), seeded
/// with `seed` (none: the world's own seed); the error names the file. The composition root's
/// way to build this backend.
tl::expected<std::unique_ptr<VirtualCmm>, WorldError> open_virtual_cmm(const std::optional<std::string>& world_path,
                                                                       std::optional<std::uint64_t> seed);

}  // namespace metron::machine
