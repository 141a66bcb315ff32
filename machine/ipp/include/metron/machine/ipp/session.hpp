// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "metron/machine/command.hpp"
#include "metron/machine/machine.hpp"

namespace metron::machine::ipp {

/// What the server offers besides what the machine reports (docs/ipp-dme.md).
struct SessionOptions {
  /// Probing tools offered next to "NoTool", "BaseTool" and "RefTool" (which carry no stylus).
  std::vector<DefineTool> tools{DefineTool{"Probe1", 2.0, -Vec3::UnitZ(), 50.0}};
  std::string machine_class = "CartCMM";   ///< GetMachineClass answer
  double max_speed_mm_s = 500;             ///< GoToPar.Speed.Max and PtMeasPar.Speed.Max
  double max_acceleration_mm_s2 = 3000;    ///< GoToPar.Accel.Max and PtMeasPar.Accel.Max
  Vec3 home_mm{0, 0, 500};                 ///< where Home() moves the ball centre (machine coordinates)
  bool start_homed = false;                ///< IsHomed() before the first Home()
  double scan_reference_deflection_mm = 0.3;  ///< E0 of the scanning commands (SEEDS.md 1)
};

/// The answer to one received line.
struct SessionReply {
  std::vector<std::string> lines;          ///< response lines in order, without line terminators
  double motion_s = 0;                     ///< simulated time the machine moved (for real-time pacing)
};

/// The server side of one I++ DME session, without any networking: command lines in, response
/// lines out, the machine driven through machine::Machine. One Session per client connection.
/// Commands run to completion before handle() returns (the machine is simulated), so an
/// E-command such as AbortE finds nothing moving.
class Session {
 public:
  explicit Session(Machine& machine, SessionOptions options = {});
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  /// Handles one received line (a trailing CR/LF is ignored).
  SessionReply handle(std::string_view line);
  /// EndSession was answered: the connection should close.
  [[nodiscard]] bool ended() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace metron::machine::ipp
