// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <vector>

#include "metron/runtime/feature.hpp"
#include "metron/runtime/requests.hpp"

namespace metron::runtime {

/// A step the scheduler plans in machine coordinates.
struct PlannedStep {
  enum class Kind { GoTo, Probe } kind = Kind::Probe;
  Vec3 point = Vec3::Zero();    ///< GoTo: ball-centre target; Probe: nominal surface point
  Vec3 normal = Vec3::UnitZ();  ///< Probe: approach side normal
};

/// The nominal surface normal on the probe's side at (near) `point`, for a PTMEAS without i,j,k.
Vec3 nominal_normal_at(const Geometry& nominal, const Vec3& point);

/// Points for a MEAS block with no PTMEAS (AUTO mode): `count` points (0 = a sensible default for
/// the type) spread over the nominal feature (MCS), with clearance moves along `up` so that the
/// ball (radius `ball_radius_mm`, whose centre the GoTo steps position) does not cut through the
/// part between points. An ARC's points lie within its span, its angles counted from
/// `arc_reference` about its axis. Empty when the type cannot be planned.
std::vector<PlannedStep> plan_auto_points(const Geometry& nominal, int count, const ProbeSettings& probe,
                                          double ball_radius_mm, const Vec3& up, const Vec3& current_position,
                                          const Vec3& arc_reference = Vec3::UnitX());

/// Fewest points that determine a feature of this type.
int minimum_points(FeatureType type);

}  // namespace metron::runtime
