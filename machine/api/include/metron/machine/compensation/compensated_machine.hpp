// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "metron/machine/compensation/error_map.hpp"
#include "metron/machine/machine.hpp"

namespace metron::machine {

/// The controller's volumetric compensation as a decorator at the machine API (SEEDS.md 4,
/// docs/error-space.md "Compensation"): any backend, seen through an error map. With e the map,
///   a commanded position P (GoTo target, PtMeas nominal) goes to the inner machine as
///   q = P - e(q), solved by the fixed point q_0 = P, q_{n+1} = P - e(q_n) (two steps; |grad e|
///   is ~1e-5, so the residual is ~1e-10 of e);
///   a reported position q (hit centre, scan sample, state, fault position) comes back as q + e(q).
/// Directions (probing normals, scan paths' shapes) pass unchanged: the map's rotation is a few
/// urad. A scan path is shifted as a whole by -e at its start (the probe's deflection absorbs the
/// rest along the path). The tool qualification, a cycle inside the machine, is redone here: its
/// ball-centre points (ToolInfo::qualification_centres_mm) are corrected and the sphere refitted,
/// and the effective radius that results replaces the machine's in tool infos and hits (a real
/// controller compensates the qualification's probing like any other).
/// A map calibrated at several temperatures follows the inner machine's thermometer
/// (MachineState::temperature_c): before each command it is rebuilt for the monitored temperature
/// when that moved by 0.01 K or more (docs/error-space.md, "Temperature").
class CompensatedMachine final : public Machine {
 public:
  /// `map` null: the identity (the inner machine as it is).
  CompensatedMachine(std::unique_ptr<Machine> inner, std::shared_ptr<const ErrorMap> map);

  void submit(Command command) override;
  std::vector<Response> execute() override;
  [[nodiscard]] MachineState state() const override;
  [[nodiscard]] std::vector<Command> queued() const override;
  /// The inner machine's operator stop (the compensation does not change where the part is).
  std::optional<std::string> operator_stop() override { return m_inner->operator_stop(); }

  /// Compensates by `map` from the next command on (null: none); a DMIS program loads one with
  /// CALL/EXTERN,SYS,'COMPENSATION file' (docs/error-space.md).
  void set_map(std::shared_ptr<const ErrorMap> map);
  /// The map in use now (null: none).
  [[nodiscard]] const ErrorMap* map() const { return m_map.get(); }

  /// Where to command the inner machine so the tip really reaches `wanted_mm`.
  [[nodiscard]] Vec3 command_for(const Vec3& wanted_mm) const;
  /// Where the tip really is when the inner machine reports `reported_mm`.
  [[nodiscard]] Vec3 corrected(const Vec3& reported_mm) const;

 private:
  std::unique_ptr<Machine> m_inner;
  void follow_temperature();
  /// The effective radius of `tool` qualified through the current map (none: not qualified with points).
  std::optional<double> compensated_radius(const std::string& tool) const;
  void compensate_tool(ToolInfo& info) const;
  std::shared_ptr<const ErrorMap> m_map;
  std::shared_ptr<const ErrorSpaceMap> m_by_temperature;  ///< the loaded map when it follows the temperature
  std::vector<Command> m_queued;                          ///< the commands as the client sent them
  Vec3 m_scan_shift_mm = Vec3::Zero();                    ///< the running segmented scan's shift (set by its command 0)
  /// Per tool, its last qualification (centres as the scales read them, certified diameter), and
  /// the effective radius refitted through the map it was last computed with.
  struct Qualification {
    std::vector<Vec3> centres_mm;
    double reference_diameter_mm = 0;
    mutable const ErrorMap* radius_map = nullptr;
    mutable double radius_mm = 0;
  };
  std::map<std::string, Qualification> m_qualifications;
};

}  // namespace metron::machine
