// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>

#include "metron/stdlib/geometry/vec.hpp"

namespace metron::machine {

/// Why the machine stopped a command. Faults are expected outcomes, returned as values.
enum class FaultKind {
  Collision,      ///< the probe touched the part on a positioning move
  NoContact,      ///< no surface within the search distance of a probing move
  OverTravel,     ///< the stop distance after a trigger exceeded the probe's over-travel limit
  AxisLimit,      ///< a target outside the axis travel
  NoTool,         ///< probing or qualification without a selected tool
  UnknownTool,    ///< a tool name the machine does not know
  BadCommand,     ///< a command with invalid parameters (zero direction, negative distance ...)
  Aborted,        ///< a queued command not executed because an earlier one faulted
  Stalled,        ///< a scan made no progress along its path (e.g. a correction term opposing the path velocity)
  Communication,  ///< the link to the machine (an I++ DME server) was lost or answered what cannot be read
};

const char* to_string(FaultKind kind);

/// A machine fault: what happened, where and when (simulated time).
struct Fault {
  FaultKind kind = FaultKind::BadCommand;
  std::string message;  ///< lowercase, human-readable, e.g. "no contact within 5.000 mm of the nominal point"
  Vec3 position_mm = Vec3::Zero();  ///< machine position when the fault was raised
  double time_s = 0;
};

}  // namespace metron::machine
