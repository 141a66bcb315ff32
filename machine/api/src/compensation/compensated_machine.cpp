// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/compensation/compensated_machine.hpp"

#include <cmath>

#include "metron/stdlib/fitting/fit.hpp"

namespace metron::machine {

CompensatedMachine::CompensatedMachine(std::unique_ptr<Machine> inner, std::shared_ptr<const ErrorMap> map)
    : m_inner(std::move(inner)) {
  set_map(std::move(map));
}

void CompensatedMachine::set_map(std::shared_ptr<const ErrorMap> map) {
  m_map = std::move(map);
  const auto by_file = std::dynamic_pointer_cast<const ErrorSpaceMap>(m_map);
  m_by_temperature = by_file && by_file->follows_temperature() ? by_file : nullptr;
  follow_temperature();
}

void CompensatedMachine::follow_temperature() {
  if (!m_by_temperature) return;
  const auto t = m_inner->state().temperature_c;
  if (!t) return;  // no thermometer: the map stays at the temperature it was built for
  const auto* now = static_cast<const ErrorSpaceMap*>(m_map.get());
  if (std::abs(*t - now->temperature_c()) < 0.01) return;
  if (auto at = m_by_temperature->at_temperature(*t)) m_map = std::make_shared<const ErrorSpaceMap>(std::move(*at));
}

Vec3 CompensatedMachine::command_for(const Vec3& wanted_mm) const {
  if (!m_map) return wanted_mm;
  // The tip reaches q + e(q); we want P: q = P - e(q) (docs/error-space.md, "Compensation").
  Vec3 q = wanted_mm;
  for (int i = 0; i < 2; ++i) q = wanted_mm - m_map->error_at_mm(q);
  return q;
}

Vec3 CompensatedMachine::corrected(const Vec3& reported_mm) const {
  return m_map ? Vec3(reported_mm + m_map->error_at_mm(reported_mm)) : reported_mm;
}

namespace {

void shift(std::vector<geometry::PccSegment>& segments, const Vec3& by_mm) {
  for (auto& s : segments) s.k.col(0) += by_mm;
}

}  // namespace

void CompensatedMachine::submit(Command command) {
  m_queued.push_back(command);
  follow_temperature();
  if (m_map) {
    if (auto* g = std::get_if<GoTo>(&command.body)) {
      g->target_mm = command_for(g->target_mm);
    } else if (auto* p = std::get_if<PtMeas>(&command.body)) {
      p->nominal_mm = command_for(p->nominal_mm);
    } else if (auto* s = std::get_if<ScanPath>(&command.body)) {
      if (!s->path.segments.empty()) {
        const Vec3 start = s->path.segments.front().start();
        shift(s->path.segments, command_for(start) - start);
      }
    } else if (auto* c = std::get_if<ContourScan>(&command.body)) {
      // One shift for the whole scan (its start), as for a path: the section and the end move with it.
      const Vec3 shift_mm = command_for(c->start_mm) - c->start_mm;
      c->start_mm += shift_mm;
      c->section.point_mm += shift_mm;
      c->end.point_mm += shift_mm;
    } else if (auto* w = std::get_if<ScanBufferWrite>(&command.body)) {
      // One shift for the whole scan (its first command's start), so the pieces still join.
      if (w->command.index == 0 && !w->command.segments.empty()) {
        const Vec3 start = w->command.segments.front().start();
        m_scan_shift_mm = command_for(start) - start;
      }
      shift(w->command.segments, m_scan_shift_mm);
    }
  }
  m_inner->submit(std::move(command));
}

std::optional<double> CompensatedMachine::compensated_radius(const std::string& tool) const {
  const auto it = m_qualifications.find(tool);
  if (!m_map || it == m_qualifications.end()) return std::nullopt;
  const Qualification& q = it->second;
  if (q.radius_map != m_map.get()) {
    // The sphere of corrected ball centres has radius R + r_effective (as in the machine's own fit).
    std::vector<Vec3> pts;
    for (const Vec3& c : q.centres_mm) pts.push_back(corrected(c));
    fitting::FitOptions options;
    options.inner = false;
    const auto f = fitting::fit(fitting::Shape::Sphere, pts, options);
    if (!f) return std::nullopt;
    q.radius_mm = f->diameter_mm / 2 - q.reference_diameter_mm / 2;
    q.radius_map = m_map.get();
  }
  return q.radius_mm;
}

void CompensatedMachine::compensate_tool(ToolInfo& info) const {
  if (const auto r = compensated_radius(info.name)) info.effective_radius_mm = *r;
}

std::vector<Response> CompensatedMachine::execute() {
  m_queued.clear();
  auto responses = m_inner->execute();
  for (const auto& r : responses)
    if (r.tool && r.tool->qualified && !r.tool->qualification_centres_mm.empty() && r.tool->reference_diameter_mm > 0)
      m_qualifications[r.tool->name] = {r.tool->qualification_centres_mm, r.tool->reference_diameter_mm};
  if (!m_map) return responses;
  const std::string active = m_inner->state().active_tool;
  const auto radius = compensated_radius(active);
  for (auto& r : responses) {
    if (r.tool) compensate_tool(*r.tool);
    if (r.hit && radius) r.hit->ball_radius_mm = *radius;
    if (r.hit) r.hit->centre_mm = corrected(r.hit->centre_mm);
    for (auto& s : r.scan) s.centre_mm = corrected(s.centre_mm);
    if (r.fault) r.fault->position_mm = corrected(r.fault->position_mm);
  }
  return responses;
}

MachineState CompensatedMachine::state() const {
  MachineState s = m_inner->state();
  if (m_map) {
    s.position_mm = corrected(s.position_mm);
    if (s.tool) compensate_tool(*s.tool);
    if (s.last_hit) {
      s.last_hit->centre_mm = corrected(s.last_hit->centre_mm);
      if (const auto r = compensated_radius(s.active_tool)) s.last_hit->ball_radius_mm = *r;
    }
  }
  return s;
}

std::vector<Command> CompensatedMachine::queued() const { return m_queued; }

}  // namespace metron::machine
