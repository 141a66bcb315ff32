// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <utility>

#include "metron/machine/virtual_cmm.hpp"

namespace metron::test_support {

/// A virtual CMM driven one command at a time with a 4 mm tool "T" (50 mm stylus, pointing down)
/// selected and not qualified: for tests that touch the simulated part directly.
class DirectMachine {
 public:
  DirectMachine(const machine::World& world, std::uint64_t seed) : cmm(world, seed) {
    exec(machine::DefineTool{"T", 4.0, -Vec3::UnitZ(), 50});
    exec(machine::SelectTool{"T"});
  }
  /// Executes one command; its response (a fault is a response too).
  machine::Response exec(decltype(machine::Command::body) body) {
    cmm.submit({m_tag++, std::move(body)});
    return cmm.execute().front();
  }
  machine::VirtualCmm cmm;

 private:
  std::uint64_t m_tag = 1;
};

}  // namespace metron::test_support
