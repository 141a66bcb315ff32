// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <limits>
#include <optional>
#include <string>
#include <tl/expected.hpp>
#include <vector>

#include "metron/runtime/alignment.hpp"
#include "metron/runtime/feature.hpp"
#include "metron/runtime/report_units.hpp"
#include "metron/stdlib/span.hpp"

namespace metron::runtime {

/// The DMIS tolerance kinds metron evaluates.
enum class ToleranceKind {
  Diam,
  Rad,
  DistB,
  Pos,
  Flat,
  Cirlty,
  Cylcty,
  Sphcty,
  Strght,
  Perp,
  Parlel,
  Anglb,
  Profs,
  DistWrt,  ///< DISTB to a reference feature named in the TOL (DMIS 5.3 6.163)
  AngWrt,   ///< ANGLB to a reference feature named in the TOL
  Cortol,   ///< one coordinate of the feature's position (CORTOL)
  Concen,   ///< concentricity: a centre within a circle about the datum axis
  Coaxial,  ///< coaxiality: an axis within a cylinder about the datum axis
  Crnout,   ///< circular runout (CRNOUT; RUNOUT in older programs)
  Totrun,   ///< total runout (TOTRUN; TRNOUT)
  Profl,    ///< line profile: PROFS on a line, circle or arc
  Profp,    ///< point profile: a point's deviation along its nominal normal
  Width,    ///< size of a PARPLN (slot or tab): its width's deviation
  Symmty,   ///< symmetry: a PARPLN's median plane about a datum plane
  Angl,     ///< a CONE's included angle: its deviation (DMIS TOL/ANGL,lo,up)
  Compos,   ///< composite position: a pattern's PATERN tier and its FEATUR tier
  Anglr     ///< angularity: a plane, median plane or axis at a basic angle to a datum, within a zone
};
const char* dmis_word(ToleranceKind kind);  ///< DIAM, RAD, DISTB, POS, FLAT, ...
/// Kinds whose value is an angle (degrees), not a length.
inline bool is_angle_kind(ToleranceKind kind) {
  return kind == ToleranceKind::Anglb || kind == ToleranceKind::AngWrt || kind == ToleranceKind::Angl;
}

struct ToleranceResult;
/// Whether a result's value is an angle (degrees): an angle kind's, or CORTOL's polar angle.
bool is_angle_result(const ToleranceResult& result);

/// Whether a tolerance kind applies to a feature type: the types its evaluator accepts (the
/// compiler checks OUTPUT with it, so that check and run agree).
bool tolerance_applies(ToleranceKind kind, FeatureType type);

/// Distance direction for DISTB (and the coordinate of CORTOL).
enum class DistanceAxis { PointToPoint, XAxis, YAxis, ZAxis };
/// CORTOL's polar coordinates, in the working plane (WKPLAN): the radius from the origin and the
/// angle from the plane's first axis.
enum class PolarCoordinate { None, Radius, Angle };
/// WKPLAN: the plane polar coordinates are taken in, named by its two axes (the angle turns from
/// the first toward the second, as the polar angle of XYPLAN turns from X toward Y).
enum class WorkingPlane { XY, YZ, ZX };
/// DISTB and DISTWRT: the distance between centres (AVG, the default) or between the near (MINIM)
/// or far (MAXIM) sides of features of size.
enum class DistanceExtent { Average, Minimum, Maximum };
/// Material condition modifier of POS.
enum class MaterialCondition { Rfs, Mmc, Lmc };

/// A tolerance definition T(label)=TOL/... (values already in mm / degrees).
struct ToleranceSpec {
  std::string label;
  ToleranceKind kind = ToleranceKind::Diam;
  double nominal = 0;      ///< DISTB nominal distance, ANGLB nominal angle, ANGLR basic angle (degrees)
  double lower = 0;        ///< lower deviation limit (DIAM, RAD, DISTB, ANGLB, PROFS)
  double upper = 0;        ///< upper deviation limit
  double zone = 0;         ///< tolerance zone (POS, form, PERP, PARLEL, ANGLR)
  bool three_d = false;    ///< POS 3D (else 2D)
  bool long_side = false;  ///< WIDTH,...,LONG: a CPARLN's length (SHORT, the default: its width)
  DistanceAxis axis = DistanceAxis::PointToPoint;
  PolarCoordinate polar = PolarCoordinate::None;  ///< CORTOL,RADIUS|ANGLE (lower, upper: mm or degrees)
  /// DISTB, DISTWRT: the LIMIT form: `lower` and `upper` bound the distance itself (no nominal).
  bool limits = false;
  DistanceExtent extent = DistanceExtent::Average;
  /// DIAM|RAD,lo,up,DIAMLP: the two-point sizes (ISO 14405-1 LP), not the least-squares size.
  bool two_point_size = false;
  /// FLAT,t,tu,a,b and STRGHT,t,tu,l: the form within every unit area a x b (unit length l) must
  /// also lie within `unit_zone` (0: no per-unit zone). a runs along the reporting frame's X
  /// projected onto the plane (its Y when X is within 30 deg of the plane's normal).
  double unit_zone = 0;
  double unit_length = 0;
  double unit_width = 0;
  MaterialCondition condition = MaterialCondition::Rfs;
  std::vector<std::string> datums;  ///< DAT() labels referenced (COMPOS: the PATERN tier's)
  /// POS: each datum's material condition (`DAT(B),MMC`), one per `datums`; empty: all RFS. A
  /// datum feature of size at MMC or LMC lets the frame shift (docs/tolerances.md "Datum shift").
  std::vector<MaterialCondition> datum_conditions;
  /// COMPOS: the FEATUR tier (the feature-relating zone), its modifier and its datums, which
  /// orient the pattern and never locate it (ASME Y14.5-2018 10.5.1).
  double feature_zone = 0;
  MaterialCondition feature_condition = MaterialCondition::Rfs;
  std::vector<std::string> feature_datums;
  std::string reference_feature;  ///< DISTWRT, ANGWRT: the FA() the distance or angle is taken to
  Span defined_at;
};

/// A datum: DATDEF/FA(x),DAT(A) binds datum A to the actual of feature x.
struct Datum {
  std::string label;
  std::string feature;
  Geometry geometry;                                            ///< the actual (MCS) at DATDEF time
  Geometry nominal;                                             ///< the datum feature's nominal (MCS)
  Frame nominal_frame = Frame::Identity();                      ///< the alignment that nominal was written in
  double rests_on_s = std::numeric_limits<double>::infinity();  ///< its feature's Feature::rests_on_s at DATDEF
};

/// The outcome of evaluating one tolerance on one or two features.
struct ToleranceResult {
  std::string label;
  ToleranceKind kind = ToleranceKind::Diam;
  std::string tier;                   ///< COMPOS: "PATERN" or "FEATUR" (empty otherwise)
  std::vector<std::string> features;  ///< feature labels it was applied to
  double value = 0;    ///< the measured quantity: deviation (DIAM, RAD, DISTB, ANGLB), zone used (POS, form ...)
  double actual = 0;   ///< the actual size/distance/angle where meaningful (DIAM: actual diameter)
  double nominal = 0;  ///< the nominal size/distance/angle where meaningful
  double lower = 0;    ///< accepted range for `value`
  double upper = 0;
  bool in_tolerance = false;
  std::string note;          ///< how it was evaluated when not obvious (e.g. the datum reference frame)
  bool three_d = false;      ///< POS: the spec's 3D zone (else 2D); the DMIS output line needs it
  bool angle_value = false;  ///< the value is an angle (degrees) though the kind is not (CORTOL,ANGLE)
  ReportUnits units;         ///< the program's UNITS and DECPL at the OUTPUT (reports only)
};

/// What an evaluation needs besides the spec and features.
struct ToleranceContext {
  const Alignment* alignment = nullptr;           ///< the current coordinate system (reporting frame)
  std::vector<const Datum*> datums;               ///< resolved datums of spec.datums, same order
  std::vector<const Datum*> feature_datums;       ///< resolved datums of spec.feature_datums (COMPOS)
  ReportUnits units;                              ///< the program's UNITS and DECPL: the notes' lengths
  WorkingPlane working_plane = WorkingPlane::XY;  ///< WKPLAN: CORTOL's polar coordinates
};

/// Evaluates `spec` on `features` (one feature, or two for DISTB). Returns an error message
/// (lowercase) when the tolerance does not apply, e.g. "DIAM needs a feature of size, got PLANE".
tl::expected<ToleranceResult, std::string> evaluate_tolerance(const ToleranceSpec& spec,
                                                              const std::vector<const Feature*>& features,
                                                              const ToleranceContext& context);

/// TOL/COMPOS on a pattern of features (one or more): the PATERN tier is POS of each feature in
/// the PATERN datums' frame (the largest zone used is reported); the FEATUR tier is the same after
/// the pattern, as a rigid group, is moved onto its true positions by least squares: free to
/// translate, turned only about what the FEATUR datums leave free (docs/tolerances.md). Two
/// results, PATERN then FEATUR.
tl::expected<std::vector<ToleranceResult>, std::string> evaluate_composite(const ToleranceSpec& spec,
                                                                           const std::vector<const Feature*>& features,
                                                                           const ToleranceContext& context);

}  // namespace metron::runtime
