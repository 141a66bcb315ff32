// SPDX-License-Identifier: GPL-3.0-or-later
// The segmented-scan session of the virtual CMM's controller (SEEDS.md 2): measurement commands
// written by the host into the double buffer while the segmented controller scans.
#include <algorithm>
#include <cmath>

#include "controller.hpp"

namespace metron::machine::detail {

// SEEDS.md 2: the host writes Ci into a free buffer; the controller scans meanwhile.
void Controller::write_scan_buffer(const ScanBufferWrite& body, Response& response) {
  const segmented::MeasurementCommand& command = body.command;
  const auto fail = [&](Fault f) {
    response.status = Response::Status::Fault;
    response.fault = std::move(f);
    segmented_scan.reset();
  };
  if (command.index == 0) {
    if (segmented_scan)
      return fail({FaultKind::BadCommand, "a segmented scan is already in progress", position, now()});
    const Tool* tool = active_tool();
    if (!tool) return fail({FaultKind::NoTool, "no tool selected", position, now()});
    // The scan's settings with the first command's segments: what the approach needs.
    ScanPath first = body.scan;
    first.path.segments = command.segments;
    first.path.normals = command.normals;
    first.path.speed_mm_s = command.speed_mm_s;
    if (const std::string bad = validate_scan(first); !bad.empty())
      return fail({FaultKind::BadCommand, bad, position, now()});
    if (auto ok = move_to(scan_approach_point(first), positioning_feed); !ok) return fail(ok.error());
    sim.set_time(now());
    const ScanSetup setup = sim.scan_setup(tool->info.nominal_radius_mm, config);
    const SegmentedScanSpec& g = config.scanning.segmented;
    segmented::ControllerConfig cfg;
    cfg.mode = g.mode;
    cfg.buffer_segments = g.buffer_segments;
    cfg.planning_s_per_segment = g.planning_s_per_segment;
    cfg.planning_fixed_s = g.planning_fixed_s;
    cfg.planning_margin = g.planning_margin;
    cfg.low = {g.low_length_mm, g.low_speed_mm_s};
    cfg.dt_s = config.dt_s;
    const double feed = body.scan.speed_mm_s.value_or(config.scanning.control.feed_mm_s);
    cfg.limits.path = {std::min(feed, config.max_speed_mm_s), g.path_acceleration_mm_s2, g.path_jerk_mm_s3};
    cfg.limits.normal_acceleration_mm_s2 = config.scanning.control.max_centripetal_mm_s2;
    cfg.retract_mm = body.scan.retract_mm;
    segmented::ProbeDriveSpec drive;
    drive.retract_mm = body.scan.retract_mm;
    ScanPath settings = body.scan;
    settings.path = {};
    auto session = std::make_unique<SegmentedSession>();
    session->probe = std::make_unique<segmented::ProbeScanDriver>(settings, setup, position, now(), drive);
    session->controller = std::make_unique<segmented::SegmentedController>(cfg, session->probe.get());
    segmented_scan = std::move(session);
  } else if (!segmented_scan) {
    return fail(
        {FaultKind::BadCommand,
         fmt::format("measurement command {} without a segmented scan in progress (the first is 0)", command.index),
         position, now()});
  }
  SegmentedSession& g = *segmented_scan;
  segmented::SegmentedController& ctl = *g.controller;
  segmented::ProbeScanDriver& probe = *g.probe;
  for (const auto& seg : command.segments)
    if (!seg.k.allFinite() || !std::isfinite(seg.d_mm) || seg.d_mm < 0)
      return fail({FaultKind::BadCommand, "scan path has a non-finite segment", position, now()});
  const double limit_s = now() + 3600;  // a controller that never frees a buffer is a bug, not a hang
  const auto step = [&] {
    ctl.step();
    emit(probe.time_s(), probe.position_mm(), probe.velocity_mm_s().norm());
  };
  // The host waits on SB: the controller runs until a buffer is writable.
  while (ctl.free_buffer() == 0 && !ctl.finished() && !probe.fault() && probe.time_s() < limit_s) step();
  std::optional<Fault> problem = probe.fault();
  if (!problem) {
    if (auto ok = ctl.load(command); !ok) {
      problem = ok.error();
      problem->position_mm = probe.position_mm();
      problem->time_s = probe.time_s();
    }
  }
  if (!problem && command.last) {
    while (!ctl.finished() && !probe.fault() && probe.time_s() < limit_s) step();
    if (!probe.fault() && !probe.finish(ctl.path_state().s_mm))
      problem = Fault{FaultKind::Stalled, "segmented scan did not finish at the path end", probe.position_mm(),
                      probe.time_s()};
    if (probe.fault()) problem = probe.fault();
  }
  const auto& samples = probe.samples();
  response.scan.assign(samples.begin() + static_cast<std::ptrdiff_t>(g.reported), samples.end());
  g.reported = samples.size();
  position = probe.position_mm();
  cycle += cycles_for(probe.time_s() - now());
  if (problem || command.last) {
    const segmented::SegmentedStats& st = ctl.stats();
    response.scan_log.push_back(fmt::format(
        "segmented scan: {} commands of up to {} segments, {} stops, {} retracts, {} late plans, {} samples",
        command.index + 1, ctl.config().buffer_segments, st.stops, probe.retracts(), st.late_plans, samples.size()));
  }
  if (problem) return fail(*problem);
  if (command.last) segmented_scan.reset();
}

}  // namespace metron::machine::detail
