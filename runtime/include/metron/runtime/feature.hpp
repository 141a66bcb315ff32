// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "metron/stdlib/geometry/vec.hpp"
#include "metron/stdlib/span.hpp"

namespace metron::runtime {

/// DMIS feature types metron measures and constructs.
enum class FeatureType {
  Point,
  Plane,
  Line,
  Circle,
  Arc,
  Sphere,
  Cylinder,
  Cone,
  ParallelPlanes,  ///< PARPLN: a slot (INNER) or tab (OUTER) between two parallel faces
  GenericSurface,  ///< GSURF: a surface known by the points the program probes on it
  GenericCurve,    ///< GCURVE: a curve known the same way
  ClosedSlot,      ///< CPARLN: closed-ended parallel lines, a slot (INNER) or tab (OUTER) outline in a plane
  Torus,           ///< TORUS: a ring (OUTER) or a toroidal groove or fillet (INNER)
  Ellipse
};  ///< ELLIPS: an elliptic hole (INNER) or boss (OUTER) outline in a plane
/// GSURF and GCURVE: no analytic nominal; each probed point carries its own nominal (the PTMEAS).
inline bool is_point_set(FeatureType type) {
  return type == FeatureType::GenericSurface || type == FeatureType::GenericCurve;
}
/// Material side of a feature of size: INNER (a bore) or OUTER (a boss); None for others.
enum class Side { None, Inner, Outer };
/// The ends of a CPARLN: ROUND (semicircles of the width's diameter) or FLAT (square).
enum class SlotEnds { Round, Flat };

const char* dmis_word(FeatureType type);  ///< POINT, PLANE, LINE, CIRCLE, ARC, SPHERE, CYLNDR, CONE, PARPLN, GSURF,
                                          ///< GCURVE, CPARLN, TORUS, ELLIPS
const char* dmis_word(Side side);         ///< INNER, OUTER, or ""
const char* dmis_word(SlotEnds ends);     ///< ROUND, FLAT

/// The geometry of a feature (nominal or actual), always in machine coordinates (MCS), mm.
struct Geometry {
  FeatureType type = FeatureType::Point;
  Side side = Side::None;
  Vec3 position = Vec3::Zero();    ///< point; a point on a plane/line; centre; a point on an axis (cone: apex); PARPLN:
                                   ///< on the median plane; CPARLN: centre
  Vec3 direction = Vec3::UnitZ();  ///< point/plane normal, line direction, circle/cylinder/cone/torus axis, PARPLN
                                   ///< normal, CPARLN, ELLIPS: normal of its plane
  Vec3 normal2 = Vec3::UnitZ();    ///< line: the normal of the plane the line lies in (DMIS LINE ... ,i2,j2,k2)
  double diameter_mm = 0;  ///< circle, arc, sphere, cylinder; torus: its centre circle's (the major diameter); ellipse:
                           ///< its major diameter
  double minor_diameter_mm = 0;          ///< torus: its tube's; ellipse: its minor diameter
  Vec3 slot_axis = Vec3::UnitX();        ///< CPARLN: its long axis; ELLIPS: its major axis (normal to `direction`)
  SlotEnds slot_ends = SlotEnds::Round;  ///< CPARLN
  double width_mm = 0;                   ///< PARPLN: the distance between its faces; CPARLN: between its parallel sides
  double length_mm = 0;                  ///< cylinder, cone, bounded line; CPARLN: overall, end to end
  double apex_angle_deg = 0;             ///< cone full apex angle
  double start_angle_deg = 0;            ///< arc
  double included_angle_deg = 0;         ///< arc
  /// ARC: the direction its angles count from when its FEAT gave one (RationalDMIS writes it after
  /// the angles); zero: the part's X axis (its Y when the arc's axis is X).
  Vec3 arc_reference = Vec3::Zero();
  bool bounded = false;  ///< line BND vs UNBND
};

/// One probed point as the runtime keeps it.
struct MeasuredPoint {
  Vec3 centre_mm = Vec3::Zero();  ///< ball centre reported by the machine (MCS)
  Vec3 normal = Vec3::UnitZ();    ///< probing (approach) direction, unit (MCS)
  double ball_radius_mm = 0;      ///< effective radius used for compensation
  double time_s = 0;              ///< simulated time of the trigger
  Span origin;                    ///< the PTMEAS (or MEAS in AUTO mode, or PAMEAS) that took it
  bool scanned = false;           ///< a scanning sample: `normal` is the deflection direction
  /// The PTMEAS's nominal surface point and its unit normal out of the material (MCS), when the
  /// point was taken by a PTMEAS (not a scan): the nominal of each point of a GSURF or GCURVE.
  std::optional<Vec3> nominal_mm;
  Vec3 nominal_normal = Vec3::UnitZ();
  [[nodiscard]] Vec3 surface_mm() const { return centre_mm - ball_radius_mm * normal; }
};

/// Fit figures of an actual feature.
struct FitFigures {
  std::vector<double> residuals_mm;  ///< signed, one per point
  double rms_mm = 0;
  double form_mm = 0;  ///< flatness, straightness, roundness, sphericity, cylindricity ...
};

/// How an actual came to be.
enum class ActualSource { Measured, Constructed };

/// A feature of the program: its nominal, and its actual once measured or constructed.
struct Feature {
  std::string label;  ///< the F()/FA() name
  Geometry nominal;
  /// The alignment in force when the nominal was defined: the program wrote the nominal's
  /// numbers in that frame (a datum reference frame compares nominals in one part frame).
  Frame nominal_frame = Frame::Identity();
  std::optional<Geometry> actual;
  ActualSource source = ActualSource::Measured;
  std::vector<MeasuredPoint> points;
  std::optional<FitFigures> fit;
  /// When the earliest probed point its actual rests on was taken (simulated s): a constructed
  /// feature's sources', a reported actual's statement time; infinity without an actual. EQUATE
  /// carries the features of a part's earlier set-up into its later one by it.
  double rests_on_s = std::numeric_limits<double>::infinity();
  /// Alignment::rests_on_s of the alignment the nominal was written in: EQUATE carries a nominal
  /// not yet measured with the set-up its frame belongs to.
  double nominal_rests_on_s = std::numeric_limits<double>::infinity();
  /// A constructed feature's lever: how far the points its construction rests on (its sources'
  /// probed points, or their positions) spread about their centroid, RMS, mm. A best fit weighs
  /// a direction's mismatch by it, as it weighs a measured feature's by its own points' spread.
  double construction_spread_mm = 0;
  Span defined_at;   ///< the FEAT statement
  Span measured_at;  ///< the MEAS or CONST statement
};

}  // namespace metron::runtime
