// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>

#include "metron/machine/solid.hpp"

namespace metron::machine {

/// First contact of a ball of radius `radius_mm` whose centre moves along the segment a -> b:
/// the fraction s in [0, 1] of the first touch, or nullopt when the ball stays free.
///
/// Sphere tracing on g = signed_distance - r with steps g / lipschitz (a step that cannot cross
/// the surface, J. C. Hart, "Sphere tracing", The Visual Computer 12(10), 1996), with a floor of
/// 1e-6 mm so grazing moves make progress, then bisection of the bracketing step until it is
/// shorter than `tol_mm`; the returned s is the touching end (penetration <= tol_mm).
/// A ball that starts in contact (a deflected stylus) is free while the move takes it away from
/// the surface; checking starts where it leaves. Starting in contact and not moving away is a
/// contact at s = 0.
std::optional<double> first_ball_contact(const Solid& solid, const Vec3& a, const Vec3& b, double radius_mm,
                                         double tol_mm = 1e-9);

}  // namespace metron::machine
