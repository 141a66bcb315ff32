// SPDX-License-Identifier: GPL-3.0-or-later
// The order of a feature's numbers (DMIS 5.x FEAT statements; docs/results-json.md).
#include "metron/runtime/feature_parameters.hpp"

namespace metron::runtime {

bool has_side(FeatureType type) {
  return type == FeatureType::Circle || type == FeatureType::Arc || type == FeatureType::Sphere ||
         type == FeatureType::Cylinder || type == FeatureType::Cone || type == FeatureType::ParallelPlanes ||
         type == FeatureType::ClosedSlot || type == FeatureType::Torus || type == FeatureType::Ellipse;
}

std::size_t feature_word_count(FeatureType type) {
  // LINE: BND|UNBND; CPARLN: ROUND|FLAT.
  const bool extra_word = type == FeatureType::Line || type == FeatureType::ClosedSlot;
  return 2 + (extra_word ? 1 : 0) + (has_side(type) ? 1 : 0);
}

// GSURF and GCURVE: FEAT/GSURF has no numbers (its points are its nominal); metron reports the
// centroid of the points and the mean normal as x,y,z,i,j,k (the GCURVE form).

std::vector<FeatureParameter> feature_parameters(const Geometry& g) {
  std::vector<FeatureParameter> out;
  const auto add = [&out](const Vec3& v, ParameterUnit unit) {
    for (int i = 0; i < 3; ++i) out.push_back({v[i], unit});
  };
  const auto length = [&out](double v) { out.push_back({v, ParameterUnit::Length}); };
  add(g.position, ParameterUnit::Length);
  switch (g.type) {
    case FeatureType::Point:
    case FeatureType::Plane: add(g.direction, ParameterUnit::Cosine); break;
    case FeatureType::Line:
      // BND: start and end point; UNBND: point and direction; then the normal of its plane.
      if (g.bounded)
        add(Vec3(g.position + g.length_mm * g.direction), ParameterUnit::Length);
      else
        add(g.direction, ParameterUnit::Cosine);
      add(g.normal2, ParameterUnit::Cosine);
      break;
    case FeatureType::Circle:
      add(g.direction, ParameterUnit::Cosine);
      length(g.diameter_mm);
      break;
    case FeatureType::Arc:
      add(g.direction, ParameterUnit::Cosine);
      length(0.5 * g.diameter_mm);
      out.push_back({g.start_angle_deg, ParameterUnit::Angle});
      out.push_back({g.included_angle_deg, ParameterUnit::Angle});
      break;
    case FeatureType::Sphere: length(g.diameter_mm); break;
    case FeatureType::Cylinder:
      add(g.direction, ParameterUnit::Cosine);
      length(g.diameter_mm);
      length(g.length_mm);
      break;
    case FeatureType::Cone:
      add(g.direction, ParameterUnit::Cosine);
      out.push_back({g.apex_angle_deg, ParameterUnit::Angle});
      break;
    case FeatureType::ParallelPlanes:
      add(g.direction, ParameterUnit::Cosine);
      length(g.width_mm);
      break;
    case FeatureType::GenericSurface:
    case FeatureType::GenericCurve: add(g.direction, ParameterUnit::Cosine); break;
    case FeatureType::ClosedSlot:
      // The normal of its plane, then its long axis (as the CPARLN statements of CMM programs).
      add(g.direction, ParameterUnit::Cosine);
      add(g.slot_axis, ParameterUnit::Cosine);
      length(g.length_mm);
      length(g.width_mm);
      break;
    case FeatureType::Torus:
      add(g.direction, ParameterUnit::Cosine);
      length(g.diameter_mm);
      length(g.minor_diameter_mm);
      break;
    case FeatureType::Ellipse:
      // As its FEAT: the normal of its plane, its major axis, the major and minor diameters.
      add(g.direction, ParameterUnit::Cosine);
      add(g.slot_axis, ParameterUnit::Cosine);
      length(g.diameter_mm);
      length(g.minor_diameter_mm);
      break;
  }
  return out;
}

}  // namespace metron::runtime
