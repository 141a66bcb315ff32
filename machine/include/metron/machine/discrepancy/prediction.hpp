// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "metron/machine/machine_errors/error_model.hpp"
#include "metron/stdlib/discrepancy/analysis.hpp"
#include "metron/stdlib/discrepancy/measured_data.hpp"

/// The virtual CMM's prediction of a measured data set (docs/discrepancy.md): each row simulated
/// the way it was measured, from the world's hidden machine error model (the model under test).
namespace metron::machine {

/// The pose of a row: axes at the nominal position, approach signs from the direction or approach
/// columns, no probe offset.
MachinePose row_pose(const discrepancy::MeasuredData& data, std::size_t row);
/// Simulated time of a row (its time column, else 0).
double row_time_s(const discrepancy::MeasuredData& data, std::size_t row);

/// The deviation the virtual CMM predicts for `row` along `axis` (0..2, or 3 = along the approach
/// vector): positioning, grid and drift data see +e (an instrument on the table against the tool);
/// artefacts measured by the CMM itself read -e (the scales put the tip at p while it is at p + e).
double predicted_deviation_mm(const MachineErrorModel& errors, const discrepancy::MeasuredData& data, std::size_t row,
                              int axis);

/// machine.errors of an extended world: `base_errors` (the world file's own machine.errors, null when
/// none) with the effects' terms appended to `terms`.
nlohmann::json extended_errors(const nlohmann::json& base_errors, const std::vector<discrepancy::Effect>& effects);

}  // namespace metron::machine
