// SPDX-License-Identifier: GPL-3.0-or-later
// Nominal and actual geometries for the tolerance tests, written the way the tests read them.
#pragma once
#include "metron/runtime/feature.hpp"

namespace metron::test_support {

/// A plane through `position` with the (normalised) `normal`.
inline runtime::Geometry plane(const Vec3& position, const Vec3& normal) {
  runtime::Geometry g;
  g.type = runtime::FeatureType::Plane;
  g.position = position;
  g.direction = normal.normalized();
  return g;
}

}  // namespace metron::test_support
