// SPDX-License-Identifier: GPL-3.0-or-later
#include "stream_commands.hpp"

#include <fmt/format.h>

namespace metron::test_support {

namespace seg = machine::segmented;

tl::expected<seg::SegmentedStats, machine::Fault> stream_commands(const std::vector<seg::MeasurementCommand>& commands,
                                                                  seg::SegmentedController& controller,
                                                                  double max_time_s) {
  std::size_t next = 0;
  while (!controller.finished()) {
    // The host writes into a buffer as soon as its status flag says writable.
    while (next < commands.size() && controller.free_buffer() != 0) {
      if (auto r = controller.load(commands[next]); !r) return tl::unexpected(r.error());
      ++next;
    }
    controller.step();
    if (controller.time_s() > max_time_s) {
      return tl::unexpected(machine::Fault{machine::FaultKind::Aborted,
                                           fmt::format("segmented scan not finished after {:.1f} s", max_time_s),
                                           Vec3::Zero(), controller.time_s()});
    }
  }
  return controller.stats();
}

}  // namespace metron::test_support
