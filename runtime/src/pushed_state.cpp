// SPDX-License-Identifier: GPL-3.0-or-later
// PUSH/word and POP/word: a macro or a subprogram saves the state it changes and gives it back
// (docs/language.md, "PUSH and POP"). Each word has its own stack; POP restores only its word's
// part of what PUSH saved.
#include <fmt/format.h>

#include "metron/runtime/measurement_runtime.hpp"

namespace metron::runtime {

bool MeasurementRuntime::pushable(std::string_view word) {
  return word == "ALGN" || word == "SNSLCT" || word == "WKPLAN" || word == "SNSET" || word == "GEOALG";
}

void MeasurementRuntime::push_state(const std::string& word) {
  m_pushed[word].push_back({m_alignment, m_active_sensor, m_working_plane, m_probe, m_fit_algorithms});
}

Result<void> MeasurementRuntime::pop_state(const std::string& word, Span span) {
  auto stack = m_pushed.find(word);
  if (stack == m_pushed.end() || stack->second.empty())
    return program_error(span, fmt::format("POP/{} without a PUSH/{} left to restore", word, word));
  const PushedState saved = std::move(stack->second.back());
  stack->second.pop_back();
  if (word == "ALGN") {
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
  }
  return {};
}

}  // namespace metron::runtime
