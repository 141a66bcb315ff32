// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <string>

#include <tl/expected.hpp>

#include "metron/machine/command.hpp"
#include "metron/runtime/feature.hpp"
#include "metron/stdlib/geometry/contour.hpp"
#include "metron/stdlib/geometry/scan_path.hpp"
#include "metron/stdlib/span.hpp"

// Scanning in the runtime (SEEDS.md 1): scan settings, PATH definitions, and the contour a scan
// of a path or of a nominal feature follows. docs/scanning-paths.md describes the statements.
namespace metron::runtime {

/// SCNMOD, SCNSET and FEDRAT/SCNVEL state.
struct ScanSettings {
  bool scan_mode = false;                        ///< SCNMOD/ON: a MEAS block without PTMEAS scans its nominal
  std::optional<double> feed_mm_s;               ///< FEDRAT/SCNVEL; empty: the machine's scanning feed
  double sample_spacing_mm = 0.1;                ///< SCNSET/DIST: one sample every this much path length
  double chord_tolerance_mm = 0.001;             ///< SCNSET/CHORD: PCC fit tolerance
  double centripetal_accel_mm_s2 = 200;          ///< SCNSET/ACCEL: curvature speed limit v = sqrt(a/kappa)
  double reference_deflection_mm = 0.3;          ///< SCNSET/DEFLEC: E0 (SEEDS.md 1 example value)
  machine::ScanLaw law = machine::ScanLaw::Vc2;  ///< SCNSET/LAW,VC1|VC1P|VC2
};

/// P(label)=PATH/...: a scan path on the design surface, in machine coordinates (mm).
struct PathDefinition {
  enum class Kind {
    Line,     ///< PATH/LINE: start, end, surface normal
    Arc,      ///< PATH/ARC: centre, axis, radius, start and end angle, INNER|OUTER
    Helical,  ///< PATH/HELICAL: as ARC plus the pitch per turn
    Section,  ///< PATH/SECTION (metron): a plane section of a CAD model
  };
  std::string label;
  Kind kind = Kind::Line;
  Vec3 point = Vec3::Zero();       ///< line start; arc/helix centre; section: a point on the plane
  Vec3 point2 = Vec3::Zero();      ///< line end; section: near the start of the scan
  std::optional<Vec3> point3;      ///< section: near the end of a sub-range (none: the whole section)
  Vec3 direction = Vec3::UnitZ();  ///< line: surface normal; arc/helix: axis; section: plane normal
  Vec3 reference = Vec3::UnitX();  ///< arc/helix: direction of angle 0
  double radius_mm = 0;
  double start_deg = 0;
  double end_deg = 360;                      ///< counterclockwise about the axis; end < start runs clockwise
  double pitch_mm = 0;                       ///< helix advance per turn along the axis
  bool inner = true;                         ///< arc/helix on a bore (normals toward the axis)
  std::string model_path;                    ///< section: the CAD file (STL, OFF, OBJ, PLY, STEP, IGES)
  std::optional<geometry::Contour> section;  ///< section: the contour, cut when the path is defined
  Span span;                                 ///< the PATH statement
};

/// The design contour of a PATH, sampled every `step_mm` (a section keeps its own sampling).
geometry::Contour path_contour(const PathDefinition& path, double step_mm);

/// The design contour a scan of a nominal feature follows (SCNMOD/ON): a circle or arc all
/// round, a bounded line along its length, a plane on a circle of 5 mm radius about its
/// position. `start_near` picks where a closed circle starts (the current probe position);
/// `depth_mm`/`up` place a circle like the touch planner does; an arc's angles count from
/// `arc_reference` projected on its plane. Error for types not scanned.
tl::expected<geometry::Contour, std::string> nominal_contour(const Geometry& nominal, const Vec3& start_near,
                                                             double depth_mm, const Vec3& up, const Vec3& arc_reference,
                                                             double step_mm);

/// SCNMOD/ON with PTMEAS: the scan of a nominal feature from `start` to `end` (points near its
/// surface, MCS). CIRCLE, ARC, CYLNDR: around the axis counterclockwise from start to end (rising
/// or falling along the axis with them, a helix); LINE, PLANE: the straight line from start to end
/// on the surface with normal `normal`. Error for other types.
tl::expected<geometry::Contour, std::string> nominal_contour_between(const Geometry& nominal, const Vec3& start,
                                                                     const Vec3& end, const Vec3& normal,
                                                                     double step_mm);

}  // namespace metron::runtime
