// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/scanning/scanning_spec.hpp"

#include <cmath>
#include <functional>
#include <map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace metron::machine {
namespace {

using nlohmann::json;

// Thrown inside the parser only; parse_scanning_spec turns it into a value.
struct Failure {
  ScanningSpecError error;
};

[[noreturn]] void fail(const std::string& pointer, std::string message) {
  throw Failure{{pointer, std::move(message)}};
}

enum class Range { Positive, NonNegative, Fraction };

void read_number(const json& j, const std::string& ptr, double& out, Range range) {
  if (!j.is_number() || !std::isfinite(j.get<double>())) fail(ptr, "expected a finite number");
  const double v = j.get<double>();
  if (range == Range::Positive && !(v > 0)) fail(ptr, "expected a positive number");
  if (range == Range::NonNegative && v < 0) fail(ptr, "expected a number >= 0");
  if (range == Range::Fraction && !(v > 0 && v < 2)) fail(ptr, "expected a number in (0, 2)");
  out = v;
}

// Reads the listed keys of one object; any other key is an error (typos must not pass).
void read_object(const json& j, const std::string& ptr,
                 const std::map<std::string, std::function<void(const json&, const std::string&)>>& keys) {
  if (!j.is_object()) fail(ptr, "expected an object");
  for (const auto& item : j.items()) {
    const auto it = keys.find(item.key());
    const std::string at = ptr + "/" + item.key();
    if (it == keys.end()) {
      std::string known;
      for (const auto& [k, f] : keys) known += (known.empty() ? "" : ", ") + k;
      fail(at, fmt::format("unknown key (expected one of: {})", known));
    }
    it->second(item.value(), at);
  }
}

auto number(double& out, Range range) {
  return [&out, range](const json& j, const std::string& p) { read_number(j, p, out, range); };
}

}  // namespace

tl::expected<ScanningSpec, ScanningSpecError> parse_scanning_spec(const json& j, const std::string& pointer,
                                                                  ScanningSpec spec) {
  try {
    read_object(j, pointer, {
      {"probe", [&](const json& pj, const std::string& pp) {
         ScanningProbeSpec& p = spec.probe;
         read_object(pj, pp, {
           {"reference_deflection_mm", number(p.reference_deflection_mm, Range::Positive)},
           {"measuring_range_mm", number(p.measuring_range_mm, Range::Positive)},
           {"stiffness_n_mm", number(p.stiffness_n_mm, Range::Positive)},
           {"stylus_mass_g", number(p.stylus_mass_g, Range::Positive)},
           {"noise_mm", number(p.noise_mm, Range::NonNegative)},
         });
         if (p.reference_deflection_mm >= p.measuring_range_mm)
           fail(pp + "/reference_deflection_mm", "expected a reference deflection below the measuring range");
       }},
      {"servo", [&](const json& sj, const std::string& sp) {
         ServoSpec& s = spec.servo;
         read_object(sj, sp, {
           {"natural_frequency_hz", number(s.natural_frequency_hz, Range::Positive)},
           {"damping", number(s.damping, Range::Fraction)},
           {"command_delay_cycles", [&](const json& dj, const std::string& dp) {
              if (!dj.is_number_integer() || dj.get<std::int64_t>() < 0 || dj.get<std::int64_t>() > 100)
                fail(dp, "expected an integer in [0, 100]");
              s.command_delay_cycles = static_cast<int>(dj.get<std::int64_t>());
            }},
           {"max_acceleration_mm_s2", number(s.max_acceleration_mm_s2, Range::Positive)},
         });
       }},
      {"control", [&](const json& cj, const std::string& cp) {
         ScanControlSpec& c = spec.control;
         read_object(cj, cp, {
           {"feed_mm_s", number(c.feed_mm_s, Range::Positive)},
           {"deflection_gain_1_s", number(c.deflection_gain_1_s, Range::Positive)},
           {"trajectory_gain_1_s", number(c.trajectory_gain_1_s, Range::NonNegative)},
           {"deflection_tolerance_mm", number(c.deflection_tolerance_mm, Range::NonNegative)},
           {"trajectory_tolerance_mm", number(c.trajectory_tolerance_mm, Range::NonNegative)},
           {"max_centripetal_mm_s2", number(c.max_centripetal_mm_s2, Range::Positive)},
           {"approach_feed_mm_s", number(c.approach_feed_mm_s, Range::Positive)},
           {"stall_time_s", number(c.stall_time_s, Range::Positive)},
           {"lost_contact_mm", number(c.lost_contact_mm, Range::Positive)},
         });
       }},
      {"segmented", [&](const json& gj, const std::string& gp) {
         SegmentedScanSpec& g = spec.segmented;
         read_object(gj, gp, {
           {"buffer_segments", [&](const json& bj, const std::string& bp) {
              if (!bj.is_number_integer() || bj.get<std::int64_t>() < 1) fail(bp, "expected an integer >= 1");
              g.buffer_segments = static_cast<std::size_t>(bj.get<std::int64_t>());
            }},
           {"mode", [&](const json& mj, const std::string& mp) {
              const std::string m = mj.is_string() ? mj.get<std::string>() : "";
              if (m == "conventional") g.mode = segmented::SegmentedMode::Conventional;
              else if (m == "seed") g.mode = segmented::SegmentedMode::Seed;
              else if (m == "look_ahead") g.mode = segmented::SegmentedMode::LookAhead;
              else fail(mp, "expected \"conventional\", \"seed\" or \"look_ahead\"");
            }},
           {"planning_s_per_segment", number(g.planning_s_per_segment, Range::NonNegative)},
           {"planning_fixed_s", number(g.planning_fixed_s, Range::NonNegative)},
           {"planning_margin", number(g.planning_margin, Range::Positive)},
           {"low_speed_mm_s", number(g.low_speed_mm_s, Range::Positive)},
           {"low_length_mm", number(g.low_length_mm, Range::NonNegative)},
           {"path_acceleration_mm_s2", number(g.path_acceleration_mm_s2, Range::Positive)},
           {"path_jerk_mm_s3", number(g.path_jerk_mm_s3, Range::Positive)},
         });
         // SEEDS.md 2 step 3: the low speed is claimed for 1-5 mm/s.
         if (g.low_speed_mm_s < 1 || g.low_speed_mm_s > 5) fail(gp + "/low_speed_mm_s", "expected 1 to 5 mm/s");
       }},
    });
  } catch (const Failure& f) {
    return tl::unexpected(f.error);
  }
  return spec;
}

}  // namespace metron::machine
