// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <memory>

#include "metron/machine/solid.hpp"
#include "metron/machine/world.hpp"

namespace metron::machine {

/// The workpiece as machined (design, pose, deviations, roughness) in machine coordinates;
/// nullptr when the world has no part.
std::unique_ptr<Solid> make_part_solid(const WorldTruth& world);

/// The reference sphere (true centre and diameter) on its post, features "REFERENCE_SPHERE"
/// and "REFERENCE_POST".
std::unique_ptr<Solid> make_reference_sphere_solid(const ReferenceSphereTruth& sphere);

/// Everything a moving probe can hit: the table (everything below table_z_mm, feature
/// "TABLE"), the reference sphere and its post, and the part.
std::unique_ptr<Solid> make_world_solid(const WorldTruth& world);

}  // namespace metron::machine
