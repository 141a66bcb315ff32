// SPDX-License-Identifier: GPL-3.0-or-later
// A part's set-ups: PAUSE (the operator may move the part) and EQUATE/DA(a),DA(b), which carries
// what one set-up measured into the next (docs/alignments.md, "A part in two set-ups").
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "metron/runtime/measurement_runtime.hpp"
#include "metron/runtime/report_units.hpp"

namespace metron::runtime {

void MeasurementRuntime::operator_stop(Span span) {
  m_operator_stops_s.push_back(m_machine.state().time_s);
  if (const auto done = m_machine.operator_stop()) note(span, fmt::format("PAUSE: {}", *done));
}

// DMIS 5.2 (quoted by a public VisualDMIS page): EQUATE/DA(a),DA(b) "creates a transformation from
// DA(label1) to DA(label2) and updates previously measured features and coordinate systems by the
// transformation". Which features were measured before the part moved is not said. metron cuts the
// set-ups at the operator's stops (PAUSE), the moments the part could be moved: with stops between
// DA(a)'s first point and DA(b)'s, the earlier set-up is what was measured between the stops around
// DA(a)'s first point, with what earlier EQUATEs carried into that set-up (so a part in three
// set-ups is made one by EQUATE/DA(1),DA(3) and EQUATE/DA(2),DA(3) as by EQUATE/DA(1),DA(2) and
// EQUATE/DA(2),DA(3)). Without a stop between them, what rests on points taken before the first
// point DA(b) rests on (the later set-up's first datum point), so the features DA(b) was built
// from are not moved themselves.
Result<void> MeasurementRuntime::equate(const std::string& earlier, const std::string& later, Span span) {
  const Alignment* a = find_alignment(earlier);
  const Alignment* b = find_alignment(later);
  for (const auto& [label, frame] : {std::pair{earlier, a}, std::pair{later, b}})
    if (!frame) return program_error(span, fmt::format("EQUATE: coordinate system DA({}) is not defined", label));
  // What cannot be told apart is not carried out: read strictly an error, leniently (as shop
  // software goes on) a warning, the results staying in the frames they were measured in.
  const auto cannot = [&](const std::string& why) -> Result<void> {
    if (m_strict) return program_error(span, "EQUATE: " + why);
    warn(span, fmt::format("EQUATE: {}; nothing is carried (--strict makes this an error)", why));
    return {};
  };
  if (std::isinf(b->rests_on_s))
    return cannot(
        fmt::format("DA({}) rests on no measured feature (a system of numbers only), so the features of the "
                    "part's earlier set-up cannot be told from the later's",
                    later));
  if (!(a->rests_on_s < b->rests_on_s))
    return cannot(
        fmt::format("DA({}) rests on no feature measured before DA({})'s first point, so it is not of an "
                    "earlier set-up (EQUATE/DA(earlier set-up),DA(later set-up) carries the earlier into the "
                    "later)",
                    earlier, later));
  // A set-up: the PAUSEs before a moment; where its measurements are now, after earlier EQUATEs.
  const auto setup_taken = [&](double t) {
    return static_cast<std::size_t>(
        std::count_if(m_operator_stops_s.begin(), m_operator_stops_s.end(), [&](double stop) { return stop < t; }));
  };
  m_setup_carried_to.reserve(m_operator_stops_s.size() + 1);
  while (m_setup_carried_to.size() <= m_operator_stops_s.size())
    m_setup_carried_to.push_back(m_setup_carried_to.size());
  const std::size_t taken_a = setup_taken(a->rests_on_s), taken_b = setup_taken(b->rests_on_s);
  const std::size_t from = m_setup_carried_to[taken_a], to = m_setup_carried_to[taken_b];
  const bool at_stop = taken_a < taken_b;
  const auto carried = [&](double rests_on_s) {
    if (!at_stop) return rests_on_s < b->rests_on_s;
    return std::isfinite(rests_on_s) && m_setup_carried_to[setup_taken(rests_on_s)] == from;
  };
  const Frame move = b->part_to_machine * a->part_to_machine.inverse();
  const Vec3 shift = b->part_to_machine.translation() - a->part_to_machine.translation();  // a moves below

  // A feature measured in the earlier set-up moves whole; one not measured yet moves its nominal
  // when the frame it was written in belongs to the earlier set-up (a nominal written in a frame
  // of numbers only, a fixture's, stays where it was put).
  std::size_t features = 0;
  for (auto& [label, f] : m_features) {
    const bool measured_before = f.actual && carried(f.rests_on_s);
    if (!measured_before && (f.actual || !carried(f.nominal_rests_on_s))) continue;
    f.nominal = to_machine(f.nominal, move);
    f.nominal_frame = move * f.nominal_frame;
    ++features;
    if (!measured_before) continue;
    f.actual = to_machine(*f.actual, move);
    for (MeasuredPoint& p : f.points) {
      p.centre_mm = move * p.centre_mm;
      p.normal = move.linear() * p.normal;
      if (p.nominal_mm) p.nominal_mm = move * *p.nominal_mm;
      p.nominal_normal = move.linear() * p.nominal_normal;
    }
  }
  for (auto& [label, d] : m_datums) {
    if (!carried(d.rests_on_s)) continue;
    d.geometry = to_machine(d.geometry, move);
    d.nominal = to_machine(d.nominal, move);
    d.nominal_frame = move * d.nominal_frame;
  }
  std::size_t systems = 0;
  for (auto* store : {&m_alignments, &m_saved})
    for (auto& [label, system] : *store)
      if (carried(system.rests_on_s)) {
        system.part_to_machine = move * system.part_to_machine;
        system.nominal_placement = move * system.nominal_placement;
        if (store == &m_alignments) ++systems;
      }
  if (carried(m_alignment.rests_on_s)) {
    m_alignment.part_to_machine = move * m_alignment.part_to_machine;
    m_alignment.nominal_placement = move * m_alignment.nominal_placement;
  }
  const bool merged = std::count(m_setup_carried_to.begin(), m_setup_carried_to.end(), from) > 1 ||
                      m_setup_carried_to[taken_a] != taken_a;
  if (at_stop) std::replace(m_setup_carried_to.begin(), m_setup_carried_to.end(), from, to);

  // Told as the part frame's motion: its origin's, and the turn about an axis (machine axes).
  const ReportUnits& u = m_report_units;
  const auto length = [&](double mm) { return without_negative_zero(length_text(mm, u)); };
  const auto fixed = [](double v, int decimals) { return without_negative_zero(fmt::format("{:.{}f}", v, decimals)); };
  const Eigen::AngleAxisd turn(move.linear());
  const auto count = [](std::size_t n, const char* what) { return fmt::format("{} {}{}", n, what, n == 1 ? "" : "s"); };
  std::string which = fmt::format("before DA({})'s first point", later);
  if (at_stop)
    which = fmt::format("{}before the PAUSE {}{}",
                        taken_a == 0 ? "" : fmt::format("after the PAUSE before DA({})'s first point and ", earlier),
                        taken_b == taken_a + 1 ? "between them" : fmt::format("after DA({})'s first point", earlier),
                        merged ? ", with what earlier EQUATEs carried into it" : "");
  const std::string told = fmt::format(
      "DA({}) carried onto DA({}): {} and {} of the earlier set-up moved with the part: its origin by {}, {}, {} {}, "
      "turned {} deg about ({}, {}, {}) (machine axes); the earlier set-up is what was measured {}",
      earlier, later, count(features, "feature"), count(systems, "coordinate system"), length(shift.x()),
      length(shift.y()), length(shift.z()), unit_word(u), fixed(turn.angle() * 180 / std::numbers::pi, 4),
      fixed(turn.axis().x(), 6), fixed(turn.axis().y(), 6), fixed(turn.axis().z(), 6), which);
  note(span, "EQUATE: " + told);
  // DMIS passes EQUATE to the output file; as a comment, so the file read back names no
  // coordinate system it does not define.
  write_device_line(fmt::format("$$ EQUATE/DA({}), DA({}): {}", earlier, later, told));
  return {};
}

}  // namespace metron::runtime
