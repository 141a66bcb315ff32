// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <nlohmann/json_fwd.hpp>
#include <tl/expected.hpp>

#include "metron/machine/csg.hpp"
#include "metron/machine/pre_travel.hpp"
#include "metron/machine/scanning/scanning_spec.hpp"
#include "metron/stdlib/geometry/cad_import.hpp"
#include "metron/stdlib/geometry/mesh.hpp"
#include "metron/stdlib/geometry/vec.hpp"

/// The world description of the virtual CMM (docs/world.md): the machine and its controller,
/// the probe as it truly is, the reference sphere, and the workpiece as designed and as
/// machined. Everything marked "hidden" is simulated truth: only the simulation reads it, the
/// controller learns it through simulated sensors (ARCHITECTURE.md rule 1).
namespace metron::machine {

/// Travel of one axis, machine coordinates of the ball centre.
struct AxisTravel {
  double min_mm = 0;                  ///< lowest position
  double max_mm = 0;                  ///< highest position
};

/// How the controller sees the probe's trigger signal (SEEDS.md 3, C->D).
struct SkipInput {
  enum class Kind {
    Latched,  ///< high-speed skip input: the axes are latched after a fixed latency
    Scanned,  ///< the input is polled once per scan period: latency uniform in [0, period)
  };
  Kind kind = Kind::Latched;          ///< which of the two
  double latency_s = 4e-6;            ///< Latched: fixed latency
  double period_s = 0.002;            ///< Scanned: scan period
};

/// How one axis accelerates to a programmed feed (SEEDS.md 3, acceleration zone). Simulated
/// truth: the runtime never reads it, it measures it with timed moves (runtime/characterisation).
struct AxisDynamics {
  enum class Mode {
    ConstantRate,  ///< acceleration ramps at the jerk limit up to a fixed rate: ramp time grows with feed
    ConstantTime,  ///< the programmed feed is reached in a fixed time: ramp distance grows linearly with feed
  };
  Mode mode = Mode::ConstantRate;     ///< which of the two
  double acceleration_mm_s2 = 1000;   ///< ConstantRate: acceleration limit of the axis
  double jerk_mm_s3 = 10000;          ///< ConstantRate: jerk limit of the axis
  double time_s = 0.06;               ///< ConstantTime: time to reach any programmed feed from rest
};

/// The machine and its controller (known to the controller: it is its own configuration).
struct MachineSpec {
  std::array<AxisTravel, 3> travel{{{-100, 1100}, {-100, 900}, {-200, 600}}};  ///< x, y, z
  double max_speed_mm_s = 300;        ///< path speed limit
  double max_acceleration_mm_s2 = 1000;  ///< path acceleration limit
  double max_jerk_mm_s3 = 10000;      ///< path jerk limit
  double dt_s = 0.001;                ///< controller cycle
  double positioning_feed_mm_s = 50;  ///< default GoTo speed
  double measuring_feed_mm_s = 3;     ///< default probing speed
  SkipInput skip;                     ///< the trigger input
  /// Per-axis acceleration behaviour (x, y, z); none: every axis at the path limits above
  /// (constant rate). Hidden from the runtime (measured by the characterisation).
  std::optional<std::array<AxisDynamics, 3>> axes;
  Vec3 home_mm{0, 0, 500};            ///< ball centre at start
  double table_z_mm = 0;              ///< table surface; everything below it is solid
};

/// The touch-trigger probe as it truly is (hidden).
struct ProbeSpec {
  double ball_radius_error_mm = 0;    ///< true ball radius = nominal (from DefineTool) + error
  PreTravel pre_travel;               ///< direction-dependent pre-travel
  double filter_delay_s = 0.002;      ///< interface filter (SEEDS.md 3, B->C)
  double transmission_delay_s = 0.002;  ///< signal transmission (optical, radio ...)
  double over_travel_mm = 1.0;        ///< largest allowed travel from contact to standstill
  double repeatability_mm = 0.0002;   ///< 1-sigma noise of the trigger threshold
};

/// The reference sphere for tool qualification, on a post.
struct ReferenceSphereSpec {
  Vec3 nominal_centre_mm{900, 700, 100};  ///< what the controller is told
  double certified_diameter_mm = 25;      ///< what the controller is told
  Vec3 true_centre_mm{900, 700, 100};     ///< hidden
  double true_diameter_mm = 25;           ///< hidden
  double post_diameter_mm = 10;       ///< the post: a capped cylinder, collision geometry
  Vec3 post_direction = -Vec3::UnitZ();   ///< unit, from the centre toward the post's foot
  double post_length_mm = 100;            ///< from the true centre
};

/// Placement of the part: p_machine = translation + Rz * Ry * Rx * p_part (x first).
struct Pose {
  Vec3 translation_mm = Vec3::Zero();  ///< where the part origin is in the machine
  Vec3 rotation_deg = Vec3::Zero();   ///< about the machine x, y, z axes, applied x, then y, then z
  /// The transform p_machine = part_to_machine() * p_part.
  [[nodiscard]] Frame part_to_machine() const;
};

/// A Gaussian bump of a CAD part's deviation field, along the outward normal.
struct Bump {
  Vec3 centre_mm = Vec3::Zero();      ///< part coordinates
  double amplitude_mm = 0;            ///< + = material added
  double sigma_mm = 1;
};

/// A CAD design: a mesh read from STEP, IGES, STL, OFF, OBJ or PLY.
struct CadDesign {
  std::string path;                   ///< resolved (relative to the world file in JSON)
  std::shared_ptr<const geometry::Mesh> mesh;  ///< part coordinates
  /// STEP/IGES: the analytic surface of each B-rep face and its triangles in `mesh`; null for
  /// plain meshes.
  std::shared_ptr<const std::vector<geometry::CadFace>> faces;
  double chord_tolerance_mm = 0;      ///< STEP/IGES: of the tessellation in `mesh`
};

/// Smooth random roughness of all part surfaces (a fixed surface, seeded by PartSpec::seed).
struct Roughness {
  double amplitude_mm = 0;            ///< peak value of the noise field
  double correlation_mm = 1;          ///< lattice spacing of the noise field
};

/// The workpiece: design, placement and (hidden) deviations.
struct PartSpec {
  std::variant<csg::Node, CadDesign> design;  ///< part coordinates
  Pose pose;                          ///< part to machine
  std::map<std::string, csg::Deviation> deviations;  ///< CSG: keyed by primitive name
  std::vector<Bump> bumps;            ///< CAD: deviation field
  Roughness roughness;                ///< hidden
  std::uint64_t seed = 1;             ///< of the roughness field
};

/// The whole world of one virtual CMM.
struct World {
  std::string name = "default";
  std::string source;                 ///< file it was read from ("<default>" when embedded)
  std::uint64_t seed = 1;             ///< default run seed (a tool may override it)
  MachineSpec machine;                ///< known to the controller
  ProbeSpec probe;                    ///< hidden
  ReferenceSphereSpec reference_sphere;  ///< nominal and certified values known, true ones hidden
  std::optional<PartSpec> part;       ///< none: an empty table
  ScanningSpec scanning;              ///< scanning probe, servo dynamics and scan controller (docs/scanning.md)
};

/// A world file that could not be read; `message` is "file: /json/pointer: what was expected".
struct WorldError {
  std::string message;                ///< "file: /pointer: what was expected"
};

/// Reads a world from a JSON file (comments allowed). Unknown keys are errors. A file may start
/// from another world with "extends": "default" (the embedded one) or a path relative to it,
/// and override it as an RFC 7386 merge patch (machine.skip and part.design replace the base's
/// whole).
tl::expected<World, WorldError> load_world(const std::string& path);

/// Builds a world from parsed JSON; `source_name` prefixes error messages and CAD paths are
/// resolved relative to `base_dir` (empty: the current directory).
tl::expected<World, WorldError> parse_world(const nlohmann::json& json, const std::string& source_name,
                                            const std::string& base_dir = {});

/// The embedded default world (identical to programs/worlds/default.json).
World default_world();
/// The JSON text of the default world.
std::string_view default_world_json();

}  // namespace metron::machine
