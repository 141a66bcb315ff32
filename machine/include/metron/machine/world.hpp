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

#include "metron/machine/active_scanning/scanning_spec.hpp"
#include "metron/machine/csg.hpp"
#include "metron/machine/machine_errors/error_model.hpp"
#include "metron/machine/probe_library.hpp"
#include "metron/machine/touch_cycle/pre_travel.hpp"
#include "metron/stdlib/geometry/cad_import.hpp"
#include "metron/stdlib/geometry/mesh.hpp"
#include "metron/stdlib/geometry/vec.hpp"

/// The world description of the virtual CMM (docs/world.md), in two types: the machine's
/// configuration (MachineConfig, known to the controller) and the truth (WorldTruth: the probe
/// as it truly is, the true reference sphere, the axes' dynamics, the workpiece as machined,
/// noise). Only the simulation reads the truth, the controller learns it through simulated
/// sensors (ARCHITECTURE.md rule 1).
namespace metron::machine {

/// Travel of one axis, machine coordinates of the ball centre.
struct AxisTravel {
  double min_mm = 0;  ///< lowest position
  double max_mm = 0;  ///< highest position
};

/// How the controller sees the probe's trigger signal (SEEDS.md 3, C->D).
struct SkipInput {
  enum class Kind {
    Latched,  ///< high-speed skip input: the axes are latched after a fixed latency
    Scanned,  ///< the input is polled once per scan period: latency uniform in [0, period)
  };
  Kind kind = Kind::Latched;  ///< which of the two
  double latency_s = 4e-6;    ///< Latched: fixed latency
  double period_s = 0.002;    ///< Scanned: scan period
};

/// One point of a tabulated ramp: the axis reaches `feed_mm_s` from rest in `ramp_time_s`.
struct RampTimePoint {
  double feed_mm_s = 0;    ///< axis feed
  double ramp_time_s = 0;  ///< time from rest to that feed
};

/// A law by which one axis changes its speed (SEEDS.md 3, acceleration zone). Simulated truth:
/// the runtime never reads it, it measures it with timed moves (runtime/characterisation).
struct RampLaw {
  enum class Mode {
    ConstantRate,  ///< acceleration ramps at the jerk limit up to a fixed rate: ramp time grows with feed
    ConstantTime,  ///< the programmed feed is reached in a fixed time: ramp distance grows linearly with feed
    Tabulated,     ///< the ramp time is a table over the axis feed, linear between its points, held beyond them
  };
  Mode mode = Mode::ConstantRate;    ///< which of the three
  double acceleration_mm_s2 = 1000;  ///< ConstantRate: acceleration (or deceleration) limit of the axis
  double jerk_mm_s3 = 10000;         ///< ConstantRate: jerk limit of the axis
  double time_s = 0.06;              ///< ConstantTime: time to reach any programmed feed from rest
  std::vector<RampTimePoint> table;  ///< Tabulated: feeds strictly increasing, at least two points
};

/// How one axis accelerates to a programmed feed and brakes from it.
struct AxisDynamics : RampLaw {
  /// Braking (every slow-down: the end of a move, the stop after a trigger) when it differs from
  /// the acceleration; none: braking mirrors the acceleration (the original behaviour).
  std::optional<RampLaw> braking;
};

/// Per-axis acceleration behaviour (x, y, z); none: every axis at the path limits (constant rate).
using AxesDynamics = std::optional<std::array<AxisDynamics, 3>>;

/// The reference sphere as the controller is told it is (its certificate).
struct ReferenceSphereConfig {
  Vec3 nominal_centre_mm{900, 700, 100};  ///< where it was set up
  double certified_diameter_mm = 25;      ///< from its certificate
};

/// Published values of the probes, as the controller knows them: a copy of the truth made when
/// the world is loaded (data_sheet_of), overridden by the world file's machine.data_sheet where
/// the published values differ from the true ones (docs/world.md).
struct DataSheet {
  double rated_over_travel_mm = 1.0;     ///< touch-trigger probe: largest travel from contact to standstill
  double scanning_stiffness_n_mm = 0.6;  ///< scanning probe: contact force per mm of deflection
  double scanning_stylus_mass_g = 5.0;   ///< scanning probe: effective moving stylus mass
};

/// The machine's configuration: everything its controller knows (its own settings, the reference
/// sphere's certificate, the probes' data sheets). The controller code receives only this.
struct MachineConfig {
  std::array<AxisTravel, 3> travel{{{-100, 1100}, {-100, 900}, {-200, 600}}};  ///< x, y, z
  double max_speed_mm_s = 300;                                                 ///< path speed limit
  double max_acceleration_mm_s2 = 1000;                                        ///< path acceleration limit
  double max_jerk_mm_s3 = 10000;                                               ///< path jerk limit
  double dt_s = 0.001;                                                         ///< controller cycle
  double positioning_feed_mm_s = 50;                                           ///< default GoTo speed
  double measuring_feed_mm_s = 3;                                              ///< default probing speed
  SkipInput skip;                                                              ///< the trigger input, as configured
  Vec3 home_mm{0, 0, 500};                                                     ///< ball centre at start
  ReferenceSphereConfig reference_sphere;    ///< nominal centre and certified diameter
  ScanningSpec scanning;                     ///< scan controller, scanning probe settings, command buffers
  DataSheet data_sheet;                      ///< the probes' published values
  std::vector<LibrarySensor> probe_library;  ///< named qualified sensors (RECALL/SA, SNSLCT/SA)
};

/// The touch-trigger probe as it truly is (hidden).
struct ProbeSpec {
  double ball_radius_error_mm = 0;      ///< true ball radius = nominal (from DefineTool) + error
  PreTravel pre_travel;                 ///< direction-dependent pre-travel
  double filter_delay_s = 0.002;        ///< interface filter (SEEDS.md 3, B->C)
  double transmission_delay_s = 0.002;  ///< signal transmission (optical, radio ...)
  double over_travel_mm = 1.0;          ///< largest allowed travel from contact to standstill
  double repeatability_mm = 0.0002;     ///< 1-sigma noise of the trigger threshold
};

/// The reference sphere for tool qualification, on a post, as it truly is (hidden).
struct ReferenceSphereTruth {
  Vec3 true_centre_mm{900, 700, 100};    ///< where it is
  double true_diameter_mm = 25;          ///< its size
  double post_diameter_mm = 10;          ///< the post: a capped cylinder, collision geometry
  Vec3 post_direction = -Vec3::UnitZ();  ///< unit, from the centre toward the post's foot
  double post_length_mm = 100;           ///< from the true centre
};

/// Placement of the part: p_machine = translation + Rz * Ry * Rx * p_part (x first).
struct Pose {
  Vec3 translation_mm = Vec3::Zero();  ///< where the part origin is in the machine
  Vec3 rotation_deg = Vec3::Zero();    ///< about the machine x, y, z axes, applied x, then y, then z
  /// The transform p_machine = part_to_machine() * p_part.
  [[nodiscard]] Frame part_to_machine() const;
};

/// A Gaussian bump of a CAD part's deviation field, along the outward normal.
struct Bump {
  Vec3 centre_mm = Vec3::Zero();  ///< part coordinates
  double amplitude_mm = 0;        ///< + = material added
  double sigma_mm = 1;
};

/// A CAD design: a mesh read from STEP, IGES, STL, OFF, OBJ or PLY.
struct CadDesign {
  std::string path;                            ///< resolved (relative to the world file in JSON)
  std::shared_ptr<const geometry::Mesh> mesh;  ///< part coordinates
  /// STEP/IGES: the analytic surface of each B-rep face and its triangles in `mesh`; null for
  /// plain meshes.
  std::shared_ptr<const std::vector<geometry::CadFace>> faces;
  double chord_tolerance_mm = 0;  ///< STEP/IGES: of the tessellation in `mesh`
};

/// Smooth random roughness of all part surfaces (a fixed surface, seeded by PartSpec::seed).
struct Roughness {
  double amplitude_mm = 0;    ///< peak value of the noise field
  double correlation_mm = 1;  ///< lattice spacing of the noise field
};

/// The workpiece: design, placement and (hidden) deviations.
struct PartSpec {
  std::variant<csg::Node, CadDesign> design;  ///< part coordinates
  Pose pose;                                  ///< part to machine
  /// Where the virtual operator puts the part at each of the program's operator stops (DMIS
  /// PAUSE), in turn: the part's later set-ups (a part turned or moved between two halves of a
  /// program). Stops after the last leave the part where it is.
  std::vector<Pose> setups;
  std::map<std::string, csg::Deviation> deviations;  ///< CSG: keyed by primitive name
  std::vector<Bump> bumps;                           ///< CAD: deviation field
  Roughness roughness;                               ///< hidden
  std::uint64_t seed = 1;                            ///< of the roughness field
};

/// The simulated truth: everything the controller must not read (ARCHITECTURE.md rule 1). Only
/// the simulation receives it; the controller learns about it through simulated sensors.
struct WorldTruth {
  ProbeSpec probe;                        ///< the touch-trigger probe
  ReferenceSphereTruth reference_sphere;  ///< true centre and size, the post
  AxesDynamics axes;                      ///< how the axes accelerate (measured by the characterisation)
  double table_z_mm = 0;                  ///< table surface; everything below it is solid
  std::optional<PartSpec> part;           ///< none: an empty table
  ScanningTruth scanning;                 ///< scanning probe dynamics and noise, axis servos
  /// The machine's geometry and thermal errors (machine.errors; none: a perfect machine): where
  /// the scales say the ball is and where it really is differ by their displacement.
  MachineErrorModel errors;
};

/// The whole world of one virtual CMM, as a world file describes it: the machine's
/// configuration (known to its controller) and the truth (hidden), as two types.
struct World {
  std::string name = "default";
  std::string source;      ///< file it was read from ("<default>" when embedded)
  std::uint64_t seed = 1;  ///< default run seed (a tool may override it)
  MachineConfig machine;   ///< known to the controller
  WorldTruth truth;        ///< hidden
};

/// The data sheet of the world's probes: the true values, exactly (the loader's copy).
DataSheet data_sheet_of(const WorldTruth& truth);

/// A world file that could not be read; `message` is "file: /json/pointer: what was expected".
struct WorldError {
  std::string message;  ///< "file: /pointer: what was expected"
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
/// The world of a file given on a command line, or the embedded default when none is given.
tl::expected<World, WorldError> load_world_or_default(const std::optional<std::string>& path);
/// The JSON text of the default world.
std::string_view default_world_json();

}  // namespace metron::machine
