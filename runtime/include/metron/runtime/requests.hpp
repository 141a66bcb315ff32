// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "metron/runtime/alignment_ops.hpp"
#include "metron/runtime/feature.hpp"
#include "metron/runtime/runtime_error.hpp"
#include "metron/stdlib/geometry/vec.hpp"
#include "metron/stdlib/span.hpp"

// What the interpreter asks of the measurement runtime: the operands of its calls, one type per
// DMIS statement or setting (in current-frame coordinates, mm, unless a field says otherwise).
namespace metron::runtime {

class MeasurementRuntime;

/// DMIS MODE: who takes the points. metron's virtual operator takes PROG MAN points as given.
enum class Mode { Auto, ProgMan, Man };

/// SNSET distances (mm).
struct ProbeSettings {
  double approach_mm = 2.0;    ///< SNSET/APPRCH
  double retract_mm = 2.0;     ///< SNSET/RETRCT
  double search_mm = 5.0;      ///< SNSET/SEARCH
  double clearance_mm = 10.0;  ///< SNSET/CLRSRF: clearance above the feature for AUTO moves
  /// SNSET/CLRSRF,F(plane),d: a clearance surface, the plane moved d along its normal (MCS);
  /// AUTO moves rise at least to it. A later SNSET/CLRSRF,d without a feature removes it.
  struct ClearancePlane {
    Vec3 point_mm = Vec3::Zero();
    Vec3 normal = Vec3::UnitZ();
  };
  std::optional<ClearancePlane> clearance_plane;
  double depth_mm = 0.0;           ///< SNSET/DEPTH: measuring depth below a feature's start for AUTO points
  bool approach_explicit = false;  ///< SNSET/APPRCH was given: it overrides a characterisation's approach
};

/// S(label)=SNSDEF/PROBE,...: a sensor as the program defines it.
struct SensorDefinition {
  std::string label;
  double ball_diameter_mm = 4.0;
  Vec3 direction = -Vec3::UnitZ();  ///< from the head to the ball (current frame)
  double length_mm = 50.0;
};

/// A feature operand: F(x) (nominal) or FA(x) (actual).
struct FeatureRef {
  std::string label;
  bool actual = true;
};

/// One step of a MEAS block, in current-frame coordinates (already in mm).
struct MeasStep {
  /// SelectSensor: a SNSLCT inside the block; the points after it are taken with that sensor.
  /// Setting: a FEDRAT, ACLRAT or SNSET inside the block; the points after it are taken with it.
  /// Reference: an RPTMEAS, a point of the surface around the feature (RMEAS ...,VECBLD): the
  /// block's reference points are probed first, and its PtMeas moved by the surface's deviation.
  enum class Kind { GoTo, PtMeas, Scan, SelectSensor, Setting, Reference } kind = Kind::PtMeas;
  Vec3 point = Vec3::Zero();
  std::optional<Vec3> normal;  ///< PTMEAS i,j,k (approach side); nullopt = from the nominal
  Span span;
  std::string path;        ///< Scan (PAMEAS/P(label)): the path's label; SelectSensor: the sensor's
  bool requalify = false;  ///< SelectSensor: SNSLCT/...,CALIB (qualify it again)
  /// Setting: applies it (its numbers evaluated where the statement stands in the program).
  std::function<Result<void>(MeasurementRuntime&)> apply;
};

/// MEAS/type,F(label),n ... ENDMES.
struct MeasBlock {
  std::string feature;
  FeatureType type = FeatureType::Point;
  int point_count = 0;
  std::vector<MeasStep> steps;
  Span span;  ///< the MEAS statement
  /// Without PTMEAS, plan the points (AUTO, a nominal scan); off for the runs of a block that a
  /// SNSLCT splits when another run has the points.
  bool plan_missing_points = true;
};

/// DATSET/... with datum labels.
struct DatsetRequest {
  struct Clause {
    std::string datum;                  ///< DAT(datum), or
    std::optional<FeatureRef> feature;  ///< a feature written in its place (DATSET/FA(x),...)
    std::optional<Axis> direction;
    bool minus = false;
    std::vector<Axis> origins;
  };
  bool mcs = false;  ///< DATSET/MCS
  std::vector<Clause> clauses;
};

/// TRANS/XORIG,v|FA(f),...
struct TransRequest {
  std::optional<double> value[3];
  std::optional<FeatureRef> feature[3];
};

/// ROTATE/axis,angle or ROTATE/axis,FA(f),XDIR|YDIR|ZDIR
struct RotateRequest {
  Axis about = Axis::Z;
  std::optional<double> angle_deg;
  std::optional<FeatureRef> feature;
  Axis align = Axis::X;
  bool align_negative = false;  ///< -XDIR ...: the feature's direction is turned onto the axis's minus side
};

/// D(l)=LOCATE/[XDIR,YDIR,ZDIR,XAXIS,YAXIS,ZAXIS,]FA(f)|DAT(d),...: a best-fit alignment.
struct LocateRequest {
  std::vector<FeatureRef> features;             ///< FA(f) or F(f) (the actual is what is fitted)
  std::vector<std::string> datums;              ///< DAT(d): the datum feature's actual
  std::array<bool, 3> along{true, true, true};  ///< XDIR, YDIR, ZDIR (all when none is written)
  std::array<bool, 3> about{true, true, true};  ///< XAXIS, YAXIS, ZAXIS
};

/// CONST/type,F(x),method,sources...
enum class ConstructMethod {
  BestFit,
  Intersection,
  Midpoint,
  Projection,
  ParallelThrough,       ///< PARTO: the reference's direction, through a point
  PerpendicularThrough,  ///< PERPTO: normal to the reference, through a point
  Cast,                  ///< CAST: one feature's geometry as another type
  Copy,                  ///< COPY: one feature's geometry, the same type
  Vertex
};  ///< VERTEX: a cone's apex as a POINT

/// OUTPUT/ item: a feature (F or FA) or a tolerance (T or TA).
struct OutputItem {
  enum class Kind { Feature, Tolerance, Sensor, CoordinateSystem } kind = Kind::Feature;
  FeatureRef feature;
  std::string tolerance;
  /// OUTPUT/S(x) (its definition) or SA(x) (its qualification): the sensor's label.
  std::string sensor;
  bool sensor_actual = false;
  /// OUTPUT/D(x) or DA(x): the coordinate system's label, and whether it was named DA.
  std::string coordinate_system;
  bool coordinate_system_actual = false;
  /// OUTPUT/FA(x)[first,last] (MODUS): the feature's points first..last (1-based) are listed.
  std::optional<std::pair<int, int>> points;
};

}  // namespace metron::runtime
