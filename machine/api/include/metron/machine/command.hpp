// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "metron/machine/fault.hpp"
#include "metron/machine/measurement_command.hpp"
#include "metron/stdlib/geometry/pcc.hpp"
#include "metron/stdlib/geometry/vec.hpp"

namespace metron::machine {

// The machine command interface, modelled on I++ DME: tagged commands are queued, executed in
// order, and every command is answered by a tagged response. All coordinates are machine
// coordinates (MCS) in mm of the stylus ball centre; speeds in mm/s.

/// Positioning move of the ball centre to `target_mm` (straight line, rest to rest).
struct GoTo {
  Vec3 target_mm = Vec3::Zero();
  std::optional<double> speed_mm_s;  ///< default: the current positioning feed
};

/// Touch-trigger point measurement, as I++ DME PtMeas: move to nominal + approach*normal
/// (positioning move), probe along -normal at the measuring feed until a trigger or until
/// `search_mm` past the nominal, then retract by `retract_mm` along +normal.
struct PtMeas {
  Vec3 nominal_mm = Vec3::Zero();    ///< nominal SURFACE point
  Vec3 normal = Vec3::UnitZ();       ///< unit surface normal on the probe's side (approach from here)
  double approach_mm = 2.0;          ///< start distance before the nominal surface
  double search_mm = 5.0;            ///< how far past the nominal the probe searches
  double retract_mm = 2.0;           ///< retract distance after the hit
  std::optional<double> speed_mm_s;  ///< default: the current measuring feed
  /// Two-touch cycle (SEEDS.md 3): the probing move above becomes a first touch at
  /// `first_speed_mm_s`; the machine backs off to `backoff_mm` from the first latched ball
  /// centre along +normal and probes again from rest at `speed_mm_s`, which gives the hit.
  struct TwoTouch {
    double first_speed_mm_s = 20;  ///< feed of the first (finding) touch
    double backoff_mm = 0.5;       ///< from the first latched centre to the second touch's start
  };
  std::optional<TwoTouch> two_touch;  ///< none: a one-touch cycle
  /// One-touch only: the probing move from the approach point speeds up toward the positioning
  /// feed and slows to the measuring feed (zero acceleration) this far before the nominal
  /// surface, so the cycle does not stop at a standoff (docs/touch-trigger.md).
  std::optional<double> blend_mm;
};

/// Defines a tool (stylus) on the probe head, as DMIS SNSDEF/PROBE does.
struct DefineTool {
  std::string name;
  double ball_diameter_mm = 4.0;           ///< nominal stylus ball diameter
  Vec3 stylus_direction = -Vec3::UnitZ();  ///< from the head to the ball
  double stylus_length_mm = 50.0;
};

/// Makes a defined tool the active one.
struct SelectTool {
  std::string name;
};

/// Qualifies the active tool on the machine's reference sphere (sets its effective radius).
struct QualifyTool {};

/// Sets feeds and acceleration (0 = leave unchanged).
struct SetFeeds {
  double positioning_mm_s = 0;
  double measuring_mm_s = 0;
  double acceleration_mm_s2 = 0;
  bool default_acceleration = false;  ///< back to the machine's own acceleration (DMIS ACLRAT DEFALT)
};

/// The trajectory-correction term of the scanning control law V = Gf*Vf + Ge*Ve + Gc*Vc
/// (SEEDS.md 1).
enum class ScanLaw {
  Vc1,       ///< conventional: toward the foot of the perpendicular on the path
  Vc1Prime,  ///< comparative example: Vc1 without its component along the deflection
  Vc2,       ///< the seed's law: the part of Vc1 orthogonal to both the deflection and the path
};

/// Active nominal scan with the scanning probe along a PCC path of ball-centre positions
/// (the offset contour, SEEDS.md 1): approach the path start along `approach_normal` until the
/// deflection reaches E0, follow the path under `law` every control cycle, retract at the end.
struct ScanPath {
  geometry::PccPath path;                ///< ball-centre path at the reference deflection
  Vec3 approach_normal = Vec3::UnitZ();  ///< surface normal at the start (approach from here)
  ScanLaw law = ScanLaw::Vc2;
  std::optional<double> speed_mm_s;               ///< scan feed; default: the machine's scanning feed
  std::optional<double> reference_deflection_mm;  ///< E0; default: the probe's
  double sample_spacing_mm = 0.1;                 ///< record a sample every this much path length (0: every cycle)
  double approach_mm = 2.0;                       ///< start distance before the surface
  double retract_mm = 2.0;                        ///< retract distance after the end
};

/// One measurement command of a segmented scan (SEEDS.md 2, docs/segmented-scanning.md): a
/// ScanPath longer than the controller's command buffer is split by the host (runtime) and written
/// command by command into whichever buffer is free. `command` holds this command's segments (and
/// the normals at their ends); `scan` holds the scan's settings (its path is empty), read from the
/// first command (index 0), which also makes the machine approach the path. The answer comes once
/// the command is in a buffer, with the samples recorded since the previous write (the controller
/// keeps scanning meanwhile); the last command is answered after the path end and the retract.
struct ScanBufferWrite {
  ScanPath scan;                          ///< the scan's settings (scan.path is not used)
  segmented::MeasurementCommand command;  ///< Ci: index, first segment, segments, normals, last
};

// GCC 12 warns that the implicit copies of these structs inside the Command variant "may use"
// members that every constructor initialises (-Wmaybe-uninitialized, a known false positive
// of std::variant copies at -O2); the members all have initialisers below.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

/// Where an unknown-contour scan keeps the ball centre: in a plane, or on a cylinder about an axis
/// at the start's distance from it.
struct ContourSection {
  enum class Kind { Plane, Cylinder } kind = Kind::Plane;
  Vec3 point_mm = Vec3::Zero();    ///< Plane: a point of it; Cylinder: a point of the axis
  Vec3 direction = Vec3::UnitZ();  ///< Plane: its normal; Cylinder: the axis (unit)
};

/// When an unknown-contour scan ends: the ball centre enters a sphere, or crosses a plane or a
/// cylinder (unbounded) a number of times.
struct ContourEnd {
  enum class Kind { Sphere, Plane, Cylinder } kind = Kind::Sphere;
  Vec3 point_mm = Vec3::Zero();    ///< Sphere: its centre; Plane: a point of it; Cylinder: a point of the axis
  Vec3 direction = Vec3::UnitZ();  ///< Plane: its normal; Cylinder: the axis (unit); Sphere: unused
  double diameter_mm = 0;          ///< Sphere and Cylinder
  int crossings = 1;               ///< Plane and Cylinder: stop at this crossing
};

/// Unknown-contour scan with the scanning probe (I++ DME ScanInPlaneEndIs..., ScanInCylEndIs...):
/// approach `start_mm` (the ball centre at the nominal contact) along -start_normal until the
/// deflection reaches E0, then follow the surface the probe feels, the ball centre held in
/// `section`, setting off along `direction`, until `end`; retract along the last deflection.
struct ContourScan {
  Vec3 start_mm = Vec3::Zero();       ///< ball centre at the nominal contact
  Vec3 start_normal = Vec3::UnitZ();  ///< surface normal there (approach from here)
  Vec3 direction = Vec3::UnitX();     ///< first direction of travel (unit, across the normal)
  ContourSection section;
  ContourEnd end;
  std::optional<double> speed_mm_s;               ///< scan feed; default: the machine's scanning feed
  std::optional<double> reference_deflection_mm;  ///< E0; default: the probe's
  double sample_spacing_mm = 0.1;                 ///< record a sample every this much travel (0: every cycle)
  double approach_mm = 2.0;                       ///< start distance before the surface
  double retract_mm = 2.0;                        ///< retract distance after the end
  double max_length_mm = 5000;                    ///< travel after which a scan that did not end is stopped (a fault)
  /// The smallest radius of curvature the contour is expected to have (I++ DME ScanUnknownHint):
  /// the feed keeps within the centripetal limit for it from the start.
  std::optional<double> min_radius_mm;
};

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

/// A command with the client's tag (the runtime uses it to find the originating statement).
struct Command {
  std::uint64_t tag = 0;
  std::variant<GoTo, PtMeas, DefineTool, SelectTool, QualifyTool, SetFeeds, ScanPath, ScanBufferWrite, ContourScan>
      body;
};

/// A probed point as the controller reports it.
struct Hit {
  Vec3 centre_mm = Vec3::Zero();  ///< ball centre latched by the controller (machine coordinates)
  Vec3 normal = Vec3::UnitZ();    ///< the probing direction's normal (from the PtMeas)
  double ball_radius_mm = 0;      ///< the active tool's calibrated (effective) radius
  double time_s = 0;              ///< simulated time of the trigger
  /// Surface point compensated along the probing normal (exact for planes; fitting redoes it).
  [[nodiscard]] Vec3 surface_mm() const { return centre_mm - ball_radius_mm * normal; }
};

/// One scanned sample as the controller reports it (encoders plus the probe's deflection).
struct ScanSample {
  double time_s = 0;                  ///< simulated time
  Vec3 centre_mm = Vec3::Zero();      ///< ball centre: encoder position plus the deflection reading
  Vec3 deflection_mm = Vec3::Zero();  ///< Ep, the stylus displacement; Ep/|Ep| estimates the surface normal
  double path_s_mm = 0;               ///< arc length along the commanded path at the foot point
  /// Surface point: the ball centre moved back along the deflection by the ball radius.
  [[nodiscard]] Vec3 surface_mm(double ball_radius_mm) const {
    const double n = deflection_mm.norm();
    return n > 0 ? Vec3(centre_mm - ball_radius_mm * deflection_mm / n) : centre_mm;
  }
};

/// Calibration state of a tool, known on the controller side.
struct ToolInfo {
  std::string name;
  double nominal_radius_mm = 0;    ///< from its definition
  double effective_radius_mm = 0;  ///< after qualification (includes pre-travel and delays)
  bool qualified = false;
  double qualification_form_mm = 0;  ///< sphere form of the qualification fit (a quality figure)
  double rated_over_travel_mm = 0;   ///< the probe's over-travel limit from its data sheet (0: unknown)
  /// The qualification's ball-centre points on the reference sphere (machine coordinates, as the
  /// scales read them) and the sphere's certified diameter: a compensating controller refits them
  /// through its map (machine::CompensatedMachine), as a real controller compensates every probing.
  std::vector<Vec3> qualification_centres_mm{};
  double reference_diameter_mm = 0;
};

/// The answer to one command.
struct Response {
  std::uint64_t tag = 0;
  enum class Status { Done, Fault } status = Status::Done;
  std::optional<Hit> hit;             ///< for PtMeas
  std::optional<ToolInfo> tool;       ///< for DefineTool, SelectTool, QualifyTool
  std::optional<Fault> fault;         ///< when status == Fault
  std::vector<ScanSample> scan;       ///< for ScanPath (ScanBufferWrite, ContourScan): the samples up to the end or the
                                      ///< fault (since the last write)
  std::vector<std::string> scan_log;  ///< for ScanPath: which speed limit bound where, and the scan's figures
  double start_time_s = 0;            ///< the controller clock when the command started (a sensor)
  double end_time_s = 0;              ///< the controller clock when it ended (the machine at rest)
};

}  // namespace metron::machine
