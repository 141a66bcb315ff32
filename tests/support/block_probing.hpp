// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Probing the default block (docs/world.md: x 300..460, y 200..300, z 0..40 on the table) one
// command at a time through any machine: the tests of the machine errors in a run and of the
// compensation share it. Header-only, in metron_test_support.
#include <gtest/gtest.h>

#include "metron/machine/machine.hpp"

namespace metron::test_support {

class BlockProbing {
 public:
  /// Defines and selects T1 (4 mm ball, 50 mm stylus down) on `machine`.
  explicit BlockProbing(machine::Machine& machine) : m_machine(machine) {
    run(machine::DefineTool{"T1", 4.0});
    run(machine::SelectTool{"T1"});
  }
  /// One command; a fault fails the test.
  machine::Response run(decltype(machine::Command::body) body) {
    m_machine.submit({++m_tag, std::move(body)});
    auto r = m_machine.execute().front();
    EXPECT_EQ(r.status, machine::Response::Status::Done) << (r.fault ? r.fault->message : "");
    return r;
  }
  /// A face at x (LEFT 300: outward -1; RIGHT 460: +1) probed at y 250, z 20 from 10 mm outside,
  /// then retracted to z 60.
  machine::Hit touch_face(double x, double outward) {
    run(machine::GoTo{Vec3(x + 10 * outward, 250, 60), std::nullopt});
    run(machine::GoTo{Vec3(x + 10 * outward, 250, 20), std::nullopt});
    machine::PtMeas m;
    m.nominal_mm = Vec3(x, 250, 20);
    m.normal = Vec3(outward, 0, 0);
    const machine::Response r = run(m);
    run(machine::GoTo{Vec3(x + 10 * outward, 250, 60), std::nullopt});
    return r.hit.value_or(machine::Hit{});
  }
  /// Positioning moves high over the table, back and forth, until the clock passes `time_s`.
  void pass_time(double time_s) {
    while (run(machine::GoTo{Vec3(800, 700, 300), std::nullopt}).end_time_s < time_s)
      run(machine::GoTo{Vec3(100, 100, 300), std::nullopt});
  }

 private:
  machine::Machine& m_machine;
  std::uint64_t m_tag = 0;
};

}  // namespace metron::test_support
