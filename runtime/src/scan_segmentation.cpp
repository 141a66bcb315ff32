// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/runtime/scan_segmentation.hpp"

namespace metron::runtime {

namespace seg = machine::segmented;

std::vector<std::size_t> command_sizes(std::size_t M, std::size_t P) {
  std::vector<std::size_t> sizes;
  if (M == 0 || P == 0) return sizes;
  const std::size_t n = M / P, m = M % P;
  if (n == 0) return {m};
  if (m == 0) return std::vector<std::size_t>(n, P);
  if (4 * m < P) {
    // SEEDS.md 2 step 1: m < P/4, so Cn and Cn+1 get (P+m)/2 each (averaging).
    sizes.assign(n - 1, P);
    sizes.push_back((P + m + 1) / 2);
    sizes.push_back((P + m) / 2);
    return sizes;
  }
  sizes.assign(n, P);
  sizes.push_back(m);
  return sizes;
}

std::vector<seg::MeasurementCommand> split_commands(const geometry::PccPath& path, std::size_t P) {
  std::vector<seg::MeasurementCommand> out;
  std::size_t first = 0;
  const auto sizes = command_sizes(path.segments.size(), P);
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    seg::MeasurementCommand c;
    c.index = i;
    c.first_segment = first;
    const auto b = path.segments.begin() + static_cast<std::ptrdiff_t>(first);
    c.segments.assign(b, b + static_cast<std::ptrdiff_t>(sizes[i]));
    if (path.speed_mm_s.size() == path.segments.size()) {
      const auto v = path.speed_mm_s.begin() + static_cast<std::ptrdiff_t>(first);
      c.speed_mm_s.assign(v, v + static_cast<std::ptrdiff_t>(sizes[i]));
    }
    if (path.normals.size() == path.segments.size() + 1) {
      const auto n = path.normals.begin() + static_cast<std::ptrdiff_t>(first);
      c.normals.assign(n, n + static_cast<std::ptrdiff_t>(sizes[i]) + 1);
    }
    c.last = i + 1 == sizes.size();
    first += sizes[i];
    out.push_back(std::move(c));
  }
  return out;
}

std::vector<machine::Command> scan_commands(const machine::ScanPath& scan, std::size_t capacity) {
  if (capacity == 0 || scan.path.segments.size() <= capacity) return {machine::Command{0, scan}};
  std::vector<machine::Command> out;
  for (seg::MeasurementCommand& c : split_commands(scan.path, capacity)) {
    machine::ScanBufferWrite w;
    w.scan = scan;
    w.scan.path = {};
    w.command = std::move(c);
    out.push_back({0, std::move(w)});
  }
  return out;
}

SegmentedScanResult scan_segmented(machine::Machine& machine, const machine::ScanPath& scan, std::uint64_t tag) {
  SegmentedScanResult out;
  const std::size_t capacity = machine.state().scan_buffer_segments;
  const auto answer = [&](machine::Command command) {
    machine.submit(std::move(command));
    auto responses = machine.execute();
    machine::Response& r = responses.front();
    out.samples.insert(out.samples.end(), r.scan.begin(), r.scan.end());
    out.log.insert(out.log.end(), r.scan_log.begin(), r.scan_log.end());
    if (r.status == machine::Response::Status::Fault) out.fault = r.fault;
    return !out.fault;
  };
  for (machine::Command& c : scan_commands(scan, capacity)) {
    if (std::holds_alternative<machine::ScanBufferWrite>(c.body)) ++out.commands;
    c.tag = tag;
    if (!answer(std::move(c))) break;
  }
  return out;
}

}  // namespace metron::runtime
