// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include "metron/machine/command.hpp"

namespace metron::machine {

/// The answer every backend gives to a queued command after an earlier one faulted
/// (Machine::execute): not executed, FaultKind::Aborted, where and when the machine stands.
inline Response aborted_response(const Command& command, const Vec3& position_mm, double time_s) {
  Response r;
  r.tag = command.tag;
  r.status = Response::Status::Fault;
  r.fault = Fault{FaultKind::Aborted, "not executed: an earlier command faulted", position_mm, time_s};
  return r;
}

}  // namespace metron::machine
