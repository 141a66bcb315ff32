// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <variant>

#include "metron/machine/fault.hpp"
#include "metron/stdlib/geometry/vec.hpp"

namespace metron::machine {

// The machine command interface, modelled on I++ DME: tagged commands are queued, executed in
// order, and every command is answered by a tagged response. All coordinates are machine
// coordinates (MCS) in mm of the stylus ball centre; speeds in mm/s.

/// Positioning move of the ball centre to `target_mm` (straight line, rest to rest).
struct GoTo {
  Vec3 target_mm = Vec3::Zero();
  std::optional<double> speed_mm_s;   ///< default: the current positioning feed
};

/// Touch-trigger point measurement, as I++ DME PtMeas: move to nominal + approach*normal
/// (positioning move), probe along -normal at the measuring feed until a trigger or until
/// `search_mm` past the nominal, then retract by `retract_mm` along +normal.
struct PtMeas {
  Vec3 nominal_mm = Vec3::Zero();     ///< nominal SURFACE point
  Vec3 normal = Vec3::UnitZ();        ///< unit surface normal on the probe's side (approach from here)
  double approach_mm = 2.0;           ///< start distance before the nominal surface
  double search_mm = 5.0;             ///< how far past the nominal the probe searches
  double retract_mm = 2.0;            ///< retract distance after the hit
  std::optional<double> speed_mm_s;   ///< default: the current measuring feed
};

/// Defines a tool (stylus) on the probe head, as DMIS SNSDEF/PROBE does.
struct DefineTool {
  std::string name;
  double ball_diameter_mm = 4.0;      ///< nominal stylus ball diameter
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
};

/// A command with the client's tag (the runtime uses it to find the originating statement).
struct Command {
  std::uint64_t tag = 0;
  std::variant<GoTo, PtMeas, DefineTool, SelectTool, QualifyTool, SetFeeds> body;
};

/// A probed point as the controller reports it.
struct Hit {
  Vec3 centre_mm = Vec3::Zero();      ///< ball centre latched by the controller (machine coordinates)
  Vec3 normal = Vec3::UnitZ();        ///< the probing direction's normal (from the PtMeas)
  double ball_radius_mm = 0;          ///< the active tool's calibrated (effective) radius
  double time_s = 0;                  ///< simulated time of the trigger
  /// Surface point compensated along the probing normal (exact for planes; fitting redoes it).
  [[nodiscard]] Vec3 surface_mm() const { return centre_mm - ball_radius_mm * normal; }
};

/// Calibration state of a tool, known on the controller side.
struct ToolInfo {
  std::string name;
  double nominal_radius_mm = 0;       ///< from its definition
  double effective_radius_mm = 0;     ///< after qualification (includes pre-travel and delays)
  bool qualified = false;
  double qualification_form_mm = 0;   ///< sphere form of the qualification fit (a quality figure)
};

/// The answer to one command.
struct Response {
  std::uint64_t tag = 0;
  enum class Status { Done, Fault } status = Status::Done;
  std::optional<Hit> hit;             ///< for PtMeas
  std::optional<ToolInfo> tool;       ///< for DefineTool, SelectTool, QualifyTool
  std::optional<Fault> fault;         ///< when status == Fault
};

}  // namespace metron::machine
