// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/discrepancy/prediction.hpp"

namespace metron::machine {

using discrepancy::Role;

MachinePose row_pose(const discrepancy::MeasuredData& data, std::size_t row) {
  MachinePose pose;
  const auto q = data.position_mm(row);
  pose.axes_mm = Vec3(q[0], q[1], q[2]);
  for (int a = 0; a < 3; ++a) {
    const auto au = static_cast<std::size_t>(a);
    if (const auto* d = data.find(Role::Direction, a))
      pose.approach[au] = d->values[row] > 0 ? 1 : -1;
    else if (const auto* dd = data.find(Role::Direction))
      pose.approach[au] = dd->values[row] > 0 ? 1 : -1;
    else if (const auto* ap = data.find(Role::Approach, a))
      pose.approach[au] = ap->values[row] > 0 ? 1 : ap->values[row] < 0 ? -1 : 0;
  }
  return pose;
}

double row_time_s(const discrepancy::MeasuredData& data, std::size_t row) {
  const auto* t = data.find(Role::Time);
  return t ? t->values[row] : 0.0;
}

double predicted_deviation_mm(const MachineErrorModel& errors, const discrepancy::MeasuredData& data, std::size_t row,
                              int axis) {
  if (errors.empty()) return 0;
  const Vec3 e = errors.displacement(row_pose(data, row), row_time_s(data, row));
  const double sign = data.description.kind == discrepancy::DataKind::Artefact ? -1.0 : 1.0;
  if (axis < 3) return sign * e[axis];
  Vec3 u = Vec3::Zero();
  for (int a = 0; a < 3; ++a)
    if (const auto* ap = data.find(Role::Approach, a)) u[a] = ap->values[row];
  const double n = u.norm();
  return n > 0 ? sign * e.dot(u / n) : 0.0;
}

nlohmann::json extended_errors(const nlohmann::json& base, const std::vector<discrepancy::Effect>& effects) {
  nlohmann::json out = base.is_object() ? base : nlohmann::json::object();
  if (!out.contains("terms")) out["terms"] = nlohmann::json::array();
  for (const auto& e : effects)
    if (!e.world_term.is_null()) out["terms"].push_back(e.world_term);
  return out;
}

}  // namespace metron::machine
