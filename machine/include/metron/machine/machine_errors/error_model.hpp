// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <memory>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>
#include <tl/expected.hpp>

#include "metron/machine/machine_errors/error_term.hpp"
#include "metron/stdlib/json_reader.hpp"

namespace metron::machine {

/// The hidden machine error model (simulated truth, ARCHITECTURE.md rule 1): a list of terms whose
/// displacements add. Empty = a perfect machine. Copies share the (immutable) terms.
class MachineErrorModel {
 public:
  /// Adds a term (the way new effects, e.g. the model-discrepancy catalogue, join the model).
  void add(std::shared_ptr<const ErrorTerm> term) { m_terms.push_back(std::move(term)); }
  /// The terms, in the order added.
  [[nodiscard]] const std::vector<std::shared_ptr<const ErrorTerm>>& terms() const { return m_terms; }
  /// No terms.
  [[nodiscard]] bool empty() const { return m_terms.empty(); }
  /// Sum of all terms: the actual tip relative to the part is nominal_tip + displacement.
  [[nodiscard]] Vec3 displacement(const MachinePose& pose, double time_s) const;
  /// Sum of the terms that move the tool (what a sensor on the ram sees against a rig on the table).
  [[nodiscard]] Vec3 tool_displacement(const MachinePose& pose, double time_s) const;
  /// What the machine's thermometer reads at `time_s` (the first term that models the machine's
  /// temperature); none when no term does.
  [[nodiscard]] std::optional<double> machine_temperature_c(double time_s) const {
    for (const auto& t : m_terms)
      if (auto c = t->machine_temperature_c(time_s)) return c;
    return std::nullopt;
  }
  /// nominal tip + displacement.
  [[nodiscard]] Vec3 actual_tip_mm(const MachinePose& pose, double time_s) const {
    return pose.nominal_tip_mm() + displacement(pose, time_s);
  }

 private:
  std::vector<std::shared_ptr<const ErrorTerm>> m_terms;
};

/// Reads a world file's `machine.errors` object (docs/error-space.md, "Machine errors"); strict:
/// unknown keys and bad values are errors naming their JSON pointer below `pointer`. A missing
/// object is the default: no errors.
tl::expected<MachineErrorModel, strict_json::ReadError> parse_machine_errors(
    const nlohmann::json& errors, const std::string& pointer = "/machine/errors");

}  // namespace metron::machine
