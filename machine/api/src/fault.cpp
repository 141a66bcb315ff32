// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/fault.hpp"

namespace metron::machine {

const char* to_string(FaultKind kind) {
  switch (kind) {
    case FaultKind::Collision: return "collision";
    case FaultKind::NoContact: return "no contact";
    case FaultKind::OverTravel: return "over-travel";
    case FaultKind::AxisLimit: return "axis limit";
    case FaultKind::NoTool: return "no tool";
    case FaultKind::UnknownTool: return "unknown tool";
    case FaultKind::BadCommand: return "bad command";
    case FaultKind::Aborted: return "aborted";
    case FaultKind::Stalled: return "stalled";
    case FaultKind::Communication: return "communication";
  }
  return "unknown fault";
}

}  // namespace metron::machine
