// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>

#include "metron/machine/machine_errors/axis_function.hpp"
#include "metron/machine/machine_errors/error_term.hpp"

namespace metron::machine {

/// The six component errors of one linear axis as functions of its own position (ISO 230-1:2012,
/// 3.4.6: for X: EXX positioning, EYX and EZX straightness, EAX roll, EBX pitch, ECX yaw).
struct AxisErrors {
  std::array<AxisFunction, 3> translation_mm;  ///< displacement along machine x, y, z (one is the positioning error)
  std::array<AxisFunction, 3> rotation_rad;    ///< small rotation about machine x, y, z (right hand)
};

/// The three squareness errors (ISO 230-1 EC0X-like location errors), rad: a later axis leans.
struct Squareness {
  double xy_rad = 0;  ///< Y leans toward +X: e_x += xy * y
  double xz_rad = 0;  ///< Z leans toward +X: e_x += xz * z
  double yz_rad = 0;  ///< Z leans toward +Y: e_y += yz * z
};

/// The rigid-body kinematic model of a three-axis machine (ISO 230-1, annex A; first order in the
/// angles, which on a CMM are ~1e-5 rad so the neglected terms are < 1e-9 mm per metre):
///   e = sum over the axes j (base -> ram) of [ d_j(q_j) + eps_j(q_j) x (sum_{k after j} q_k u_k + t) ]
///       + squareness,
/// with t the probe offset from the ram reference point. So an angular error of axis j acts on the
/// lever from that axis to the tip (the Abbe error). Each axis' translations are those of the ram
/// reference point with the later axes at zero.
class RigidBodyTerm final : public ErrorTerm {
 public:
  /// `stacking`: axis indices (0 x, 1 y, 2 z) from the base (carrying the part) to the ram; a
  /// moving-bridge CMM is {1, 0, 2}: the bridge on Y, the carriage on X, the ram on Z.
  RigidBodyTerm(std::array<AxisErrors, 3> axes, Squareness squareness, std::array<int, 3> stacking = {1, 0, 2});
  [[nodiscard]] Vec3 displacement(const MachinePose& pose, double time_s) const override;
  [[nodiscard]] std::string_view name() const override { return "rigid-body"; }

 private:
  std::array<AxisErrors, 3> m_axes;
  Squareness m_squareness;
  std::array<int, 3> m_stacking;
};

/// Reversal: per axis half the reversal value, with the sign of the last motion (ISO 230-2's B).
class ReversalTerm final : public ErrorTerm {
 public:
  /// `reversal_mm`: per axis, the difference between approaching in + and in - direction.
  explicit ReversalTerm(std::array<double, 3> reversal_mm) : m_reversal_mm(reversal_mm) {}
  [[nodiscard]] Vec3 displacement(const MachinePose& pose, double time_s) const override;
  [[nodiscard]] std::string_view name() const override { return "reversal"; }

 private:
  std::array<double, 3> m_reversal_mm;
};

}  // namespace metron::machine
