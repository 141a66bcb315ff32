// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "metron/machine/machine_errors/error_model.hpp"
#include "metron/machine/machine_errors/thermal.hpp"

/// The model-discrepancy catalogue's effects as machine error terms (docs/discrepancy.md), so that
/// an extended world simulates what the analysis found. Written in `machine.errors.terms`.
namespace metron::machine {

/// e_c += k q_j: a scale error (j = c) or a squareness / constant angular error with a lever (j != c).
class LinearTerm final : public ErrorTerm {
 public:
  LinearTerm(int component, int along, double coefficient) : m_c(component), m_j(along), m_k(coefficient) {}
  [[nodiscard]] Vec3 displacement(const MachinePose& pose, double time_s) const override;
  [[nodiscard]] std::string_view name() const override { return "linear"; }

 private:
  int m_c, m_j;
  double m_k;
};

/// e_c += k q_i q_j: a non-rigid cross-axis term (bending that grows with two axes together).
class CrossAxisTerm final : public ErrorTerm {
 public:
  CrossAxisTerm(int component, int i, int j, double coefficient) : m_c(component), m_i(i), m_j(j), m_k(coefficient) {}
  [[nodiscard]] Vec3 displacement(const MachinePose& pose, double time_s) const override;
  [[nodiscard]] std::string_view name() const override { return "cross-axis"; }

 private:
  int m_c, m_i, m_j;
  double m_k;
};

/// e_c += A sin(2 pi q_j / P + phi): cyclic error of a screw, rack or scale (ISO 230-2 periodic error).
class CyclicTerm final : public ErrorTerm {
 public:
  CyclicTerm(int component, int along, double amplitude_mm, double period_mm, double phase_rad)
      : m_c(component), m_j(along), m_a(amplitude_mm), m_p(period_mm), m_phi(phase_rad) {}
  [[nodiscard]] Vec3 displacement(const MachinePose& pose, double time_s) const override;
  [[nodiscard]] std::string_view name() const override { return "cyclic"; }

 private:
  int m_c, m_j;
  double m_a, m_p, m_phi;
};

/// e_c += r (t - t0): drift over simulated time.
class DriftTerm final : public ErrorTerm {
 public:
  DriftTerm(int component, double rate_mm_per_s, double t0_s) : m_c(component), m_rate(rate_mm_per_s), m_t0(t0_s) {}
  [[nodiscard]] Vec3 displacement(const MachinePose& pose, double time_s) const override;
  [[nodiscard]] std::string_view name() const override { return "drift"; }

 private:
  int m_c;
  double m_rate, m_t0;
};

/// e_c += A exp(-(t - t0) / tau) for t >= t0: a start-up transient settling over simulated time.
class TransientTerm final : public ErrorTerm {
 public:
  TransientTerm(int component, double amplitude_mm, double tau_s, double t0_s)
      : m_c(component), m_a(amplitude_mm), m_tau(tau_s), m_t0(t0_s) {}
  [[nodiscard]] Vec3 displacement(const MachinePose& pose, double time_s) const override;
  [[nodiscard]] std::string_view name() const override { return "transient"; }

 private:
  int m_c;
  double m_a, m_tau, m_t0;
};

/// e_c += (k0 + k1 q_c)(T(t) - T_ref), T a recorded temperature through a first-order lag: thermal
/// growth of a structure (k0) or a scale (k1 = alpha) that follows a temperature (ISO 230-3).
class ThermalLagTerm final : public ErrorTerm {
 public:
  ThermalLagTerm(int component, double mm_per_k, double per_k, double reference_c,
                 std::shared_ptr<const TemperatureHistory> t)
      : m_c(component), m_k0(mm_per_k), m_k1(per_k), m_ref(reference_c), m_t(std::move(t)) {}
  [[nodiscard]] Vec3 displacement(const MachinePose& pose, double time_s) const override;
  [[nodiscard]] std::string_view name() const override { return "thermal-lag"; }

 private:
  int m_c;
  double m_k0, m_k1, m_ref;
  std::shared_ptr<const TemperatureHistory> m_t;
};

/// Reads `machine.errors.terms` (an array of {"kind": linear|cross_axis|cyclic|drift|transient|thermal|reversal, ...})
/// into `model`; strict, throws strict_json::ReadError naming the pointer.
void parse_catalogue_terms(const nlohmann::json& terms, const std::string& pointer, MachineErrorModel& model);

}  // namespace metron::machine
