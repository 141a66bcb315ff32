// SPDX-License-Identifier: GPL-3.0-or-later
// PUSH/word and POP/word: a macro or a subprogram saves the state it changes and gives it back
// (docs/language.md, "PUSH and POP"). Each word has its own stack; POP restores only its word's
// part of what PUSH saved.
#include <fmt/format.h>

#include "metron/runtime/measurement_runtime.hpp"

namespace metron::runtime {

bool MeasurementRuntime::pushable(std::string_view word) {
  return word == "ALGN" || word == "SNSLCT" || word == "WKPLAN" || word == "SNSET" || word == "GEOALG" ||
         word == "FEDRAT";
}

void MeasurementRuntime::push_state(const std::string& word) {
  const auto machine = m_machine.state();
  m_pushed[word].push_back({m_alignment, m_active_sensor, m_working_plane, m_probe, m_fit_algorithms,
                            machine.positioning_feed_mm_s, machine.measuring_feed_mm_s, m_scan.feed_mm_s,
                            m_measuring_feed_explicit});
}

Result<void> MeasurementRuntime::pop_state(const std::string& word, Span span) {
  auto stack = m_pushed.find(word);
  if (stack == m_pushed.end() || stack->second.empty())
    return program_error(span, fmt::format("POP/{} without a PUSH/{} left to restore", word, word));
  const PushedState saved = std::move(stack->second.back());
  stack->second.pop_back();
  if (word == "ALGN") {
    move_nominals(saved.alignment.nominal_placement * m_alignment.nominal_placement.inverse());
    m_alignment = saved.alignment;
  } else if (word == "SNSLCT") {
    // The sensor selected at the PUSH (none: the current one stays).
    if (!saved.sensor.empty() && saved.sensor != m_active_sensor)
      return m_sensors.count(saved.sensor) ? select_sensor(saved.sensor, span)
                                           : select_library_sensor(saved.sensor, span);
  } else if (word == "WKPLAN") {
    m_working_plane = saved.working_plane;
  } else if (word == "SNSET") {
    m_probe = saved.probe;
  } else if (word == "GEOALG") {
    m_fit_algorithms = saved.fit_algorithms;
  } else if (word == "FEDRAT") {
    // The feeds in force at the PUSH (a backend that does not tell its feeds keeps its own).
    m_scan.feed_mm_s = saved.scan_feed_mm_s;
    const auto now = m_machine.state();
    const auto changed = [](double was, double is) { return was > 0 && was != is ? std::optional(was) : std::nullopt; };
    const auto positioning = changed(saved.positioning_feed_mm_s, now.positioning_feed_mm_s);
    const auto measuring = changed(saved.measuring_feed_mm_s, now.measuring_feed_mm_s);
    if (positioning || measuring)
      if (auto r = set_feeds(positioning, measuring, span); !r) return r;
    m_measuring_feed_explicit = saved.measuring_feed_explicit;
  }
  return {};
}

}  // namespace metron::runtime
