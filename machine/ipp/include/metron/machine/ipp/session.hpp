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
  std::string machine_class = "CartCMM";      ///< GetMachineClass answer
  double max_speed_mm_s = 500;                ///< GoToPar.Speed.Max and PtMeasPar.Speed.Max
  double max_acceleration_mm_s2 = 3000;       ///< GoToPar.Accel.Max and PtMeasPar.Accel.Max
  Vec3 home_mm{0, 0, 500};                    ///< where Home() moves the ball centre (machine coordinates)
  bool start_homed = false;                   ///< IsHomed() before the first Home()
  double scan_reference_deflection_mm = 0.3;  ///< E0 of the scanning commands (SEEDS.md 1)
};

/// The answer to one received line.
struct SessionReply {
  std::vector<std::string> lines;  ///< response lines in order, without line terminators
  double motion_s = 0;             ///< simulated time the machine moved (for real-time pacing)
  /// When each line is due, in seconds of simulated motion after the acknowledgement (real-time
  /// pacing): daemon reports along the motion at their time, the rest at the motion's end.
  std::vector<double> due_s;
  /// interrupt() stopped the paced command: these lines replace what is left of its answer.
  bool interrupted = false;
};

/// The server side of one I++ DME session, without any networking: command lines in, response
/// lines out, the machine driven through machine::Machine. One Session per client connection.
/// Commands run to completion before handle() returns (the machine is simulated); a server that
/// paces the answers in real time passes lines received meanwhile to interrupt(), so that an
/// AbortE stops the motion where it would have been.
class Session {
 public:
  explicit Session(Machine& machine, SessionOptions options = {});
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  /// Handles one received line (a trailing CR/LF is ignored).
  SessionReply handle(std::string_view line);
  /// Handles a line received `elapsed_s` after the last command's acknowledgement while its
  /// answer is still paced: an AbortE stops that command on the machine at that point of its
  /// motion (Machine::stop_last_motion) and answers it 0006 (reply.interrupted); any other line
  /// is handled as handle() does.
  SessionReply interrupt(std::string_view line, double elapsed_s);
  /// EndSession was answered: the connection should close.
  [[nodiscard]] bool ended() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace metron::machine::ipp
