// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/active_scanning/scanning_spec.hpp"

#include <cstdint>

#include <nlohmann/json.hpp>

namespace metron::machine {

namespace sj = strict_json;
using nlohmann::json;

tl::expected<void, sj::ReadError> parse_scanning_spec(const json& j, const std::string& pointer, ScanningSpec& config,
                                                      ScanningTruth& truth) {
  return sj::read([&] {
    sj::Object o(j, pointer);
    o.read("probe", [&](const json& pj, const std::string& pp) {
      sj::Object p(pj, pp);
      p.positive("reference_deflection_mm", config.probe.reference_deflection_mm);
      p.positive("measuring_range_mm", config.probe.measuring_range_mm);
      p.positive("stiffness_n_mm", truth.probe.stiffness_n_mm);
      p.positive("stylus_mass_g", truth.probe.stylus_mass_g);
      p.non_negative("noise_mm", truth.probe.noise_mm);
      p.finish();
      if (config.probe.reference_deflection_mm >= config.probe.measuring_range_mm)
        sj::fail(p.at("reference_deflection_mm"), "expected a reference deflection below the measuring range");
    });
    o.read("servo", [&](const json& vj, const std::string& vp) {
      sj::Object v(vj, vp);
      ServoSpec& s = truth.servo;
      v.positive("natural_frequency_hz", s.natural_frequency_hz);
      v.read("damping", [&](const json& dj, const std::string& dp) { s.damping = sj::open_interval(dj, dp, 0, 2); });
      v.read("command_delay_cycles", [&](const json& dj, const std::string& dp) {
        s.command_delay_cycles = static_cast<int>(sj::integer(dj, dp, 0, 100));
      });
      v.positive("max_acceleration_mm_s2", s.max_acceleration_mm_s2);
      v.finish();
    });
    o.read("control", [&](const json& cj, const std::string& cp) {
      sj::Object c(cj, cp);
      ScanControlSpec& k = config.control;
      c.positive("feed_mm_s", k.feed_mm_s);
      c.positive("deflection_gain_1_s", k.deflection_gain_1_s);
      c.non_negative("trajectory_gain_1_s", k.trajectory_gain_1_s);
      c.non_negative("deflection_tolerance_mm", k.deflection_tolerance_mm);
      c.non_negative("trajectory_tolerance_mm", k.trajectory_tolerance_mm);
      c.positive("max_centripetal_mm_s2", k.max_centripetal_mm_s2);
      c.positive("approach_feed_mm_s", k.approach_feed_mm_s);
      c.positive("stall_time_s", k.stall_time_s);
      c.positive("lost_contact_mm", k.lost_contact_mm);
      c.finish();
    });
    o.read("segmented", [&](const json& gj, const std::string& gp) {
      sj::Object g(gj, gp);
      SegmentedScanSpec& s = config.segmented;
      g.read("buffer_segments", [&](const json& bj, const std::string& bp) {
        s.buffer_segments = static_cast<std::size_t>(sj::integer(bj, bp, 1, INT64_MAX));
      });
      g.read("mode", [&](const json& mj, const std::string& mp) {
        const std::string m = mj.is_string() ? mj.get<std::string>() : "";
        if (m == "conventional")
          s.mode = segmented::SegmentedMode::Conventional;
        else if (m == "seed")
          s.mode = segmented::SegmentedMode::Seed;
        else if (m == "look_ahead")
          s.mode = segmented::SegmentedMode::LookAhead;
        else
          sj::fail(mp, "expected \"conventional\", \"seed\" or \"look_ahead\"");
      });
      g.non_negative("planning_s_per_segment", s.planning_s_per_segment);
      g.non_negative("planning_fixed_s", s.planning_fixed_s);
      g.positive("planning_margin", s.planning_margin);
      g.positive("low_speed_mm_s", s.low_speed_mm_s);
      g.non_negative("low_length_mm", s.low_length_mm);
      g.positive("path_acceleration_mm_s2", s.path_acceleration_mm_s2);
      g.positive("path_jerk_mm_s3", s.path_jerk_mm_s3);
      g.finish();
      // SEEDS.md 2 step 3: the low speed is claimed for 1-5 mm/s.
      if (s.low_speed_mm_s < 1 || s.low_speed_mm_s > 5) sj::fail(g.at("low_speed_mm_s"), "expected 1 to 5 mm/s");
    });
    o.finish();
  });
}

}  // namespace metron::machine
