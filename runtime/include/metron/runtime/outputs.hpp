// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
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
/// `TA(l) = TOL/COMPOS,PATERN,v1,INTOL|OUTOL,FEATUR,v2,INTOL|OUTOL`: a composite's two tiers on one line.
std::string dmis_composite_line(const ToleranceResult& pattern, const ToleranceResult& feature);

/// results.json (schema documented in docs/results-json.md).
nlohmann::json results_json(const RunRecord& record);

/// Writes results.json atomically: the JSON (every string made valid UTF-8, invalid bytes as
/// U+FFFD) goes to a temporary file in the same folder, which is renamed over `path` only when
/// completely written. Any failure leaves the earlier file intact and says why.
std::optional<std::string> write_results_file(const RunRecord& record, const std::string& path);

/// Writes `text` to `path` atomically (a temporary file in the same folder, then rename); the
/// error names the file.
std::optional<std::string> write_file_atomically(const std::string& path, const std::string& text);

}  // namespace metron::runtime
