// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/runtime/feature.hpp"

namespace metron::runtime {

const char* dmis_word(FeatureType type) {
  switch (type) {
    case FeatureType::Point: return "POINT";
    case FeatureType::Plane: return "PLANE";
    case FeatureType::Line: return "LINE";
    case FeatureType::Circle: return "CIRCLE";
    case FeatureType::Arc: return "ARC";
    case FeatureType::Sphere: return "SPHERE";
    case FeatureType::Cylinder: return "CYLNDR";
    case FeatureType::Cone: return "CONE";
    case FeatureType::ParallelPlanes: return "PARPLN";
    case FeatureType::GenericSurface: return "GSURF";
    case FeatureType::GenericCurve: return "GCURVE";
    case FeatureType::ClosedSlot: return "CPARLN";
    case FeatureType::Torus: return "TORUS";
    case FeatureType::Ellipse: return "ELLIPS";
  }
  return "POINT";
}

const char* dmis_word(Side side) {
  switch (side) {
    case Side::None: return "";
    case Side::Inner: return "INNER";
    case Side::Outer: return "OUTER";
  }
  return "";
}

const char* dmis_word(SlotEnds ends) { return ends == SlotEnds::Flat ? "FLAT" : "ROUND"; }

}  // namespace metron::runtime
