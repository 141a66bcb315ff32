// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>

#include <nlohmann/json.hpp>

#include "metron/runtime/run_record.hpp"

namespace metron::runtime {

/// Human report block for one OUTPUT of a feature: nominal, actual, deviation, form.
std::string format_feature_report(const FeatureReport& report);
/// Human report line(s) for one tolerance: value, limits, IN/OUT.
std::string format_tolerance_result(const ToleranceResult& result);
/// Human report of a fault (kind, message, statement position and text).
std::string format_fault(const FaultReport& fault);

/// DMIS output statement `FA(label)=FEAT/...` for a reported feature (actual values).
std::string dmis_feature_line(const FeatureReport& report);
/// DMIS output statement `TA(label)=TOL/...,value,INTOL|OUTOL`.
std::string dmis_tolerance_line(const ToleranceResult& result);

/// results.json (schema documented in docs/results-json.md).
nlohmann::json results_json(const RunRecord& record);

}  // namespace metron::runtime
