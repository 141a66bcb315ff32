// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "metron/machine/machine.hpp"

namespace metron::machine::ipp {

/// "ipp://host:port" (port default 1294); nullopt when it is not of that form.
std::optional<std::pair<std::string, std::uint16_t>> parse_ipp_url(std::string_view url);

/// A machine backend that drives an I++ DME server over TCP (metron's own `metron serve`, or a
/// controller): each machine command becomes protocol commands, each answer a Response.
/// GoTo -> GoTo; PtMeas -> SetProp(Tool.PtMeasPar...) and PtMeas with the ball-centre nominal;
/// DefineTool (SNSDEF) -> the server's tool of the same name, else the one with the same ball
/// diameter and stylus direction (EnumTools, FindTool, FoundTool.AvrRadius/.Alignment; with a
/// warning), else a fault naming the sensor; SelectTool -> ChangeTool of that tool;
/// QualifyTool -> ReQualify; SetFeeds -> SetProp(Tool.GoToPar/PtMeasPar.Speed, .Accel);
/// ScanPath -> ScanOnCurve through the ends of its segments (ball centres at the contact, with
/// their normals; ScanOnCurveDensity when the program sets a spacing and the server takes it).
/// ScanBufferWrite (a segmented scan) is not mapped: answered BadCommand. Errors come back as
/// faults, and the client clears them. GOHOME: the server's home is not part of the protocol
/// (MachineState::home_mm stays empty).
/// The controller's clock is not part of the protocol: times in responses are 0.
class ClientMachine final : public Machine {
 public:
  /// Connects, starts a session and homes the machine when it is not homed; throws
  /// std::runtime_error when the server cannot be reached or refuses.
  ClientMachine(const std::string& host, std::uint16_t port);
  ~ClientMachine() override;  ///< ends the session

  void submit(Command command) override;
  std::vector<Response> execute() override;
  [[nodiscard]] MachineState state() const override;
  [[nodiscard]] std::vector<Command> queued() const override;
  /// Where warnings go (a sensor mapped onto a server tool of another name or geometry);
  /// without a handler they are only in the transcript.
  void on_warning(std::function<void(const std::string&)> handler);
  /// Every line sent (`> `) and received (`< `), for diagnostics.
  [[nodiscard]] const std::vector<std::string>& transcript() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace metron::machine::ipp
