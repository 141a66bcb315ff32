// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <functional>
#include <string>

#include "metron/machine/active_scanning/scan_controller.hpp"
#include "metron/machine/command.hpp"

namespace metron::machine {

/// "" when the unknown-contour scan can be run, else what is wrong with it.
std::string validate_contour_scan(const ContourScan& command);
/// The approach point: the start plus approach_mm along the start normal.
Vec3 contour_approach_point(const ContourScan& command);

/// Unknown-contour scanning (docs/scanning.md, "Unknown contours"). From rest at `start_mm`
/// (normally the approach point) the head moves along -start_normal until the deflection reaches
/// E0; then every control cycle it commands
///   V = Gf*Vf*t + Ge*K*(|Ep| - E0)*eu' - Kc*g*grad g
/// where eu is the deflection's direction (the surface normal the probe feels), eu' its part in
/// the section, g the ball's signed distance from the section (plane or cylinder) and
/// t = (grad g x eu)/|grad g x eu| the direction along the contour, kept on the side of the
/// previous cycle's (first: `direction`). There is no path to follow: the surface leads, the
/// section holds the ball in its plane or cylinder. Vf is the feed, limited by the curvature the
/// probe has felt (v^2 * kappa <= the centripetal limit). The scan ends when the ball centre
/// meets `end`; then the head retracts along the deflection. Samples (ball centre, deflection)
/// every sample_spacing_mm of travel. Faults: over-range (OverTravel), no contact at the start or
/// contact lost (NoContact), no progress or no end within max_length_mm (Stalled).
ScanOutcome run_contour_scan(const ContourScan& command, const ScanSetup& setup, const Vec3& start_mm,
                             double start_time_s, const std::function<void(const ScanCycle&)>& cycle = {});

}  // namespace metron::machine
