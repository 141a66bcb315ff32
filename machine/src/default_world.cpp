// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/world.hpp"

namespace metron::machine {

// Byte for byte programs/worlds/default.json (tests/machine/test_world.cpp checks it).
std::string_view default_world_json() {
  static constexpr std::string_view text = R"json({
  // metron's default virtual CMM (docs/world.md). Lengths mm, times s, angles degrees.
  "name": "default",
  "description": "prismatic test block 160 x 100 x 40 on a 1200 x 1000 x 800 bridge CMM",
  "seed": 1,
  "machine": {
    "travel_mm": {"x": [-100, 1100], "y": [-100, 900], "z": [-200, 600]},
    "max_speed_mm_s": 300,
    "max_acceleration_mm_s2": 1000,
    "max_jerk_mm_s3": 10000,
    "dt_s": 0.001,
    "positioning_feed_mm_s": 50,
    "measuring_feed_mm_s": 3,
    "skip": {"latched": {"latency_s": 4e-6}},
    "home_mm": [0, 0, 500],
    "table_z_mm": 0
  },
  "probe": {
    "ball_radius_error_mm": 0,
    "pre_travel": {"horizontal_mm": 0.010, "vertical_mm": 0.010, "lobes": 3,
                   "lobe_amplitude_mm": 0, "lobe_phase_deg": 0},
    "filter_delay_s": 0.002,
    "transmission_delay_s": 0.002,
    "over_travel_mm": 1.0,
    "repeatability_mm": 0.0002
  },
  "scanning": {
    "probe": {"reference_deflection_mm": 0.3, "measuring_range_mm": 1.0, "stiffness_n_mm": 0.6,
              "stylus_mass_g": 5, "noise_mm": 0.0001},
    "servo": {"natural_frequency_hz": 20, "damping": 0.4, "command_delay_cycles": 1,
              "max_acceleration_mm_s2": 3000},
    "control": {"feed_mm_s": 10, "deflection_gain_1_s": 40, "trajectory_gain_1_s": 40,
                "deflection_tolerance_mm": 0.1, "trajectory_tolerance_mm": 0.5,
                "max_centripetal_mm_s2": 500, "approach_feed_mm_s": 2, "stall_time_s": 1.0,
                "lost_contact_mm": 2.0}
  },
  "reference_sphere": {
    "nominal_centre_mm": [900, 700, 100],
    "certified_diameter_mm": 25,
    "true_centre_mm": [900, 700, 100],
    "true_diameter_mm": 25,
    "post": {"diameter_mm": 10, "direction": [0, 0, -1], "length_mm": 100}
  },
  "part": {
    "pose": {"translation_mm": [300, 200, 0], "rotation_deg": [0, 0, 0]},
    "design": {"union": [
      {"difference": [
        {"intersection": [
          {"type": "half_space", "name": "TOP",    "point": [80, 50, 40],  "normal": [0, 0, 1]},
          {"type": "half_space", "name": "BOTTOM", "point": [80, 50, 0],   "normal": [0, 0, -1]},
          {"type": "half_space", "name": "FRONT",  "point": [80, 0, 20],   "normal": [0, -1, 0]},
          {"type": "half_space", "name": "BACK",   "point": [80, 100, 20], "normal": [0, 1, 0]},
          {"type": "half_space", "name": "LEFT",   "point": [0, 50, 20],   "normal": [-1, 0, 0]},
          {"type": "half_space", "name": "RIGHT",  "point": [160, 50, 20], "normal": [1, 0, 0]}
        ]},
        {"intersection": [
          {"type": "cylinder",   "name": "BORE1", "point": [40, 50, 15], "axis": [0, 0, 1], "diameter_mm": 20},
          {"type": "half_space", "name": "BORE1_BOTTOM", "point": [40, 50, 15], "normal": [0, 0, -1]}
        ]},
        {"intersection": [
          {"type": "cylinder",   "name": "BORE2", "point": [120, 30, 20], "axis": [0, 0, 1], "diameter_mm": 12},
          {"type": "half_space", "name": "BORE2_BOTTOM", "point": [120, 30, 20], "normal": [0, 0, -1]}
        ]},
        {"type": "cone", "name": "CONE1", "apex": [40, 20, 32], "axis": [0, 0, 1], "half_angle_deg": 45}
      ]},
      {"intersection": [
        {"type": "cylinder",   "name": "BOSS1", "point": [120, 70, 40], "axis": [0, 0, 1], "diameter_mm": 24},
        {"type": "half_space", "name": "BOSS1_TOP", "point": [120, 70, 55], "normal": [0, 0, 1]},
        {"type": "half_space", "point": [120, 70, 39], "normal": [0, 0, -1]}
      ]},
      {"type": "sphere", "name": "SPHERE1", "centre": [75, 75, 48], "diameter_mm": 20}
    ]},
    "deviations": {},
    "roughness": {"amplitude_mm": 0, "correlation_mm": 1},
    "seed": 1
  }
}
)json";
  return text;
}

}  // namespace metron::machine
