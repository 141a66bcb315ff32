// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <functional>
#include <memory>

#include "metron/machine/machine.hpp"
#include "metron/machine/world.hpp"

namespace metron::machine {

/// One controller cycle of motion, for plots and timing studies.
struct TraceSample {
  double time_s = 0;                  ///< simulated time at the end of the cycle
  Vec3 position_mm = Vec3::Zero();    ///< ball centre (undeflected), machine coordinates
  double speed_mm_s = 0;              ///< path speed
};

/// The virtual CMM: a motion controller stepping in cycles of dt (jerk-limited straight moves,
/// collision checks every cycle, skip input latched or scanned) driving a simulated world (the
/// part as machined, the probe's true pre-travel and delays, noise). The controller side only
/// sees sensor data: encoder positions, the trigger signal at its skip input, the probe's
/// collision and over-travel switches. Deterministic for a given world and seed.
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

  /// The controller's clock: cycles executed times dt.
  [[nodiscard]] double simulated_time_s() const;
  /// Called once per controller cycle while the machine moves (nullptr: no tracing).
  void set_trace(std::function<void(const TraceSample&)> trace);
  /// The simulated truth. For tests and hidden-truth reports only: the controller and the
  /// runtime must not use it (ARCHITECTURE.md rule 1).
  [[nodiscard]] const World& world() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

/// A virtual CMM for `world`, every random draw seeded from `seed`.
std::unique_ptr<Machine> make_virtual_cmm(const World& world, std::uint64_t seed);

}  // namespace metron::machine
